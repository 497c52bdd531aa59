//! Panels tiled from any relaxed periodic cell (a 3-D weave's, [`crate::weave3d`]): `tiles`
//! cells along x and y, `layers` of them stacked. A panel yarn is one cell yarn repeated
//! along its direction, one per tile across; node `k` of its fibre is the cell's node
//! `k mod n` shifted by `k div n` periods, and the last node is the image of the first, so
//! every node is a pure function of (yarn, fibre, k) as in a plain-woven panel
//! ([`crate::panel`], docs/theory.md F6, F11).

use std::sync::Arc;

use dea_core::{FibreMaterial, FibreSection, Vec3};

use crate::cell::{PeriodicCell, YarnDirection};
use crate::panel::{first_fibres, touching_pitch, Boundary, Tiling};

/// A panel of `layers` identical layers, each `tiles[0] x tiles[1]` cells, centred on the
/// origin in plan; layer 0 on top.
#[derive(Clone, Debug, PartialEq)]
pub struct TiledPanel {
    /// the relaxed cell the panel repeats
    pub cell: Arc<PeriodicCell>,
    /// cells along x and y
    pub tiles: [u32; 2],
    /// stacked layers
    pub layers: u32,
    /// in-plane shift of each layer relative to the one above (x, y) [m]
    pub layer_shift: [f64; 2],
    /// vertical distance between the node centres of neighbouring layers: the smallest at
    /// which no node of one is closer than a contact diameter plus the gap to a node of the
    /// next ([`touching_pitch`] with the shift) [m]
    pub layer_pitch: f64,
    /// how the panel is held
    pub boundary: Boundary,
    /// tensile strength given to every element before any Weibull sampling [Pa]
    pub tensile_strength: f64,
    /// the cell's yarns along x, then along y
    cell_yarns: [Vec<usize>; 2],
    /// global id of each yarn's first fibre, plus the total at the end
    first_fibre: Vec<u32>,
}

/// Where a panel yarn lies.
struct Place {
    layer: u32,
    /// 0 along x, 1 along y
    axis: usize,
    /// tile across the yarn's direction
    tile: u32,
    /// the cell yarn it repeats
    cell_yarn: usize,
}

impl TiledPanel {
    /// A panel of `layers` layers of `tiles` cells, neighbouring layers `gap` apart (0 =
    /// touching), each shifted by `shift` from the one above.
    pub fn new(cell: Arc<PeriodicCell>, tiles: [u32; 2], layers: u32, gap: f64, shift: [f64; 2], boundary: Boundary, tensile_strength: f64) -> Self {
        let along = |direction: YarnDirection| (0..cell.yarns.len()).filter(|&y| cell.yarns[y].direction == direction).collect::<Vec<_>>();
        let cell_yarns = [along(YarnDirection::Warp), along(YarnDirection::Weft)];
        let layer_pitch = touching_pitch(&cell, shift, gap);
        let mut panel = Self { cell, tiles, layers, layer_shift: shift, layer_pitch, boundary, tensile_strength, cell_yarns, first_fibre: Vec::new() };
        panel.first_fibre = first_fibres(panel.yarn_count(), |yarn| panel.yarn_fibres(yarn));
        panel
    }

    /// Yarns of one layer: the x yarns of every tile row, then the y yarns of every column.
    pub fn yarns_per_layer(&self) -> usize {
        self.cell_yarns[0].len() * self.tiles[1] as usize + self.cell_yarns[1].len() * self.tiles[0] as usize
    }

    /// Yarns of the whole panel.
    pub fn yarn_count(&self) -> usize {
        self.yarns_per_layer() * self.layers as usize
    }

    fn place(&self, yarn: usize) -> Place {
        let per_layer = self.yarns_per_layer();
        let (layer, mut within) = (yarn / per_layer, yarn % per_layer);
        let x_yarns = self.cell_yarns[0].len() * self.tiles[1] as usize;
        let axis = usize::from(within >= x_yarns);
        if axis == 1 {
            within -= x_yarns;
        }
        let per_tile = self.cell_yarns[axis].len();
        Place { layer: layer as u32, axis, tile: (within / per_tile) as u32, cell_yarn: self.cell_yarns[axis][within % per_tile] }
    }

    /// Layer of yarn `yarn` (0 on top).
    pub fn layer(&self, yarn: usize) -> u32 {
        self.place(yarn).layer
    }

    /// Centres of yarn `yarn`'s fibres in its section at the cell's first node, (across, up)
    /// about their mean [m].
    pub fn packing(&self, yarn: usize) -> Vec<[f64; 2]> {
        let place = self.place(yarn);
        let first = self.cell.yarn_first_fibre(place.cell_yarn);
        let points: Vec<Vec3> = (first..first + self.yarn_fibres(yarn)).map(|f| self.cell.position(f, 0)).collect();
        let mean = points.iter().sum::<Vec3>() / points.len() as f64;
        points.iter().map(|p| [p[1 - place.axis] - mean[1 - place.axis], p.z - mean.z]).collect()
    }

    /// Digital fibres of yarn `yarn`.
    pub fn yarn_fibres(&self, yarn: usize) -> usize {
        self.cell.yarns[self.place(yarn).cell_yarn].fibres
    }

    /// Global id of each yarn's first fibre.
    pub fn first_fibres(&self) -> &[u32] {
        &self.first_fibre
    }

    /// Nodes of every fibre of yarn `yarn`: its cell yarn's nodes in each tile along, plus
    /// the closing node.
    pub fn nodes_per_fibre(&self, yarn: usize) -> u32 {
        let place = self.place(yarn);
        self.tiles[place.axis] * self.cell.yarns[place.cell_yarn].nodes_per_period + 1
    }

    /// Global ids of fibre `f` are `f * stride + k`: the most nodes any fibre has.
    pub fn gid_stride(&self) -> u32 {
        (0..self.yarns_per_layer()).map(|y| self.nodes_per_fibre(y)).max().expect("a yarn")
    }

    /// Plan size of a layer along x and y [m].
    pub fn size(&self) -> [f64; 2] {
        [self.tiles[0] as f64 * self.cell.period[0], self.tiles[1] as f64 * self.cell.period[1]]
    }

    /// Position of node `k` of fibre `fibre` of yarn `yarn` [m].
    pub fn position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3 {
        let place = self.place(yarn);
        let cell_fibre = self.cell.yarn_first_fibre(place.cell_yarn) + fibre;
        let n = self.cell.yarns[place.cell_yarn].nodes_per_period;
        let size = self.size();
        let mut p = self.cell.position(cell_fibre, k % n) + self.cell.closure(cell_fibre) * (k / n) as f64;
        p[1 - place.axis] += place.tile as f64 * self.cell.period[1 - place.axis];
        let layer = place.layer as f64;
        p + Vec3::new(layer * self.layer_shift[0] - 0.5 * size[0], layer * self.layer_shift[1] - 0.5 * size[1], -layer * self.layer_pitch)
    }

    /// Whether node `k` of a fibre of yarn `yarn`, at `position`, is held by the boundary.
    pub fn clamped(&self, yarn: usize, position: &Vec3, k: u32) -> bool {
        self.boundary.holds([position.x, position.y], k, self.nodes_per_fibre(yarn))
    }

    /// Highest node centre [m].
    pub fn top(&self) -> f64 {
        self.cell.z_range().1
    }

    /// Lowest node centre [m].
    pub fn bottom(&self) -> f64 {
        self.cell.z_range().0 - (self.layers as f64 - 1.0) * self.layer_pitch
    }

    /// Mass of one layer over its plan area [kg/m^2].
    pub fn areal_density(&self, material: &FibreMaterial) -> f64 {
        let size = self.size();
        self.layer_mass(material) / (size[0] * size[1])
    }
}

impl Tiling for TiledPanel {
    fn yarns(&self) -> usize {
        self.yarn_count()
    }
    fn yarns_in_layer(&self) -> usize {
        self.yarns_per_layer()
    }
    fn fibres_of(&self, yarn: usize) -> usize {
        self.yarn_fibres(yarn)
    }
    fn first_fibre_of(&self, yarn: usize) -> u32 {
        self.first_fibre[yarn]
    }
    fn nodes_of(&self, yarn: usize) -> u32 {
        self.nodes_per_fibre(yarn)
    }
    fn stride(&self) -> u32 {
        self.gid_stride()
    }
    fn section_of(&self, _yarn: usize) -> usize {
        0
    }
    fn all_sections(&self) -> Vec<FibreSection> {
        vec![self.cell.section.clone()]
    }
    fn node_position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3 {
        self.position(yarn, fibre, k)
    }
    fn node_rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64 {
        let place = self.place(yarn);
        let cell_fibre = self.cell.yarn_first_fibre(place.cell_yarn) + fibre;
        let n = self.cell.yarns[place.cell_yarn].nodes_per_period;
        self.cell.rest_angles[self.cell.fibre_nodes(cell_fibre).start + (k % n) as usize]
    }
    fn fibre_rest_length(&self, yarn: usize, fibre: usize) -> f64 {
        self.cell.rest_lengths[self.cell.yarn_first_fibre(self.place(yarn).cell_yarn) + fibre]
    }
    fn held(&self, yarn: usize, position: &Vec3, k: u32) -> bool {
        self.clamped(yarn, position, k)
    }
    fn strength(&self) -> f64 {
        self.tensile_strength
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relax::{relax, BendingAtRest, RelaxOptions};
    use crate::weave3d::{Pattern, ThreeDWeave, YarnKind};
    use dea_core::contact::NormalLaw;

    fn relaxed_orthogonal() -> (PeriodicCell, FibreMaterial) {
        let material = FibreMaterial::kevlar_km2();
        let yarn = YarnKind { area_m2: 4.63e-8, section_aspect: 3.0 };
        let weave = ThreeDWeave::of_pattern(Pattern::Orthogonal, 2, 1.0e-3, 0.8e-3, yarn, 4, yarn, YarnKind { area_m2: 2.315e-8, section_aspect: 2.0 });
        let mut cell = weave.unit_cell(&material).unwrap();
        relax(&mut cell, &material, &NormalLaw::ElastoPlasticKm2, &RelaxOptions { tolerance: 1e-6, max_iterations: 400_000, bending_at_rest: BendingAtRest::Straight }).unwrap();
        (cell, material)
    }

    #[test]
    fn a_tiled_panel_repeats_its_cell_and_keeps_its_mass() {
        let (cell, material) = relaxed_orthogonal();
        let panel = TiledPanel::new(Arc::new(cell.clone()), [3, 2], 2, 0.0, [0.0, 0.0], Boundary::FixedEdges, 3.8e9);
        let built = panel.build(&material, |_, _| true);
        assert_eq!(built.nodes.len() as u64, panel.node_count());
        // the layer's mass per area is the cell's: every fibre spans whole periods
        assert!((panel.areal_density(&material) / cell.areal_density(&material) - 1.0).abs() < 1e-12);
        // every element of a panel fibre is as long as the cell's, across tiles too
        for yarn in [0, panel.yarns_per_layer() - 1] {
            for k in 0..panel.nodes_per_fibre(yarn) - 1 {
                let place = panel.place(yarn);
                let f = cell.yarn_first_fibre(place.cell_yarn);
                let n = cell.yarns[place.cell_yarn].nodes_per_period;
                let expected = (cell.position(f, (k + 1) % n) + if (k + 1) % n == 0 { cell.closure(f) } else { Vec3::zeros() } - cell.position(f, k % n)).norm();
                assert!(((panel.position(yarn, 0, k + 1) - panel.position(yarn, 0, k)).norm() - expected).abs() < 1e-15, "yarn {yarn} k {k}");
            }
        }
        // centred in plan; layers touching, one pitch apart
        let (low, high) = built.nodes.position.iter().fold((Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)), |(l, h), p| (l.inf(p), h.sup(p)));
        assert!((low.x + high.x).abs() < 0.6 * cell.period[0] && (low.y + high.y).abs() < 0.6 * cell.period[1], "{low} {high}");
        assert!(panel.layer_pitch > 0.0 && (panel.top() - panel.bottom() - panel.layer_pitch - (cell.z_range().1 - cell.z_range().0)).abs() < 1e-15);
        // fixed edges hold the two ends of every fibre, and nothing else
        let held = built.nodes.clamped.iter().filter(|&&c| c).count();
        assert_eq!(held, 2 * *panel.first_fibres().last().unwrap() as usize);
    }

    #[test]
    fn shifted_layers_with_a_gap_keep_it_and_move_by_the_shift() {
        let (cell, material) = relaxed_orthogonal();
        let (gap, shift) = (20e-6, [0.3e-3, -0.2e-3]);
        let panel = TiledPanel::new(Arc::new(cell), [2, 2], 2, gap, shift, Boundary::FixedEdges, 3.8e9);
        let built = panel.build(&material, |_, _| true);
        let nodes = &built.nodes;
        let d = built.sections[0].contact_diameter;
        let per_layer = *panel.first_fibres().get(panel.yarns_per_layer()).unwrap();
        let layer_of = |i: usize| usize::from(nodes.fibre[i].0 >= per_layer);
        let mut closest = f64::INFINITY;
        for i in (0..nodes.len()).filter(|&i| layer_of(i) == 0) {
            for j in (0..nodes.len()).filter(|&j| layer_of(j) == 1) {
                closest = closest.min((nodes.position[i] - nodes.position[j]).norm());
            }
        }
        // the pitch is periodic: across the finite panel's edges the layers may sit farther
        assert!(closest >= d + gap - 1e-12 && closest < d + gap + 0.05 * d, "{closest} vs {}", d + gap);
        let yarn = panel.yarns_per_layer();
        let moved = panel.position(yarn, 0, 3) - panel.position(0, 0, 3);
        assert!((moved.x - shift[0]).abs() < 1e-15 && (moved.y - shift[1]).abs() < 1e-15 && (moved.z + panel.layer_pitch).abs() < 1e-15);
    }
}
