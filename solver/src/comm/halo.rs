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
use dea_core::{bounding_box, Domain, GhostRecord, GlobalNodeId, LocalNodeId, Nodes, Rank, Vec3};

use super::codec::{
    from_halo_words, ghost_record_from_words, ghost_record_is_chain, ghost_record_position, ghost_record_words,
    halo_words, integer, word, HALO_WORDS, RECORD_WORDS,
};
use super::Comm;

/// The most cubes of a box two ranks share ([`SharedCubes`]) before `borders` sends every
/// node in the partner's grown box instead (a fragment flung far away grows the boxes).
const MOST_SHARED_CUBES: usize = 1 << 21;

/// What [`HaloPlan::extend`] adds to a rank's halo.
#[derive(Debug, Default)]
pub struct HaloExtension {
    /// the new ghosts, in the order they are appended ([`Domain::append_ghosts`])
    pub ghosts: Vec<GhostRecord>,
    /// each new ghost's neighbour-list reference: its owner's [m]
    pub references: Vec<Vec3>,
    /// the ghosts held before whose owners moved them (local indices, ascending)
    pub moved_ghosts: Vec<u32>,
}

/// Who sends what to whom each step.
#[derive(Debug, Default)]
pub struct HaloPlan {
    partners: Vec<Rank>,
    /// owned local indices sent to each partner, ascending
    send_nodes: Vec<Vec<LocalNodeId>>,
    send_buffers: Vec<Vec<f64>>,
    /// what each partner sends (HALO_WORDS per ghost, so a buffer's length also counts that
    /// partner's ghosts)
    receive_buffers: Vec<Vec<f64>>,
    /// the local index of each ghost a partner sends, in its message's order: the ghosts
    /// of `borders` lie in partner order, those of `extend` after them
    receive_slots: Vec<Vec<u32>>,
    /// the first ghost's local index (the owned nodes held)
    first_ghost: usize,
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
        let boxes = RankBoxes::gather(comm, owned, reach);
        // partners: chain neighbours, and ranks whose region comes within reach of ours
        let mut partners: Vec<Rank> = chain_send.iter().map(|(r, _)| *r).collect();
        partners.extend(boxes.within_reach_of(me));
        partners.sort_unstable();
        partners.dedup();
        // the cubes of the box both ranks of a pair know (their grown boxes overlap there)
        // that hold the partner's nodes: a node of ours within reach of one of them lies in
        // that box, next to one of those cubes; the cubes of a huge box are not worth it
        let shared = |r: usize| {
            let (mine, theirs) = (boxes.grown(me.0 as usize), boxes.grown(r));
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
            let region = boxes.grown(partner.0 as usize);
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
        let mut next = nodes.n_owned as u32;
        let receive_slots = receive_counts
            .iter()
            .map(|&n| {
                next += n as u32;
                (next - n as u32..next).collect()
            })
            .collect();
        let plan = HaloPlan {
            send_buffers: send_nodes.iter().map(|s| Vec::with_capacity(s.len() * HALO_WORDS)).collect(),
            receive_buffers: receive_counts.iter().map(|&n| vec![0.0; n * HALO_WORDS]).collect(),
            receive_slots,
            first_ghost: nodes.n_owned,
            partners,
            send_nodes,
        };
        (plan, ghosts)
    }

    /// Extends every rank's ghosts around the owned nodes that are about to take new
    /// list references, on every rank together: what keeps the halo whole between two
    /// [`Self::borders`] (theory M2). Each owned node has a border position: its neighbour
    /// list reference, or its present position if it is in `moved` (owned local indices,
    /// ascending), which the caller's rebuild then makes its reference. The halo holds, for
    /// every pair of ranks, every owned node of one whose border position lies within
    /// `reach` [m] of the border position of an owned node of the other; `borders` makes it
    /// so at present positions, and this keeps it so when the moved nodes' border positions
    /// change: each rank sends its moved nodes' new positions to the ranks whose grown box
    /// holds them, each answers with its owned nodes within `reach` of them, and offers its
    /// own moved nodes; the receiver keeps what comes within `reach` of an owned node. No
    /// ghost is dropped (the next `borders` does that). Each rank also learns which of its
    /// ghosts their owners moved, so that every node has the same reference on every rank
    /// that holds it (the lists are then a function of the references alone, which a
    /// checkpoint relies on).
    pub fn extend<C: Comm>(&mut self, comm: &C, domain: &Domain, moved: &[u32], reach: f64) -> HaloExtension {
        let me = comm.rank();
        let nodes = &domain.nodes;
        let n_owned = nodes.n_owned;
        assert_eq!(self.first_ghost, n_owned, "a halo extends the plan of the same owned nodes");
        let mut border: Vec<Vec3> = domain.pairs.reference_position[..n_owned].to_vec();
        for &i in moved {
            border[i as usize] = nodes.position[i as usize];
        }
        let boxes = RankBoxes::gather(comm, &border, reach);
        // this round's partners: the plan's, and ranks whose region comes within reach of ours
        let mut partners = self.partners.clone();
        partners.extend(boxes.within_reach_of(me));
        partners.sort_unstable();
        partners.dedup();
        // the moved nodes' new positions to each partner whose grown box holds them
        let moved_inside: Vec<Vec<u32>> = partners
            .iter()
            .map(|p| {
                let region = boxes.grown(p.0 as usize);
                moved.iter().copied().filter(|&i| inside(&border[i as usize], &region)).collect()
            })
            .collect();
        // with them, which of the ghosts it holds moved (their places in its messages)
        let mut is_moved = vec![false; n_owned];
        for &i in moved {
            is_moved[i as usize] = true;
        }
        let messages: Vec<Vec<f64>> = partners
            .iter()
            .zip(&moved_inside)
            .map(|(partner, list)| {
                let mut words = vec![word(list.len() as u64)];
                words.extend(list.iter().flat_map(|&i| border[i as usize].as_slice().to_vec()));
                if let Ok(p) = self.partners.binary_search(partner) {
                    let places = self.send_nodes[p].iter().enumerate().filter(|(_, i)| is_moved[i.index()]);
                    words.extend(places.map(|(k, _)| word(k as u64)));
                }
                words
            })
            .collect();
        let mut answers: Vec<Vec<f64>> = vec![Vec::new(); partners.len()];
        comm.exchange_sized(&partners, &messages, &mut answers);
        let mut moved_ghosts = Vec::new();
        let theirs_moved: Vec<&[f64]> = partners
            .iter()
            .zip(&answers)
            .map(|(partner, words)| {
                let count = integer(words[0]) as usize;
                if let Ok(p) = self.partners.binary_search(partner) {
                    moved_ghosts
                        .extend(words[1 + 3 * count..].iter().map(|&w| self.receive_slots[p][integer(w) as usize]));
                }
                &words[1..1 + 3 * count]
            })
            .collect();
        moved_ghosts.sort_unstable();
        // offers: owned nodes within reach of a partner's moved ones, and our moved ones in
        // its box, less what it holds already
        let mut candidates: Vec<Vec<u32>> = Vec::with_capacity(partners.len());
        let mut records: Vec<Vec<f64>> = Vec::with_capacity(partners.len());
        for (k, partner) in partners.iter().enumerate() {
            let targets: Vec<Vec3> = theirs_moved[k].chunks_exact(3).map(|w| Vec3::new(w[0], w[1], w[2])).collect();
            let mut list: Vec<u32> = (0..n_owned as u32)
                .zip(within_reach_near(&targets, &border, reach))
                .filter_map(|(i, near)| near.then_some(i))
                .collect();
            list.extend_from_slice(&moved_inside[k]);
            list.sort_unstable();
            list.dedup();
            if let Ok(p) = self.partners.binary_search(partner) {
                let mut sent: Vec<u32> = self.send_nodes[p].iter().map(|i| i.0).collect();
                sent.sort_unstable();
                list.retain(|i| sent.binary_search(i).is_err());
            }
            let mut words = Vec::with_capacity(list.len() * (RECORD_WORDS + 3));
            for &i in &list {
                words.extend_from_slice(&ghost_record_words(nodes, &domain.elements, i as usize, false));
                words.extend_from_slice(border[i as usize].as_slice());
            }
            candidates.push(list);
            records.push(words);
        }
        let mut received: Vec<Vec<f64>> = vec![Vec::new(); partners.len()];
        comm.exchange_sized(&partners, &records, &mut received);
        // keep what comes within reach of an owned node's border position
        let offered: Vec<Vec3> = received
            .iter()
            .flat_map(|w| w.chunks_exact(RECORD_WORDS + 3))
            .map(|w| Vec3::new(w[RECORD_WORDS], w[RECORD_WORDS + 1], w[RECORD_WORDS + 2]))
            .collect();
        let near = within_reach_near(&border, &offered, reach);
        let (mut ghosts, mut references) = (Vec::new(), Vec::new());
        let mut masks: Vec<Vec<f64>> = Vec::with_capacity(partners.len());
        let mut kept_from: Vec<usize> = Vec::with_capacity(partners.len());
        let mut k = 0;
        for words in &received {
            let mut mask = Vec::with_capacity(words.len() / (RECORD_WORDS + 3));
            for w in words.chunks_exact(RECORD_WORDS + 3) {
                mask.push(if near[k] { 1.0 } else { 0.0 });
                if near[k] {
                    ghosts.push(ghost_record_from_words(&w[..RECORD_WORDS]));
                    references.push(offered[k]);
                }
                k += 1;
            }
            kept_from.push(mask.iter().filter(|&&m| m == 1.0).count());
            masks.push(mask);
        }
        let mut kept: Vec<Vec<f64>> = candidates.iter().map(|c| vec![0.0; c.len()]).collect();
        comm.exchange(&partners, &masks, &mut kept);
        // the plan grows: new sends after the old ones, new ghosts after every local node
        let mut next = nodes.len() as u32;
        for (k, partner) in partners.iter().enumerate() {
            let sends: Vec<LocalNodeId> =
                candidates[k].iter().zip(&kept[k]).filter(|(_, &m)| m == 1.0).map(|(&i, _)| LocalNodeId(i)).collect();
            let receives = kept_from[k];
            let p = match self.partners.binary_search(partner) {
                Ok(p) => p,
                Err(_) if sends.is_empty() && receives == 0 => continue,
                Err(p) => {
                    self.partners.insert(p, *partner);
                    self.send_nodes.insert(p, Vec::new());
                    self.send_buffers.insert(p, Vec::new());
                    self.receive_buffers.insert(p, Vec::new());
                    self.receive_slots.insert(p, Vec::new());
                    p
                }
            };
            self.send_nodes[p].extend(sends);
            let total = self.receive_slots[p].len() + receives;
            self.receive_slots[p].extend(next..next + receives as u32);
            self.receive_buffers[p].resize(total * HALO_WORDS, 0.0);
            next += receives as u32;
        }
        HaloExtension { ghosts, references, moved_ghosts }
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
        let mut bytes = 0;
        for (buffer, slots) in self.receive_buffers.iter().zip(&self.receive_slots) {
            for (w, &g) in buffer.chunks_exact(HALO_WORDS).zip(slots) {
                (nodes.position[g as usize], failure[g as usize]) = from_halo_words(w);
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

    /// Ghosts held.
    fn ghosts(&self) -> usize {
        self.receive_slots.iter().map(Vec::len).sum()
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
        let mut vectors = vec![Vec3::zeros(); self.ghosts()];
        for (buffer, slots) in receives.iter().zip(&self.receive_slots) {
            for (v, &g) in buffer.chunks_exact(3).zip(slots) {
                vectors[g as usize - self.first_ghost] = Vec3::new(v[0], v[1], v[2]);
            }
        }
        vectors
    }

    /// The plan: (partner, owned global ids sent to it each step, global ids of the ghosts
    /// received from it, in message order), with `gid` the global ids of the local nodes.
    pub fn summary(&self, gid: &[GlobalNodeId]) -> Vec<(Rank, Vec<GlobalNodeId>, Vec<GlobalNodeId>)> {
        self.partners
            .iter()
            .zip(&self.send_nodes)
            .zip(&self.receive_slots)
            .map(|((&p, s), r)| {
                (p, s.iter().map(|&i| gid[i.index()]).collect(), r.iter().map(|&g| gid[g as usize]).collect())
            })
            .collect()
    }
}

/// Every rank's box around its points, grown by a reach, for choosing ghosts (LAMMPS
/// compares sub-domains the same way). A rank without points has an inverted box, which
/// meets none.
struct RankBoxes {
    /// low and high corners of each rank's box, six words per rank [m]
    boxes: Vec<f64>,
    /// [m]
    reach: f64,
}

impl RankBoxes {
    /// Every rank's box around its `points` (collective).
    fn gather<C: Comm>(comm: &C, points: &[Vec3], reach: f64) -> Self {
        let (low, high) = bounding_box(points.iter().copied());
        Self { boxes: comm.all_gather_f64(&[low.x, low.y, low.z, high.x, high.y, high.z]), reach }
    }

    /// Rank `r`'s box grown by the reach [m].
    fn grown(&self, r: usize) -> (Vec3, Vec3) {
        let b = &self.boxes[6 * r..6 * r + 6];
        (Vec3::new(b[0], b[1], b[2]).add_scalar(-self.reach), Vec3::new(b[3], b[4], b[5]).add_scalar(self.reach))
    }

    /// The other ranks whose grown box meets `me`'s box: the only ones that may hold a
    /// point within reach of one of `me`'s.
    fn within_reach_of(&self, me: Rank) -> impl Iterator<Item = Rank> + '_ {
        let m = me.0 as usize;
        let (low, high) = (
            Vec3::from_row_slice(&self.boxes[6 * m..6 * m + 3]),
            Vec3::from_row_slice(&self.boxes[6 * m + 3..6 * m + 6]),
        );
        (0..self.boxes.len() / 6).filter(move |&r| r != m).filter_map(move |r| {
            let (l, h) = self.grown(r);
            (0..3).all(|k| l[k] <= high[k] && h[k] >= low[k]).then_some(Rank(r as u32))
        })
    }
}

/// Whether `x` lies in the box `(low, high)`.
fn inside(x: &Vec3, (low, high): &(Vec3, Vec3)) -> bool {
    (0..3).all(|k| x[k] >= low[k] && x[k] <= high[k])
}

/// Whether each of `candidates` lies within `reach` [m] of one of `targets`
/// ([`dea_core::neighbour::within_reach_of_any`]), when one of the two sets is small: each
/// set is first cut to the other's box grown by the reach, so a search around a few moved
/// nodes bins and scans only their surroundings.
fn within_reach_near(targets: &[Vec3], candidates: &[Vec3], reach: f64) -> Vec<bool> {
    let mut near = vec![false; candidates.len()];
    if targets.is_empty() || candidates.is_empty() {
        return near;
    }
    let grown = |(low, high): (Vec3, Vec3)| (low.add_scalar(-reach), high.add_scalar(reach));
    let (around_targets, around_candidates) =
        (grown(bounding_box(targets.iter().copied())), grown(bounding_box(candidates.iter().copied())));
    let targets: Vec<Vec3> = targets.iter().filter(|x| inside(x, &around_candidates)).copied().collect();
    let boxed: Vec<usize> = (0..candidates.len()).filter(|&i| inside(&candidates[i], &around_targets)).collect();
    let positions: Vec<Vec3> = boxed.iter().map(|&i| candidates[i]).collect();
    for (i, n) in boxed.into_iter().zip(dea_core::neighbour::within_reach_of_any(&targets, &positions, reach)) {
        near[i] = n;
    }
    near
}
