//! Dynamic relaxation of a unit cell with periodic boundaries (seed §3.1, ref. \[2\] of the
//! seed): the fibres of the initial topology carry an initial yarn tension; rods, bending
//! springs and fibre–fibre contact (the elastic law 4-8 on the modified diameter 3-1…3-3)
//! act on every node; nodes near the cell's edges see the images of the nodes across it, and
//! each fibre's last node is joined to the image of its first. The motion is damped by FIRE
//! (Bitzek et al., Phys. Rev. Lett. 97, 170201, 2006) until the largest nodal force has
//! fallen by the asked factor. No friction acts: the relaxed state is an equilibrium of the
//! conservative forces (docs/theory.md, F3).
//!
//! The cell is small (a few yarns), so it is relaxed whole by every rank that needs it; the
//! arithmetic is sequential and in a fixed order, so every rank gets the same bits.

use dea_core::bending::{torsional_spring, RestAngleLaw};
use dea_core::contact::{ContactGeometry, NormalLaw};
use dea_core::rod::axial_force;
use dea_core::stability::stable_time_step;
use dea_core::{FibreMaterial, Vec3};

use crate::cell::{CellStatistics, PeriodicCell};

/// What the relaxation is asked to reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelaxOptions {
    /// stop when the largest nodal force is this fraction of the initial one [-]
    pub tolerance: f64,
    /// give up after this many iterations
    pub max_iterations: u64,
    /// what the bending springs hold at rest
    pub bending_at_rest: BendingAtRest,
}

/// The shape in which a woven fibre's bending springs are at rest (docs/theory.md F4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BendingAtRest {
    /// the relaxed, crimped shape: the cell relaxes without bending (pin-jointed chains, as
    /// the seed's DEA relaxation) and each spring takes its relaxed angle as its rest angle
    AsWoven,
    /// straight: the springs act during relaxation and the crimp holds them bent
    Straight,
}

impl Default for RelaxOptions {
    fn default() -> Self {
        Self { tolerance: 1e-7, max_iterations: 2_000_000, bending_at_rest: BendingAtRest::AsWoven }
    }
}

/// How the relaxation went.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RelaxReport {
    /// iterations taken
    pub iterations: u64,
    /// largest nodal force of the initial topology [N]
    pub initial_residual_n: f64,
    /// largest nodal force at the end [N]
    pub final_residual_n: f64,
    /// fibre–fibre contacts (overlapping node pairs) at the end
    pub contacts: usize,
    /// largest overlap of a contact at the end, over the contact diameter [-]
    pub largest_overlap_ratio: f64,
    /// (iteration, largest nodal force [N]) every 1000 iterations and at the end
    pub history: Vec<(u64, f64)>,
    /// the micro-geometry of the initial topology
    pub before: CellStatistics,
    /// the relaxed micro-geometry
    pub after: CellStatistics,
}

/// Why a cell could not be relaxed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RelaxError {
    /// The largest nodal force did not fall far enough.
    #[error("relaxation did not converge: the largest nodal force fell by {reduction:.3e} in {iterations} iterations, {tolerance:.1e} was asked (raise relaxation.max_iterations or relax the tolerance)")]
    NotConverged {
        /// iterations taken
        iterations: u64,
        /// the largest nodal force's fall, final over initial [-]
        reduction: f64,
        /// the fall asked for [-]
        tolerance: f64,
    },
    /// A nodal force is not finite.
    #[error("relaxation diverged at iteration {iteration}: a nodal force is not finite")]
    NonFinite {
        /// the iteration
        iteration: u64,
    },
}

/// Two nodes of different fibres within reach of each other: `j`'s nearest image relative to
/// `i` is `x_j - x_i - image * period` (x and y).
#[derive(Clone, Copy, Debug, PartialEq)]
struct PeriodicPair {
    i: u32,
    j: u32,
    /// periods to take off the separation along x and y (whole numbers) [-]
    image: [f64; 2],
}

impl PeriodicPair {
    /// The separation `x_j - x_i` of the pair's images, as [`minimum_image`] gives it while
    /// neither node has moved by half a period since the pair was listed [m].
    #[inline]
    fn separation(&self, positions: &[Vec3], period: [f64; 2]) -> Vec3 {
        let mut d = positions[self.j as usize] - positions[self.i as usize];
        d.x -= period[0] * self.image[0];
        d.y -= period[1] * self.image[1];
        d
    }
}

/// Pairs of nodes on different fibres within `reach` of each other, nearest image across the
/// periodic edges in x and y, ascending (i, j) with i < j. Bins of side >= reach, so only the
/// 27 bins around a node can hold a partner.
fn periodic_pairs(cell: &PeriodicCell, reach: f64) -> Vec<PeriodicPair> {
    let period = cell.period;
    let fibre_of = node_fibres(cell);
    let bins = period.map(|p| ((p / reach).floor() as i64).max(1));
    let (low, high) = cell.z_range();
    let layers = (((high - low) / reach).floor() as i64 + 1).max(1);
    let bin_of = |p: &Vec3| {
        let wrap = |v: f64, axis: usize| {
            ((v - period[axis] * (v / period[axis]).floor()) / period[axis] * bins[axis] as f64)
                .floor()
                .clamp(0.0, (bins[axis] - 1) as f64) as i64
        };
        (wrap(p.x, 0), wrap(p.y, 1), (((p.z - low) / reach).floor() as i64).clamp(0, layers - 1))
    };
    let index = |x: i64, y: i64, z: i64| ((z * bins[1] + y) * bins[0] + x) as usize;
    let mut heads = vec![Vec::new(); (bins[0] * bins[1] * layers) as usize];
    for (i, p) in cell.positions.iter().enumerate() {
        let (x, y, z) = bin_of(p);
        heads[index(x, y, z)].push(i as u32);
    }
    let mut pairs = Vec::new();
    let mut near = Vec::with_capacity(27);
    for (i, p) in cell.positions.iter().enumerate() {
        let (x, y, z) = bin_of(p);
        near.clear();
        for dz in -1..=1 {
            let zz = z + dz;
            if zz < 0 || zz >= layers {
                continue;
            }
            for dy in -1..=1 {
                for dx in -1..=1 {
                    near.push(index((x + dx).rem_euclid(bins[0]), (y + dy).rem_euclid(bins[1]), zz));
                }
            }
        }
        // fewer than three bins across wrap onto the same bin: visit each once
        near.sort_unstable();
        near.dedup();
        for &b in &near {
            for &j in &heads[b] {
                let j = j as usize;
                if j <= i || fibre_of[j] == fibre_of[i] {
                    continue;
                }
                let d = cell.positions[j] - p;
                let image = [(d.x / period[0]).round(), (d.y / period[1]).round()];
                let pair = PeriodicPair { i: i as u32, j: j as u32, image };
                if pair.separation(&cell.positions, period).norm() < reach {
                    pairs.push(pair);
                }
            }
        }
    }
    pairs.sort_unstable_by_key(|p| (p.i, p.j));
    pairs
}

/// The fibre of every node of the cell.
fn node_fibres(cell: &PeriodicCell) -> Vec<u32> {
    (0..cell.fibres()).flat_map(|f| std::iter::repeat_n(f as u32, cell.fibre_nodes(f).len())).collect()
}

/// Distance between the closest nodes of two fibres `counted(fibre_a, fibre_b)` picks
/// (infinite when none are within a contact diameter) [m].
pub(crate) fn closest_approach(cell: &PeriodicCell, counted: impl Fn(usize, usize) -> bool) -> f64 {
    let fibre_of = node_fibres(cell);
    periodic_pairs(cell, cell.section.contact_diameter)
        .into_iter()
        .filter(|p| counted(fibre_of[p.i as usize] as usize, fibre_of[p.j as usize] as usize))
        .map(|p| p.separation(&cell.positions, cell.period).norm())
        .fold(f64::INFINITY, f64::min)
}

/// Turning angle at every node of the cell, each fibre closed on its periodic image [rad].
fn turning_angles(cell: &PeriodicCell) -> Vec<f64> {
    let mut angles = vec![0.0; cell.positions.len()];
    for fibre in 0..cell.fibres() {
        let nodes = cell.fibre_nodes(fibre);
        let (base, n) = (nodes.start, nodes.len());
        let closure = cell.closure(fibre);
        let at = |k: isize| {
            let wrapped = k.rem_euclid(n as isize) as usize;
            let shift = k.div_euclid(n as isize) as f64;
            cell.positions[base + wrapped] + closure * shift
        };
        for k in 0..n as isize {
            let (a, b) = (at(k) - at(k - 1), at(k + 1) - at(k));
            angles[base + k as usize] = a.cross(&b).norm().atan2(a.dot(&b));
        }
    }
    angles
}

/// Deepest overlap of two nodes of the cell (different fibres, periodic images included),
/// over the contact diameter [-]: where the fabric's contacts start.
pub fn largest_overlap_ratio(cell: &PeriodicCell) -> f64 {
    let d = cell.section.contact_diameter;
    periodic_pairs(cell, d)
        .into_iter()
        .map(|p| (d - p.separation(&cell.positions, cell.period).norm()) / d)
        .fold(0.0, f64::max)
}

/// The shortest periodic image of a separation in x and y [m].
#[inline]
pub(crate) fn minimum_image(mut d: Vec3, period: [f64; 2]) -> Vec3 {
    d.x -= period[0] * (d.x / period[0]).round();
    d.y -= period[1] * (d.y / period[1]).round();
    d
}

/// Which forces [`cell_forces`] evaluates.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Rods {
    /// the cell as the solver will see it: its rest lengths, its bending springs
    Rest,
    /// during relaxation: each fibre's rest length follows its current length so that it
    /// carries the fibre tension (material drawn in or let out as on the loom); the bending
    /// springs act only when `bending` (springs straight at rest)
    Tension { bending: bool },
}

/// Rest length of the `elements` elements of a fibre of current length `length` that carries
/// the cell's fibre tension on average [m].
fn tensioned_rest_length(cell: &PeriodicCell, material: &FibreMaterial, length: f64, elements: usize) -> f64 {
    length / elements as f64 / (1.0 + cell.fibre_tension / (material.longitudinal_modulus * cell.section.area))
}

/// Forces on every node of the cell [N]: rods (4-2), bending springs (5-1), elastic contact
/// (4-8) of the listed pairs. Returns (contacts, largest overlap / contact diameter).
/// Per-fibre element directions and lengths, reused by every force evaluation.
#[derive(Default)]
struct ChainScratch {
    direction: Vec<Vec3>,
    length: Vec<f64>,
}

fn cell_forces(
    cell: &PeriodicCell,
    material: &FibreMaterial,
    law: &NormalLaw,
    rods: Rods,
    pairs: &[PeriodicPair],
    chain: &mut ChainScratch,
    force: &mut [Vec3],
) -> (usize, f64) {
    let section = &cell.section;
    force.fill(Vec3::zeros());
    for fibre in 0..cell.fibres() {
        let nodes = cell.fibre_nodes(fibre);
        let (base, n) = (nodes.start, nodes.len());
        // element k of a fibre joins node k to node k + 1 (the image of node 0 after the last)
        chain.direction.resize(n, Vec3::zeros());
        chain.length.resize(n, 0.0);
        let (direction, length) = (&mut chain.direction[..n], &mut chain.length[..n]);
        let closure = cell.closure(fibre);
        for k in 0..n {
            let next = if k + 1 == n { cell.positions[base] + closure } else { cell.positions[base + k + 1] };
            let axis = next - cell.positions[base + k];
            length[k] = axis.norm();
            direction[k] = axis / length[k];
        }
        let rest = match rods {
            Rods::Rest => cell.rest_lengths[fibre],
            Rods::Tension { .. } => tensioned_rest_length(cell, material, length.iter().sum(), n),
        };
        for k in 0..n {
            let strain = (length[k] - rest) / rest;
            let tension = direction[k] * axial_force(material, section.area, strain);
            force[base + k] += tension;
            force[base + (k + 1) % n] -= tension;
        }
        if rods != (Rods::Tension { bending: false }) && section.torsional_stiffness > 0.0 {
            for k in 0..n {
                let previous = (k + n - 1) % n;
                let (on_prev, on_next, _, _) = torsional_spring(
                    direction[previous],
                    1.0 / length[previous],
                    direction[k],
                    1.0 / length[k],
                    section.torsional_stiffness,
                    cell.rest_angles[base + k],
                    // the springs act here only resting straight (as woven, they take the
                    // relaxed angles after): no spring is below a rest angle
                    RestAngleLaw::Cone,
                );
                force[base + previous] += on_prev;
                force[base + (k + 1) % n] += on_next;
                force[base + k] -= on_prev + on_next;
            }
        }
    }
    let geometry = ContactGeometry::new(0.5 * section.diameter, section.element_length, section.diameter);
    let (mut contacts, mut largest) = (0, 0.0f64);
    for pair in pairs {
        let (i, j) = (pair.i as usize, pair.j as usize);
        let d = pair.separation(&cell.positions, cell.period);
        let distance = d.norm();
        let overlap = section.contact_diameter - distance;
        if overlap <= 0.0 {
            continue;
        }
        contacts += 1;
        largest = largest.max(overlap / section.contact_diameter);
        let (response, _) = law.evaluate(&geometry, overlap, 0.0);
        let push = d * (response.force / distance);
        force[i] -= push;
        force[j] += push;
    }
    (contacts, largest)
}

fn largest_force(force: &[Vec3]) -> f64 {
    force.iter().map(|f| f.norm()).fold(0.0, f64::max)
}

/// Relaxes `cell` in place under constant fibre tension with the contact law `law` (its
/// loading curve), then gives every fibre the rest length at which its rods carry that
/// tension in the relaxed shape, so the relaxed cell is in equilibrium as the solver will see
/// it. The section (nominal element length, contact diameter, spring rigidity) stays.
pub fn relax(
    cell: &mut PeriodicCell,
    material: &FibreMaterial,
    law: &NormalLaw,
    options: &RelaxOptions,
) -> Result<RelaxReport, RelaxError> {
    let law = *law;
    let bending = options.bending_at_rest == BendingAtRest::Straight;
    cell.rest_angles.fill(0.0);
    let before = cell.statistics(material);
    let section = cell.section.clone();
    let mass = section.node_mass(material);
    let critical = stable_time_step(material, std::slice::from_ref(&section), &law, 0.0, 0.5, 0.9);
    // FIRE's constants (Bitzek et al. 2006)
    let (n_min, f_inc, f_dec, alpha_start, f_alpha) = (5u64, 1.1, 0.5, 0.1, 0.99);
    let (mut dt, mut alpha, mut since_negative) = (0.25 * critical, alpha_start, 0u64);
    let skin = 0.5 * section.contact_diameter;
    let reach = section.contact_diameter + skin;
    let mut pairs = periodic_pairs(cell, reach);
    let mut anchor = cell.positions.clone();
    let count = cell.positions.len();
    let mut force = vec![Vec3::zeros(); count];
    let mut chain = ChainScratch::default();
    let mut velocity = vec![Vec3::zeros(); count];
    cell_forces(cell, material, &law, Rods::Tension { bending }, &pairs, &mut chain, &mut force);
    let initial = largest_force(&force);
    let mut residual = initial;
    let mut history = vec![(0, initial)];
    let mut iteration = 0;
    let (started, mut last_word) = (std::time::Instant::now(), std::time::Instant::now());
    while residual > options.tolerance * initial {
        if iteration == options.max_iterations {
            return Err(RelaxError::NotConverged {
                iterations: iteration,
                reduction: residual / initial,
                tolerance: options.tolerance,
            });
        }
        iteration += 1;
        // FIRE: steer the velocity towards the force while the motion goes downhill
        let power: f64 = force.iter().zip(&velocity).map(|(f, v)| f.dot(v)).sum();
        if power > 0.0 {
            let speed = velocity.iter().map(|v| v.norm_squared()).sum::<f64>().sqrt();
            let push = force.iter().map(|f| f.norm_squared()).sum::<f64>().sqrt();
            for (v, f) in velocity.iter_mut().zip(&force) {
                *v = *v * (1.0 - alpha) + f * (alpha * speed / push);
            }
            since_negative += 1;
            if since_negative > n_min {
                dt = (dt * f_inc).min(critical);
                alpha *= f_alpha;
            }
        } else {
            velocity.fill(Vec3::zeros());
            since_negative = 0;
            dt *= f_dec;
            alpha = alpha_start;
        }
        for ((x, v), f) in cell.positions.iter_mut().zip(&mut velocity).zip(&force) {
            *v += f * (dt / mass);
            *x += *v * dt;
        }
        let moved = cell.positions.iter().zip(&anchor).map(|(x, a)| (x - a).norm_squared()).fold(0.0, f64::max).sqrt();
        if 2.0 * moved > skin {
            pairs = periodic_pairs(cell, reach);
            anchor.clone_from(&cell.positions);
        }
        cell_forces(cell, material, &law, Rods::Tension { bending }, &pairs, &mut chain, &mut force);
        residual = largest_force(&force);
        if !residual.is_finite() {
            return Err(RelaxError::NonFinite { iteration });
        }
        if iteration % 1000 == 0 {
            history.push((iteration, residual));
        }
        // a large cell relaxes for minutes: say how far it is, every 10 s of it
        if iteration % 50 == 0 && last_word.elapsed().as_secs_f64() >= 10.0 {
            last_word = std::time::Instant::now();
            tracing::info!(
                "relaxing the unit cell ({} nodes): iteration {iteration} of at most {}, largest force down to {:.1e} of its start (to reach {:.0e}), {:.0} s so far",
                count,
                options.max_iterations,
                residual / initial,
                options.tolerance,
                started.elapsed().as_secs_f64()
            );
        }
    }
    for fibre in 0..cell.fibres() {
        cell.rest_lengths[fibre] =
            tensioned_rest_length(cell, material, cell.fibre_length(fibre), cell.fibre_nodes(fibre).len());
    }
    if !bending {
        cell.rest_angles = turning_angles(cell);
    }
    // the forces the solver will see: the same as the last iteration's, as the rest lengths
    // are those the tension gave and the springs rest at their angles (or acted throughout)
    let (contacts, largest_overlap) = cell_forces(cell, material, &law, Rods::Rest, &pairs, &mut chain, &mut force);
    residual = largest_force(&force);
    history.push((iteration, residual));
    Ok(RelaxReport {
        iterations: iteration,
        initial_residual_n: initial,
        final_residual_n: residual,
        contacts,
        largest_overlap_ratio: largest_overlap,
        history,
        before,
        after: cell.statistics(material),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weave::PlainWeave;

    #[test]
    fn periodic_pairs_match_brute_force() {
        let material = FibreMaterial::kevlar_km2();
        let cell = PlainWeave::km2_style_706(7).unit_cell(&material).unwrap();
        let reach = 1.5 * cell.section.contact_diameter;
        let n = cell.nodes_per_period as usize;
        let mut expected = Vec::new();
        for i in 0..cell.positions.len() {
            for j in i + 1..cell.positions.len() {
                if i / n != j / n
                    && minimum_image(cell.positions[j] - cell.positions[i], cell.periodic.period).norm() < reach
                {
                    expected.push((i as u32, j as u32));
                }
            }
        }
        assert!(!expected.is_empty());
        assert_eq!(periodic_pairs(&cell, reach).iter().map(|p| (p.i, p.j)).collect::<Vec<_>>(), expected);
    }

    #[test]
    fn relaxation_reaches_equilibrium_and_keeps_the_fabric_real() {
        let material = FibreMaterial::kevlar_km2();
        let law = NormalLaw::ElastoPlasticKm2;
        let mut cell = PlainWeave::km2_style_706(4).unit_cell(&material).unwrap();
        let (crimp, thickness) = (cell.crimp(), cell.thickness());
        let report = relax(
            &mut cell,
            &material,
            &law,
            &RelaxOptions { tolerance: 1e-6, max_iterations: 100_000, ..Default::default() },
        )
        .unwrap();
        assert!(report.final_residual_n <= 1e-6 * report.initial_residual_n, "{report:?}");
        // the solver's forces on the relaxed cell are the converged ones
        let pairs = periodic_pairs(&cell, 1.5 * cell.section.contact_diameter);
        let mut force = vec![Vec3::zeros(); cell.positions.len()];
        cell_forces(&cell, &material, &law, Rods::Rest, &pairs, &mut ChainScratch::default(), &mut force);
        assert!((largest_force(&force) - report.final_residual_n).abs() <= 1e-9 * report.initial_residual_n);
        // tension pulls the yarns straighter and flatter; no contact is compressed beyond the
        // strain the stable time step is designed for
        assert!(cell.crimp() < crimp && cell.thickness() < thickness);
        assert!(
            report.contacts > 0 && report.largest_overlap_ratio < dea_core::stability::DESIGN_CONTACT_STRAIN,
            "{}",
            report.largest_overlap_ratio
        );
        // style 706: 180 g/m^2 (DuPont), within 2 %
        assert!((cell.areal_density(&material) / 0.180 - 1.0).abs() < 0.02, "{}", cell.areal_density(&material));
        // every element carries the fibre tension on average
        let n = cell.nodes_per_period as usize;
        for fibre in 0..cell.fibres() {
            let strain = cell.fibre_length(fibre) / (n as f64 * cell.rest_lengths[fibre]) - 1.0;
            assert!(
                (strain * material.longitudinal_modulus * cell.section.area / cell.fibre_tension - 1.0).abs() < 1e-9
            );
        }
        // the same bits every time
        let mut again = PlainWeave::km2_style_706(4).unit_cell(&material).unwrap();
        relax(
            &mut again,
            &material,
            &law,
            &RelaxOptions { tolerance: 1e-6, max_iterations: 100_000, ..Default::default() },
        )
        .unwrap();
        assert_eq!(again, cell);
    }

    #[test]
    fn a_relaxation_that_cannot_finish_says_so() {
        let material = FibreMaterial::kevlar_km2();
        let mut cell = PlainWeave::km2_style_706(4).unit_cell(&material).unwrap();
        let error = relax(
            &mut cell,
            &material,
            &NormalLaw::ElastoPlasticKm2,
            &RelaxOptions { tolerance: 1e-6, max_iterations: 10, ..Default::default() },
        )
        .unwrap_err();
        assert!(matches!(error, RelaxError::NotConverged { iterations: 10, .. }));
    }

    #[test]
    fn internal_forces_sum_to_zero() {
        let material = FibreMaterial::kevlar_km2();
        let mut cell = PlainWeave::km2_style_706(4).unit_cell(&material).unwrap();
        // push the yarns into each other so that contacts act too
        for p in cell.positions.iter_mut() {
            p.z *= 0.6;
        }
        let pairs = periodic_pairs(&cell, 1.5 * cell.section.contact_diameter);
        let mut force = vec![Vec3::zeros(); cell.positions.len()];
        let law = NormalLaw::Elastic { transverse_modulus: material.transverse_modulus };
        let (contacts, _) =
            cell_forces(&cell, &material, &law, Rods::Rest, &pairs, &mut ChainScratch::default(), &mut force);
        assert!(contacts > 0);
        let total: Vec3 = force.iter().sum();
        let scale = largest_force(&force);
        assert!(total.norm() < 1e-10 * scale * force.len() as f64, "{total}");
    }
}
