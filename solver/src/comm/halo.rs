//! The halo, in LAMMPS's vocabulary: the plan of who holds whose owned nodes as ghosts,
//! [`HaloPlan::borders`] (choose the ghosts again, at a rebuild) and [`HaloPlan::forward`]
//! (owned state to the ghosts, every step).
//!
//! Ghosts: the chain stencil (±`CHAIN_STENCIL` positions along each fibre, chosen by topology,
//! so no stretching can lose one) and every node within the search reach of an owned node
//! (largest contact diameter plus the Verlet skin, plus a margin). Each step the forward halo
//! sends position and element failure state of every ghost (velocities are not needed: no
//! force depends on a partner's velocity; snapshots ask for them apart).

use dea_core::neighbour::SharedCubes;
use dea_core::nodes::FailureMode;
use dea_core::{Domain, GhostRecord, GlobalNodeId, LocalNodeId, Nodes, Rank, Vec3};

use super::codec::{
    from_halo_words, ghost_record_from_words, ghost_record_is_chain, ghost_record_position, ghost_record_words,
    halo_words, integer, word, HALO_WORDS, RECORD_WORDS,
};
use super::Comm;

/// The most cubes of a box two ranks share ([`SharedCubes`]) before `borders` sends every
/// node in the partner's grown box instead (a fragment flung far away grows the boxes).
const MOST_SHARED_CUBES: usize = 1 << 21;

/// Who sends what to whom each step.
#[derive(Debug, Default)]
pub struct HaloPlan {
    partners: Vec<Rank>,
    /// owned local indices sent to each partner, ascending
    send_nodes: Vec<Vec<LocalNodeId>>,
    send_buffers: Vec<Vec<f64>>,
    /// what each partner sends (HALO_WORDS per ghost; the ghosts are stored contiguously
    /// in partner order, so a buffer's length also counts that partner's ghosts)
    receive_buffers: Vec<Vec<f64>>,
}

impl HaloPlan {
    /// Chooses every rank's ghosts again, on every rank together (LAMMPS `borders`): each rank
    /// offers a partner its nodes of `chain_send` for that partner's chain stencil (always kept)
    /// and those that may lie within `reach` [m] of the partner's owned nodes; the partner keeps
    /// the stencil's and those within `reach` of an owned node, and says which. Returns the new
    /// plan and the ghosts, in partner order.
    pub fn borders<C: Comm>(
        comm: &C,
        domain: &Domain,
        chain_send: &[(Rank, Vec<u32>)],
        reach: f64,
    ) -> (Self, Vec<GhostRecord>) {
        let me = comm.rank();
        let nodes = &domain.nodes;
        let owned = &nodes.position[..nodes.n_owned];
        let (low, high) = owned
            .iter()
            .fold((Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)), |(l, h), x| (l.inf(x), h.sup(x)));
        let boxes = comm.all_gather_f64(&[low.x, low.y, low.z, high.x, high.y, high.z]);
        let grown = |r: usize| {
            let low = Vec3::new(boxes[6 * r], boxes[6 * r + 1], boxes[6 * r + 2]).add_scalar(-reach);
            (low, Vec3::new(boxes[6 * r + 3], boxes[6 * r + 4], boxes[6 * r + 5]).add_scalar(reach))
        };
        let inside = |x: &Vec3, (l, h): &(Vec3, Vec3)| (0..3).all(|k| x[k] >= l[k] && x[k] <= h[k]);
        // partners: chain neighbours, and ranks whose region comes within reach of ours
        let mut partners: Vec<Rank> = chain_send.iter().map(|(r, _)| *r).collect();
        for r in (0..comm.size()).filter(|&r| Rank(r as u32) != me) {
            let (l, h) = grown(r);
            if !owned.is_empty() && (0..3).all(|k| l[k] <= high[k] && h[k] >= low[k]) {
                partners.push(Rank(r as u32));
            }
        }
        partners.sort_unstable();
        partners.dedup();
        // the cubes of the box both ranks of a pair know (their grown boxes overlap there)
        // that hold the partner's nodes: a node of ours within reach of one of them lies in
        // that box, next to one of those cubes; the cubes of a huge box are not worth it
        let shared = |r: usize| {
            let (mine, theirs) = (grown(me.0 as usize), grown(r));
            SharedCubes::new(mine.0.sup(&theirs.0), mine.1.inf(&theirs.1), reach, MOST_SHARED_CUBES)
        };
        let cubes: Vec<Option<SharedCubes>> = partners.iter().map(|p| shared(p.0 as usize)).collect();
        let offers: Vec<Vec<f64>> = cubes
            .iter()
            .map(|c| c.as_ref().map_or(Vec::new(), |c| c.occupied(owned.iter()).into_iter().map(word).collect()))
            .collect();
        let mut occupied: Vec<Vec<f64>> = offers.iter().map(|o| vec![0.0; o.len()]).collect();
        comm.exchange(&partners, &offers, &mut occupied);
        // candidates for each partner: its chain stencil plus our nodes inside its grown box,
        // next to its nodes where the cubes tell
        let mut candidates: Vec<Vec<u32>> = Vec::with_capacity(partners.len());
        let mut records: Vec<Vec<f64>> = Vec::with_capacity(partners.len());
        for ((&partner, cubes), occupied) in partners.iter().zip(&cubes).zip(&occupied) {
            let chain =
                chain_send.binary_search_by_key(&partner, |(r, _)| *r).map_or(&[][..], |k| &chain_send[k].1[..]);
            let region = grown(partner.0 as usize);
            let near =
                cubes.as_ref().map(|c| (c, c.next_to(&occupied.iter().map(|&w| integer(w)).collect::<Vec<u64>>())));
            let next_to_theirs = |x: &Vec3| near.as_ref().is_none_or(|(c, near)| c.cube(x).is_some_and(|k| near[k]));
            let is_offered =
                |i: u32| inside(&nodes.position[i as usize], &region) && next_to_theirs(&nodes.position[i as usize]);
            let mut list: Vec<u32> = (0..nodes.n_owned as u32).filter(|&i| is_offered(i)).collect();
            list.extend_from_slice(chain);
            list.sort_unstable();
            list.dedup();
            let mut words = Vec::with_capacity(list.len() * RECORD_WORDS);
            for &i in &list {
                let in_chain = chain.binary_search(&i).is_ok();
                words.extend_from_slice(&ghost_record_words(nodes, &domain.elements, i as usize, in_chain));
            }
            candidates.push(list);
            records.push(words);
        }
        let mut received: Vec<Vec<f64>> = vec![Vec::new(); partners.len()];
        comm.exchange_sized(&partners, &records, &mut received);
        // keep what our stencil needs and what comes within reach of an owned node
        let positions: Vec<Vec3> =
            received.iter().flat_map(|w| w.chunks_exact(RECORD_WORDS)).map(ghost_record_position).collect();
        let near = dea_core::neighbour::within_reach_of_any(owned, &positions, reach);
        let mut ghosts = Vec::with_capacity(positions.len());
        let mut masks: Vec<Vec<f64>> = Vec::with_capacity(partners.len());
        let mut receive_counts = Vec::with_capacity(partners.len());
        let mut k = 0;
        for words in &received {
            let mut mask = Vec::with_capacity(words.len() / RECORD_WORDS);
            for w in words.chunks_exact(RECORD_WORDS) {
                let keep = ghost_record_is_chain(w) || near[k];
                k += 1;
                mask.push(if keep { 1.0 } else { 0.0 });
                if keep {
                    ghosts.push(ghost_record_from_words(w));
                }
            }
            receive_counts.push(mask.iter().filter(|&&m| m == 1.0).count());
            masks.push(mask);
        }
        let mut kept: Vec<Vec<f64>> = candidates.iter().map(|c| vec![0.0; c.len()]).collect();
        comm.exchange(&partners, &masks, &mut kept);
        let send_nodes: Vec<Vec<LocalNodeId>> = candidates
            .iter()
            .zip(&kept)
            .map(|(c, m)| c.iter().zip(m).filter(|(_, &m)| m == 1.0).map(|(&i, _)| LocalNodeId(i)).collect())
            .collect();
        let plan = HaloPlan {
            send_buffers: send_nodes.iter().map(|s| Vec::with_capacity(s.len() * HALO_WORDS)).collect(),
            receive_buffers: receive_counts.iter().map(|&n| vec![0.0; n * HALO_WORDS]).collect(),
            partners,
            send_nodes,
        };
        (plan, ghosts)
    }

    /// Sends position and failure state of every owned node a partner holds as a ghost, and
    /// sets this rank's ghosts (stored after the owned nodes, in partner order) from what the
    /// partners send (LAMMPS `forward_comm`). Returns the bytes received.
    pub fn forward<C: Comm>(&mut self, comm: &C, nodes: &mut Nodes, failure: &mut [FailureMode]) -> u64 {
        for (buffer, send) in self.send_buffers.iter_mut().zip(&self.send_nodes) {
            buffer.clear();
            for &i in send {
                buffer.extend_from_slice(&halo_words(nodes, failure, i.index()));
            }
        }
        comm.exchange(&self.partners, &self.send_buffers, &mut self.receive_buffers);
        let mut g = nodes.n_owned;
        let mut bytes = 0;
        for buffer in &self.receive_buffers {
            for w in buffer.chunks_exact(HALO_WORDS) {
                (nodes.position[g], failure[g]) = from_halo_words(w);
                g += 1;
            }
            bytes += (buffer.len() * std::mem::size_of::<f64>()) as u64;
        }
        bytes
    }

    /// Sends the velocity of every ghost to the ranks that hold it (snapshots only: no force
    /// needs it).
    pub fn forward_velocities<C: Comm>(&self, comm: &C, domain: &mut Domain) {
        let velocities = self.forward_vectors(comm, |i| domain.velocity(i));
        let n = domain.nodes.n_owned;
        domain.nodes.velocity[n..n + velocities.len()].copy_from_slice(&velocities);
    }

    /// `owned(i)` of the owner of every ghost, in ghost order (snapshots only: values no
    /// step needs, such as a velocity or a displacement).
    pub fn forward_vectors<C: Comm>(&self, comm: &C, owned: impl Fn(usize) -> Vec3) -> Vec<Vec3> {
        let sends: Vec<Vec<f64>> = self
            .send_nodes
            .iter()
            .map(|send| send.iter().flat_map(|&i| owned(i.index()).as_slice().to_vec()).collect())
            .collect();
        let mut receives: Vec<Vec<f64>> =
            self.receive_buffers.iter().map(|r| vec![0.0; 3 * (r.len() / HALO_WORDS)]).collect();
        comm.exchange(&self.partners, &sends, &mut receives);
        receives.iter().flat_map(|buffer| buffer.chunks_exact(3).map(|v| Vec3::new(v[0], v[1], v[2]))).collect()
    }

    /// The plan: (partner, owned global ids sent to it each step, ghosts received), with
    /// `gid` the global ids of the local nodes.
    pub fn summary(&self, gid: &[GlobalNodeId]) -> Vec<(Rank, Vec<GlobalNodeId>, usize)> {
        self.partners
            .iter()
            .zip(&self.send_nodes)
            .zip(&self.receive_buffers)
            .map(|((&p, s), r)| (p, s.iter().map(|&i| gid[i.index()]).collect(), r.len() / HALO_WORDS))
            .collect()
    }
}
