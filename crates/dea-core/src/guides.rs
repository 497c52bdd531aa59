//! The guides of the single-yarn fixture of seed §5.3 (Fig. 5-5; docs/theory.md F13): the
//! yarn's end masses slide along its axis on a friction surface, and its fibres are kept
//! from spreading sideways.
//!
//! Both are forces added after every other force of a step, so they see each node's whole
//! load:
//! - **lateral hold**: every owned node loses the y component (across the yarn, in the
//!   fabric's plane) of its force. A node that starts at rest across the yarn stays so, and
//!   the guide does no work.
//! - **sliding ends**: a fibre's end node (its first or last) keeps only its x component (the
//!   yarn's axis), and the surface under it resists with Coulomb friction of at most `limit`
//!   [N]. The friction is decided on the half-step velocity the next drift will use,
//!   `v' = v + (F + F_f) dt / m` with `v` the present half-step velocity: when the load alone
//!   would leave `|v + F dt / m| <= limit dt / m` the node sticks (`F_f` brings `v'` to
//!   exactly 0), else it slides with `F_f = -limit sign(v + F dt / m)`, which never reverses
//!   the motion it opposes. The work friction takes is `-F_f (v + v') dt / 2`, the leapfrog's
//!   own measure of a force's work over the step, booked as dissipated friction.

use crate::nodes::Nodes;

/// The fixture's guides.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Guides {
    /// keep every node's y velocity (across the yarn) at its start, zero
    pub hold_lateral: bool,
    /// the largest friction force on one fibre end node sliding along x, or `None` when the
    /// ends are clamped or free [N]
    pub end_friction: Option<f64>,
}

impl Guides {
    /// No guide acts (every target but the fixture).
    pub fn is_none(&self) -> bool {
        !self.hold_lateral && self.end_friction.is_none()
    }
}

/// Adds the guides' forces to the owned nodes' `force` and their friction work to
/// `friction_dissipated` [J]; `time_step` [s]. The velocities are the half-step ones the
/// next drift continues from (the domain's closing kick deferred).
#[allow(clippy::needless_range_loop)] // a node's arrays are read together by its index
pub fn add_guide_forces(nodes: &mut Nodes, guides: &Guides, time_step: f64, friction_dissipated: &mut [f64]) {
    if guides.is_none() {
        return;
    }
    for i in 0..nodes.n_owned {
        if nodes.clamped[i] {
            continue;
        }
        if guides.hold_lateral {
            nodes.force[i].y = 0.0;
        }
        let Some(limit) = guides.end_friction else { continue };
        if nodes.along[i] != 0 && !nodes.last[i] {
            continue;
        }
        let force = &mut nodes.force[i];
        force.y = 0.0;
        force.z = 0.0;
        let (mass, velocity) = (nodes.mass[i], nodes.velocity[i].x);
        let unopposed = velocity + force.x * time_step / mass;
        let load = force.x;
        if unopposed.abs() * mass <= limit * time_step {
            // stick: the force that stops the node (exactly zero for one at rest)
            force.x = -velocity * mass / time_step;
        } else {
            force.x -= limit * unopposed.signum();
        }
        let friction = force.x - load;
        let next = velocity + force.x * time_step / mass;
        friction_dissipated[i] -= friction * 0.5 * (velocity + next) * time_step;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::{FibreId, GlobalNodeId};
    use crate::Vec3;

    /// One free node of mass `mass` [kg] that is a fibre's first node (a sliding end).
    fn end_node(mass: f64, velocity: f64) -> Nodes {
        let mut nodes = Nodes::default();
        nodes.push(GlobalNodeId(0), Vec3::zeros(), Vec3::new(velocity, 0.0, 0.0), mass, FibreId(0), 0, 0, false, false);
        nodes.n_owned = 1;
        nodes
    }

    /// Steps one node under a constant load `load` [N] along x with the guides, leapfrog as
    /// the domain does; returns its position, velocity and the friction's work [m, m/s, J].
    fn slide(mass: f64, velocity: f64, load: f64, limit: f64, dt: f64, steps: usize) -> (f64, f64, f64) {
        let mut nodes = end_node(mass, velocity);
        let guides = Guides { hold_lateral: true, end_friction: Some(limit) };
        let mut dissipated = [0.0];
        for _ in 0..steps {
            nodes.force[0] = Vec3::new(load, 7.0, -3.0);
            add_guide_forces(&mut nodes, &guides, dt, &mut dissipated);
            assert_eq!((nodes.force[0].y, nodes.force[0].z), (0.0, 0.0), "only the axis is free");
            nodes.velocity[0] += nodes.force[0] * (dt / mass);
            let v = nodes.velocity[0];
            nodes.position[0] += v * dt;
        }
        (nodes.position[0].x, nodes.velocity[0].x, dissipated[0])
    }

    #[test]
    fn a_sliding_end_stops_where_coulomb_friction_stops_a_block() {
        // a 1 g block at 2 m/s against 10 N: a = 1e4 m/s^2, stops after 0.2 ms over 0.2 mm
        let (mass, v0, limit, dt) = (1e-3, 2.0, 10.0, 1e-7);
        let (x, v, dissipated) = slide(mass, v0, 0.0, limit, dt, 4000);
        assert!(v.abs() < 1e-15, "it stopped, and stays stopped: {v} m/s");
        let distance = v0 * v0 / (2.0 * limit / mass);
        assert!((x / distance - 1.0).abs() < 1e-3, "{x} against {distance}");
        // the friction took the whole kinetic energy
        let kinetic = 0.5 * mass * v0 * v0;
        assert!((dissipated / kinetic - 1.0).abs() < 1e-3, "{dissipated} J against {kinetic} J");
    }

    #[test]
    fn a_load_below_the_friction_limit_leaves_an_end_at_rest_and_above_it_accelerates_it() {
        let (mass, limit, dt) = (1e-3, 10.0, 1e-7);
        assert_eq!(slide(mass, 0.0, 9.99, limit, dt, 1000), (0.0, 0.0, 0.0));
        assert_eq!(slide(mass, 0.0, -9.99, limit, dt, 1000), (0.0, 0.0, 0.0));
        // 15 N against 10 N: a = 5e3 m/s^2 after the first step
        let steps = 1000;
        let (x, v, dissipated) = slide(mass, 0.0, 15.0, limit, dt, steps);
        let time = steps as f64 * dt;
        assert!((v / (5e3 * time) - 1.0).abs() < 1e-9, "{v}");
        assert!((x / (0.5 * 5e3 * time * time) - 1.0).abs() < 2e-3, "{x}");
        // it took limit times the distance slid
        assert!((dissipated / (limit * x) - 1.0).abs() < 2e-3, "{dissipated}");
        // and the opposite way
        let (x_back, v_back, _) = slide(mass, 0.0, -15.0, limit, dt, steps);
        assert_eq!((x_back, v_back), (-x, -v));
    }

    #[test]
    fn the_lateral_hold_leaves_interior_nodes_free_along_the_axis_and_through_the_fabric() {
        let mut nodes = end_node(1e-6, 0.0);
        nodes.along[0] = 5;
        let load = Vec3::new(1.0, 2.0, 3.0);
        nodes.force[0] = load;
        let mut dissipated = [0.0];
        add_guide_forces(&mut nodes, &Guides { hold_lateral: true, end_friction: Some(10.0) }, 1e-9, &mut dissipated);
        assert_eq!(nodes.force[0], Vec3::new(1.0, 0.0, 3.0));
        nodes.force[0] = load;
        add_guide_forces(&mut nodes, &Guides::default(), 1e-9, &mut dissipated);
        assert_eq!(nodes.force[0], load, "no guide: no force");
        assert_eq!(dissipated[0], 0.0);
    }
}
