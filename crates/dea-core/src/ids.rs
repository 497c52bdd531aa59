//! Identifier newtypes. Global ids are stable across partitions; local indices are positions
//! in one rank's arrays and never leave that rank.

use serde::{Deserialize, Serialize};

/// Global id of a node: unique in the whole problem, independent of the partition.
/// Elements are named by the global id of their first node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct GlobalNodeId(pub u64);

/// Global id of a digital fibre.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct FibreId(pub u32);

/// Index of a node in one rank's arrays (owned nodes first, ghosts after): meaningful on that
/// rank only, and only until its ghosts change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct LocalNodeId(pub u32);

impl LocalNodeId {
    /// The index into the rank's node arrays.
    #[inline(always)]
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// The id of array index `i` (below 2^32: node indices are 32-bit).
    #[inline(always)]
    pub fn of(i: usize) -> Self {
        Self(i as u32)
    }
}

/// Sentinel local index: "no node" (chain end).
pub const NONE: u32 = u32::MAX;

/// An MPI rank (a part of the domain decomposition).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Rank(pub u32);
