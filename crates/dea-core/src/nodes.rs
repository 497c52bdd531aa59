//! Structure-of-arrays storage of nodes and rod elements.
//!
//! A digital fibre is a chain of nodes. Element `i` joins local node `i` to `next[i]` and is
//! named by the global id of node `i`; it exists when `next[i] != NONE`. Owned nodes come
//! first (ascending global id), ghosts after.

use crate::ids::{FibreId, GlobalNodeId, NONE};
use crate::Vec3;

/// Nodes of one domain (owned, then ghosts).
#[derive(Clone, Debug, Default)]
pub struct Nodes {
    /// number of owned nodes; indices `n_owned..len()` are ghosts
    pub n_owned: usize,
    /// global id of each node
    pub gid: Vec<GlobalNodeId>,
    /// position [m]
    pub position: Vec<Vec3>,
    /// velocity; half a step behind while a domain defers its closing kick (read
    /// `Domain::velocity` for the present step's) [m/s]
    pub velocity: Vec<Vec3>,
    /// force accumulated in the current step [N]
    pub force: Vec<Vec3>,
    /// lumped mass [kg]
    pub mass: Vec<f64>,
    /// fibre the node belongs to
    pub fibre: Vec<FibreId>,
    /// position of the node along its fibre (0 at the first node)
    pub along: Vec<u32>,
    /// index into the domain's section table
    pub section: Vec<u16>,
    /// local index of the previous node on the fibre, or `NONE`
    pub prev: Vec<u32>,
    /// local index of the next node on the fibre, or `NONE`
    pub next: Vec<u32>,
    /// clamped nodes never move (fixed boundary)
    pub clamped: Vec<bool>,
    /// the node is the last of its fibre (so a missing `next` is an end, not a missing ghost)
    pub last: Vec<bool>,
    /// turning angle at which the node's bending spring is at rest: 0 for a straight fibre,
    /// the relaxed angle of a woven one (docs/theory.md F4) [rad]
    pub rest_angle: Vec<f64>,
}

/// Why an element failed (seed eq. 5-6 split by the dominant term).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, PartialOrd, Ord)]
#[repr(u8)]
pub enum FailureMode {
    #[default]
    /// not broken
    Intact = 0,
    /// shear term below 10% of the criterion
    Tension = 1,
    /// tension term below 10% of the criterion
    Shear = 2,
    /// both terms matter
    Combined = 3,
}

/// Per-element state, indexed by the local index of the element's first node.
#[derive(Clone, Debug, Default)]
pub struct Elements {
    /// rest length l0 [m]
    pub rest_length: Vec<f64>,
    /// tensile strength sigma_u of this element [Pa]
    pub tensile_strength: Vec<f64>,
    /// failure state (Intact while the element carries force)
    pub failure: Vec<FailureMode>,
    /// engineering strain (l - l0) / l0 of the current step [-] (scratch)
    pub strain: Vec<f64>,
    /// axial force of the element, positive in tension [N] (scratch; it pulls its first node
    /// along `direction`)
    pub axial_force: Vec<f64>,
    /// unit vector from the first to the second node; zero for a broken element, whose
    /// ends may meet (scratch, reused by bending)
    pub direction: Vec<Vec3>,
    /// 1 / current length [1/m]; zero for a broken element (scratch, reused by bending)
    pub inverse_length: Vec<f64>,
}

impl FailureMode {
    /// The mode of a stored code (results files and halo messages).
    pub fn from_code(code: u8) -> Option<Self> {
        [Self::Intact, Self::Tension, Self::Shear, Self::Combined].get(code as usize).copied()
    }
}

impl Nodes {
    /// Number of local nodes (owned + ghosts).
    pub fn len(&self) -> usize {
        self.gid.len()
    }

    /// No node is held.
    pub fn is_empty(&self) -> bool {
        self.gid.is_empty()
    }

    /// Appends one node; chain links are set by [`Nodes::link_chains`].
    #[allow(clippy::too_many_arguments)]
    pub fn push(&mut self, gid: GlobalNodeId, position: Vec3, velocity: Vec3, mass: f64, fibre: FibreId, along: u32, section: u16, clamped: bool, last: bool) {
        self.gid.push(gid);
        self.position.push(position);
        self.velocity.push(velocity);
        self.force.push(Vec3::zeros());
        self.mass.push(mass);
        self.fibre.push(fibre);
        self.along.push(along);
        self.section.push(section);
        self.prev.push(NONE);
        self.next.push(NONE);
        self.clamped.push(clamped);
        self.last.push(last);
        self.rest_angle.push(0.0);
    }

    /// Drops every ghost, keeping the owned nodes.
    pub fn truncate_to_owned(&mut self) {
        let n = self.n_owned;
        self.gid.truncate(n);
        self.position.truncate(n);
        self.velocity.truncate(n);
        self.force.truncate(n);
        self.mass.truncate(n);
        self.fibre.truncate(n);
        self.along.truncate(n);
        self.section.truncate(n);
        self.prev.truncate(n);
        self.next.truncate(n);
        self.clamped.truncate(n);
        self.last.truncate(n);
        self.rest_angle.truncate(n);
    }

    /// The first owned node (ascending local index) whose chain stencil of `depth` nodes on
    /// either side is not all present locally, with the position along the fibre of the
    /// missing node. A missing node would silently turn into a fibre end, so a domain checks
    /// this after every change of its ghosts.
    pub fn missing_chain_neighbour(&self, depth: u32) -> Option<(GlobalNodeId, u32)> {
        for i in 0..self.n_owned {
            let mut j = i;
            for _ in 0..depth.min(self.along[i]) {
                match self.prev[j] {
                    NONE => return Some((self.gid[i], self.along[j] - 1)),
                    p => j = p as usize,
                }
            }
            let mut j = i;
            for _ in 0..depth {
                if self.last[j] {
                    break;
                }
                match self.next[j] {
                    NONE => return Some((self.gid[i], self.along[j] + 1)),
                    n => j = n as usize,
                }
            }
        }
        None
    }

    /// Sets `prev`/`next` from (fibre, along): consecutive positions on one fibre are linked.
    /// Works for any local order, so ghosts can sit anywhere after the owned nodes. Owned
    /// nodes already in (fibre, along) order (ascending gid) are merged with the sorted
    /// ghosts instead of sorted again: a rank relinks after every ghost rebuild.
    pub fn link_chains(&mut self) {
        let key = |i: u32| (self.fibre[i as usize], self.along[i as usize]);
        let owned_in_order = (1..self.n_owned as u32).all(|i| key(i - 1) <= key(i));
        let order: Vec<u32> = if owned_in_order {
            let mut ghosts: Vec<u32> = (self.n_owned as u32..self.len() as u32).collect();
            ghosts.sort_unstable_by_key(|&i| key(i));
            let mut merged = Vec::with_capacity(self.len());
            let (mut a, mut b) = (0u32, 0usize);
            while a < self.n_owned as u32 || b < ghosts.len() {
                if b == ghosts.len() || (a < self.n_owned as u32 && key(a) <= key(ghosts[b])) {
                    merged.push(a);
                    a += 1;
                } else {
                    merged.push(ghosts[b]);
                    b += 1;
                }
            }
            merged
        } else {
            let mut all: Vec<u32> = (0..self.len() as u32).collect();
            all.sort_unstable_by_key(|&i| key(i));
            all
        };
        self.prev.fill(NONE);
        self.next.fill(NONE);
        for pair in order.windows(2) {
            let (a, b) = (pair[0] as usize, pair[1] as usize);
            if self.fibre[a] == self.fibre[b] && self.along[a] + 1 == self.along[b] {
                self.next[a] = b as u32;
                self.prev[b] = a as u32;
            }
        }
    }
}

impl Elements {
    /// Appends the state of one element (of a node without element: zero rest length).
    pub fn push(&mut self, rest_length: f64, tensile_strength: f64, failure: FailureMode) {
        self.rest_length.push(rest_length);
        self.tensile_strength.push(tensile_strength);
        self.failure.push(failure);
        self.strain.push(0.0);
        self.axial_force.push(0.0);
        self.direction.push(Vec3::zeros());
        self.inverse_length.push(0.0);
    }

    /// Keeps the first `n` elements (those of the owned nodes).
    pub fn truncate(&mut self, n: usize) {
        self.rest_length.truncate(n);
        self.tensile_strength.truncate(n);
        self.failure.truncate(n);
        self.strain.truncate(n);
        self.axial_force.truncate(n);
        self.direction.truncate(n);
        self.inverse_length.truncate(n);
    }

    /// True when element `i` exists and carries force.
    #[inline]
    pub fn is_intact(&self, nodes: &Nodes, i: usize) -> bool {
        nodes.next[i] != NONE && self.failure[i] == FailureMode::Intact
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two fibres of 6 nodes; `order` gives the local order of (fibre, along) pairs.
    fn chain(order: &[(u32, u32)], n_owned: usize) -> Nodes {
        let mut nodes = Nodes::default();
        for &(f, a) in order {
            nodes.push(GlobalNodeId((f * 6 + a) as u64), Vec3::zeros(), Vec3::zeros(), 1.0, FibreId(f), a, 0, false, a == 5);
        }
        nodes.n_owned = n_owned;
        nodes.link_chains();
        nodes
    }

    fn links(nodes: &Nodes) -> Vec<(u64, Option<u64>, Option<u64>)> {
        let gid = |j: u32| (j != NONE).then(|| nodes.gid[j as usize].0);
        let mut l: Vec<_> = (0..nodes.len()).map(|i| (nodes.gid[i].0, gid(nodes.prev[i]), gid(nodes.next[i]))).collect();
        l.sort();
        l
    }

    #[test]
    fn chains_link_the_same_whatever_the_local_order_and_report_missing_neighbours() {
        // owned in order, ghosts scattered; owned out of order; all in order
        let sorted: Vec<(u32, u32)> = (0..2).flat_map(|f| (0..6).map(move |a| (f, a))).collect();
        let reference = links(&chain(&sorted, sorted.len()));
        let ghosts_scattered = [(0, 2), (0, 3), (1, 1), (1, 4), (0, 5), (1, 0), (0, 0), (1, 5), (0, 4), (1, 2), (0, 1), (1, 3)];
        assert_eq!(links(&chain(&ghosts_scattered, 4)), reference);
        assert_eq!(links(&chain(&ghosts_scattered, 0)), reference);
        // owned nodes 0..4 of fibre 0 with only one ghost: the stencil of 3 is incomplete
        let partial = chain(&[(0, 0), (0, 1), (0, 2), (0, 3), (0, 4)], 4);
        assert_eq!(partial.missing_chain_neighbour(3), Some((GlobalNodeId(2), 5)));
        assert_eq!(partial.missing_chain_neighbour(1), None);
        // the stencil stops at the fibre's last node
        let whole = chain(&sorted[..6], 6);
        assert_eq!(whole.missing_chain_neighbour(3), None);
    }
}
