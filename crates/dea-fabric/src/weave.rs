//! Plain-weave topology (seed §3.1, §2.3.3): the unit cell of two warp and two weft yarns,
//! each yarn a bundle of digital fibres packed in a flat section, laid on a sinusoidal path
//! whose amplitude keeps the crossing yarns apart. The cell is the starting point of the
//! periodic relaxation ([`crate::relax`]).

use dea_core::material::{InertiaModel, SectionInertia};
use std::ops::{Deref, DerefMut};

use dea_core::{FibreMaterial, FibreSection, Vec3};

pub use crate::cell::{CellStatistics, YarnDirection};
use crate::cell::{CellYarn, PeriodicCell, YarnRole};

/// Why a weave cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WeaveError {
    /// The packed yarn section is too wide for the yarn spacing.
    #[error("section_aspect: the packed yarn section ({packed_width:.3e} m wide) is too wide for yarns {spacing:.3e} m apart (its outer fibre centres must stay within 0.45 spacings of the yarn's axis)")]
    TooWide {
        /// width of the packed yarn section [m]
        packed_width: f64,
        /// centre distance of parallel yarns [m]
        spacing: f64,
    },
    /// The crimp asked for cannot keep crossing yarns apart.
    #[error(
        "initial_crimp: {requested} needs a smaller amplitude than the {minimum:.4} that keeps crossing yarns apart"
    )]
    CrimpTooSmall {
        /// the crimp asked for [-]
        requested: f64,
        /// the least that keeps crossing yarns apart [-]
        minimum: f64,
    },
}

/// Centres of `count` digital fibres in a flat yarn section: points of a hexagonal lattice of
/// pitch `pitch` (touching fibres, rows parallel to the fabric) taken in order of the
/// elliptical radius with semi-axes in the ratio `aspect` = width / thickness, then centred on
/// their bounding box. Returns (across, up) offsets [m]. The order is total (radius, angle,
/// lattice indices), so every rank packs the same way.
pub fn elliptical_packing(count: usize, pitch: f64, aspect: f64) -> Vec<[f64; 2]> {
    let aspect = aspect.max(1.0);
    // enough lattice points to hold `count` inside the ellipse with a margin
    let half = ((count as f64 * aspect).sqrt().ceil() as i64 + 2).max(2);
    let rows = ((count as f64 / aspect).sqrt().ceil() as i64 + 2).max(2);
    let mut points = Vec::new();
    for b in -rows..=rows {
        for a in -half - rows..=half + rows {
            let (x, z) = (a as f64 + 0.5 * b as f64, b as f64 * 3f64.sqrt() / 2.0);
            points.push((a, b, x, z));
        }
    }
    let radius = |x: f64, z: f64| (x / aspect).hypot(z);
    points.sort_by(|p, q| {
        radius(p.2, p.3)
            .total_cmp(&radius(q.2, q.3))
            .then(p.3.atan2(p.2).total_cmp(&q.3.atan2(q.2)))
            .then((p.0, p.1).cmp(&(q.0, q.1)))
    });
    points.truncate(count);
    let extent = |k: fn(&(i64, i64, f64, f64)) -> f64| {
        let low = points.iter().map(k).fold(f64::INFINITY, f64::min);
        let high = points.iter().map(k).fold(f64::NEG_INFINITY, f64::max);
        0.5 * (low + high)
    };
    let (centre_x, centre_z) = (extent(|p| p.2), extent(|p| p.3));
    points.iter().map(|p| [(p.2 - centre_x) * pitch, (p.3 - centre_z) * pitch]).collect()
}

/// A balanced plain weave of one yarn, before relaxation.
#[derive(Clone, Debug, PartialEq)]
pub struct PlainWeave {
    /// centre distance of neighbouring parallel yarns, warp and weft alike [m]
    pub yarn_spacing: f64,
    /// width / thickness of the yarn section that orders the packing [-]
    pub section_aspect: f64,
    /// digital fibres per yarn
    pub fibres_per_yarn: usize,
    /// cross-section area of the whole yarn [m^2]
    pub yarn_area: f64,
    /// target element length / digital fibre diameter [-]
    pub element_length_ratio: f64,
    /// initial crimp (path length / straight length - 1); `None` takes the smallest that
    /// keeps the crossing yarns apart [-]
    pub initial_crimp: Option<f64>,
    /// tension of a whole yarn at the start of relaxation [N]
    pub yarn_tension: f64,
    /// bending model of the fibres, its friction weight (5-10) applied
    pub inertia: SectionInertia,
}

/// The four yarns of a plain-weave unit cell: warp 0 and 1 along x at y = 0 and y = s,
/// weft 0 and 1 along y at x = 0 and x = s. Warp 0 passes over weft 0 at the origin.
pub const CELL_YARNS: [(YarnDirection, usize); 4] =
    [(YarnDirection::Warp, 0), (YarnDirection::Warp, 1), (YarnDirection::Weft, 0), (YarnDirection::Weft, 1)];

/// A plain-weave unit cell: the [`PeriodicCell`] of the four [`CELL_YARNS`], `2 s` square,
/// with what a panel needs to tile it (its fibres all have `nodes_per_period` nodes, and the
/// yarns' packing). It reads as its periodic cell.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitCell {
    /// the relaxed periodic cell
    pub periodic: PeriodicCell,
    /// centre distance of neighbouring parallel yarns; the cell is `2 s` square [m]
    pub yarn_spacing: f64,
    /// digital fibres of every yarn
    pub fibres_per_yarn: usize,
    /// nodes of one fibre in one period
    pub nodes_per_period: u32,
    /// the packing of the yarn section: (across, up) offsets of the fibres [m]
    pub packing: Vec<[f64; 2]>,
    /// amplitude of the initial centreline [m]
    pub initial_amplitude: f64,
}

impl Deref for UnitCell {
    type Target = PeriodicCell;
    fn deref(&self) -> &PeriodicCell {
        &self.periodic
    }
}

impl DerefMut for UnitCell {
    fn deref_mut(&mut self) -> &mut PeriodicCell {
        &mut self.periodic
    }
}

impl UnitCell {
    /// Assembles a plain-weave cell from the positions of its four yarns (in [`CELL_YARNS`]
    /// order), checking the sizes.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        yarn_spacing: f64,
        fibres_per_yarn: usize,
        nodes_per_period: u32,
        section: FibreSection,
        positions: Vec<Vec3>,
        rest_lengths: Vec<f64>,
        rest_angles: Vec<f64>,
        fibre_tension: f64,
        packing: Vec<[f64; 2]>,
        initial_amplitude: f64,
    ) -> Result<Self, crate::cell::CellError> {
        if packing.len() != fibres_per_yarn || !nodes_per_period.is_multiple_of(4) {
            return Err(crate::cell::CellError::Sizes(format!("{} packing points for {fibres_per_yarn} fibres per yarn, {nodes_per_period} nodes per period (a multiple of 4)", packing.len())));
        }
        let yarns = CELL_YARNS
            .iter()
            .map(|&(direction, _)| CellYarn {
                direction,
                role: YarnRole::Plain,
                fibres: fibres_per_yarn,
                nodes_per_period,
            })
            .collect();
        let period = 2.0 * yarn_spacing;
        let periodic =
            PeriodicCell::new([period, period], yarns, section, positions, rest_lengths, rest_angles, fibre_tension)?;
        Ok(Self { periodic, yarn_spacing, fibres_per_yarn, nodes_per_period, packing, initial_amplitude })
    }

    /// Side of the square cell, `2 s` [m].
    pub fn period(&self) -> f64 {
        2.0 * self.yarn_spacing
    }
}

/// Length of one half-wave `s` of `z = A cos(pi x / s)`, relative to `s` (crimp + 1), by
/// Simpson's rule on 512 intervals (the integrand is smooth and periodic).
pub fn sinusoid_length_ratio(amplitude: f64, half_wave: f64) -> f64 {
    let k = amplitude * std::f64::consts::PI / half_wave;
    let n = 512;
    let f = |i: usize| {
        let theta = std::f64::consts::PI * i as f64 / n as f64;
        (1.0 + (k * theta.sin()).powi(2)).sqrt()
    };
    let mut sum = f(0) + f(n);
    for i in 1..n {
        sum += if i % 2 == 1 { 4.0 * f(i) } else { 2.0 * f(i) };
    }
    sum / (3.0 * n as f64)
}

impl PlainWeave {
    /// Kevlar KM2 style 706: 600 denier yarns (4.63e-8 m^2, PHYSICS.md §8), 34 x 34 yarns per
    /// inch, `fibres_per_yarn` digital fibres in a section 6 times wider than thick (an
    /// assumption: the flat yarn of a tight plain weave; docs/theory.md F2), crimp left to
    /// the relaxation, 0.5 N of initial yarn tension (F3), bending by I_e with k1 = 0.8,
    /// k2 = 1 and mu = 0.3 (seed §5.3).
    pub fn km2_style_706(fibres_per_yarn: usize) -> Self {
        Self {
            yarn_spacing: 0.0254 / 34.0,
            section_aspect: 6.0,
            fibres_per_yarn,
            yarn_area: 4.63e-8,
            element_length_ratio: 0.5,
            initial_crimp: None,
            yarn_tension: 0.5,
            inertia: InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3),
        }
    }

    /// Area of one digital fibre [m^2].
    pub fn fibre_area(&self) -> f64 {
        self.yarn_area / self.fibres_per_yarn as f64
    }

    /// Builds the initial unit cell: fibres packed in the section, centrelines on sinusoids of
    /// the smallest amplitude that keeps crossing yarns one contact diameter apart (or the
    /// amplitude of `initial_crimp`), nodes at equal arc length, rest lengths shorter than the
    /// path by the strain of the initial yarn tension.
    pub fn unit_cell(&self, material: &FibreMaterial) -> Result<UnitCell, WeaveError> {
        let s = self.yarn_spacing;
        let area = self.fibre_area();
        let diameter = (4.0 * area / std::f64::consts::PI).sqrt();
        let stretch = 1.0 + self.yarn_tension / (material.longitudinal_modulus * self.yarn_area);
        // the contact diameter depends on the element length, which depends on the path: pack
        // at the target ratio, then repeat with the element length found until it settles
        let mut section = FibreSection::new(material, area, self.element_length_ratio * diameter, self.inertia);
        let mut previous = 0;
        let mut clearance = 1.0;
        loop {
            let packing = elliptical_packing(self.fibres_per_yarn, section.contact_diameter, self.section_aspect);
            let across = packing.iter().map(|p| p[0].abs()).fold(0.0, f64::max);
            let (low, high) =
                packing.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p[1]), h.max(p[1])));
            let packed_width = 2.0 * across + section.contact_diameter;
            if 2.0 * across >= 0.9 * s {
                return Err(WeaveError::TooWide { packed_width, spacing: s });
            }
            // where an edge fibre of one yarn crosses an edge fibre of the other, both
            // centrelines have dipped from their crests: A 2 cos(pi across / s) >= h keeps the
            // sections a contact diameter apart there; `clearance` grows if the nodes of the
            // laid-out cell still come closer elsewhere
            let height = high - low + section.contact_diameter;
            let minimum = clearance * height / (2.0 * (std::f64::consts::PI * across / s).cos());
            let minimum_crimp = sinusoid_length_ratio(minimum, s) - 1.0;
            let amplitude = match self.initial_crimp {
                None => minimum,
                Some(crimp) if crimp < minimum_crimp => {
                    return Err(WeaveError::CrimpTooSmall { requested: crimp, minimum: minimum_crimp })
                }
                Some(crimp) => {
                    let (mut a, mut b) = (minimum, s);
                    for _ in 0..200 {
                        let mid = 0.5 * (a + b);
                        if sinusoid_length_ratio(mid, s) - 1.0 < crimp {
                            a = mid;
                        } else {
                            b = mid;
                        }
                    }
                    0.5 * (a + b)
                }
            };
            let path = 2.0 * s * sinusoid_length_ratio(amplitude, s);
            // a multiple of four puts nodes on both crossings of a period and halfway between
            // them, where a panel's fibres start and end (crate::panel)
            let nodes_per_period = (((path / (self.element_length_ratio * diameter)) / 4.0).round() as u32).max(1) * 4;
            // equal chords, so every element starts at the strain of the initial tension
            let (stations, chord) = equal_chord_stations(amplitude, s, nodes_per_period);
            let rest_length = chord / stretch;
            let grown = FibreSection::new(material, area, rest_length, self.inertia);
            // settled once the count of elements repeats and the packing used a contact
            // diameter no smaller than the final one
            if nodes_per_period == previous && grown.contact_diameter <= section.contact_diameter {
                let cell = self.lay_out(grown.clone(), packing, &stations, amplitude, nodes_per_period);
                let closest = crate::relax::closest_approach(&cell, |a, b| cell.direction(a) != cell.direction(b));
                if closest >= cell.section.contact_diameter {
                    return Ok(cell);
                }
                clearance *= 1.001 * cell.section.contact_diameter / closest;
            }
            previous = nodes_per_period;
            section = FibreSection { contact_diameter: grown.contact_diameter.max(section.contact_diameter), ..grown };
        }
    }

    /// Places the fibres of the four yarns on their sinusoids.
    fn lay_out(
        &self,
        section: FibreSection,
        packing: Vec<[f64; 2]>,
        stations: &[(f64, f64)],
        amplitude: f64,
        nodes_per_period: u32,
    ) -> UnitCell {
        let s = self.yarn_spacing;
        let mut positions = Vec::with_capacity(4 * packing.len() * nodes_per_period as usize);
        for (direction, index) in CELL_YARNS {
            // warp i at y = i s follows A cos(pi x / s + i pi); weft j the opposite phase
            let sign = if index == 0 { 1.0 } else { -1.0 };
            for offset in &packing {
                for &(along, centre) in stations {
                    let across = index as f64 * s + offset[0];
                    positions.push(match direction {
                        YarnDirection::Warp => Vec3::new(along, across, sign * centre + offset[1]),
                        YarnDirection::Weft => Vec3::new(across, along, -sign * centre + offset[1]),
                    });
                }
            }
        }
        let rest_lengths = vec![section.element_length; 4 * packing.len()];
        let fibre_tension = self.yarn_tension / self.fibres_per_yarn as f64;
        let rest_angles = vec![0.0; positions.len()];
        UnitCell::new(
            s,
            self.fibres_per_yarn,
            nodes_per_period,
            section,
            positions,
            rest_lengths,
            rest_angles,
            fibre_tension,
            packing,
            amplitude,
        )
        .expect("a laid-out cell fits its yarns")
    }
}

/// `n` stations `(x, A cos(pi x / s))` over one period `[0, 2 s)`, consecutive stations (and
/// the last and the first's image) one chord `c` apart: `c` is found by bisection so that
/// `n` chords close the period, each station from the last by bisection on x. Returns the
/// stations and the chord [m]. Starting on a crest of the even curve, the stations fall on
/// both crests and both inflections of a period when `n` is a multiple of four.
fn equal_chord_stations(amplitude: f64, s: f64, n: u32) -> (Vec<(f64, f64)>, f64) {
    let curve = |x: f64| amplitude * (std::f64::consts::PI * x / s).cos();
    let walk = |chord: f64| {
        let mut stations = Vec::with_capacity(n as usize);
        let mut x = 0.0;
        for _ in 0..n {
            stations.push((x, curve(x)));
            // the chord from x grows with the step: bisect on the step in (0, chord]
            let (mut low, mut high) = (0.0, chord);
            for _ in 0..80 {
                let mid = 0.5 * (low + high);
                if mid.hypot(curve(x + mid) - curve(x)) < chord {
                    low = mid;
                } else {
                    high = mid;
                }
            }
            x += 0.5 * (low + high);
        }
        (stations, x)
    };
    let (mut low, mut high) = (0.0, 2.0 * s * sinusoid_length_ratio(amplitude, s) / n as f64);
    for _ in 0..80 {
        let mid = 0.5 * (low + high);
        if walk(mid).1 < 2.0 * s {
            low = mid;
        } else {
            high = mid;
        }
    }
    let chord = 0.5 * (low + high);
    (walk(chord).0, chord)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_fills_a_flat_section_without_overlap() {
        for (count, aspect) in [(1, 7.0), (4, 7.0), (7, 1.0), (19, 3.0), (100, 6.0)] {
            let points = elliptical_packing(count, 1.0, aspect);
            assert_eq!(points.len(), count);
            for (a, p) in points.iter().enumerate() {
                for q in &points[a + 1..] {
                    assert!((p[0] - q[0]).hypot(p[1] - q[1]) >= 1.0 - 1e-12);
                }
            }
            let width = points.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max)
                - points.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min)
                + 1.0;
            let height = points.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max)
                - points.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min)
                + 1.0;
            if count > 1 && aspect > 2.0 {
                assert!(width > 1.5 * height, "{count} fibres, aspect {aspect}: {width} x {height}");
            }
        }
        assert_eq!(
            elliptical_packing(4, 1.0, 7.0).iter().filter(|p| p[1] == 0.0).count(),
            4,
            "four fibres lie in one row"
        );
    }

    #[test]
    fn sinusoid_length_matches_its_limits() {
        assert!((sinusoid_length_ratio(0.0, 1.0) - 1.0).abs() < 1e-15);
        // small amplitude: 1 + (k/2)^2 with k = A pi / s
        let k = 1e-3 * std::f64::consts::PI;
        assert!((sinusoid_length_ratio(1e-3, 1.0) - 1.0 - k * k / 4.0).abs() < 1e-10);
        // A = s / pi: (1/pi) times the integral of sqrt(1 + sin^2) over [0, pi] = 1.2160067
        assert!((sinusoid_length_ratio(1.0 / std::f64::consts::PI, 1.0) - 1.216_006_7).abs() < 1e-7);
    }

    #[test]
    fn cell_has_the_spacing_crimp_and_mass_asked_for() {
        let material = FibreMaterial::kevlar_km2();
        let mut weave = PlainWeave::km2_style_706(4);
        weave.initial_crimp = Some(0.06);
        let cell = weave.unit_cell(&material).unwrap();
        assert_eq!(cell.positions.len(), 16 * cell.nodes_per_period as usize);
        assert_eq!(cell.nodes_per_period % 4, 0);
        // the chords of the discrete fibre are a little shorter than the arc
        assert!((cell.crimp() - 0.06).abs() < 1e-3, "crimp {}", cell.crimp());
        let n = cell.nodes_per_period;
        for (k, x) in [(n / 4, 0.5), (n / 2, 1.0), (3 * n / 4, 1.5)] {
            assert!((cell.position(0, k).x / weave.yarn_spacing - x).abs() < 1e-9, "station {k}");
        }
        // warp 1 lies one spacing from warp 0, weft 1 likewise
        let (w0, w1) = (cell.position(0, 0), cell.position(4, 0));
        assert!(((w1.y - w0.y) - weave.yarn_spacing).abs() < 1e-15);
        let (f0, f1) = (cell.position(8, 0), cell.position(12, 0));
        assert!(((f1.x - f0.x) - weave.yarn_spacing).abs() < 1e-15);
        // elements of equal length, rest shorter by the tension strain
        let strain = weave.yarn_tension / (material.longitudinal_modulus * weave.yarn_area);
        for k in 0..cell.nodes_per_period - 1 {
            let length = (cell.position(1, k + 1) - cell.position(1, k)).norm();
            assert!((length / cell.section.element_length - 1.0 - strain).abs() < 1e-12, "element {k}");
        }
        // areal density: two yarn sets of linear density rho A, spaced s, times path / length
        let expected =
            2.0 * material.density * weave.yarn_area / weave.yarn_spacing * (1.0 + cell.crimp()) / (1.0 + strain);
        assert!((cell.areal_density(&material) / expected - 1.0).abs() < 1e-3);
    }

    #[test]
    fn crossing_yarns_start_apart_and_alternate() {
        let material = FibreMaterial::kevlar_km2();
        for fibres in [1, 4, 7] {
            let cell = PlainWeave::km2_style_706(fibres).unit_cell(&material).unwrap();
            let d = cell.section.contact_diameter;
            let mut closest = f64::INFINITY;
            for a in 0..cell.fibres() {
                for b in 0..cell.fibres() {
                    if cell.direction(a) == cell.direction(b) {
                        continue;
                    }
                    for p in
                        &cell.positions[a * cell.nodes_per_period as usize..(a + 1) * cell.nodes_per_period as usize]
                    {
                        for q in &cell.positions
                            [b * cell.nodes_per_period as usize..(b + 1) * cell.nodes_per_period as usize]
                        {
                            closest = closest.min((p - q).norm());
                        }
                    }
                }
            }
            assert!(closest >= d * (1.0 - 1e-9), "{fibres} fibres: {closest} < {d}");
            // warp 0 over weft 0 at the origin, under weft 1 at x = s
            let n = cell.nodes_per_period;
            let centre = |yarn: usize, k: u32| {
                (0..fibres).map(|f| cell.position(yarn * fibres + f, k).z).sum::<f64>() / fibres as f64
            };
            assert!(centre(0, 0) > centre(2, 0));
            assert!(centre(0, n / 2) < centre(3, 0));
            assert!(centre(1, 0) < centre(2, n / 2));
        }
    }

    #[test]
    fn a_section_wider_than_the_spacing_is_refused() {
        let mut weave = PlainWeave::km2_style_706(40);
        weave.section_aspect = 100.0;
        assert!(matches!(weave.unit_cell(&FibreMaterial::kevlar_km2()), Err(WeaveError::TooWide { .. })));
        let mut weave = PlainWeave::km2_style_706(4);
        weave.initial_crimp = Some(1e-5);
        assert!(matches!(weave.unit_cell(&FibreMaterial::kevlar_km2()), Err(WeaveError::CrimpTooSmall { .. })));
    }
}
