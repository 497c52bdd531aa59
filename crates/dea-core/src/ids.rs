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

/// Sentinel local index: "no node" (chain end).
pub const NONE: u32 = u32::MAX;

/// An MPI rank (a part of the domain decomposition).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Rank(pub u32);
