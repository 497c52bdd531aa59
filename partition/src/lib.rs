//! Domain decomposition of a digital fabric.
//!
//! Graph vertices are fibre segments (runs of consecutive nodes of one fibre), weighted by
//! their expected work: rods per node plus contact-list entries, in the proportion the
//! benchmark measured (docs/performance.md). Edges join consecutive segments of a fibre and
//! segments whose nodes share contact-list entries, weighted by the ghosts a cut would
//! create. METIS (k-way, or recursive bisection) gives every segment a rank; every node
//! follows its segment. [`QualityReport`] says what the partition will cost before a
//! cluster hour is spent: owned and ghost nodes per rank, edge cut, load imbalance and
//! halo bytes per step.

use std::collections::BTreeSet;

use dea_core::neighbour::NeighbourList;
use dea_core::{Nodes, Rank, NONE};
use serde::Serialize;

/// Work of one node's rods, bending and integration relative to one contact-list entry:
/// 34.7 ns against 2.9 ns in the bench (docs/performance.md), rounded.
pub const NODE_WORK_PER_CONTACT_ENTRY: i64 = 12;
/// Nodes on each side of a node that its chain forces read (tension, bending, shear).
pub const CHAIN_STENCIL: u32 = 3;
/// Bytes a ghost node costs per step in the forward halo: position and velocity.
pub const HALO_BYTES_PER_GHOST: usize = 6 * std::mem::size_of::<f64>();

/// METIS algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    KWay,
    RecursiveBisection,
}

/// Why a partition could not be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PartitionError {
    #[error("cannot split {segments} fibre segments over {ranks} ranks: use fewer ranks or shorter segments")]
    TooFewSegments { segments: usize, ranks: usize },
    #[error("METIS failed: {0:?}")]
    Metis(metis::Error),
}

/// A partition of the nodes of one (whole) domain over `ranks` ranks.
#[derive(Clone, Debug, PartialEq)]
pub struct Partition {
    /// owning rank of every node, in local order
    pub rank_of_node: Vec<Rank>,
    /// number of ranks
    pub ranks: usize,
    /// METIS edge cut (sum of the weights of cut edges)
    pub edge_cut: i64,
}

/// Cost of one rank's part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RankReport {
    pub rank: u32,
    pub owned_nodes: usize,
    /// ghosts for the chain stencil and the contact lists, each node counted once
    pub ghost_nodes: usize,
    /// expected work in units of one contact-list entry
    pub work: i64,
    /// bytes received by the forward halo per step
    pub halo_bytes_per_step: usize,
}

/// Quality of a partition.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QualityReport {
    pub ranks: Vec<RankReport>,
    pub edge_cut: i64,
    /// max / mean expected work [-]
    pub load_imbalance: f64,
    /// ghost nodes / owned nodes, summed over ranks [-]
    pub ghost_fraction: f64,
    pub halo_bytes_per_step: usize,
}

/// Nodes per segment: 64, or fewer (down to 4) so that each rank has at least 32 segments
/// to balance with.
pub fn default_segment_nodes(nodes: usize, ranks: usize) -> u32 {
    (nodes / (32 * ranks.max(1))).clamp(4, 64) as u32
}

/// Segment of each node: consecutive runs of `segment_nodes` positions along a fibre.
fn segment_ids(nodes: &Nodes, segment_nodes: u32) -> (Vec<u32>, usize) {
    let mut keys: Vec<(u32, u32)> = (0..nodes.len()).map(|i| (nodes.fibre[i].0, nodes.along[i] / segment_nodes)).collect();
    let mut distinct = keys.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let ids = keys.drain(..).map(|k| distinct.binary_search(&k).expect("key is present") as u32).collect();
    (ids, distinct.len())
}

/// Partitions a whole domain whose neighbour lists cover every node (`n_owned == len()`).
pub fn partition(nodes: &Nodes, pairs: &NeighbourList, ranks: usize, segment_nodes: u32, method: Method) -> Result<Partition, PartitionError> {
    assert_eq!(nodes.n_owned, nodes.len(), "partition takes a whole domain");
    let (segment, n_segments) = segment_ids(nodes, segment_nodes.max(1));
    if ranks == 1 {
        return Ok(Partition { rank_of_node: vec![Rank(0); nodes.len()], ranks, edge_cut: 0 });
    }
    if n_segments < ranks {
        return Err(PartitionError::TooFewSegments { segments: n_segments, ranks });
    }
    let mut weight = vec![0i64; n_segments];
    // (segment, segment, weight) for both directions; summed after sorting
    let mut edges: Vec<(u32, u32, i64)> = Vec::new();
    for i in 0..nodes.len() {
        let s = segment[i];
        weight[s as usize] += NODE_WORK_PER_CONTACT_ENTRY + pairs.row(i).len() as i64;
        let n = nodes.next[i];
        if n != NONE && segment[n as usize] != s {
            let t = segment[n as usize];
            edges.push((s, t, CHAIN_STENCIL as i64));
            edges.push((t, s, CHAIN_STENCIL as i64));
        }
        for k in pairs.row(i) {
            let t = segment[pairs.partner[k] as usize];
            if t != s {
                edges.push((s, t, 1));
            }
        }
    }
    edges.sort_unstable();
    let mut xadj: Vec<metis::Idx> = vec![0; n_segments + 1];
    let mut adjncy: Vec<metis::Idx> = Vec::new();
    let mut adjwgt: Vec<metis::Idx> = Vec::new();
    let mut k = 0;
    while k < edges.len() {
        let (s, t, _) = edges[k];
        let mut total = 0;
        while k < edges.len() && edges[k].0 == s && edges[k].1 == t {
            total += edges[k].2;
            k += 1;
        }
        adjncy.push(t as metis::Idx);
        adjwgt.push(total as metis::Idx);
        xadj[s as usize + 1] += 1;
    }
    for s in 0..n_segments {
        xadj[s + 1] += xadj[s];
    }
    let vwgt: Vec<metis::Idx> = weight.iter().map(|&w| w as metis::Idx).collect();
    let mut part: Vec<metis::Idx> = vec![0; n_segments];
    let graph = metis::Graph::new(1, ranks as metis::Idx, &xadj, &adjncy).map_err(|e| PartitionError::Metis(e.into()))?.set_vwgt(&vwgt).set_adjwgt(&adjwgt);
    let edge_cut = match method {
        Method::KWay => graph.part_kway(&mut part),
        Method::RecursiveBisection => graph.part_recursive(&mut part),
    }
    .map_err(PartitionError::Metis)?;
    Ok(Partition { rank_of_node: segment.iter().map(|&s| Rank(part[s as usize] as u32)).collect(), ranks, edge_cut: edge_cut as i64 })
}

/// Ghosts rank `rank` needs: nodes of other ranks within the chain stencil of an owned node
/// or in an owned node's contact list, ascending local index.
pub fn ghosts_of(nodes: &Nodes, pairs: &NeighbourList, partition: &Partition, rank: Rank) -> Vec<u32> {
    let mut ghosts = BTreeSet::new();
    for i in (0..nodes.len()).filter(|&i| partition.rank_of_node[i] == rank) {
        for link in [&nodes.prev, &nodes.next] {
            let mut j = i as u32;
            for _ in 0..CHAIN_STENCIL {
                j = link[j as usize];
                if j == NONE {
                    break;
                }
                if partition.rank_of_node[j as usize] != rank {
                    ghosts.insert(j);
                }
            }
        }
        for k in pairs.row(i) {
            let j = pairs.partner[k];
            if partition.rank_of_node[j as usize] != rank {
                ghosts.insert(j);
            }
        }
    }
    ghosts.into_iter().collect()
}

/// What a partition costs.
pub fn quality(nodes: &Nodes, pairs: &NeighbourList, partition: &Partition) -> QualityReport {
    let ranks: Vec<RankReport> = (0..partition.ranks as u32)
        .map(|r| {
            let owned: Vec<usize> = (0..nodes.len()).filter(|&i| partition.rank_of_node[i] == Rank(r)).collect();
            let ghost_nodes = ghosts_of(nodes, pairs, partition, Rank(r)).len();
            RankReport {
                rank: r,
                owned_nodes: owned.len(),
                ghost_nodes,
                work: owned.iter().map(|&i| NODE_WORK_PER_CONTACT_ENTRY + pairs.row(i).len() as i64).sum(),
                halo_bytes_per_step: ghost_nodes * HALO_BYTES_PER_GHOST,
            }
        })
        .collect();
    let mean = ranks.iter().map(|r| r.work as f64).sum::<f64>() / ranks.len() as f64;
    let max = ranks.iter().map(|r| r.work).max().unwrap_or(0) as f64;
    let ghosts: usize = ranks.iter().map(|r| r.ghost_nodes).sum();
    QualityReport {
        edge_cut: partition.edge_cut,
        load_imbalance: if mean > 0.0 { max / mean } else { 1.0 },
        ghost_fraction: ghosts as f64 / nodes.len() as f64,
        halo_bytes_per_step: ranks.iter().map(|r| r.halo_bytes_per_step).sum(),
        ranks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::material::InertiaModel;
    use dea_core::FibreMaterial;
    use dea_fabric::StraightBundle;

    fn yarn(fibres: usize, length: f64) -> (Nodes, NeighbourList) {
        let material = FibreMaterial::kevlar_km2();
        let built = StraightBundle {
            length,
            fibres,
            fibre_area: 4.63e-8 / fibres as f64,
            element_length_ratio: 0.5,
            inertia: InertiaModel::Locked,
            friction_coefficient: 0.3,
            tensile_strength: 3.8e9,
            clamp_ends: true,
        }
        .build(&material);
        let mut pairs = NeighbourList::new(0.25 * built.sections[0].contact_diameter);
        pairs.rebuild(&built.nodes, &built.sections);
        (built.nodes, pairs)
    }

    #[test]
    fn every_node_owned_once_balanced_and_deterministic() {
        let (nodes, pairs) = yarn(19, 0.02);
        for ranks in [2, 3, 4] {
            let partition = partition(&nodes, &pairs, ranks, 32, Method::KWay).unwrap();
            assert_eq!(partition.rank_of_node.len(), nodes.len(), "every node has exactly one owner");
            let report = quality(&nodes, &pairs, &partition);
            assert!(report.ranks.iter().all(|r| r.owned_nodes > 0), "{ranks}: every rank owns nodes");
            assert_eq!(report.ranks.iter().map(|r| r.owned_nodes).sum::<usize>(), nodes.len());
            assert!(report.load_imbalance < 1.05, "{ranks} ranks: imbalance {}", report.load_imbalance);
            assert!(report.ghost_fraction > 0.0 && report.halo_bytes_per_step > 0);
            assert_eq!(partition, super::partition(&nodes, &pairs, ranks, 32, Method::KWay).unwrap(), "same input, same partition");
        }
    }

    #[test]
    fn ghosts_cover_the_chain_stencil_and_the_contact_lists_and_are_symmetric() {
        let (nodes, pairs) = yarn(7, 0.01);
        let partition = partition(&nodes, &pairs, 3, 16, Method::RecursiveBisection).unwrap();
        let ghost_sets: Vec<Vec<u32>> = (0..3).map(|r| ghosts_of(&nodes, &pairs, &partition, Rank(r))).collect();
        for i in 0..nodes.len() {
            let owner = partition.rank_of_node[i];
            for k in pairs.row(i) {
                let j = pairs.partner[k];
                let other = partition.rank_of_node[j as usize];
                if other != owner {
                    // a contact across ranks: each side holds the other as a ghost
                    assert!(ghost_sets[owner.0 as usize].binary_search(&j).is_ok());
                    assert!(ghost_sets[other.0 as usize].binary_search(&(i as u32)).is_ok());
                }
            }
            let next = nodes.next[i];
            if next != NONE && partition.rank_of_node[next as usize] != owner {
                assert!(ghost_sets[owner.0 as usize].binary_search(&next).is_ok(), "chain neighbour across ranks is a ghost");
            }
            assert!(ghost_sets[owner.0 as usize].binary_search(&(i as u32)).is_err(), "an owned node is never its own rank's ghost");
        }
    }

    #[test]
    fn too_many_ranks_for_the_segments_is_an_error() {
        let (nodes, pairs) = yarn(1, 0.001);
        assert!(matches!(partition(&nodes, &pairs, 64, 1000, Method::KWay), Err(PartitionError::TooFewSegments { .. })));
    }
}
