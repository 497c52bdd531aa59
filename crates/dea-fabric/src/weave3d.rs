//! 3-D woven unit cells (seed chapter 3: orthogonal, layer-to-layer and angle-interlock
//! weaves), built as the seed builds its fabrics: yarns laid out in the weave's topology,
//! split into digital fibres, then relaxed ([`crate::relax`]).
//!
//! The topology is a table of levels. Straight filler yarns (weft, along y) lie in
//! `filler_layers` layers at each of the cell's filler columns (x). Warp-direction yarns
//! (along x) stand in columns across the cell (y); each passes every filler column in one
//! of the `filler_layers + 1` gaps between filler layers (gap 0 below them all, gap L above
//! them all). A stuffer keeps one gap; a binder changes gap between filler columns and so
//! binds the filler layers: from the top to the bottom gap in an orthogonal weave, by two
//! gaps in a layer-to-layer weave, by one gap per column in an angle interlock.
//!
//! Between filler columns a binder's centreline turns on two circular arcs joined by a
//! straight run, every arc of a radius that keeps its innermost fibre a half contact
//! diameter from the centre of turning. Each fibre is offset from the centreline along the
//! path's normal, so a binder keeps its section where it runs steeply, and no fibre folds.
//! Nodes are spaced at equal chords along each fibre, so every element starts at the strain
//! of the initial tension (docs/theory.md F10).

use dea_core::material::{InertiaModel, SectionInertia};
use dea_core::{FibreMaterial, FibreSection, Vec3};

use crate::cell::{CellYarn, PeriodicCell, YarnDirection, YarnRole};
use crate::weave::elliptical_packing;

/// Why a 3-D weave cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum Weave3dError {
    /// The weave's layout is inconsistent.
    #[error("{0}")]
    Topology(String),
    /// A binder has no room to turn between filler columns.
    #[error("a filler yarn {filler_width:.3e} m wide leaves {room:.3e} m between filler columns, and a binder needs {needed:.3e} m there to turn (widen the pick spacing, narrow the filler with a smaller section_aspect, or thin the binder)")]
    NoRoomToTurn {
        /// [m]
        filler_width: f64,
        /// gap between filler columns [m]
        room: f64,
        /// room a binder needs to turn [m]
        needed: f64,
    },
    /// A binder cannot change gap this steeply.
    #[error("a binder changing gap by {levels} filler layer(s) cannot turn within {room:.3e} m between filler columns on arcs of radius {radius:.3e} m (widen the pick spacing)")]
    TooSteep {
        /// filler layers the binder changes gap by
        levels: u32,
        /// gap between filler columns [m]
        room: f64,
        /// radius of the binder's arcs [m]
        radius: f64,
    },
    /// Fibres of different yarns overlap.
    #[error("the yarns cannot be laid out apart: two fibres of different yarns stay {closest:.3e} m apart, under one contact diameter ({contact_diameter:.3e} m) (widen end_spacing_m or pick_spacing_m)")]
    Crowded {
        /// closest distance of two fibres of different yarns [m]
        closest: f64,
        /// [m]
        contact_diameter: f64,
    },
}

impl Weave3dError {
    /// The case field (under `target.weave`) the error is about; empty for the whole weave.
    pub fn field(&self) -> &'static str {
        match self {
            Weave3dError::Topology(_) | Weave3dError::Crowded { .. } => "",
            Weave3dError::NoRoomToTurn { .. } | Weave3dError::TooSteep { .. } => ".pick_spacing_m",
        }
    }

    /// The error as a case error message: `target.weave[.field]: why`.
    pub fn in_case(&self) -> String {
        format!("target.weave{}: {self}", self.field())
    }
}

/// The weaves of seed chapter 3 the generator knows by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pattern {
    /// stuffers in every inner gap of a column; beside it a binder from the top gap to the
    /// bottom one and back over two filler columns; then stuffers again and a binder in
    /// opposite phase, so that every filler column is bound on both faces
    Orthogonal,
    /// one binder per column, each wrapping two neighbouring filler layers (gap b + 2 to gap
    /// b and back), neighbouring columns in opposite phase
    LayerToLayer,
    /// a binder that passes one filler layer per column, top to bottom and back over
    /// `2 L` filler columns; a second column half a period out of phase
    AngleInterlock,
}

/// One warp-direction yarn: its role and its gap at every filler column.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarpPath {
    /// "stuffer" (one gap) or "binder"
    pub role: PathRole,
    /// the gap at each filler column, 0 (below every filler layer) to L (above them all)
    pub gaps: Vec<u32>,
}

/// Role of a warp-direction yarn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PathRole {
    /// a straight warp yarn between the filler layers
    Stuffer,
    /// a warp yarn that binds the filler layers together
    Binder,
}

/// A kind of yarn of the weave.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YarnKind {
    /// cross-section area of the whole yarn (seed Tables 3-3, 3-4) [m^2]
    pub area_m2: f64,
    /// width / thickness of the section its fibres are packed in [-]
    pub section_aspect: f64,
}

impl Pattern {
    /// The warp-direction columns of the pattern over `layers` filler layers (at least 2).
    pub fn columns(self, layers: u32) -> Vec<Vec<WarpPath>> {
        let binder = |gaps: Vec<u32>| WarpPath { role: PathRole::Binder, gaps };
        match self {
            Pattern::Orthogonal => {
                let stuffers: Vec<WarpPath> =
                    (1..layers).map(|g| WarpPath { role: PathRole::Stuffer, gaps: vec![g, g] }).collect();
                vec![stuffers.clone(), vec![binder(vec![layers, 0])], stuffers, vec![binder(vec![0, layers])]]
            }
            Pattern::LayerToLayer => (0..layers.saturating_sub(1))
                .map(|b| vec![binder(if b % 2 == 0 { vec![b + 2, b] } else { vec![b, b + 2] })])
                .collect(),
            Pattern::AngleInterlock => {
                let down: Vec<u32> = (0..2 * layers).map(|c| layers.abs_diff(c)).collect();
                let shifted: Vec<u32> =
                    (0..2 * layers as usize).map(|c| down[(c + layers as usize) % down.len()]).collect();
                vec![vec![binder(down)], vec![binder(shifted)]]
            }
        }
    }
}

/// A 3-D weave before relaxation (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct ThreeDWeave {
    /// layers of filler yarns (L)
    pub filler_layers: u32,
    /// the warp-direction columns across the cell, each a stack of yarns listed bottom to top
    pub columns: Vec<Vec<WarpPath>>,
    /// centre distance of neighbouring filler columns (along x) [m]
    pub pick_spacing: f64,
    /// centre distance of neighbouring warp-direction columns (along y) [m]
    pub end_spacing: f64,
    /// the filler (weft) yarns
    pub filler: YarnKind,
    /// digital fibres of a filler yarn; every digital fibre has the filler's fibre section,
    /// so a yarn of area A holds round(A / a) of them (at least one)
    pub filler_fibres: usize,
    /// the stuffer yarns
    pub stuffer: YarnKind,
    /// the binder yarns
    pub binder: YarnKind,
    /// target element length / digital fibre diameter [-]
    pub element_length_ratio: f64,
    /// tension of a filler yarn during relaxation; every digital fibre carries the same
    /// share (one stress in every yarn) [N]
    pub filler_tension: f64,
    /// bending model of the fibres, its friction weight (5-10) applied
    pub inertia: SectionInertia,
}

/// A warp-direction fibre's path: a dense polyline over one period, with its arc length.
struct Polyline {
    points: Vec<Vec3>,
    /// arc length at each point; the last entry is the length of the closed period
    length_at: Vec<f64>,
    closure: Vec3,
}

impl Polyline {
    fn new(points: Vec<Vec3>, closure: Vec3) -> Self {
        let mut length_at = Vec::with_capacity(points.len() + 1);
        length_at.push(0.0);
        for k in 0..points.len() {
            let next = if k + 1 == points.len() { points[0] + closure } else { points[k + 1] };
            length_at.push(length_at[k] + (next - points[k]).norm());
        }
        Self { points, length_at, closure }
    }

    fn length(&self) -> f64 {
        *self.length_at.last().expect("a length")
    }

    /// The point at arc length `t` (any real: periods repeat with the closure).
    fn at(&self, t: f64) -> Vec3 {
        let period = self.length();
        let wraps = (t / period).floor();
        let local = t - wraps * period;
        let k = self.length_at.partition_point(|&s| s <= local).clamp(1, self.points.len()) - 1;
        let next = if k + 1 == self.points.len() { self.points[0] + self.closure } else { self.points[k + 1] };
        let span = self.length_at[k + 1] - self.length_at[k];
        let fraction = if span > 0.0 { (local - self.length_at[k]) / span } else { 0.0 };
        self.points[k] + (next - self.points[k]) * fraction + self.closure * wraps
    }

    /// `n` stations one chord apart, the last one chord from the image of the first
    /// (bisection on the chord, each station from the last by bisection on the arc). Returns
    /// the stations and the chord [m].
    fn equal_chords(&self, n: u32) -> (Vec<Vec3>, f64) {
        let walk = |chord: f64| {
            let mut stations = Vec::with_capacity(n as usize);
            let mut t = 0.0;
            for _ in 0..n {
                let here = self.at(t);
                stations.push(here);
                // no chord is longer than its arc, and within two chords of arc the chord
                // grows with the arc (every fibre turns on a radius above half a chord)
                let (mut low, mut high) = (chord, 2.0 * chord);
                for _ in 0..60 {
                    let mid = 0.5 * (low + high);
                    if (self.at(t + mid) - here).norm() < chord {
                        low = mid;
                    } else {
                        high = mid;
                    }
                }
                t += 0.5 * (low + high);
            }
            (stations, t)
        };
        let (mut low, mut high) = (0.0, self.length() / n as f64);
        for _ in 0..60 {
            let mid = 0.5 * (low + high);
            if walk(mid).1 < self.length() {
                low = mid;
            } else {
                high = mid;
            }
        }
        let chord = 0.5 * (low + high);
        (walk(chord).0, chord)
    }
}

/// A centreline in the x–z plane sampled densely: (x, z, angle of the tangent to x).
type Centreline = Vec<(f64, f64, f64)>;

/// The turn between two heights over `room` along x, starting level at `(x0, z0)`: an arc
/// of `radius`, a straight run at angle `phi`, an arc back to level at (`x0 + room`, `z1`).
/// Appends samples `step` apart in arc length (the last point excluded).
fn turn(samples: &mut Centreline, (x0, z0): (f64, f64), z1: f64, room: f64, radius: f64, phi: f64, step: f64) {
    let sign = (z1 - z0).signum();
    let run = (room - 2.0 * radius * phi.sin()) / phi.cos();
    let arc = radius * phi;
    let total = 2.0 * arc + run;
    let count = (total / step).ceil().max(1.0) as usize;
    // the end of the first arc and the start of the second, relative to the start
    let (ax, az) = (radius * phi.sin(), radius * (1.0 - phi.cos()));
    for k in 0..count {
        let s = total * k as f64 / count as f64;
        let (dx, dz, angle) = if s < arc {
            let psi = s / radius;
            (radius * psi.sin(), radius * (1.0 - psi.cos()), psi)
        } else if s < arc + run {
            let along = s - arc;
            (ax + along * phi.cos(), az + along * phi.sin(), phi)
        } else {
            // the second arc, measured back from the end
            let psi = (total - s) / radius;
            (room - radius * psi.sin(), (z1 - z0).abs() - radius * (1.0 - psi.cos()), psi)
        };
        samples.push((x0 + dx, z0 + sign * dz, sign * angle));
    }
}

/// The angle of the straight run of a turn that rises `height` over `room` on arcs of
/// `radius`: `2 R (1 - cos phi) + L sin phi = height` with `L = (room - 2 R sin phi) / cos phi`.
/// `None` when the arcs alone cannot reach the height within the room.
fn turn_angle(height: f64, room: f64, radius: f64) -> Option<f64> {
    let rise = |phi: f64| 2.0 * radius * (1.0 - phi.cos()) + (room - 2.0 * radius * phi.sin()) / phi.cos() * phi.sin();
    let steepest =
        if room >= 2.0 * radius { std::f64::consts::FRAC_PI_2 * (1.0 - 1e-9) } else { (room / (2.0 * radius)).asin() };
    if rise(steepest) < height {
        return None;
    }
    let (mut low, mut high) = (0.0, steepest);
    for _ in 0..100 {
        let mid = 0.5 * (low + high);
        if rise(mid) < height {
            low = mid;
        } else {
            high = mid;
        }
    }
    Some(0.5 * (low + high))
}

/// The radius a binder turns on to rise `height` within `room`: as gentle as the room allows
/// (two arcs alone where they fit, otherwise arcs filling 90 % of the room around a steep
/// run), never under `tightest`. The fewer elements a turn bends over, the bumpier the
/// node-to-node contacts of its fibres and the slower the relaxation.
fn turn_radius(height: f64, room: f64, tightest: f64) -> f64 {
    let arcs_alone = (room * room + height * height) / (4.0 * height);
    arcs_alone.min(0.45 * room).max(tightest)
}

/// A packed section: its fibres' (across, up) offsets and its extents.
struct Packed {
    offsets: Vec<[f64; 2]>,
    /// across extent of the fibre surfaces [m]
    width: f64,
    /// up extent of the fibre surfaces [m]
    thickness: f64,
    /// largest |up| of a fibre centre [m]
    largest_up: f64,
}

fn pack(fibres: usize, contact_diameter: f64, aspect: f64) -> Packed {
    let offsets = elliptical_packing(fibres, contact_diameter, aspect);
    let extent = |axis: usize| {
        let (low, high) =
            offsets.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p[axis]), h.max(p[axis])));
        high - low + contact_diameter
    };
    let largest_up = offsets.iter().map(|p| p[1].abs()).fold(0.0, f64::max);
    Packed { width: extent(0), thickness: extent(1), largest_up, offsets }
}

impl ThreeDWeave {
    /// A weave of a named pattern with `filler_layers` layers and the given yarns, 0.5 N of
    /// filler tension, element length half a fibre diameter and bending by I_e with k1 = 0.8,
    /// k2 = 1 and mu = 0.3 (seed §5.3), as the plain weave's preset.
    #[allow(clippy::too_many_arguments)]
    pub fn of_pattern(
        pattern: Pattern,
        filler_layers: u32,
        pick_spacing: f64,
        end_spacing: f64,
        filler: YarnKind,
        filler_fibres: usize,
        stuffer: YarnKind,
        binder: YarnKind,
    ) -> Self {
        Self {
            filler_layers,
            columns: pattern.columns(filler_layers),
            pick_spacing,
            end_spacing,
            filler,
            filler_fibres,
            stuffer,
            binder,
            element_length_ratio: 0.5,
            filler_tension: 0.5,
            inertia: InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3),
        }
    }

    /// Filler columns of the cell (the length of every path).
    pub fn filler_columns(&self) -> usize {
        self.columns.iter().flatten().map(|p| p.gaps.len()).next().unwrap_or(0)
    }

    /// Area of one digital fibre [m^2].
    pub fn fibre_area(&self) -> f64 {
        self.filler.area_m2 / self.filler_fibres as f64
    }

    /// Digital fibres of a yarn of `kind`.
    pub fn fibres_of(&self, kind: &YarnKind) -> usize {
        ((kind.area_m2 / self.fibre_area()).round() as usize).max(1)
    }

    /// Checks the topology: at least two filler columns and layers, every path as long as
    /// the others with gaps in 0..=L, a stuffer on one gap, and the yarns of a column in
    /// strict bottom-to-top order at every filler column, at most one of them changing gap
    /// between two columns (so no two yarns of a column cross or run together steeply).
    pub fn check_topology(&self) -> Result<(), Weave3dError> {
        let fail = |message: String| Err(Weave3dError::Topology(message));
        let columns = self.filler_columns();
        if self.filler_layers < 1 || columns < 2 {
            return fail(format!(
                "a 3-D weave needs at least one filler layer and two filler columns, got {} and {columns}",
                self.filler_layers
            ));
        }
        if self.filler_fibres == 0 || self.columns.is_empty() || self.columns.iter().any(Vec::is_empty) {
            return fail("a 3-D weave needs filler fibres and at least one yarn in every warp-direction column".into());
        }
        for (k, column) in self.columns.iter().enumerate() {
            for (y, path) in column.iter().enumerate() {
                let at = format!("columns[{k}][{y}]");
                if path.gaps.len() != columns {
                    return fail(format!("{at}.gaps: {} gaps, but the first path has {columns}", path.gaps.len()));
                }
                if let Some(g) = path.gaps.iter().find(|&&g| g > self.filler_layers) {
                    return fail(format!("{at}.gaps: gap {g} above the top gap {}", self.filler_layers));
                }
                if path.role == PathRole::Stuffer && path.gaps.iter().any(|&g| g != path.gaps[0]) {
                    return fail(format!("{at}: a stuffer keeps one gap"));
                }
                if y > 0 && (0..columns).any(|c| path.gaps[c] <= column[y - 1].gaps[c]) {
                    return fail(format!("{at}: must lie above columns[{k}][{}] at every filler column (yarns of a column may not cross)", y - 1));
                }
            }
            for c in 0..columns {
                let moving = column.iter().filter(|p| p.gaps[c] != p.gaps[(c + 1) % columns]).count();
                if moving > 1 {
                    return fail(format!("columns[{k}]: {moving} yarns change gap between filler columns {c} and {} (put binders that move together in columns of their own)", (c + 1) % columns));
                }
            }
        }
        Ok(())
    }

    /// Builds the initial cell: filler layers stacked with their gaps, binders turning
    /// between filler columns, every fibre on its own path offset from its yarn's, nodes at
    /// equal chords, rest lengths shorter than the chords by the strain of the tension. The
    /// vertical clearance grows until no two fibres of different yarns are within a contact
    /// diameter.
    pub fn unit_cell(&self, material: &FibreMaterial) -> Result<PeriodicCell, Weave3dError> {
        self.check_topology()?;
        let area = self.fibre_area();
        let diameter = (4.0 * area / std::f64::consts::PI).sqrt();
        let stretch = 1.0 + self.filler_tension / self.filler_fibres as f64 / (material.longitudinal_modulus * area);
        let mut section = FibreSection::new(material, area, self.element_length_ratio * diameter, self.inertia);
        let (mut previous, mut clearance) = (Vec::new(), 1.0);
        for _ in 0..100 {
            let mut cell = self.lay_out(&section, clearance, stretch)?;
            let counts: Vec<u32> = cell.yarns.iter().map(|y| y.nodes_per_period).collect();
            let mean_rest = cell.rest_lengths.iter().sum::<f64>() / cell.rest_lengths.len() as f64;
            let longest_rest = cell.rest_lengths.iter().copied().fold(0.0, f64::max);
            let grown = FibreSection::new(material, area, mean_rest, self.inertia);
            // the contact diameter must cover the longest element's
            let needed = dea_core::material::modified_contact_diameter(diameter, longest_rest);
            if counts == previous && needed <= section.contact_diameter {
                cell.section = FibreSection { contact_diameter: section.contact_diameter, ..grown };
                let closest = crate::relax::closest_approach(&cell, |a, b| cell.fibre_yarn(a) != cell.fibre_yarn(b));
                if closest >= cell.section.contact_diameter {
                    return Ok(cell);
                }
                let ratio = cell.section.contact_diameter / closest;
                if clearance * ratio > 3.0 {
                    return Err(Weave3dError::Crowded { closest, contact_diameter: cell.section.contact_diameter });
                }
                clearance *= 1.001 * ratio;
            }
            previous = counts;
            section = FibreSection { contact_diameter: needed.max(section.contact_diameter), ..grown };
        }
        Err(Weave3dError::Topology("the element length of the laid-out yarns did not settle in 100 layouts".into()))
    }

    /// Lays the yarns out with fibres packed at the section's contact diameter and the
    /// vertical pitch of the layers scaled by `clearance`.
    fn lay_out(&self, section: &FibreSection, clearance: f64, stretch: f64) -> Result<PeriodicCell, Weave3dError> {
        let d = section.contact_diameter;
        let target_element = self.element_length_ratio * section.diameter;
        let filler = pack(self.filler_fibres, d, self.filler.section_aspect);
        let stuffer = pack(self.fibres_of(&self.stuffer), d, self.stuffer.section_aspect);
        let binder = pack(self.fibres_of(&self.binder), d, self.binder.section_aspect);
        let packed = |role: PathRole| match role {
            PathRole::Stuffer => &stuffer,
            PathRole::Binder => &binder,
        };
        let columns = self.filler_columns();
        let layers = self.filler_layers;
        // gap g lies at g p, filler layer j at (j + 1/2) p: a gap holds the thickest
        // warp-direction yarn, a filler layer a filler, each a contact diameter apart
        let thickest = self.columns.iter().flatten().map(|p| packed(p.role).thickness).fold(0.0, f64::max);
        let pitch = clearance * (thickest + filler.thickness);
        let gap_height = |g: u32| g as f64 * pitch;
        let period = [columns as f64 * self.pick_spacing, self.columns.len() as f64 * self.end_spacing];
        // a binder turns between filler columns, its innermost fibre on a radius of half a
        // contact diameter, a twentieth of a diameter clear of the fillers
        let margin = 0.05 * d;
        let room = self.pick_spacing - filler.width - 2.0 * margin;
        let tightest = binder.largest_up + 0.5 * d + margin;
        let binds =
            self.columns.iter().flatten().any(|p| p.role == PathRole::Binder && p.gaps.iter().any(|&g| g != p.gaps[0]));
        if binds && room <= 0.0 {
            return Err(Weave3dError::NoRoomToTurn {
                filler_width: filler.width,
                room: room.max(0.0),
                needed: 2.0 * tightest,
            });
        }
        let step = 0.02 * section.diameter;
        let (mut yarns, mut positions, mut rest_lengths) = (Vec::new(), Vec::new(), Vec::new());
        // fillers: straight along y, column c at x = c s, layer j up
        let filler_nodes = ((period[1] / target_element).round() as u32).max(4);
        let chord = period[1] / filler_nodes as f64;
        for c in 0..columns {
            for j in 0..layers {
                yarns.push(CellYarn {
                    direction: YarnDirection::Weft,
                    role: YarnRole::Filler,
                    fibres: filler.offsets.len(),
                    nodes_per_period: filler_nodes,
                });
                for offset in &filler.offsets {
                    positions.extend((0..filler_nodes).map(|k| {
                        Vec3::new(
                            c as f64 * self.pick_spacing + offset[0],
                            k as f64 * chord,
                            (j as f64 + 0.5) * pitch + offset[1],
                        )
                    }));
                    rest_lengths.push(chord / stretch);
                }
            }
        }
        // warp-direction yarns: level over each filler column, turning between them
        for (k, column) in self.columns.iter().enumerate() {
            let across = (k as f64 + 0.5) * self.end_spacing;
            for path in column {
                let mut centreline: Centreline = Vec::new();
                let half_plateau = 0.5 * (self.pick_spacing - room);
                for c in 0..columns {
                    let (x, z) = (c as f64 * self.pick_spacing, gap_height(path.gaps[c]));
                    let z_next = gap_height(path.gaps[(c + 1) % columns]);
                    let plateau_start = if c == 0 { x } else { x - half_plateau };
                    let samples = ((x + half_plateau - plateau_start) / step).ceil().max(1.0) as usize;
                    centreline.extend((0..samples).map(|s| {
                        (plateau_start + (x + half_plateau - plateau_start) * s as f64 / samples as f64, z, 0.0)
                    }));
                    if z_next == z {
                        let samples = (room / step).ceil().max(1.0) as usize;
                        centreline.extend(
                            (0..samples).map(|s| (x + half_plateau + room * s as f64 / samples as f64, z, 0.0)),
                        );
                    } else {
                        let levels = path.gaps[c].abs_diff(path.gaps[(c + 1) % columns]);
                        let radius = turn_radius((z_next - z).abs(), room, tightest);
                        let phi = turn_angle((z_next - z).abs(), room, radius).ok_or(Weave3dError::TooSteep {
                            levels,
                            room,
                            radius,
                        })?;
                        turn(&mut centreline, (x + half_plateau, z), z_next, room, radius, phi, step);
                    }
                    if c + 1 == columns {
                        // the last plateau ends where the first one's image starts
                        let start = x + self.pick_spacing - half_plateau;
                        let samples = (half_plateau / step).ceil().max(1.0) as usize;
                        centreline.extend((0..samples).map(|s| {
                            (start + half_plateau * s as f64 / samples as f64, gap_height(path.gaps[0]), 0.0)
                        }));
                    }
                }
                let section_of = packed(path.role);
                let centre = Polyline::new(
                    centreline.iter().map(|&(x, z, _)| Vec3::new(x, across, z)).collect(),
                    Vec3::new(period[0], 0.0, 0.0),
                );
                let nodes = ((centre.length() / target_element).round() as u32).max(4);
                let role = match path.role {
                    PathRole::Stuffer => YarnRole::Stuffer,
                    PathRole::Binder => YarnRole::Binder,
                };
                yarns.push(CellYarn {
                    direction: YarnDirection::Warp,
                    role,
                    fibres: section_of.offsets.len(),
                    nodes_per_period: nodes,
                });
                for offset in &section_of.offsets {
                    // offset along the path's normal (-sin a, 0, cos a), across along y
                    let fibre = Polyline::new(
                        centreline
                            .iter()
                            .map(|&(x, z, angle)| {
                                Vec3::new(x - offset[1] * angle.sin(), across + offset[0], z + offset[1] * angle.cos())
                            })
                            .collect(),
                        Vec3::new(period[0], 0.0, 0.0),
                    );
                    let (stations, chord) = fibre.equal_chords(nodes);
                    positions.extend(stations);
                    rest_lengths.push(chord / stretch);
                }
            }
        }
        let rest_angles = vec![0.0; positions.len()];
        let fibre_tension = self.filler_tension / self.filler_fibres as f64;
        Ok(PeriodicCell::new(period, yarns, section.clone(), positions, rest_lengths, rest_angles, fibre_tension)
            .expect("a laid-out cell fits its yarns"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relax::{relax, BendingAtRest, RelaxOptions};
    use dea_core::contact::NormalLaw;

    /// KM2 600 denier yarns: fillers of 4 digital fibres, stuffers alike, binders of half the
    /// area (2 fibres).
    fn km2_weave(pattern: Pattern, layers: u32) -> ThreeDWeave {
        let yarn = YarnKind { area_m2: 4.63e-8, section_aspect: 3.0 };
        ThreeDWeave::of_pattern(
            pattern,
            layers,
            1.0e-3,
            0.8e-3,
            yarn,
            4,
            yarn,
            YarnKind { area_m2: 2.315e-8, section_aspect: 2.0 },
        )
    }

    fn yarn_fibres(cell: &PeriodicCell, role: YarnRole) -> Vec<usize> {
        (0..cell.fibres()).filter(|&f| cell.yarns[cell.fibre_yarn(f)].role == role).collect()
    }

    #[test]
    fn patterns_have_the_seed_topologies() {
        let orthogonal = Pattern::Orthogonal.columns(3);
        let stuffers = vec![
            WarpPath { role: PathRole::Stuffer, gaps: vec![1, 1] },
            WarpPath { role: PathRole::Stuffer, gaps: vec![2, 2] },
        ];
        assert_eq!(
            orthogonal,
            vec![
                stuffers.clone(),
                vec![WarpPath { role: PathRole::Binder, gaps: vec![3, 0] }],
                stuffers,
                vec![WarpPath { role: PathRole::Binder, gaps: vec![0, 3] }]
            ]
        );
        let layer_to_layer = Pattern::LayerToLayer.columns(3);
        assert_eq!(layer_to_layer.iter().map(|c| c[0].gaps.clone()).collect::<Vec<_>>(), vec![vec![2, 0], vec![1, 3]]);
        let interlock = Pattern::AngleInterlock.columns(3);
        assert_eq!(interlock[0][0].gaps, vec![3, 2, 1, 0, 1, 2]);
        assert_eq!(interlock[1][0].gaps, vec![0, 1, 2, 3, 2, 1]);
        for pattern in [Pattern::Orthogonal, Pattern::LayerToLayer, Pattern::AngleInterlock] {
            km2_weave(pattern, 3).check_topology().unwrap();
        }
    }

    #[test]
    fn impossible_topologies_are_refused_with_the_path_named() {
        let mut weave = km2_weave(Pattern::Orthogonal, 3);
        // the binder beside the stuffers, in their column: it would cut through them
        let binder = weave.columns.pop().unwrap().pop().unwrap();
        weave.columns[0].push(binder);
        let error = weave.check_topology().unwrap_err().to_string();
        assert!(error.contains("columns[0][2]") && error.contains("cross"), "{error}");
        let mut weave = km2_weave(Pattern::Orthogonal, 3);
        weave.columns[1][0].gaps = vec![4, 0];
        assert!(weave.check_topology().unwrap_err().to_string().contains("columns[1][0].gaps: gap 4"));
        weave.columns[1][0].gaps = vec![3, 0, 1];
        assert!(weave.check_topology().unwrap_err().to_string().contains("3 gaps"));
        let mut weave = km2_weave(Pattern::Orthogonal, 3);
        weave.columns[0][0].gaps = vec![0, 1];
        assert!(weave.check_topology().unwrap_err().to_string().contains("a stuffer keeps one gap"));
        let mut weave = km2_weave(Pattern::LayerToLayer, 3);
        let second = weave.columns.pop().unwrap().pop().unwrap();
        weave.columns[0].insert(0, WarpPath { gaps: vec![0, 1], ..second });
        weave.columns[0][1].gaps = vec![2, 3];
        assert!(weave.check_topology().unwrap_err().to_string().contains("2 yarns change gap"));
        let mut weave = km2_weave(Pattern::Orthogonal, 3);
        weave.pick_spacing = 0.5e-3;
        assert!(matches!(weave.unit_cell(&FibreMaterial::kevlar_km2()), Err(Weave3dError::NoRoomToTurn { .. })));
    }

    #[test]
    fn a_turn_rises_its_height_within_its_room() {
        let (radius, step) = (1.0, 1e-3);
        for (height, room) in [(0.3, 3.0), (5.0, 2.5), (8.0, 2.1), (0.35, 1.2)] {
            let phi = turn_angle(height, room, radius).unwrap();
            let mut samples = Vec::new();
            turn(&mut samples, (0.0, 0.0), -height, room, radius, phi, step);
            let end = samples.last().unwrap();
            assert!(
                (end.0 - room).abs() < 2.0 * step && (end.1 + height).abs() < 2.0 * step,
                "{height} over {room}: ends at {end:?}"
            );
            // tangent continuity: neighbouring samples' angles and chord directions agree
            for w in samples.windows(2) {
                let chord_angle = (w[1].1 - w[0].1).atan2(w[1].0 - w[0].0);
                assert!((chord_angle - 0.5 * (w[0].2 + w[1].2)).abs() < 1e-3, "{w:?}");
            }
        }
        // arcs alone cannot rise more than 2 R (1 - cos phi) when the room is under 2 R
        assert!(turn_angle(1.0, 1.0, 1.0).is_none());
    }

    #[test]
    fn a_cell_is_woven_as_asked_with_its_yarns_apart() {
        let material = FibreMaterial::kevlar_km2();
        for pattern in [Pattern::Orthogonal, Pattern::LayerToLayer, Pattern::AngleInterlock] {
            let weave = km2_weave(pattern, 3);
            let cell = weave.unit_cell(&material).unwrap();
            let d = cell.section.contact_diameter;
            let closest = crate::relax::closest_approach(&cell, |a, b| cell.fibre_yarn(a) != cell.fibre_yarn(b));
            assert!(closest >= d, "{pattern:?}: {closest} < {d}");
            assert_eq!(cell.period, [weave.filler_columns() as f64 * 1.0e-3, weave.columns.len() as f64 * 0.8e-3]);
            // fillers and stuffers are straight; binders are crimped
            assert!(cell.crimp_of(YarnRole::Filler).unwrap().abs() < 1e-12);
            if let Some(crimp) = cell.crimp_of(YarnRole::Stuffer) {
                assert!(crimp.abs() < 1e-9, "{crimp}");
            }
            assert!(cell.crimp_of(YarnRole::Binder).unwrap() > 0.05);
            // equal chords along every fibre, rest lengths shorter by the tension's strain
            let strain = cell.fibre_tension / (material.longitudinal_modulus * cell.section.area);
            for f in 0..cell.fibres() {
                let nodes = cell.fibre_nodes(f);
                let length = cell.fibre_length(f);
                let chord = length / nodes.len() as f64;
                for i in nodes.start..nodes.end - 1 {
                    assert!(
                        ((cell.positions[i + 1] - cell.positions[i]).norm() / chord - 1.0).abs() < 1e-9,
                        "{pattern:?} fibre {f}"
                    );
                }
                assert!((chord / cell.rest_lengths[f] - 1.0 - strain).abs() < 1e-9);
            }
            // the mass is the yarns' linear density times their path
            let expected: f64 = cell
                .yarns
                .iter()
                .enumerate()
                .map(|(y, yarn)| {
                    let fibres: Vec<usize> = (0..cell.fibres()).filter(|&f| cell.fibre_yarn(f) == y).collect();
                    fibres.iter().map(|&f| material.density * cell.section.area * cell.fibre_length(f)).sum::<f64>()
                        / (1.0 + strain)
                        * yarn.fibres as f64
                        / fibres.len() as f64
                })
                .sum::<f64>()
                / (cell.period[0] * cell.period[1]);
            assert!((cell.areal_density(&material) / expected - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn an_orthogonal_binder_passes_over_the_top_filler_and_under_the_bottom_one() {
        let material = FibreMaterial::kevlar_km2();
        let cell = km2_weave(Pattern::Orthogonal, 3).unit_cell(&material).unwrap();
        let fillers = yarn_fibres(&cell, YarnRole::Filler);
        // the first binder (the second column) over the fillers at the first filler column
        let first_binder = cell.yarns.iter().position(|y| y.role == YarnRole::Binder).unwrap();
        let binder: Vec<usize> = (0..cell.fibres()).filter(|&f| cell.fibre_yarn(f) == first_binder).collect();
        let mean_z = |fibres: &[usize], near_x: f64| {
            let points: Vec<Vec3> = fibres
                .iter()
                .flat_map(|&f| cell.fibre_nodes(f).map(|i| cell.positions[i]))
                .filter(|p| (p.x - near_x).abs() < 0.1e-3)
                .collect();
            points.iter().map(|p| p.z).sum::<f64>() / points.len() as f64
        };
        let (top, bottom) = (
            fillers.iter().map(|&f| cell.position(f, 0).z).fold(f64::NEG_INFINITY, f64::max),
            fillers.iter().map(|&f| cell.position(f, 0).z).fold(f64::INFINITY, f64::min),
        );
        assert!(mean_z(&binder, 0.0) > top, "over the fillers at the first column");
        assert!(mean_z(&binder, 1.0e-3) < bottom, "under them at the second");
        // the stuffers lie between the filler layers: gaps 1 and 2 in each stuffer column
        let pitch = (cell.z_range().1 - cell.z_range().0) / 3.0;
        let stuffers: Vec<usize> = (0..cell.yarns.len()).filter(|&y| cell.yarns[y].role == YarnRole::Stuffer).collect();
        assert_eq!(stuffers.len(), 4);
        for (rank, &yarn) in stuffers.iter().enumerate() {
            let gap = (rank % 2 + 1) as f64;
            for f in (0..cell.fibres()).filter(|&f| cell.fibre_yarn(f) == yarn) {
                let z = cell.position(f, 0).z;
                assert!((z / pitch - gap).abs() < 0.5, "stuffer fibre {f} at {z} in gap {gap}");
            }
        }
    }

    #[test]
    fn relaxation_compacts_an_orthogonal_weave_and_keeps_its_yarns_apart() {
        let material = FibreMaterial::kevlar_km2();
        let law = NormalLaw::ElastoPlasticKm2;
        let weave = km2_weave(Pattern::Orthogonal, 2);
        let mut cell = weave.unit_cell(&material).unwrap();
        let options =
            RelaxOptions { tolerance: 1e-6, max_iterations: 400_000, bending_at_rest: BendingAtRest::Straight };
        let report = relax(&mut cell, &material, &law, &options).unwrap();
        assert!(report.final_residual_n <= 1e-6 * report.initial_residual_n, "{report:?}");
        // the binder's tension pulls the filler layers together
        assert!(
            report.after.thickness_m < report.before.thickness_m,
            "{} -> {}",
            report.before.thickness_m,
            report.after.thickness_m
        );
        assert!(
            report.largest_overlap_ratio < dea_core::stability::DESIGN_CONTACT_STRAIN,
            "{}",
            report.largest_overlap_ratio
        );
        let mut again = weave.unit_cell(&material).unwrap();
        relax(&mut again, &material, &law, &options).unwrap();
        assert_eq!(again, cell, "the same bits every time");
    }
}
