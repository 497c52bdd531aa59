//! Displacements, and the back-face deflection of the last layer: what a range measures
//! behind a panel (the depth of the dent in the backing), as a history of the run
//! (docs/output.md, docs/theory.md V8).

use dea_core::nodes::FailureMode;
use dea_core::projectile::RigidProjectile;
use dea_core::Vec3;

use crate::comm::Comm;
use crate::distributed::Distributed;

/// A projectile's line of flight: a point on it (its centre) and its direction (down the
/// panel's normal for a projectile at rest) [m, -]. At time zero, the impact axis.
pub fn line_of_flight(projectile: &RigidProjectile) -> (Vec3, Vec3) {
    (projectile.position, projectile.velocity.try_normalize(0.0).unwrap_or(-Vec3::z()))
}

/// Where the back-face deflection is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BackFaceProbe {
    /// the layer measured: the last one, the panel's back face (layer 0 is struck first)
    pub layer: u32,
    /// on the rank that owns it, the owned index of the back layer's node nearest the impact
    /// axis as built (the same node on any number of ranks and after a restart)
    pub axis_node: Option<usize>,
}

impl<C: Comm> Distributed<C> {
    /// Owned node `i`'s position less its position as built, before any settle [m].
    pub fn displacement(&self, i: usize) -> Vec3 {
        self.domain.nodes.position[i] - self.as_built[i]
    }

    /// Finds the back layer's node nearest the impact axis, the line through `point` along
    /// `direction` (a unit vector), by the positions as built; ties go to the lower global id
    /// (collective).
    pub(crate) fn locate_back_face(&mut self, point: Vec3, direction: Vec3) {
        let nodes = &self.domain.nodes;
        let layer = self.layer_of_yarn.iter().copied().max().unwrap_or(0);
        let from_axis = |x: &Vec3| {
            let r = x - point;
            (r - direction * r.dot(&direction)).norm()
        };
        // (distance, gid) compared as integers: a distance is never negative, so its bits
        // order as its values do
        let mut best = [u64::MAX, u64::MAX];
        for i in 0..nodes.n_owned {
            if self.layer_of(nodes.fibre[i]) == layer {
                best = best.min([from_axis(&self.as_built[i]).to_bits(), nodes.gid[i].0]);
            }
        }
        let mut nearest = [best[0]];
        self.comm.min_u64(&mut nearest);
        let mut gid = [if best[0] == nearest[0] { best[1] } else { u64::MAX }];
        self.comm.min_u64(&mut gid);
        let axis_node = nodes.gid[..nodes.n_owned].binary_search_by_key(&gid[0], |g| g.0).ok();
        self.back_face = BackFaceProbe { layer, axis_node };
    }

    /// The back layer's deflection along the panel's inward normal (-z) [m]: the largest over
    /// its nodes still joined to both fibre neighbours (a loose end is not the face), and
    /// that of its node nearest the impact axis; NaN when there is no such node (collective;
    /// maxima, so the same bits on any number of ranks).
    pub fn back_face_deflection(&self) -> [f64; 2] {
        let nodes = &self.domain.nodes;
        let failure = &self.domain.elements.failure;
        let intact = |j: u32| j == dea_core::NONE || failure[j as usize] == FailureMode::Intact;
        // as built less now, so that a node at rest reads +0, not -0
        let depth = |i: usize| self.as_built[i].z - self.domain.nodes.position[i].z;
        let mut deflection = [f64::NEG_INFINITY; 2];
        for i in 0..nodes.n_owned {
            let joined = failure[i] == FailureMode::Intact && intact(nodes.prev[i]);
            if joined && self.layer_of(nodes.fibre[i]) == self.back_face.layer {
                deflection[0] = deflection[0].max(depth(i));
            }
        }
        if let Some(i) = self.back_face.axis_node {
            deflection[1] = depth(i);
        }
        self.comm.max_f64(&mut deflection);
        deflection.map(|d| if d == f64::NEG_INFINITY { f64::NAN } else { d })
    }
}
