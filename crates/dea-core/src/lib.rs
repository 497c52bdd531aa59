//! Digital-element physics kernels (modified DEA, seed chapters 4–5).
//!
//! Everything here is MPI-free: a kernel sees a local node set (owned nodes first, ghosts
//! after), reads positions and parameters, and adds into a force slice. Every per-node sum is
//! a gather in a fixed order (rod, bending, contacts sorted by partner global id, projectile),
//! so the result for a node never depends on how the problem is partitioned.

pub mod bending;
pub mod contact;
pub mod dispatch;
pub mod domain;
pub mod energy;
pub mod exact;
pub mod failure;
pub mod fibre_contact;
#[doc(hidden)]
pub mod fixtures;
pub mod friction;
pub mod guides;
pub mod ids;
pub mod integrate;
#[cfg(target_arch = "x86_64")]
pub mod lanes;
pub mod material;
pub mod measure;
pub mod multi_rate;
pub mod neighbour;
pub mod nodes;
pub mod pair_data;
pub mod projectile;
pub mod projectile_contact;
pub mod rod;
pub mod shear_gauge;
pub mod stability;
pub mod surface;
pub mod tension_gauge;
pub mod tie;
pub mod weibull;

pub use domain::{Domain, DomainError, GhostRecord, NodeMotion, CHAIN_STENCIL};
pub use projectile_contact::Reaction;
pub use ids::{FibreId, GlobalNodeId, LocalNodeId, Rank, NONE};
pub use material::{FibreMaterial, FibreSection};
pub use nodes::{Elements, Nodes};

/// 3-vector of f64 used for every position, velocity and force.
pub type Vec3 = nalgebra::Vector3<f64>;

/// Smallest axis-aligned box holding `points`: (low, high) corners; inverted (+inf, -inf)
/// when there are none, so it grows from any first point.
pub fn bounding_box(points: impl IntoIterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.into_iter().fold((Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)), |(low, high), p| (low.inf(&p), high.sup(&p)))
}

/// `v.floor() as i64` (saturating, NaN to 0) without a call: the baseline x86-64 target has
/// no rounding instruction, and the cell grids take this three times per node.
#[inline]
pub fn floor_index(v: f64) -> i64 {
    let truncated = v as i64;
    truncated.saturating_sub(i64::from(v < truncated as f64))
}

#[cfg(test)]
mod tests {
    #[test]
    fn floor_index_is_the_saturating_floor() {
        let values = [0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.999999, -2.000001, 1e-300, -1e-300, 4.5e15, -4.5e15, 1e30, -1e30, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        for v in values.into_iter().chain((-2000..2000).map(|k| k as f64 * 0.37)) {
            assert_eq!(super::floor_index(v), v.floor() as i64, "{v}");
        }
    }
}
