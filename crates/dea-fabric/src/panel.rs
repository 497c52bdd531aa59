//! Woven panels: a relaxed unit cell tiled over the panel and stacked in layers (seed §3.1:
//! "the relaxed unit-cell is assembled in weft and warp direction to form a piece of
//! fabric"). Every node is a pure function of (yarn, fibre, position along the fibre), so a
//! rank builds exactly the nodes it owns and no rank ever holds the whole panel.

use std::sync::Arc;

use dea_core::nodes::FailureMode;
use dea_core::{Elements, FibreId, FibreMaterial, GlobalNodeId, Nodes, Vec3};

use crate::weave::{UnitCell, YarnDirection};
use crate::Built;

/// How the panel is held.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Boundary {
    /// both ends of every fibre fixed (the seed's "four edges fixed", §4.4)
    FixedEdges,
    /// every node outside a square opening of side `opening_m` centred on the panel is fixed
    /// (the seed's clamp fixture: 15 in fabric in a 12 in opening, §6.2.2)
    Clamp { opening_m: f64 },
}

/// A plain-woven panel of `layers` identical layers, each `cells` x `cells` unit cells.
#[derive(Clone, Debug, PartialEq)]
pub struct WovenPanel {
    /// the relaxed unit cell every layer repeats
    pub cell: Arc<UnitCell>,
    /// unit cells along each side of a layer
    pub cells: u32,
    pub layers: u32,
    /// gap between the contact surfaces of neighbouring layers; 0 = touching [m]
    pub layer_gap: f64,
    /// in-plane shift of each layer relative to the one above (x, y) [m]
    pub layer_shift: [f64; 2],
    /// vertical distance between the node centres of neighbouring layers: the smallest at
    /// which no node of one layer is closer than a contact diameter plus the gap to a node of
    /// the next ([`touching_pitch`]) [m]
    pub layer_pitch: f64,
    pub boundary: Boundary,
    /// tensile strength given to every element before any Weibull sampling [Pa]
    pub tensile_strength: f64,
}

/// Where a panel yarn lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct YarnPlace {
    pub layer: u32,
    pub direction: YarnDirection,
    /// index across the layer, 0 at the lowest coordinate
    pub index: u32,
}

/// Smallest vertical distance between two copies of `cell`, the lower shifted in plane by
/// `shift`, at which no node pair of the two is closer than `clearance` (periodic in x and y).
/// Only the nodes within `clearance` of the cell's bottom and top can decide it [m].
pub fn touching_pitch(cell: &UnitCell, shift: [f64; 2], clearance: f64) -> f64 {
    let (low, high) = cell.z_range();
    let period = cell.period();
    let bottom: Vec<&Vec3> = cell.positions.iter().filter(|p| p.z < low + clearance).collect();
    let top: Vec<&Vec3> = cell.positions.iter().filter(|p| p.z > high - clearance).collect();
    let mut pitch = high - low;
    for upper in &bottom {
        for lower in &top {
            let wrap = |d: f64| d - period * (d / period).round();
            let (dx, dy) = (wrap(lower.x + shift[0] - upper.x), wrap(lower.y + shift[1] - upper.y));
            let planar = dx * dx + dy * dy;
            if planar < clearance * clearance {
                pitch = pitch.max(lower.z - upper.z + (clearance * clearance - planar).sqrt());
            }
        }
    }
    pitch
}

impl WovenPanel {
    /// A panel of `layers` layers of `cells` x `cells` cells, neighbouring layers `gap` apart
    /// (0 = touching), each shifted by `shift` from the one above.
    pub fn new(cell: Arc<UnitCell>, cells: u32, layers: u32, gap: f64, shift: [f64; 2], boundary: Boundary, tensile_strength: f64) -> Self {
        let layer_pitch = touching_pitch(&cell, shift, cell.section.contact_diameter + gap);
        Self { cell, cells, layers, layer_gap: gap, layer_shift: shift, layer_pitch, boundary, tensile_strength }
    }

    /// Yarns of one layer: `2 cells` warp yarns, then `2 cells` weft yarns.
    pub fn yarns_per_layer(&self) -> usize {
        4 * self.cells as usize
    }

    /// Yarns of the panel.
    pub fn yarn_count(&self) -> usize {
        self.yarns_per_layer() * self.layers as usize
    }

    /// Layer, direction and index of yarn `yarn`.
    pub fn place(&self, yarn: usize) -> YarnPlace {
        let per_layer = self.yarns_per_layer();
        let (layer, within) = (yarn / per_layer, yarn % per_layer);
        let half = 2 * self.cells as usize;
        let (direction, index) = if within < half { (YarnDirection::Warp, within) } else { (YarnDirection::Weft, within - half) };
        YarnPlace { layer: layer as u32, direction, index: index as u32 }
    }

    /// Nodes of every fibre: `cells` periods plus the closing node.
    pub fn nodes_per_fibre(&self) -> u32 {
        self.cells * self.cell.nodes_per_period + 1
    }

    /// Side of one layer, `2 s cells` [m].
    pub fn side(&self) -> f64 {
        self.cells as f64 * self.cell.period()
    }

    /// Centre of a layer's plan (x = y) [m]. The crossing of the middle yarns is the origin;
    /// the fibres start and end half a spacing outside the outermost yarns.
    pub fn plan_centre(&self) -> f64 {
        -0.5 * self.cell.yarn_spacing
    }

    /// Translation of the whole panel from the cell's frame: the first yarn at `-cells s`.
    fn origin(&self) -> f64 {
        -(self.cells as f64) * self.cell.yarn_spacing
    }

    /// The cell fibre that fibre `fibre` of yarn `yarn` repeats.
    pub fn cell_fibre(&self, yarn: usize, fibre: usize) -> usize {
        let place = self.place(yarn);
        let cell_yarn = match place.direction {
            YarnDirection::Warp => place.index as usize % 2,
            YarnDirection::Weft => 2 + place.index as usize % 2,
        };
        cell_yarn * self.cell.fibres_per_yarn + fibre
    }

    /// Position of node `k` of fibre `fibre` (within its yarn) of yarn `yarn` [m].
    pub fn position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3 {
        let place = self.place(yarn);
        let n = self.cell.nodes_per_period;
        let (period, origin) = (self.cell.period(), self.origin());
        // fibres start a quarter period into the cell (halfway between crossings), so the
        // panel's node k is the cell's node k + 3n/4 one period back
        let shifted = k + 3 * n / 4;
        let along = (shifted / n) as f64 * period - period + origin;
        let across = (place.index / 2) as f64 * period + origin;
        let p = self.cell.position(self.cell_fibre(yarn, fibre), shifted % n);
        let layer = place.layer as f64;
        let stack = Vec3::new(layer * self.layer_shift[0], layer * self.layer_shift[1], -layer * self.layer_pitch);
        stack + p + match place.direction {
            YarnDirection::Warp => Vec3::new(along, across, 0.0),
            YarnDirection::Weft => Vec3::new(across, along, 0.0),
        }
    }

    /// Rest angle of the bending spring at node `k` of fibre `fibre` of yarn `yarn` [rad].
    pub fn rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64 {
        let n = self.cell.nodes_per_period;
        self.cell.rest_angles[self.cell_fibre(yarn, fibre) * n as usize + ((k + 3 * n / 4) % n) as usize]
    }

    /// Whether a node at `position`, `k` along its fibre, is held by the boundary.
    pub fn clamped(&self, position: &Vec3, k: u32) -> bool {
        match self.boundary {
            Boundary::FixedEdges => k == 0 || k + 1 == self.nodes_per_fibre(),
            Boundary::Clamp { opening_m } => {
                let centre = self.plan_centre();
                (position.x - centre).abs() > 0.5 * opening_m || (position.y - centre).abs() > 0.5 * opening_m
            }
        }
    }

    /// Highest node centre [m].
    pub fn top(&self) -> f64 {
        self.cell.z_range().1
    }

    /// Lowest node centre [m].
    pub fn bottom(&self) -> f64 {
        self.cell.z_range().0 - (self.layers as f64 - 1.0) * self.layer_pitch
    }

    /// Box of the node centres of yarn `yarn` between positions `first` and `last` [m].
    pub fn segment_box(&self, yarn: usize, first: u32, last: u32) -> (Vec3, Vec3) {
        let (mut low, mut high) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
        for fibre in 0..self.cell.fibres_per_yarn {
            for k in first..=last {
                let p = self.position(yarn, fibre, k);
                low = low.inf(&p);
                high = high.sup(&p);
            }
        }
        (low, high)
    }

    /// Builds the nodes `keep(yarn, k)` selects, ascending global id (fibre f, node k has
    /// id `f * nodes_per_fibre + k`). Elements have their cell fibre's rest length l0;
    /// interior nodes carry `rho A l0`, chain ends half.
    pub fn build(&self, material: &FibreMaterial, keep: impl Fn(usize, u32) -> bool) -> Built {
        let section = self.cell.section.clone();
        let nodes_per_fibre = self.nodes_per_fibre();
        let last = nodes_per_fibre - 1;
        let fibres = self.cell.fibres_per_yarn;
        let mut nodes = Nodes::default();
        let mut elements = Elements::default();
        for yarn in 0..self.yarn_count() {
            let kept: Vec<u32> = (0..nodes_per_fibre).filter(|&k| keep(yarn, k)).collect();
            for fibre in 0..fibres {
                let id = (yarn * fibres + fibre) as u32;
                let rest = self.cell.rest_lengths[self.cell_fibre(yarn, fibre)];
                let interior_mass = material.density * section.area * rest;
                for &k in &kept {
                    let end = k == 0 || k == last;
                    let position = self.position(yarn, fibre, k);
                    nodes.push(
                        GlobalNodeId(id as u64 * nodes_per_fibre as u64 + k as u64),
                        position,
                        Vec3::zeros(),
                        if end { 0.5 * interior_mass } else { interior_mass },
                        FibreId(id),
                        k,
                        0,
                        self.clamped(&position, k),
                        k == last,
                    );
                    *nodes.rest_angle.last_mut().expect("just pushed") = self.rest_angle(yarn, fibre, k);
                    elements.push(if k == last { 0.0 } else { rest }, self.tensile_strength, FailureMode::Intact);
                }
            }
        }
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        Built { sections: vec![section], nodes, elements }
    }

    /// Builds every node (a whole domain, for single-domain use and tests).
    pub fn build_all(&self, material: &FibreMaterial) -> Built {
        self.build(material, |_, _| true)
    }

    /// Mass of one layer over its plan area [kg/m^2].
    pub fn areal_density(&self, material: &FibreMaterial) -> f64 {
        // every cell fibre is repeated by `cells` panel fibres over `cells` periods
        let cells = self.cells as f64;
        self.cell.areal_density(material) * self.cell.period() * self.cell.period() * cells * cells / (self.side() * self.side())
    }

    /// Nodes of the whole panel.
    pub fn node_count(&self) -> u64 {
        (self.yarn_count() * self.cell.fibres_per_yarn) as u64 * self.nodes_per_fibre() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weave::PlainWeave;

    fn panel(cells: u32, layers: u32, fibres: usize) -> (WovenPanel, FibreMaterial) {
        let material = FibreMaterial::kevlar_km2();
        let cell = PlainWeave::km2_style_706(fibres).unit_cell(&material).unwrap();
        let panel = WovenPanel::new(Arc::new(cell), cells, layers, 0.0, [0.0, 0.0], Boundary::FixedEdges, 3.8e9);
        (panel, material)
    }

    #[test]
    fn tiled_fibres_are_continuous_chains() {
        let (panel, material) = panel(3, 1, 4);
        let built = panel.build_all(&material);
        let nodes = &built.nodes;
        for i in 0..nodes.len() {
            let j = nodes.next[i];
            if j != dea_core::NONE {
                let (length, l0) = ((nodes.position[j as usize] - nodes.position[i]).norm(), built.elements.rest_length[i]);
                assert!((length / l0 - 1.0).abs() < 1e-3, "element {i}: {length} vs {l0}");
            }
        }
    }

    #[test]
    fn yarn_spacing_and_areal_density_hold_over_the_panel() {
        let (panel, material) = panel(4, 1, 1);
        let s = panel.cell.yarn_spacing;
        // yarn centres one spacing apart, the middle crossing at the origin
        let across: Vec<f64> = (0..8).map(|j| panel.position(j, 0, 0).y).collect();
        for pair in across.windows(2) {
            assert!((pair[1] - pair[0] - s).abs() < 1e-15);
        }
        assert!(across.iter().any(|y| y.abs() < 1e-15));
        // fibres span the side, half a spacing beyond the outer yarns
        let (start, end) = (panel.position(0, 0, 0).x, panel.position(0, 0, panel.nodes_per_fibre() - 1).x);
        assert!((end - start - panel.side()).abs() < 1e-12);
        assert!((start - (across[0] - 0.5 * s)).abs() < 1e-12);
        let mass: f64 = panel.build_all(&material).nodes.mass.iter().sum();
        assert!((mass / (panel.side() * panel.side()) / panel.areal_density(&material) - 1.0).abs() < 1e-12);
        assert!((panel.areal_density(&material) / panel.cell.areal_density(&material) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn layers_touch_and_the_clamp_holds_the_rim() {
        let (mut panel, material) = panel(2, 3, 4);
        let built = panel.build_all(&material);
        let d = built.sections[0].contact_diameter;
        let layer_of = |i: usize| built.nodes.fibre[i].0 as usize / (panel.yarns_per_layer() * 4);
        let mut closest = f64::INFINITY;
        for i in 0..built.nodes.len() {
            for j in 0..built.nodes.len() {
                if layer_of(j) == layer_of(i) + 1 {
                    closest = closest.min((built.nodes.position[i] - built.nodes.position[j]).norm());
                }
            }
        }
        assert!((closest - d).abs() < 1e-12 * d, "{closest} vs {d}");
        assert!((panel.top() - panel.bottom() - (2.0 * panel.layer_pitch + panel.cell.z_range().1 - panel.cell.z_range().0)).abs() < 1e-15);
        assert_eq!(built.nodes.clamped.iter().filter(|&&c| c).count(), 2 * panel.yarn_count() * 4);
        panel.boundary = Boundary::Clamp { opening_m: 0.5 * panel.side() };
        let clamped = panel.build_all(&material);
        let centre = panel.plan_centre();
        for (p, &c) in clamped.nodes.position.iter().zip(&clamped.nodes.clamped) {
            let inside = (p.x - centre).abs() <= 0.25 * panel.side() && (p.y - centre).abs() <= 0.25 * panel.side();
            assert_eq!(c, !inside);
        }
    }

    #[test]
    fn a_rank_builds_exactly_its_piece() {
        let (panel, material) = panel(2, 2, 4);
        let whole = panel.build_all(&material);
        let keep = |y: usize, k: u32| (y + k as usize / 7) % 3 == 0;
        let piece = panel.build(&material, keep);
        let n = panel.nodes_per_fibre() as u64;
        let mut w = 0;
        for i in 0..piece.nodes.len() {
            while whole.nodes.gid[w] != piece.nodes.gid[i] {
                w += 1;
            }
            let gid = piece.nodes.gid[i].0;
            assert!(keep((gid / n) as usize / 4, (gid % n) as u32));
            assert_eq!(piece.nodes.position[i], whole.nodes.position[w]);
        }
        let expected = whole.nodes.gid.iter().filter(|g| keep((g.0 / n) as usize / 4, (g.0 % n) as u32)).count();
        assert_eq!(piece.nodes.len(), expected);
    }
}
