//! Central-difference integration, seed eqs (4-18)…(4-20), written as kick–drift–kick:
//! `v(n+1/2) = v(n) + a(n) dt/2`, `x(n+1) = x(n) + v(n+1/2) dt`, `v(n+1) = v(n+1/2) + a(n+1) dt/2`.
//! The positions are exactly those of (4-19), (4-20) with `v(1/2) = v(0) + a(0) dt/2`; the
//! synchronous velocities make the energy balance exact to the scheme's order. A step's
//! closing kick may wait for the next step's opening one, which applies both in one pass
//! over the nodes with the same bits ([`kick_drift`]'s `deferred`).

use crate::nodes::Nodes;
use crate::Vec3;

/// `v += F/m * h` for owned nodes (4-18, 4-19); clamped nodes keep zero velocity.
pub fn kick(nodes: &mut Nodes, h: f64) {
    let i = crate::in_avx2_lanes!(kick_in_lanes(nodes, h)).unwrap_or(0);
    for i in i..nodes.n_owned {
        nodes.velocity[i] = kicked(nodes, h, i);
    }
}

/// The velocity of node `i` after a kick of `h` [m/s]: zero for a clamped node.
#[inline]
pub fn kicked(nodes: &Nodes, h: f64, i: usize) -> Vec3 {
    if nodes.clamped[i] {
        Vec3::zeros()
    } else {
        // (4-18), with one division per node instead of one per component
        nodes.velocity[i] + nodes.force[i] * (h / nodes.mass[i])
    }
}

/// [`kick`] four nodes at a time (the scalar code's bits); returns where the scalar code
/// takes over.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn kick_in_lanes(nodes: &mut Nodes, h: f64) -> usize {
    use crate::lanes::{F4, V4};
    let mut i = 0;
    while i + 4 <= nodes.n_owned {
        if nodes.clamped[i..i + 4].iter().any(|&c| c) {
            for k in i..i + 4 {
                nodes.velocity[k] = kicked(nodes, h, k);
            }
        } else {
            let factor = F4::splat(h).div(F4::load(&nodes.mass, i));
            V4::load(&nodes.velocity, i).add(V4::load(&nodes.force, i).scale(factor)).store(&mut nodes.velocity, i);
        }
        i += 4;
    }
    i
}

/// Scales the velocity of every owned node by `factor`: mass-proportional damping
/// `dv/dt = -c v` over a half step is `factor = exp(-c h)` (a settle, never a shot).
pub fn damp(nodes: &mut Nodes, factor: f64) {
    for v in &mut nodes.velocity[..nodes.n_owned] {
        *v *= factor;
    }
}

/// Half-step velocity update followed by the position update (4-19, 4-20), in one pass
/// over the owned nodes; clamped nodes keep zero velocity and their position. A `deferred`
/// closing kick of the last step (its half step [s], with the forces still in
/// `nodes.force`) is applied first in the same pass, with the bits of [`kick`]. Returns the
/// largest distance a node moved in the step, and the largest distance of a node from
/// `reference` (where the neighbour lists were built; infinite when they were built for
/// other nodes), taken in the same pass rather than in one more over every node [m].
pub fn kick_drift(nodes: &mut Nodes, deferred: Option<f64>, h: f64, dt: f64, reference: &[Vec3]) -> (f64, f64) {
    let tracked = reference.len() == nodes.n_owned;
    let (mut fastest, mut farthest): (f64, f64) = (0.0, if tracked { 0.0 } else { f64::INFINITY });
    let mut i = 0;
    if let Some(lanes) =
        tracked.then(|| crate::in_avx2_lanes!(kick_drift_in_lanes(nodes, deferred, h, dt, reference))).flatten()
    {
        (i, fastest, farthest) = lanes;
    }
    for i in i..nodes.n_owned {
        kick_drift_node(nodes, deferred, h, dt, i, &mut fastest);
        if tracked {
            farthest = farthest.max((nodes.position[i] - reference[i]).norm_squared());
        }
    }
    (fastest.sqrt() * dt, farthest.sqrt())
}

/// [`kick_drift`] of node `i`, keeping the largest squared speed in `fastest`.
#[inline]
fn kick_drift_node(nodes: &mut Nodes, deferred: Option<f64>, h: f64, dt: f64, i: usize, fastest: &mut f64) {
    if let Some(first) = deferred {
        nodes.velocity[i] = kicked(nodes, first, i);
    }
    let velocity = kicked(nodes, h, i);
    nodes.velocity[i] = velocity;
    if !nodes.clamped[i] {
        nodes.position[i] += velocity * dt;
        *fastest = fastest.max(velocity.norm_squared());
    }
}

/// [`kick_drift`] four nodes at a time (the scalar code's bits: the largest values do not
/// depend on the order they are taken in); returns where the scalar code takes over and the
/// largest squared speed and squared distance from `reference` so far.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn kick_drift_in_lanes(
    nodes: &mut Nodes,
    deferred: Option<f64>,
    h: f64,
    dt: f64,
    reference: &[Vec3],
) -> (usize, f64, f64) {
    use crate::lanes::{F4, V4};
    let (mut fastest, mut farthest) = (F4::splat(0.0), F4::splat(0.0));
    let mut i = 0;
    while i + 4 <= nodes.n_owned {
        if nodes.clamped[i..i + 4].iter().any(|&c| c) {
            let mut fastest_here = 0.0;
            for k in i..i + 4 {
                kick_drift_node(nodes, deferred, h, dt, k, &mut fastest_here);
            }
            fastest = F4::splat(fastest_here).max_with(fastest);
        } else {
            let (mass, force) = (F4::load(&nodes.mass, i), V4::load(&nodes.force, i));
            let factor = F4::splat(h).div(mass);
            let mut velocity = V4::load(&nodes.velocity, i);
            if let Some(first) = deferred {
                // the time step is fixed: the two half steps are the same, and so their factors
                let first_factor = if first == h { factor } else { F4::splat(first).div(mass) };
                velocity = velocity.add(force.scale(first_factor));
            }
            let velocity = velocity.add(force.scale(factor));
            velocity.store(&mut nodes.velocity, i);
            V4::load(&nodes.position, i).add(velocity.scale(F4::splat(dt))).store(&mut nodes.position, i);
            fastest = velocity.dot(velocity).max_with(fastest);
        }
        let displacement = V4::load(&nodes.position, i).sub(V4::load(reference, i));
        farthest = displacement.dot(displacement).max_with(farthest);
        i += 4;
    }
    let largest = |lanes: F4| lanes.to_array().into_iter().fold(0.0, f64::max);
    (i, largest(fastest), largest(farthest))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::{FibreId, GlobalNodeId};

    /// 103 owned nodes with random positions, velocities, forces and masses, a few clamped,
    /// and random reference positions near them.
    fn random_nodes() -> (Nodes, Vec<Vec3>) {
        let mut state = 5u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut nodes = Nodes::default();
        for k in 0..103u32 {
            let (x, v, f) = (
                Vec3::new(next(), next(), next()),
                Vec3::new(next(), next(), next()),
                Vec3::new(next(), next(), next()) * 1e-3,
            );
            nodes.push(GlobalNodeId(k as u64), x, v, 1e-12 * (1.0 + next()), FibreId(0), k, 0, k % 37 == 5, false);
            *nodes.force.last_mut().unwrap() = f;
        }
        nodes.n_owned = nodes.len();
        let reference = nodes.position.iter().map(|x| x + Vec3::new(next(), next(), next()) * 1e-3).collect();
        (nodes, reference)
    }

    fn bits(nodes: &Nodes) -> Vec<u64> {
        nodes
            .position
            .iter()
            .chain(&nodes.velocity)
            .flat_map(|v| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>())
            .collect()
    }

    #[test]
    fn the_lanes_give_the_bits_of_the_scalar_kick_and_drift() {
        let (h, dt) = (0.5e-9, 1e-9);
        // no deferred kick, one of the same half step, one of another
        for deferred in [None, Some(h), Some(0.3e-9)] {
            let (mut nodes, reference) = random_nodes();
            let mut scalar = nodes.clone();
            let (moved, farthest) = kick_drift(&mut nodes, deferred, h, dt, &reference);
            let mut fastest = 0.0;
            for i in 0..scalar.n_owned {
                kick_drift_node(&mut scalar, deferred, h, dt, i, &mut fastest);
            }
            let scalar_farthest =
                scalar.position.iter().zip(&reference).map(|(x, r)| (x - r).norm_squared()).fold(0.0, f64::max);
            assert_eq!(
                (moved.to_bits(), farthest.to_bits()),
                ((fastest.sqrt() * dt).to_bits(), scalar_farthest.sqrt().to_bits())
            );
            kick(&mut nodes, h);
            for i in 0..scalar.n_owned {
                scalar.velocity[i] = kicked(&scalar, h, i);
            }
            assert_eq!(bits(&nodes), bits(&scalar), "{deferred:?}");
            // clamped nodes stayed put, at rest
            assert!((0..nodes.n_owned).filter(|&i| nodes.clamped[i]).all(|i| nodes.velocity[i] == Vec3::zeros()));
        }
    }

    #[test]
    fn a_deferred_kick_gives_the_bits_of_the_kick_it_stands_for() {
        let (h, dt) = (0.5e-9, 1e-9);
        let (mut fused, reference) = random_nodes();
        let mut apart = fused.clone();
        let unchanged = bits(&fused);
        let fused_motion = kick_drift(&mut fused, Some(h), h, dt, &reference);
        kick(&mut apart, h);
        assert_ne!(bits(&apart), unchanged, "the kick changed nothing: the test would prove nothing");
        let apart_motion = kick_drift(&mut apart, None, h, dt, &reference);
        assert_eq!(bits(&fused), bits(&apart));
        assert_eq!(
            (fused_motion.0.to_bits(), fused_motion.1.to_bits()),
            (apart_motion.0.to_bits(), apart_motion.1.to_bits())
        );
    }

    #[test]
    fn the_drift_reports_the_farthest_node_from_the_reference_and_the_longest_step() {
        let mut nodes = Nodes::default();
        for k in 0..4 {
            nodes.push(
                GlobalNodeId(k),
                Vec3::new(k as f64, 0.0, 0.0),
                Vec3::new(0.0, k as f64, 0.0),
                2.0,
                FibreId(0),
                k as u32,
                0,
                k == 3,
                k == 3,
            );
        }
        nodes.n_owned = 4;
        // node 3 is clamped; its reference is off by 5, node 1's by 1
        let mut reference = nodes.position.clone();
        reference[1].z += 1.0;
        reference[3].z += 5.0;
        nodes.force[2] = Vec3::new(0.0, 4.0, 0.0);
        let (moved, farthest) = kick_drift(&mut nodes, None, 0.5, 0.1, &reference);
        // node 2: velocity 2 + 4 * 0.5 / 2 = 3 along y, moved 0.3
        assert!((moved - 0.3).abs() < 1e-15, "{moved}");
        assert_eq!(nodes.position[3], Vec3::new(3.0, 0.0, 0.0));
        let expected = nodes.position.iter().zip(&reference).map(|(x, r)| (x - r).norm()).fold(0.0, f64::max);
        assert_eq!(farthest, expected);
        assert_eq!(farthest, 5.0);
        // lists built for other nodes: every node counts as far
        assert_eq!(kick_drift(&mut nodes, None, 0.5, 0.1, &reference[..3]).1, f64::INFINITY);
    }
}
