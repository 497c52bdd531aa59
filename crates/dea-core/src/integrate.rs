//! Central-difference integration, seed eqs (4-18)…(4-20), written as kick–drift–kick:
//! `v(n+1/2) = v(n) + a(n) dt/2`, `x(n+1) = x(n) + v(n+1/2) dt`, `v(n+1) = v(n+1/2) + a(n+1) dt/2`.
//! The positions are exactly those of (4-19), (4-20) with `v(1/2) = v(0) + a(0) dt/2`; the
//! synchronous velocities make the energy balance exact to the scheme's order.

use crate::nodes::Nodes;

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
/// largest distance a node moved [m].
pub fn kick_drift(nodes: &mut Nodes, h: f64, dt: f64) -> f64 {
    let mut fastest: f64 = 0.0;
    for i in 0..nodes.n_owned {
        if nodes.clamped[i] {
            nodes.velocity[i].fill(0.0);
        } else {
            let velocity = nodes.velocity[i] + nodes.force[i] * (h / nodes.mass[i]);
            nodes.velocity[i] = velocity;
            nodes.position[i] += velocity * dt;
            fastest = fastest.max(velocity.norm_squared());
        }
    }
    fastest.sqrt() * dt
}
