//! Message encoding: every message is a vector of f64 words; integers travel as the bits of
//! a word ([`word`], [`integer`]), so nothing is rounded. The records here are the ghost
//! record of `borders`, the forward halo's, the projectile state and the reactions.

use dea_core::nodes::{Elements, FailureMode, Nodes};
use dea_core::projectile::RigidProjectile;
use dea_core::{FibreId, GhostRecord, GlobalNodeId, Reaction, Vec3};
use nalgebra::{Quaternion, UnitQuaternion};

/// f64 words of a ghost record at a rebuild.
pub const RECORD_WORDS: usize = 12;
/// f64 words per ghost in the per-step halo: position and element failure state.
pub const HALO_WORDS: usize = 4;
/// f64 words of the projectile state broadcast.
pub const PROJECTILE_WORDS: usize = 19;
/// f64 words of a reaction record: gid, force, torque, triangle, weights.
pub const REACTION_WORDS: usize = 11;

const FLAG_CLAMPED: u64 = 1;
const FLAG_LAST: u64 = 2;
/// the sender includes the node for the receiver's chain stencil (always kept)
const FLAG_CHAIN: u64 = 4;

/// The state of a rigid projectile as words: position, velocity, angular momentum, force,
/// torque, orientation quaternion (i, j, k, w).
pub fn projectile_words(p: &RigidProjectile) -> [f64; PROJECTILE_WORDS] {
    let mut words = [0.0; PROJECTILE_WORDS];
    for (k, v) in [p.position, p.velocity, p.angular_momentum, p.force, p.torque].iter().enumerate() {
        words[3 * k..3 * k + 3].copy_from_slice(v.as_slice());
    }
    words[15..19].copy_from_slice(p.orientation.quaternion().coords.as_slice());
    words
}

/// Inverse of [`projectile_words`]; the bits are copied, so no renormalisation happens.
pub fn set_projectile_words(p: &mut RigidProjectile, words: &[f64]) {
    let vector = |k: usize| Vec3::new(words[3 * k], words[3 * k + 1], words[3 * k + 2]);
    p.position = vector(0);
    p.velocity = vector(1);
    p.angular_momentum = vector(2);
    p.force = vector(3);
    p.torque = vector(4);
    p.orientation = UnitQuaternion::new_unchecked(Quaternion::new(words[18], words[15], words[16], words[17]));
}

/// A reaction as the words of a message or checkpoint.
pub fn reaction_words(r: &Reaction) -> [f64; REACTION_WORDS] {
    let [f, t, w] = [r.force, r.torque, Vec3::from(r.weights)];
    [word(r.gid.0), f.x, f.y, f.z, t.x, t.y, t.z, word(r.triangle as u64), w.x, w.y, w.z]
}

/// Inverse of [`reaction_words`].
pub fn reaction_from_words(w: &[f64]) -> Reaction {
    Reaction {
        gid: GlobalNodeId(integer(w[0])),
        force: Vec3::new(w[1], w[2], w[3]),
        torque: Vec3::new(w[4], w[5], w[6]),
        triangle: integer(w[7]) as u32,
        weights: [w[8], w[9], w[10]],
    }
}

/// An integer as the bits of a word.
pub fn word(value: u64) -> f64 {
    f64::from_bits(value)
}

/// Inverse of [`word`].
pub fn integer(word: f64) -> u64 {
    word.to_bits()
}

/// Owned node `i` as a ghost record of `borders`; `chain`: the receiver needs it for its
/// chain stencil and keeps it whatever its distance.
pub fn ghost_record_words(nodes: &Nodes, elements: &Elements, i: usize, chain: bool) -> [f64; RECORD_WORDS] {
    let x = nodes.position[i];
    let mut flags = if nodes.clamped[i] { FLAG_CLAMPED } else { 0 } | if nodes.last[i] { FLAG_LAST } else { 0 };
    if chain {
        flags |= FLAG_CHAIN;
    }
    [
        word(nodes.gid[i].0),
        x.x,
        x.y,
        x.z,
        word(nodes.fibre[i].0 as u64),
        word(nodes.along[i] as u64),
        word(nodes.section[i] as u64),
        word(flags),
        elements.rest_length[i],
        elements.tensile_strength[i],
        word(elements.failure[i] as u64),
        nodes.rest_angle[i],
    ]
}

/// The position of the node of a ghost record [m].
pub fn ghost_record_position(w: &[f64]) -> Vec3 {
    Vec3::new(w[1], w[2], w[3])
}

/// Whether the sender marked a ghost record as needed for the receiver's chain stencil.
pub fn ghost_record_is_chain(w: &[f64]) -> bool {
    integer(w[7]) & FLAG_CHAIN != 0
}

/// Inverse of [`ghost_record_words`].
pub fn ghost_record_from_words(w: &[f64]) -> GhostRecord {
    let flags = integer(w[7]);
    GhostRecord {
        gid: GlobalNodeId(integer(w[0])),
        position: Vec3::new(w[1], w[2], w[3]),
        fibre: FibreId(integer(w[4]) as u32),
        along: integer(w[5]) as u32,
        section: integer(w[6]) as u16,
        clamped: flags & FLAG_CLAMPED != 0,
        last: flags & FLAG_LAST != 0,
        rest_length: w[8],
        tensile_strength: w[9],
        failure: FailureMode::from_code(integer(w[10]) as u8).expect("a failure code sent by a rank"),
        rest_angle: w[11],
    }
}

/// Owned node `i`'s forward-halo words: its position and its element's failure state.
#[inline]
pub fn halo_words(nodes: &Nodes, failure: &[FailureMode], i: usize) -> [f64; HALO_WORDS] {
    let x = &nodes.position[i];
    [x.x, x.y, x.z, word(failure[i] as u64)]
}

/// Inverse of [`halo_words`]: the position [m] and the failure state.
#[inline]
pub fn from_halo_words(w: &[f64]) -> (Vec3, FailureMode) {
    (Vec3::new(w[0], w[1], w[2]), FailureMode::from_code(integer(w[3]) as u8).expect("a failure code sent by a rank"))
}
