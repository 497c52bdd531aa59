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
use dea_core::tie::{Tie, TieEnd};
use dea_core::{Elements, FibreId, FibreMaterial, FibreSection, GlobalNodeId, Nodes, Vec3};

use crate::cell::PeriodicCell;
use crate::relax;
use crate::transition::{self, EndNode};
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
    Clamp {
        /// side of the square opening [m]
        opening_m: f64,
    },
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

/// Where a hybrid panel's yarns are fine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FineRegion {
    /// a yarn whose centreline passes within `half_width` of the panel's centre is fine over
    /// its whole length, the others coarse (the yarn-based mesh of seed Fig. 2-25) [m]
    Band {
        /// [m]
        half_width: f64,
    },
    /// a yarn is fine between its crossings within `radius` of the panel's centre and coarse
    /// beyond, its fine fibres tied to its coarse ones halfway between two crossings
    /// (docs/theory.md F12) [m]
    Disc {
        /// [m]
        radius: f64,
    },
}

/// The coarse yarns of a hybrid panel.
#[derive(Clone, Debug, PartialEq)]
pub struct CoarseYarns {
    /// the relaxed cell the coarse yarns repeat: the fine cell's weave with fewer, thicker
    /// digital fibres and longer elements (same yarn spacing and yarn area)
    pub cell: Arc<UnitCell>,
    /// where the yarns are fine
    pub fine: FineRegion,
}

/// A stretch of one panel yarn with one kind of fibres: the whole yarn, or, where a hybrid
/// panel's fine region is a disc, its fine middle or one of its coarse ends. The panel's
/// [`Tiling`] yarns are its pieces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    /// the panel yarn (layer, then warp before weft, then across)
    pub yarn: u32,
    /// made of the coarse fibres of a hybrid yarn
    pub coarse: bool,
    /// position of the piece's first node along a whole fibre of its kind
    pub start: u32,
    /// nodes of each of its fibres
    pub nodes: u32,
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
    /// stacked layers
    pub layers: u32,
    /// gap between the contact surfaces of neighbouring layers; 0 = touching [m]
    pub layer_gap: f64,
    /// in-plane shift of each layer relative to the one above (x, y) [m]
    pub layer_shift: [f64; 2],
    /// vertical distance between the node centres of neighbouring layers: the smallest at
    /// which no node of one layer is closer than its pair's contact distance plus the gap to
    /// a node of the next ([`touching_pitch`]) [m]
    pub layer_pitch: f64,
    /// how the panel is held
    pub boundary: Boundary,
    /// tensile strength given to every element before any Weibull sampling [Pa]
    pub tensile_strength: f64,
    /// fine nodes left out on the fine side of each transition of a yarn with a fine disc,
    /// so that no fine node touches a coarse one there ([`transition_nodes`])
    pub transition_nodes: u32,
    /// the pieces, ascending panel yarn and along it
    pieces: Vec<Piece>,
    /// the ties of a fine disc's transitions, ascending piece (none otherwise)
    ties: Vec<Tie>,
    /// global id of each piece's first fibre, plus the total at the end
    first_fibre: Vec<u32>,
}

/// How far a hybrid panel's transitions are from passing the force straight on
/// ([`WovenPanel::transition_quality`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct TransitionQuality {
    /// largest relative difference between a coarse fibre's area and the fine area tied to it [-]
    pub area_mismatch: f64,
    /// largest distance of a coarse fibre's tied fine ends' centre from its axis, over its
    /// contact diameter [-]
    pub eccentricity: f64,
}

/// Where a panel yarn lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct YarnPlace {
    /// the layer, 0 on top
    pub layer: u32,
    /// warp or weft
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

/// Position of node `k` of cell fibre `fibre` counted on past the cell's ends (negative
/// before its first node) [m].
fn unwrapped(cell: &UnitCell, fibre: usize, k: i64) -> Vec3 {
    let n = cell.nodes_per_period as i64;
    cell.position(fibre, k.rem_euclid(n) as u32) + cell.closure(fibre) * k.div_euclid(n) as f64
}

/// Fine nodes to leave out on the fine side of a transition halfway between two crossings,
/// where a coarse fibre's last node sits: the fewest that keep every fine node at least a
/// fine–coarse contact distance from every coarse node there, on either side and at either
/// kind of halfway point of every cell yarn. `None` when that leaves no fine node between
/// two neighbouring transitions.
pub fn transition_nodes(fine: &UnitCell, coarse: &UnitCell) -> Option<u32> {
    let reach = 0.5 * (fine.section.contact_diameter + coarse.section.contact_diameter);
    let (n_fine, n_coarse) = (fine.nodes_per_period as i64, coarse.nodes_per_period as i64);
    let clear = |t: i64| {
        (0..4).all(|yarn| {
            [1, 3].iter().all(|&quarter| {
                let coarse_nodes: Vec<Vec3> = (0..coarse.fibres_per_yarn).map(|c| unwrapped(coarse, yarn * coarse.fibres_per_yarn + c, quarter * n_coarse / 4)).collect();
                (0..fine.fibres_per_yarn).all(|f| {
                    [quarter * n_fine / 4 - t, quarter * n_fine / 4 + t].iter().all(|&k| {
                        let p = unwrapped(fine, yarn * fine.fibres_per_yarn + f, k);
                        coarse_nodes.iter().all(|q| (p - q).norm() >= reach)
                    })
                })
            })
        })
    };
    let t = (1..=n_fine / 4).find(|&t| clear(t))?;
    (4 * t < n_fine).then_some(t as u32)
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
        let transition_nodes = match &coarse {
            Some(CoarseYarns { cell: coarse, fine: FineRegion::Disc { .. } }) => transition_nodes(&cell, coarse).expect("the caller checks that the transition fits (transition_nodes)"),
            _ => 0,
        };
        let mut panel = Self {
            cell,
            coarse,
            cells,
            layers,
            layer_gap: gap,
            layer_shift: shift,
            layer_pitch,
            boundary,
            tensile_strength,
            transition_nodes,
            pieces: Vec::new(),
            ties: Vec::new(),
            first_fibre: Vec::new(),
        };
        panel.pieces = (0..panel.panel_yarns()).flat_map(|yarn| panel.pieces_of(yarn)).collect();
        panel.first_fibre = first_fibres(panel.yarn_count(), |yarn| panel.yarn_fibres(yarn));
        panel.ties = panel.tie_transitions();
        panel
    }

    /// The ties of a fine disc's transitions (`Self::tie_transitions`).
    pub fn ties(&self) -> &[Tie] {
        &self.ties
    }

    /// Panel yarns of one layer: `2 cells` warp yarns, then `2 cells` weft yarns.
    fn panel_yarns_per_layer(&self) -> usize {
        4 * self.cells as usize
    }

    /// Panel yarns of all layers.
    pub fn panel_yarns(&self) -> usize {
        self.panel_yarns_per_layer() * self.layers as usize
    }

    /// Nodes of a whole fibre of the coarse or the fine kind.
    fn whole_fibre_nodes(&self, coarse: bool) -> u32 {
        self.cells * self.kind_cell(coarse).nodes_per_period + 1
    }

    fn kind_cell(&self, coarse: bool) -> &UnitCell {
        match &self.coarse {
            Some(c) if coarse => &c.cell,
            _ => &self.cell,
        }
    }

    /// The pieces of panel yarn `yarn`, along it.
    fn pieces_of(&self, yarn: usize) -> Vec<Piece> {
        let whole = |coarse: bool| Piece { yarn: yarn as u32, coarse, start: 0, nodes: self.whole_fibre_nodes(coarse) };
        let Some(coarse) = &self.coarse else {
            return vec![whole(false)];
        };
        let index = self.panel_place(yarn).index as f64;
        let s = self.cell.yarn_spacing;
        // from the panel's centre: the yarn's centreline, and its crossings, in its layer's own
        // frame (before the layer's shift); yarn i of either direction lies at (i - cells + 1/2) s
        let from_centre = |i: f64| (i - self.cells as f64 + 0.5) * s;
        let across = from_centre(index);
        match coarse.fine {
            FineRegion::Band { half_width } => vec![whole(across.abs() > half_width)],
            FineRegion::Disc { radius } => {
                let crossings = 2 * self.cells;
                let fine: Vec<u32> = (0..crossings).filter(|&i| from_centre(i as f64).hypot(across) <= radius).collect();
                let (Some(&first), Some(&last)) = (fine.first(), fine.last()) else {
                    return vec![whole(true)];
                };
                // halfway points between crossings: node i n / 2 of a whole fibre
                let halfway = |coarse: bool, i: u32| i * self.kind_cell(coarse).nodes_per_period / 2;
                let t = self.transition_nodes;
                let fine_start = if first > 0 { halfway(false, first) + t } else { 0 };
                let fine_end = if last + 1 < crossings { halfway(false, last + 1) - t } else { self.whole_fibre_nodes(false) - 1 };
                let mut pieces = Vec::new();
                if first > 0 {
                    pieces.push(Piece { yarn: yarn as u32, coarse: true, start: 0, nodes: halfway(true, first) + 1 });
                }
                pieces.push(Piece { yarn: yarn as u32, coarse: false, start: fine_start, nodes: fine_end - fine_start + 1 });
                if last + 1 < crossings {
                    let start = halfway(true, last + 1);
                    pieces.push(Piece { yarn: yarn as u32, coarse: true, start, nodes: self.whole_fibre_nodes(true) - start });
                }
                pieces
            }
        }
    }

    /// The panel's pieces, ascending panel yarn and along it.
    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// Pieces of one layer (every layer has the same).
    pub fn yarns_per_layer(&self) -> usize {
        self.pieces.len() / self.layers as usize
    }

    /// Pieces of the panel: the yarns the panel is built and partitioned by.
    pub fn yarn_count(&self) -> usize {
        self.pieces.len()
    }

    /// Layer, direction and index of panel yarn `yarn`.
    fn panel_place(&self, yarn: usize) -> YarnPlace {
        let per_layer = self.panel_yarns_per_layer();
        let (layer, within) = (yarn / per_layer, yarn % per_layer);
        let half = 2 * self.cells as usize;
        let (direction, index) = if within < half { (YarnDirection::Warp, within) } else { (YarnDirection::Weft, within - half) };
        YarnPlace { layer: layer as u32, direction, index: index as u32 }
    }

    /// Layer, direction and index of the panel yarn piece `yarn` belongs to.
    pub fn place(&self, yarn: usize) -> YarnPlace {
        self.panel_place(self.pieces[yarn].yarn as usize)
    }

    /// Whether piece `yarn` is coarse (only in a hybrid panel).
    pub fn is_coarse(&self, yarn: usize) -> bool {
        self.pieces[yarn].coarse
    }

    /// The relaxed cell piece `yarn` repeats.
    pub fn yarn_cell(&self, yarn: usize) -> &UnitCell {
        self.kind_cell(self.is_coarse(yarn))
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

    /// Nodes of every fibre of piece `yarn` (of a whole yarn: `cells` periods plus the
    /// closing node).
    pub fn nodes_per_fibre(&self, yarn: usize) -> u32 {
        self.pieces[yarn].nodes
    }

    /// Global ids of fibre `f` are `f * stride + k`: the most nodes any fibre has.
    pub fn gid_stride(&self) -> u32 {
        self.whole_fibre_nodes(false).max(self.whole_fibre_nodes(self.coarse.is_some()))
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

    /// Position of node `k` of fibre `fibre` (within its yarn) of piece `yarn` [m].
    pub fn position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3 {
        let (node, stack, offset) = self.cell_place(yarn, k);
        stack + self.yarn_cell(yarn).position(self.cell_fibre(yarn, fibre), node) + offset
    }

    /// Where node `k` of piece `yarn`'s fibres comes from: the cell node it repeats, the
    /// layer's place in the stack and the cell's translation in the layer [m]. The position
    /// is `stack + cell position + offset`, summed in that order.
    fn cell_place(&self, yarn: usize, k: u32) -> (u32, Vec3, Vec3) {
        let place = self.place(yarn);
        let cell = self.yarn_cell(yarn);
        let k = k + self.pieces[yarn].start;
        let n = cell.nodes_per_period;
        let (period, origin) = (cell.period(), self.origin());
        // fibres start a quarter period into the cell (halfway between crossings), so the
        // panel's node k is the cell's node k + 3n/4 one period back
        let shifted = k + 3 * n / 4;
        let along = (shifted / n) as f64 * period - period + origin;
        let across = (place.index / 2) as f64 * period + origin;
        let layer = place.layer as f64;
        let stack = Vec3::new(layer * self.layer_shift[0], layer * self.layer_shift[1], -layer * self.layer_pitch);
        let offset = match place.direction {
            YarnDirection::Warp => Vec3::new(along, across, 0.0),
            YarnDirection::Weft => Vec3::new(across, along, 0.0),
        };
        (shifted % n, stack, offset)
    }

    /// Rest angle of the bending spring at node `k` of fibre `fibre` of piece `yarn` [rad].
    pub fn rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64 {
        let cell = self.yarn_cell(yarn);
        let n = cell.nodes_per_period;
        let k = k + self.pieces[yarn].start;
        cell.rest_angles[self.cell_fibre(yarn, fibre) * n as usize + ((k + 3 * n / 4) % n) as usize]
    }

    /// Whether node `k` of a fibre of piece `yarn`, at `position`, is held by the boundary.
    pub fn clamped(&self, yarn: usize, position: &Vec3, k: u32) -> bool {
        let centre = self.plan_centre();
        let piece = &self.pieces[yarn];
        self.boundary.holds([position.x - centre, position.y - centre], piece.start + k, self.whole_fibre_nodes(piece.coarse))
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
    /// that of each relaxed cell, and where a band hybrid's fine and coarse yarns cross.
    pub fn largest_overlap_ratio(&self) -> f64 {
        let mut largest = relax::largest_overlap_ratio(&self.cell);
        if let Some(coarse) = &self.coarse {
            largest = largest.max(relax::largest_overlap_ratio(&coarse.cell));
            let period = self.cell.period();
            // in a fine disc both yarns of a crossing are of one kind
            let mixed_crossings = matches!(coarse.fine, FineRegion::Band { .. });
            for (warp, weft) in [(&*self.cell, &*coarse.cell), (&*coarse.cell, &*self.cell)].into_iter().filter(|_| mixed_crossings) {
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

    /// The ties of every transition from a fine piece to a coarse one (docs/theory.md F12):
    /// each fine fibre's end node joined to the coarse fibres' ends there
    /// ([`transition::transition_ties`]: every coarse fibre receives its own area, centred on
    /// its axis as far as the two kinds' centres allow). A tie stands for the fine fibre's
    /// elements left out, so the yarn's mass per unit of plan length is that of its fine or
    /// coarse kind on either side of the transition's station.
    fn tie_transitions(&self) -> Vec<Tie> {
        let stride = self.gid_stride() as u64;
        let mut ties = Vec::new();
        for p in 1..self.pieces.len() {
            let (before, after) = (self.pieces[p - 1], self.pieces[p]);
            if before.yarn != after.yarn {
                continue;
            }
            // the coarse end element: its end node at the transition and the node inside
            let ((fine, fine_k), (coarse, coarse_k, next_k)) = if before.coarse { ((p, 0), (p - 1, before.nodes - 1, before.nodes - 2)) } else { ((p - 1, before.nodes - 1), (p, 0, 1)) };
            let end = |piece: usize, fibre: usize, along: u32| {
                let f = self.first_fibre[piece] + fibre as u32;
                TieEnd { gid: GlobalNodeId(f as u64 * stride + along as u64), fibre: FibreId(f), along }
            };
            let at = |piece: usize, fibre: usize, along: u32| EndNode { end: end(piece, fibre, along), at: self.position(piece, fibre, along) };
            let fine_ends: Vec<(EndNode, f64)> = (0..self.yarn_fibres(fine)).map(|f| (at(fine, f, fine_k), self.transition_nodes as f64 * self.fibre_rest_length(fine, f))).collect();
            let coarse_ends: Vec<(EndNode, EndNode)> = (0..self.yarn_fibres(coarse)).map(|c| (at(coarse, c, coarse_k), at(coarse, c, next_k))).collect();
            ties.extend(transition::transition_ties(&fine_ends, &coarse_ends, self.cell.section.area, 2.0 * self.cell.section.contact_diameter));
        }
        ties
    }

    /// Position of a node named by its fibre's global id and its place along it [m].
    fn node_at(&self, end: &TieEnd) -> Vec3 {
        let piece = self.first_fibre.partition_point(|&f| f <= end.fibre.0) - 1;
        self.position(piece, (end.fibre.0 - self.first_fibre[piece]) as usize, end.along)
    }

    /// How far the transitions of a fine disc are from passing the yarn's force straight on
    /// (docs/theory.md F12), over every coarse fibre that ends at one: the largest relative
    /// difference between its area and the fine area tied to it, and the largest distance of
    /// the (area-weighted) centre of its tied fine ends from its axis, over its contact
    /// diameter. Either bends the coarse fibres' ends and reflects part of a wave. Both 0
    /// without ties.
    pub fn transition_quality(&self) -> TransitionQuality {
        let Some(coarse) = &self.coarse else {
            return TransitionQuality::default();
        };
        let mut groups: std::collections::BTreeMap<GlobalNodeId, (f64, Vec3)> = Default::default();
        for tie in &self.ties {
            let offset = Tie::offset_across(&self.node_at(&tie.fine), &self.node_at(&tie.coarse), &self.node_at(&tie.coarse_next));
            let group = groups.entry(tie.coarse.gid).or_insert((0.0, Vec3::zeros()));
            group.0 += tie.area;
            group.1 += offset * tie.area;
        }
        let section = &coarse.cell.section;
        groups.values().fold(TransitionQuality::default(), |q, (area, moment)| TransitionQuality {
            area_mismatch: q.area_mismatch.max((area / section.area - 1.0).abs()),
            eccentricity: q.eccentricity.max((moment / *area).norm() / section.contact_diameter),
        })
    }

    /// Warp yarns of one layer that are fine somewhere (all of them unless hybrid).
    pub fn fine_yarns_per_layer(&self) -> usize {
        let warp = 2 * self.cells;
        let fine: std::collections::BTreeSet<u32> = self.pieces.iter().filter(|p| !p.coarse && p.yarn < warp).map(|p| p.yarn).collect();
        fine.len()
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
    /// Yarns of the whole panel (its pieces, for a hybrid disc).
    fn yarns(&self) -> usize;
    /// yarns of one layer (the first `yarns_in_layer()` yarns are layer 0)
    fn yarns_in_layer(&self) -> usize;
    /// Digital fibres of yarn `yarn`.
    fn fibres_of(&self, yarn: usize) -> usize;
    /// Global id of the first fibre of yarn `yarn`.
    fn first_fibre_of(&self, yarn: usize) -> u32;
    /// Nodes of each fibre of yarn `yarn`.
    fn nodes_of(&self, yarn: usize) -> u32;
    /// Nodes reserved per fibre in the global numbering.
    fn stride(&self) -> u32;
    /// Index of yarn `yarn`'s fibre section in [`Self::all_sections`].
    fn section_of(&self, yarn: usize) -> usize;
    /// Every fibre section of the panel.
    fn all_sections(&self) -> Vec<FibreSection>;
    /// position of node `k` of fibre `fibre` of yarn `yarn` [m]
    fn node_position(&self, yarn: usize, fibre: usize, k: u32) -> Vec3;
    /// rest angle of its bending spring [rad]
    fn node_rest_angle(&self, yarn: usize, fibre: usize, k: u32) -> f64;
    /// rest length of the fibre's elements [m]
    fn fibre_rest_length(&self, yarn: usize, fibre: usize) -> f64;
    /// Whether node `k` of a fibre of yarn `yarn`, at `position` [m], is held fixed.
    fn held(&self, yarn: usize, position: &Vec3, k: u32) -> bool;
    /// Tensile strength of every element before any Weibull sampling [Pa].
    fn strength(&self) -> f64;
    /// Ties joining fine fibres to coarse ones along a yarn (none unless a hybrid has them).
    fn ties(&self) -> &[Tie] {
        &[]
    }

    /// Builds the nodes `keep(yarn, k)` selects, ascending global id (fibre f, node k has
    /// id `f * stride + k`). Elements have their cell fibre's rest length l0; interior nodes
    /// carry `rho A l0`, chain ends half, and each end of a tie half the tie's mass. The
    /// ties with a kept end come along.
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
        let mut ties = self.ties().to_vec();
        ties.retain(|tie| {
            let mut kept = false;
            for gid in [tie.fine.gid, tie.coarse.gid] {
                if let Ok(i) = nodes.gid.binary_search(&gid) {
                    nodes.mass[i] += 0.5 * tie.mass(material);
                    kept = true;
                }
            }
            kept
        });
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        Built { sections, nodes, elements, ties }
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
        dea_core::bounding_box((0..self.fibres_of(yarn)).flat_map(|fibre| (first..=last).map(move |k| self.node_position(yarn, fibre, k))))
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
    fn ties(&self) -> &[Tie] {
        WovenPanel::ties(self)
    }
    /// The box of a segment from the box of each cell node over its yarn's fibres: a node's
    /// position is monotone in its cell position, so the bits are those of the box over every
    /// node, for a fraction of the work.
    fn segment_box(&self, yarn: usize, first: u32, last: u32) -> (Vec3, Vec3) {
        let cell = self.yarn_cell(yarn);
        let fibres = self.cell_fibre(yarn, 0)..self.cell_fibre(yarn, self.yarn_fibres(yarn));
        dea_core::bounding_box((first..=last).flat_map(|k| {
            let (node, stack, offset) = self.cell_place(yarn, k);
            let (low, high) = dea_core::bounding_box(fibres.clone().map(|fibre| cell.position(fibre, node)));
            [stack + low + offset, stack + high + offset]
        }))
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
        let coarse = CoarseYarns { cell: cell(coarse), fine: FineRegion::Band { half_width: 1.6 * s } };
        (WovenPanel::new(fine_cell, Some(coarse), cells, layers, 0.0, shift, Boundary::FixedEdges, 3.8e9), material)
    }

    fn disc(cells: u32, layers: u32, fine: usize, coarse: usize, radius_in_spacings: f64) -> (WovenPanel, FibreMaterial) {
        let material = FibreMaterial::kevlar_km2();
        let cell = |fibres| Arc::new(PlainWeave::km2_style_706(fibres).unit_cell(&material).unwrap());
        let fine_cell = cell(fine);
        let s = fine_cell.yarn_spacing;
        let coarse = CoarseYarns { cell: cell(coarse), fine: FineRegion::Disc { radius: radius_in_spacings * s } };
        (WovenPanel::new(fine_cell, Some(coarse), cells, layers, 0.0, [0.0, 0.0], Boundary::FixedEdges, 3.8e9), material)
    }

    #[test]
    fn a_fine_disc_ties_every_fine_fibre_and_keeps_mass_and_stiffness_per_length() {
        for (fine, coarse) in [(7, 1), (7, 4)] {
            let (panel, material) = disc(3, 1, fine, coarse, 1.6);
            let built = panel.build_all(&material);
            let nodes = &built.nodes;
            let yarn_area = 4.63e-8;
            // crossings within 1.6 s of the centre: the middle yarns are fine across two
            // crossings each side of it, the outer ones across none
            let pieces = panel.pieces();
            let per_yarn = |y: u32| pieces.iter().filter(|p| p.yarn == y).count();
            assert_eq!((0..6).map(per_yarn).collect::<Vec<_>>(), [1, 3, 3, 3, 3, 1], "{fine}/{coarse}");
            let fine_pieces: Vec<usize> = (0..pieces.len()).filter(|&p| !pieces[p].coarse).collect();
            let ties = panel.ties();
            assert_eq!(ties, built.ties);
            // every fine end of a transition tied with its whole area, to coarse ends of its
            // own yarn; every coarse end receives its own area, centred on its axis as far as
            // the two kinds' centres allow
            let piece_of = |f: FibreId| panel.first_fibres().partition_point(|&x| x <= f.0) - 1;
            let mut by_fine: std::collections::BTreeMap<GlobalNodeId, f64> = Default::default();
            let mut by_coarse: std::collections::BTreeMap<GlobalNodeId, f64> = Default::default();
            for tie in ties {
                let (f, c) = (piece_of(tie.fine.fibre), piece_of(tie.coarse.fibre));
                assert!(!pieces[f].coarse && pieces[c].coarse && pieces[f].yarn == pieces[c].yarn);
                assert!(tie.fine.along == 0 || tie.fine.along + 1 == pieces[f].nodes);
                *by_fine.entry(tie.fine.gid).or_default() += tie.area;
                *by_coarse.entry(tie.coarse.gid).or_default() += tie.area;
                let at = |e: &TieEnd| nodes.position[nodes.gid.binary_search(&e.gid).unwrap()];
                assert_eq!(Tie::rest_geometry(&at(&tie.fine), &at(&tie.coarse), &at(&tie.coarse_next)), (tie.axial_length, tie.radial_offset));
                assert!(tie.axial_length > 0.0 && tie.coarse_next.fibre == tie.coarse.fibre && tie.coarse_next.along.abs_diff(tie.coarse.along) == 1);
            }
            assert_eq!(by_fine.len(), fine_pieces.len() * 2 * fine, "{fine}/{coarse}");
            assert_eq!(by_coarse.len(), fine_pieces.len() * 2 * coarse, "{fine}/{coarse}");
            assert!(by_fine.values().all(|a| (a / (yarn_area / fine as f64) - 1.0).abs() < 1e-12));
            // a single coarse fibre sits near the fine fibres' centre; four have their own
            // centre, and the difference bends their ends (docs/theory.md F12)
            let quality = panel.transition_quality();
            assert!(quality.area_mismatch < 1e-5, "{fine}/{coarse}: {quality:?}");
            assert!(coarse > 1 || quality.eccentricity < 0.15, "{fine}/{coarse}: {quality:?}");
            // mass per unit of material length rho A_yarn along every panel yarn, ties
            // included: the nodes carry their elements' mass and half of each tie's
            let mut mass = vec![0.0; panel.panel_yarns()];
            let mut length = vec![0.0; panel.panel_yarns()];
            for i in 0..nodes.len() {
                let yarn = pieces[piece_of(nodes.fibre[i])].yarn as usize;
                mass[yarn] += nodes.mass[i];
                length[yarn] += built.elements.rest_length[i] * built.sections[nodes.section[i] as usize].area / yarn_area;
            }
            for tie in ties {
                length[pieces[piece_of(tie.fine.fibre)].yarn as usize] += tie.fibre_length * tie.area / yarn_area;
            }
            // per unit of plan length: each kind's between the halfway stations where it ends
            // (every half period of either kind holds exactly half its cell's elements)
            let per_plan = |cell: &UnitCell| {
                material.density * yarn_area * cell.rest_lengths[..cell.fibres_per_yarn].iter().sum::<f64>() / cell.fibres_per_yarn as f64 * cell.nodes_per_period as f64 / cell.period()
            };
            let (fine_mass, coarse_mass) = (per_plan(&panel.cell), per_plan(&panel.coarse.as_ref().unwrap().cell));
            let s = panel.cell.yarn_spacing;
            for yarn in 0..panel.panel_yarns() {
                assert!((mass[yarn] / length[yarn] / (material.density * yarn_area) - 1.0).abs() < 1e-12, "yarn {yarn}");
                let span = |coarse: bool| {
                    let stations = |p: &Piece| (p.start, p.start + p.nodes - 1);
                    pieces
                        .iter()
                        .filter(|p| p.yarn == yarn as u32 && p.coarse == coarse)
                        .map(|p| {
                            let n = panel.kind_cell(coarse).nodes_per_period;
                            // the fine piece's ends lie t nodes inside its stations
                            let (first, last) = stations(p);
                            let (first, last) = if coarse {
                                (first, last)
                            } else {
                                (first.saturating_sub(if first > 0 { panel.transition_nodes } else { 0 }), if last + 1 < panel.whole_fibre_nodes(false) { last + panel.transition_nodes } else { last })
                            };
                            (last - first) as f64 / (n / 2) as f64 * s
                        })
                        .sum::<f64>()
                };
                let expected = fine_mass * span(false) + coarse_mass * span(true);
                assert!((mass[yarn] / expected - 1.0).abs() < 1e-12, "{fine}/{coarse} yarn {yarn}: {} vs {expected}", mass[yarn]);
            }
            // no fine node touches a coarse one of its own yarn at a transition
            let reach = 0.5 * (built.sections[0].contact_diameter + built.sections[1].contact_diameter);
            for i in 0..nodes.len() {
                for j in 0..nodes.len() {
                    let (a, b) = (pieces[piece_of(nodes.fibre[i])], pieces[piece_of(nodes.fibre[j])]);
                    if a.yarn == b.yarn && !a.coarse && b.coarse {
                        assert!((nodes.position[i] - nodes.position[j]).norm() >= reach, "{fine}/{coarse}: nodes {:?} and {:?}", nodes.gid[i], nodes.gid[j]);
                    }
                }
            }
            // a rank builds its piece with the masses and ties of its nodes
            let keep = |y: usize, k: u32| (y + k as usize / 5).is_multiple_of(3);
            let part = panel.build(&material, keep);
            for i in 0..part.nodes.len() {
                let w = nodes.gid.binary_search(&part.nodes.gid[i]).unwrap();
                assert_eq!(part.nodes.mass[i], nodes.mass[w]);
            }
            let kept = |e: &TieEnd| keep(piece_of(e.fibre), e.along);
            assert_eq!(part.ties, ties.iter().filter(|t| kept(&t.fine) || kept(&t.coarse)).copied().collect::<Vec<_>>());
        }
    }

    #[test]
    fn a_segment_box_is_the_box_of_its_nodes_to_the_bit() {
        let (mut panel, _) = disc(3, 2, 7, 1, 1.6);
        panel.layer_shift = [1e-4, -3e-5];
        let panel = &panel;
        for yarn in 0..panel.yarn_count() {
            let nodes = panel.nodes_per_fibre(yarn);
            for (first, last) in [(0, nodes - 1), (1, nodes / 2), (nodes / 3, nodes / 3)] {
                let every_node = dea_core::bounding_box((0..panel.yarn_fibres(yarn)).flat_map(|fibre| (first..=last).map(move |k| panel.position(yarn, fibre, k))));
                assert_eq!(panel.segment_box(yarn, first, last), every_node, "piece {yarn} nodes {first}..={last}");
            }
        }
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
