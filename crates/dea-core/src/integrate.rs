//! Central-difference integration, seed eqs (4-18)…(4-20), written as kick–drift–kick:
//! `v(n+1/2) = v(n) + a(n) dt/2`, `x(n+1) = x(n) + v(n+1/2) dt`, `v(n+1) = v(n+1/2) + a(n+1) dt/2`.
//! The positions are exactly those of (4-19), (4-20) with `v(1/2) = v(0) + a(0) dt/2`; the
//! synchronous velocities make the energy balance exact to the scheme's order.

use crate::nodes::Nodes;
use crate::Vec3;

/// `v += F/m * h` for owned nodes (4-18, 4-19); clamped nodes keep zero velocity.
pub fn kick(nodes: &mut Nodes, h: f64) {
    for i in 0..nodes.n_owned {
        if nodes.clamped[i] {
            nodes.velocity[i].fill(0.0);
        } else {
            // (4-18), with one division per node instead of one per component
            nodes.velocity[i] += nodes.force[i] * (h / nodes.mass[i]);
        }
    }
}

/// Scales the velocity of every owned node by `factor`: mass-proportional damping
/// `dv/dt = -c v` over a half step is `factor = exp(-c h)` (a settle, never a shot).
pub fn damp(nodes: &mut Nodes, factor: f64) {
    for v in &mut nodes.velocity[..nodes.n_owned] {
        *v *= factor;
    }
}

/// Half-step velocity update followed by the position update (4-19, 4-20), in one pass
/// over the owned nodes; clamped nodes keep zero velocity and their position. Returns the
/// largest distance a node moved in the step, and the largest distance of a node from
/// `reference` (where the neighbour lists were built; infinite when they were built for
/// other nodes), taken in the same pass rather than in one more over every node [m].
pub fn kick_drift(nodes: &mut Nodes, h: f64, dt: f64, reference: &[Vec3]) -> (f64, f64) {
    let tracked = reference.len() == nodes.n_owned;
    let (mut fastest, mut farthest): (f64, f64) = (0.0, if tracked { 0.0 } else { f64::INFINITY });
    for i in 0..nodes.n_owned {
        if nodes.clamped[i] {
            nodes.velocity[i].fill(0.0);
        } else {
            let velocity = nodes.velocity[i] + nodes.force[i] * (h / nodes.mass[i]);
            nodes.velocity[i] = velocity;
            nodes.position[i] += velocity * dt;
            fastest = fastest.max(velocity.norm_squared());
        }
        if tracked {
            farthest = farthest.max((nodes.position[i] - reference[i]).norm_squared());
        }
    }
    (fastest.sqrt() * dt, farthest.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::{FibreId, GlobalNodeId};

    #[test]
    fn the_drift_reports_the_farthest_node_from_the_reference_and_the_longest_step() {
        let mut nodes = Nodes::default();
        for k in 0..4 {
            nodes.push(GlobalNodeId(k), Vec3::new(k as f64, 0.0, 0.0), Vec3::new(0.0, k as f64, 0.0), 2.0, FibreId(0), k as u32, 0, k == 3, k == 3);
        }
        nodes.n_owned = 4;
        // node 3 is clamped; its reference is off by 5, node 1's by 1
        let mut reference = nodes.position.clone();
        reference[1].z += 1.0;
        reference[3].z += 5.0;
        nodes.force[2] = Vec3::new(0.0, 4.0, 0.0);
        let (moved, farthest) = kick_drift(&mut nodes, 0.5, 0.1, &reference);
        // node 2: velocity 2 + 4 * 0.5 / 2 = 3 along y, moved 0.3
        assert!((moved - 0.3).abs() < 1e-15, "{moved}");
        assert_eq!(nodes.position[3], Vec3::new(3.0, 0.0, 0.0));
        let expected = nodes.position.iter().zip(&reference).map(|(x, r)| (x - r).norm()).fold(0.0, f64::max);
        assert_eq!(farthest, expected);
        assert_eq!(farthest, 5.0);
        // lists built for other nodes: every node counts as far
        assert_eq!(kick_drift(&mut nodes, 0.5, 0.1, &reference[..3]).1, f64::INFINITY);
    }
}
