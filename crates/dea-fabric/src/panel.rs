//! Woven panels: a relaxed unit cell tiled over the panel and stacked in layers (seed §3.1:
//! "the relaxed unit-cell is assembled in weft and warp direction to form a piece of
//! fabric"). Every node is a pure function of (yarn, fibre, position along the fibre), so a
//! rank builds exactly the nodes it owns and no rank ever holds the whole panel.
//!
//! A hybrid panel (seed §2.3.4.1, the yarn-based mesh of Dippolito, Wang et al. 2014) makes
//! the yarns that pass near the impact point fine (many digital fibres, short elements) and
//! the others coarse (few fibres, long elements). Each yarn repeats the fibres of its own
//! relaxed cell along its whole length, so no yarn has a seam; where a fine yarn crosses a
//! coarse one, each keeps the crimp it has against its own kind (docs/theory.md F8).

use std::sync::Arc;

use dea_core::nodes::FailureMode;
use dea_core::{Elements, FibreId, FibreMaterial, FibreSection, GlobalNodeId, Nodes, Vec3};

use crate::cell::PeriodicCell;
use crate::relax;
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

impl Boundary {
    /// Whether node `k` of a fibre of `nodes` nodes, `plan` from the panel's centre in x and y,
    /// is held.
    pub fn holds(&self, plan: [f64; 2], k: u32, nodes: u32) -> bool {
        match *self {
            Boundary::FixedEdges => k == 0 || k + 1 == nodes,
            Boundary::Clamp { opening_m } => plan[0].abs() > 0.5 * opening_m || plan[1].abs() > 0.5 * opening_m,
        }
    }
}

/// The coarse yarns of a hybrid panel.
#[derive(Clone, Debug, PartialEq)]
pub struct CoarseYarns {
    /// the relaxed cell the coarse yarns repeat: the fine cell's weave with fewer, thicker
    /// digital fibres and longer elements (same yarn spacing and yarn area)
    pub cell: Arc<UnitCell>,
    /// a yarn is fine when its centreline passes within this distance of the panel's
    /// centre, coarse otherwise [m]
    pub fine_half_width: f64,
}

/// A plain-woven panel of `layers` identical layers, each `cells` x `cells` unit cells.
#[derive(Clone, Debug, PartialEq)]
pub struct WovenPanel {
    /// the relaxed unit cell every yarn repeats (the fine yarns of a hybrid panel)
    pub cell: Arc<UnitCell>,
    /// the coarse yarns of a hybrid panel
    pub coarse: Option<CoarseYarns>,
    /// unit cells along each side of a layer
    pub cells: u32,
    pub layers: u32,
    /// gap between the contact surfaces of neighbouring layers; 0 = touching [m]
    pub layer_gap: f64,
    /// in-plane shift of each layer relative to the one above (x, y) [m]
    pub layer_shift: [f64; 2],
    /// vertical distance between the node centres of neighbouring layers: the smallest at
    /// which no node of one layer is closer than its pair's contact distance plus the gap to
    /// a node of the next ([`touching_pitch`]) [m]
    pub layer_pitch: f64,
    pub boundary: Boundary,
    /// tensile strength given to every element before any Weibull sampling [Pa]
    pub tensile_strength: f64,
    /// global id of each yarn's first fibre, plus the total at the end
    first_fibre: Vec<u32>,
}

/// Where a panel yarn lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct YarnPlace {
    pub layer: u32,
    pub direction: YarnDirection,
    /// index across the layer, 0 at the lowest coordinate
    pub index: u32,
}

/// A node of a periodic pattern and its contact radius (half the contact diameter) [m].
type Sphere = (Vec3, f64);

/// Smallest vertical distance between two copies of a periodic pattern of period `period`
/// in x and y, the lower one (`lower`) shifted in plane by `shift`, at which no node of the
/// upper one (`upper`) is closer to a lower node than their contact radii plus `gap`. Only
/// nodes within reach of the patterns' facing sides can decide it [m].
fn pitch_between(upper: &[Sphere], lower: &[Sphere], period: [f64; 2], shift: [f64; 2], gap: f64) -> f64 {
    let largest = upper.iter().chain(lower).map(|s| s.1).fold(0.0, f64::max);
    let reach = 2.0 * largest + gap;
    let low = upper.iter().map(|s| s.0.z).fold(f64::INFINITY, f64::min);
    let high = lower.iter().map(|s| s.0.z).fold(f64::NEG_INFINITY, f64::max);
    let bottom: Vec<&Sphere> = upper.iter().filter(|s| s.0.z < low + reach).collect();
    let top: Vec<&Sphere> = lower.iter().filter(|s| s.0.z > high - reach).collect();
    let mut pitch = f64::NEG_INFINITY;
    for (u, ru) in &bottom {
        for (l, rl) in &top {
            let clearance = ru + rl + gap;
            let wrap = |d: f64, p: f64| d - p * (d / p).round();
            let (dx, dy) = (wrap(l.x + shift[0] - u.x, period[0]), wrap(l.y + shift[1] - u.y, period[1]));
            let planar = dx * dx + dy * dy;
            if planar < clearance * clearance {
                pitch = pitch.max(l.z - u.z + (clearance * clearance - planar).sqrt());
            }
        }
    }
    pitch.max(high - low)
}

/// The nodes of one cell with the contact radius of its section.
fn spheres(cell: &PeriodicCell) -> Vec<Sphere> {
    cell.positions.iter().map(|p| (*p, 0.5 * cell.section.contact_diameter)).collect()
}

/// Smallest vertical distance between two copies of `cell`, the lower shifted in plane by
/// `shift`, at which no node pair of the two is closer than a contact diameter plus `gap`
/// (periodic in x and y) [m].
pub fn touching_pitch(cell: &PeriodicCell, shift: [f64; 2], gap: f64) -> f64 {
    let nodes = spheres(cell);
    pitch_between(&nodes, &nodes, cell.period, shift, gap)
}

/// The nodes of a plain-weave tile whose warp yarns repeat `warp` and weft yarns `weft`.
fn tile(warp: &UnitCell, weft: &UnitCell) -> Vec<Sphere> {
    let warp_nodes = 2 * warp.fibres_per_yarn * warp.nodes_per_period as usize;
    let weft_nodes = 2 * weft.fibres_per_yarn * weft.nodes_per_period as usize;
    let mut nodes: Vec<Sphere> = spheres(warp)[..warp_nodes].to_vec();
    nodes.extend_from_slice(&spheres(weft)[weft.positions.len() - weft_nodes..]);
    nodes
}

impl WovenPanel {
    /// A panel of `layers` layers of `cells` x `cells` cells, neighbouring layers `gap` apart
    /// (0 = touching), each shifted by `shift` from the one above; hybrid when `coarse` is
    /// given. The coarse cell must have the fine cell's yarn spacing.
    #[allow(clippy::too_many_arguments)]
    pub fn new(cell: Arc<UnitCell>, coarse: Option<CoarseYarns>, cells: u32, layers: u32, gap: f64, shift: [f64; 2], boundary: Boundary, tensile_strength: f64) -> Self {
        let layer_pitch = match &coarse {
            None => touching_pitch(&cell, shift, gap),
            Some(coarse) => {
                // the four kinds of tile (fine or coarse warp, fine or coarse weft); without a
                // shift each lies on its own kind, with one near the hybrid's borders it may
                // lie on any other
                let kinds: Vec<Vec<Sphere>> = [(&cell, &cell), (&cell, &coarse.cell), (&coarse.cell, &cell), (&coarse.cell, &coarse.cell)].iter().map(|(w, f)| tile(w, f)).collect();
                let shifted = shift != [0.0, 0.0];
                let mut pitch = f64::NEG_INFINITY;
                for (a, upper) in kinds.iter().enumerate() {
                    for (b, lower) in kinds.iter().enumerate() {
                        if a == b || shifted {
                            pitch = pitch.max(pitch_between(upper, lower, [cell.period(); 2], shift, gap));
                        }
                    }
                }
                pitch
            }
        };
        let mut panel = Self { cell, coarse, cells, layers, layer_gap: gap, layer_shift: shift, layer_pitch, boundary, tensile_strength, first_fibre: Vec::new() };
        panel.first_fibre = first_fibres(panel.yarn_count(), |yarn| panel.yarn_fibres(yarn));
        panel
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

    /// Whether yarn `yarn` is coarse (only in a hybrid panel).
    pub fn is_coarse(&self, yarn: usize) -> bool {
        self.coarse.as_ref().is_some_and(|c| {
            let index = self.place(yarn).index;
            // the yarn's centreline in its layer's own frame (before the layer's shift)
            let across = (index / 2) as f64 * self.cell.period() + self.origin() + (index % 2) as f64 * self.cell.yarn_spacing;
            (across - self.plan_centre()).abs() > c.fine_half_width
        })
    }

    /// The relaxed cell yarn `yarn` repeats.
    pub fn yarn_cell(&self, yarn: usize) -> &UnitCell {
        match &self.coarse {
            Some(coarse) if self.is_coarse(yarn) => &coarse.cell,
            _ => &self.cell,
        }
    }

    /// Index of yarn `yarn`'s section in [`Self::sections`]: 0 fine, 1 coarse.
    pub fn yarn_section(&self, yarn: usize) -> usize {
        usize::from(self.is_coarse(yarn))
    }

    /// The sections of the panel's fibres: the fine (or only) one, then the coarse one.
    pub fn sections(&self) -> Vec<FibreSection> {
        self.cells_used().map(|c| c.section.clone()).collect()
    }

    /// Digital fibres of yarn `yarn`.
    pub fn yarn_fibres(&self, yarn: usize) -> usize {
        self.yarn_cell(yarn).fibres_per_yarn
    }

    /// Global id of each yarn's first fibre, plus the total at the end.
    pub fn first_fibres(&self) -> &[u32] {
        &self.first_fibre
    }

    /// Nodes of every fibre of yarn `yarn`: `cells` periods plus the closing node.
    pub fn nodes_per_fibre(&self, yarn: usize) -> u32 {
        self.cells * self.yarn_cell(yarn).nodes_per_period + 1
    }

    /// Global ids of fibre `f` are `f * stride + k`: the most nodes any fibre has.
    pub fn gid_stride(&self) -> u32 {
        self.cells_used().map(|c| self.cells * c.nodes_per_period + 1).max().expect("a fine cell")
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
        cell_yarn * self.yarn_fibres(yarn) + fibre
    }

    /// Position of node `k` of fibre `fibre` (within its yarn) of yarn `yarn` [m].
    pub fn position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3 {
        let place = self.place(yarn);
        let cell = self.yarn_cell(yarn);
        let n = cell.nodes_per_period;
        let (period, origin) = (cell.period(), self.origin());
        // fibres start a quarter period into the cell (halfway between crossings), so the
        // panel's node k is the cell's node k + 3n/4 one period back
        let shifted = k + 3 * n / 4;
        let along = (shifted / n) as f64 * period - period + origin;
        let across = (place.index / 2) as f64 * period + origin;
        let p = cell.position(self.cell_fibre(yarn, fibre), shifted % n);
        let layer = place.layer as f64;
        let stack = Vec3::new(layer * self.layer_shift[0], layer * self.layer_shift[1], -layer * self.layer_pitch);
        stack + p + match place.direction {
            YarnDirection::Warp => Vec3::new(along, across, 0.0),
            YarnDirection::Weft => Vec3::new(across, along, 0.0),
        }
    }

    /// Rest angle of the bending spring at node `k` of fibre `fibre` of yarn `yarn` [rad].
    pub fn rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64 {
        let cell = self.yarn_cell(yarn);
        let n = cell.nodes_per_period;
        cell.rest_angles[self.cell_fibre(yarn, fibre) * n as usize + ((k + 3 * n / 4) % n) as usize]
    }

    /// Whether node `k` of a fibre of yarn `yarn`, at `position`, is held by the boundary.
    pub fn clamped(&self, yarn: usize, position: &Vec3, k: u32) -> bool {
        let centre = self.plan_centre();
        self.boundary.holds([position.x - centre, position.y - centre], k, self.nodes_per_fibre(yarn))
    }

    /// The cells the panel repeats: the fine (or only) one, then the coarse one.
    fn cells_used(&self) -> impl Iterator<Item = &UnitCell> {
        std::iter::once(&*self.cell).chain(self.coarse.as_ref().map(|c| &*c.cell))
    }

    /// Highest node centre [m].
    pub fn top(&self) -> f64 {
        self.cells_used().map(|c| c.z_range().1).fold(f64::NEG_INFINITY, f64::max)
    }

    /// Lowest node centre [m].
    pub fn bottom(&self) -> f64 {
        self.cells_used().map(|c| c.z_range().0).fold(f64::INFINITY, f64::min) - (self.layers as f64 - 1.0) * self.layer_pitch
    }

    /// Mass of one layer over its plan area [kg/m^2].
    pub fn areal_density(&self, material: &FibreMaterial) -> f64 {
        self.layer_mass(material) / (self.side() * self.side())
    }

    /// How much farther apart the layers of the fine kind of tile start than that kind alone
    /// would stack: a hybrid panel's pitch is its thickest kind's, so where the coarse yarns
    /// are thicker the fine region's layers begin with this gap (0 when not hybrid) [m].
    pub fn fine_layer_gap(&self) -> f64 {
        self.layer_pitch - touching_pitch(&self.cell, self.layer_shift, self.layer_gap)
    }

    /// Deepest overlap of two nodes of the panel as built, over their contact distance [-]:
    /// that of each relaxed cell, and where a hybrid panel's fine and coarse yarns cross.
    pub fn largest_overlap_ratio(&self) -> f64 {
        let mut largest = relax::largest_overlap_ratio(&self.cell);
        if let Some(coarse) = &self.coarse {
            largest = largest.max(relax::largest_overlap_ratio(&coarse.cell));
            let period = self.cell.period();
            for (warp, weft) in [(&*self.cell, &*coarse.cell), (&*coarse.cell, &*self.cell)] {
                let warp_nodes = &warp.positions[..2 * warp.fibres_per_yarn * warp.nodes_per_period as usize];
                let weft_nodes = &weft.positions[weft.positions.len() - 2 * weft.fibres_per_yarn * weft.nodes_per_period as usize..];
                let reach = 0.5 * (warp.section.contact_diameter + weft.section.contact_diameter);
                for p in warp_nodes {
                    for q in weft_nodes {
                        let distance = relax::minimum_image(q - p, [period, period]).norm();
                        largest = largest.max((reach - distance) / reach);
                    }
                }
            }
        }
        largest
    }

    /// Nodes of the fine yarns of the whole panel (all of them when not hybrid).
    pub fn fine_node_count(&self) -> u64 {
        (0..self.yarn_count()).filter(|&y| !self.is_coarse(y)).map(|y| self.yarn_fibres(y) as u64 * self.nodes_per_fibre(y) as u64).sum()
    }
}

/// Global id of each yarn's first fibre, plus the total at the end, for `yarns` yarns of
/// `fibres(yarn)` fibres.
pub(crate) fn first_fibres(yarns: usize, fibres: impl Fn(usize) -> usize) -> Vec<u32> {
    let mut first = vec![0u32];
    for yarn in 0..yarns {
        first.push(first[yarn] + fibres(yarn) as u32);
    }
    first
}

/// A panel whose every node is a pure function of (yarn, fibre, k): what the builder needs,
/// and what it gives (the plain-woven [`WovenPanel`], the [`crate::tiled::TiledPanel`]).
pub trait Tiling {
    fn yarns(&self) -> usize;
    /// yarns of one layer (the first `yarns_in_layer()` yarns are layer 0)
    fn yarns_in_layer(&self) -> usize;
    fn fibres_of(&self, yarn: usize) -> usize;
    fn first_fibre_of(&self, yarn: usize) -> u32;
    fn nodes_of(&self, yarn: usize) -> u32;
    fn stride(&self) -> u32;
    fn section_of(&self, yarn: usize) -> usize;
    fn all_sections(&self) -> Vec<FibreSection>;
    /// position of node `k` of fibre `fibre` of yarn `yarn` [m]
    fn node_position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3;
    /// rest angle of its bending spring [rad]
    fn node_rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64;
    /// rest length of the fibre's elements [m]
    fn fibre_rest_length(&self, yarn: usize, fibre: usize) -> f64;
    fn held(&self, yarn: usize, position: &Vec3, k: u32) -> bool;
    fn strength(&self) -> f64;

    /// Builds the nodes `keep(yarn, k)` selects, ascending global id (fibre f, node k has
    /// id `f * stride + k`). Elements have their cell fibre's rest length l0; interior nodes
    /// carry `rho A l0`, chain ends half.
    fn build(&self, material: &FibreMaterial, keep: impl Fn(usize, u32) -> bool) -> Built {
        let sections = self.all_sections();
        let stride = self.stride() as u64;
        let mut nodes = Nodes::default();
        let mut elements = Elements::default();
        for yarn in 0..self.yarns() {
            let section = self.section_of(yarn);
            let nodes_per_fibre = self.nodes_of(yarn);
            let last = nodes_per_fibre - 1;
            let kept: Vec<u32> = (0..nodes_per_fibre).filter(|&k| keep(yarn, k)).collect();
            for fibre in 0..self.fibres_of(yarn) {
                let id = self.first_fibre_of(yarn) + fibre as u32;
                let rest = self.fibre_rest_length(yarn, fibre);
                let interior_mass = material.density * sections[section].area * rest;
                for &k in &kept {
                    let end = k == 0 || k == last;
                    let position = self.node_position(yarn, fibre, k);
                    nodes.push(
                        GlobalNodeId(id as u64 * stride + k as u64),
                        position,
                        Vec3::zeros(),
                        if end { 0.5 * interior_mass } else { interior_mass },
                        FibreId(id),
                        k,
                        section as u16,
                        self.held(yarn, &position, k),
                        k == last,
                    );
                    *nodes.rest_angle.last_mut().expect("just pushed") = self.node_rest_angle(yarn, fibre, k);
                    elements.push(if k == last { 0.0 } else { rest }, self.strength(), FailureMode::Intact);
                }
            }
        }
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        Built { sections, nodes, elements }
    }

    /// Builds every node (a whole domain, for single-domain use and tests).
    fn build_all(&self, material: &FibreMaterial) -> Built {
        self.build(material, |_, _| true)
    }

    /// Mass of one layer [kg]: every element of its fibres, `rho A l0`.
    fn layer_mass(&self, material: &FibreMaterial) -> f64 {
        let sections = self.all_sections();
        (0..self.yarns_in_layer())
            .map(|yarn| {
                let (area, elements) = (sections[self.section_of(yarn)].area, (self.nodes_of(yarn) - 1) as f64);
                (0..self.fibres_of(yarn)).map(|f| material.density * area * self.fibre_rest_length(yarn, f) * elements).sum::<f64>()
            })
            .sum()
    }

    /// Nodes of the whole panel.
    fn node_count(&self) -> u64 {
        (0..self.yarns()).map(|y| self.fibres_of(y) as u64 * self.nodes_of(y) as u64).sum()
    }

    /// Box of the node centres of yarn `yarn` between positions `first` and `last` [m].
    fn segment_box(&self, yarn: usize, first: u32, last: u32) -> (Vec3, Vec3) {
        let (mut low, mut high) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
        for fibre in 0..self.fibres_of(yarn) {
            for k in first..=last {
                let p = self.node_position(yarn, fibre, k);
                low = low.inf(&p);
                high = high.sup(&p);
            }
        }
        (low, high)
    }
}

impl Tiling for WovenPanel {
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
    fn section_of(&self, yarn: usize) -> usize {
        self.yarn_section(yarn)
    }
    fn all_sections(&self) -> Vec<FibreSection> {
        self.sections()
    }
    fn node_position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3 {
        self.position(yarn, fibre, k)
    }
    fn node_rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64 {
        self.rest_angle(yarn, fibre, k)
    }
    fn fibre_rest_length(&self, yarn: usize, fibre: usize) -> f64 {
        self.yarn_cell(yarn).rest_lengths[self.cell_fibre(yarn, fibre)]
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
    use crate::weave::PlainWeave;

    fn panel(cells: u32, layers: u32, fibres: usize) -> (WovenPanel, FibreMaterial) {
        let material = FibreMaterial::kevlar_km2();
        let cell = PlainWeave::km2_style_706(fibres).unit_cell(&material).unwrap();
        let panel = WovenPanel::new(Arc::new(cell), None, cells, layers, 0.0, [0.0, 0.0], Boundary::FixedEdges, 3.8e9);
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
        let (start, end) = (panel.position(0, 0, 0).x, panel.position(0, 0, panel.nodes_per_fibre(0) - 1).x);
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
        let keep = |y: usize, k: u32| (y + k as usize / 7).is_multiple_of(3);
        let piece = panel.build(&material, keep);
        let n = panel.gid_stride() as u64;
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

    fn hybrid(cells: u32, layers: u32, fine: usize, coarse: usize, shift: [f64; 2]) -> (WovenPanel, FibreMaterial) {
        let material = FibreMaterial::kevlar_km2();
        let cell = |fibres| Arc::new(PlainWeave::km2_style_706(fibres).unit_cell(&material).unwrap());
        let fine_cell = cell(fine);
        let s = fine_cell.yarn_spacing;
        let coarse = CoarseYarns { cell: cell(coarse), fine_half_width: 1.6 * s };
        (WovenPanel::new(fine_cell, Some(coarse), cells, layers, 0.0, shift, Boundary::FixedEdges, 3.8e9), material)
    }

    #[test]
    fn a_hybrid_panel_keeps_mass_and_axial_stiffness_per_length_across_the_transition() {
        let (panel, material) = hybrid(3, 2, 7, 1, [0.0, 0.0]);
        let built = panel.build_all(&material);
        let nodes = &built.nodes;
        let s = panel.cell.yarn_spacing;
        // fine: the yarns 0.5 s and 1.5 s from the centre, each way, in every layer
        let fine: Vec<usize> = (0..panel.yarn_count()).filter(|&y| !panel.is_coarse(y)).collect();
        assert_eq!(fine.len(), 2 * 2 * 4);
        for &y in &fine {
            let centre = panel.position(y, 0, 0);
            let across = if panel.place(y).direction == YarnDirection::Warp { centre.y } else { centre.x };
            assert!((across - panel.plan_centre()).abs() < 1.6 * s + panel.cell.section.contact_diameter);
        }
        assert_eq!(panel.first_fibres().last().copied(), Some((fine.len() * 7 + (panel.yarn_count() - fine.len())) as u32));
        // every yarn, fine or coarse: mass per unit of material length rho A_yarn, and the
        // summed axial stiffness E A_yarn, however its area is split into fibres
        let yarn_area = 4.63e-8;
        let first = panel.first_fibres();
        let mut per_yarn = vec![(0.0, 0.0, 0.0); panel.yarn_count()];
        for i in 0..nodes.len() {
            let yarn = first.partition_point(|&f| f <= nodes.fibre[i].0) - 1;
            let area = built.sections[nodes.section[i] as usize].area;
            assert_eq!(nodes.section[i] as usize, panel.yarn_section(yarn));
            let entry = &mut per_yarn[yarn];
            entry.0 += nodes.mass[i];
            entry.1 += built.elements.rest_length[i] * area / yarn_area;
            if nodes.along[i] == 0 {
                entry.2 += material.longitudinal_modulus * area;
            }
        }
        for (yarn, (mass, length, stiffness)) in per_yarn.iter().enumerate() {
            assert!((mass / length / (material.density * yarn_area) - 1.0).abs() < 1e-12, "yarn {yarn}");
            assert!((stiffness / (material.longitudinal_modulus * yarn_area) - 1.0).abs() < 1e-12, "yarn {yarn}");
        }
        // the panel's mass is its areal density's, and within the crimps' difference of a
        // uniform fine layer's
        let mass: f64 = nodes.mass.iter().sum();
        assert!((mass / (2.0 * panel.side() * panel.side() * panel.areal_density(&material)) - 1.0).abs() < 1e-12);
        assert!((panel.areal_density(&material) / panel.cell.areal_density(&material) - 1.0).abs() < 0.05);
        // global ids: unique, ascending, fibre f node k at f * stride + k
        assert!(nodes.gid.windows(2).all(|g| g[0] < g[1]));
        let stride = panel.gid_stride() as u64;
        assert!(nodes.gid.iter().zip(&nodes.fibre).zip(&nodes.along).all(|((g, f), k)| g.0 == f.0 as u64 * stride + *k as u64));
        assert_eq!(panel.node_count(), nodes.len() as u64);
        assert!(panel.fine_node_count() > 0 && panel.fine_node_count() < panel.node_count());
        // coarse fibres span the panel like the fine ones, with fewer, longer elements
        let last = |y: usize| panel.position(y, 0, panel.nodes_per_fibre(y) - 1).x - panel.position(y, 0, 0).x;
        let coarse = (0..panel.yarn_count()).find(|&y| panel.is_coarse(y)).unwrap();
        assert!((last(coarse) - panel.side()).abs() < 1e-12 && (last(fine[0]) - panel.side()).abs() < 1e-12);
        assert!(panel.nodes_per_fibre(coarse) < panel.nodes_per_fibre(fine[0]));
    }

    #[test]
    fn hybrid_layers_do_not_overlap_and_a_rank_builds_its_piece() {
        for shift in [[0.0, 0.0], [2e-4, 1e-4]] {
            let (panel, material) = hybrid(3, 2, 4, 1, shift);
            let built = panel.build_all(&material);
            let nodes = &built.nodes;
            let layer_of = |i: usize| panel.place(panel.first_fibres().partition_point(|&f| f <= nodes.fibre[i].0) - 1).layer;
            let distance = |i: usize, j: usize| 0.5 * (built.sections[nodes.section[i] as usize].contact_diameter + built.sections[nodes.section[j] as usize].contact_diameter);
            let mut closest = f64::INFINITY;
            for i in 0..nodes.len() {
                for j in 0..nodes.len() {
                    if layer_of(j) == layer_of(i) + 1 {
                        closest = closest.min((nodes.position[i] - nodes.position[j]).norm() / distance(i, j));
                    }
                }
            }
            assert!(closest >= 1.0 - 1e-12, "{shift:?}: layers {closest} contact distances apart");
            // where fine crosses coarse the two relaxed shapes may overlap: the panel says how much
            assert!(panel.largest_overlap_ratio() >= crate::relax::largest_overlap_ratio(&panel.cell));
            let keep = |y: usize, k: u32| (y + k as usize / 5).is_multiple_of(3);
            let piece = panel.build(&material, keep);
            let mut whole = built.nodes.gid.iter().enumerate();
            for i in 0..piece.nodes.len() {
                let (w, _) = whole.find(|(_, g)| **g == piece.nodes.gid[i]).expect("in the whole");
                assert_eq!(piece.nodes.position[i], nodes.position[w]);
                assert_eq!(piece.nodes.mass[i], nodes.mass[w]);
                assert_eq!(piece.nodes.section[i], nodes.section[w]);
            }
            let first = panel.first_fibres();
            let expected = (0..nodes.len()).filter(|&i| keep(first.partition_point(|&f| f <= nodes.fibre[i].0) - 1, nodes.along[i])).count();
            assert_eq!(piece.nodes.len(), expected);
        }
    }
}
