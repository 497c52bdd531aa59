//! The distributed step (DESIGN.md §4): a rank's [`Domain`] plus its ghosts, halo plan and
//! the collectives around the kernels.
//!
//! Ghosts: the chain stencil (±[`CHAIN_STENCIL`] positions along each fibre, chosen by
//! topology, so no stretching can lose one) and every node within contact reach (largest
//! contact diameter plus the Verlet skin) of an owned node, and one skin more. They are
//! rebuilt collectively when some rank's lists may miss a pair: once a node has moved more
//! than half the skin, unless, on every rank, the nodes near each other moved together and
//! no node moved a whole skin ([`Domain::lists_may_miss_a_pair`]). Each step a forward halo
//! sends position and element failure state of every ghost (velocities are not needed: no
//! force depends on a partner's velocity). Rank 0 owns the projectile: it integrates it,
//! broadcasts its state every step, and sums the reactions of every rank's nodes in
//! global-id order.

use std::time::Instant;

use crate::step::{compute_forces, Stage, StageTimer};

use dea_core::failure::BrokenCount;
use dea_core::energy::EnergySums;
use dea_core::nodes::FailureMode;
use dea_core::projectile::{RigidProjectile, RigidShape};
use dea_core::neighbour::SharedCubes;
use dea_core::{Domain, DomainError, FibreId, GhostRecord, GlobalNodeId, NodeMotion, Rank, Reaction, Vec3, CHAIN_STENCIL};
use dea_io::checkpoint::NodeState;
use dea_io::snapshot::SnapshotPart;
use dea_partition::Partition;
use nalgebra::{Quaternion, UnitQuaternion};
use serde::Serialize;

use crate::comm::local::LocalComm;
use crate::comm::Comm;
use crate::deformable::DeformableProjectile;

/// The most cubes of a box two ranks share ([`SharedCubes`]) before the rebuild sends every
/// node in the partner's grown box instead (a fragment flung far away grows the boxes).
const MOST_SHARED_CUBES: usize = 1 << 21;

/// f64 words of a ghost record at a rebuild.
const RECORD_WORDS: usize = 12;
/// f64 words per ghost in the per-step halo: position and element failure state.
pub const HALO_WORDS: usize = 4;
/// f64 words of the projectile state broadcast.
pub const PROJECTILE_WORDS: usize = 19;
/// f64 words of a reaction record: gid, force, torque, triangle, weights.
const REACTION_WORDS: usize = 11;

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
fn reaction_words(r: &Reaction) -> [f64; REACTION_WORDS] {
    let [f, t, w] = [r.force, r.torque, Vec3::from(r.weights)];
    [word(r.gid.0), f.x, f.y, f.z, t.x, t.y, t.z, word(r.triangle as u64), w.x, w.y, w.z]
}

/// Inverse of [`reaction_words`].
fn reaction_from_words(w: &[f64]) -> Reaction {
    Reaction { gid: GlobalNodeId(integer(w[0])), force: Vec3::new(w[1], w[2], w[3]), torque: Vec3::new(w[4], w[5], w[6]), triangle: integer(w[7]) as u32, weights: [w[8], w[9], w[10]] }
}

fn word(value: u64) -> f64 {
    f64::from_bits(value)
}

fn integer(word: f64) -> u64 {
    word.to_bits()
}

/// Who sends what to whom each step.
#[derive(Debug, Default)]
struct HaloPlan {
    partners: Vec<Rank>,
    /// owned local indices sent to each partner, ascending
    send_nodes: Vec<Vec<u32>>,
    send_buffers: Vec<Vec<f64>>,
    /// what each partner sends (HALO_WORDS per ghost; the ghosts are stored contiguously
    /// in partner order, so a buffer's length also counts that partner's ghosts)
    receive_buffers: Vec<Vec<f64>>,
}

/// One rank of a distributed run.
pub struct Distributed<C: Comm> {
    pub comm: C,
    pub domain: Domain,
    pub partition: Partition,
    /// contact search distance: largest contact diameter plus the skin [m]
    reach: f64,
    /// owned nodes each rank needs for its chain stencil, by rank (static: the partition
    /// never changes), ascending rank
    chain_send: Vec<(Rank, Vec<u32>)>,
    halo: HaloPlan,
    /// the one timer of this rank's stages
    pub timer: StageTimer,
    /// bytes of forward halo received so far
    pub halo_bytes: u64,
    /// steps that sent the forward halo (every step: the rebuild check reads the ghosts)
    pub halo_steps: u64,
    pub rebuilds: u64,
    /// this rank's requests for the next step's reduction: (stop on a signal, checkpoint due)
    pub requests: [bool; 2],
    /// the requests of any rank, agreed in the last step
    pub agreed: [bool; 2],
    /// layer of each yarn (for snapshots and per-layer diagnostics); empty: all in layer 0
    pub layer_of_yarn: Vec<u32>,
    /// fibres of the whole target
    pub fibres: usize,
    /// reaction records of this rank, and (rank 0) of all ranks: reused every step
    reaction_words: Vec<f64>,
    reactions: Vec<Reaction>,
    /// a deformable projectile's body, on rank 0 (the other ranks see its meshed proxy)
    pub deformable: Option<DeformableProjectile>,
    /// projectile broadcast buffer, and a deformable body's surface decoded from it
    projectile_words: Vec<f64>,
    surface: Vec<Vec3>,
    /// how the target settled before the shot (none: no settle, or a restart)
    pub settled: Option<SettleReport>,
}

impl Distributed<LocalComm> {
    /// A whole domain of owned nodes (ascending gid) on one rank in the calling thread, its
    /// lists built and its initial forces computed: how the physics tests run the production
    /// step on hand-made targets.
    pub fn whole(domain: Domain) -> Result<Self, DomainError> {
        let reach = domain.sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max) + domain.pairs.skin;
        Self::new(LocalComm::alone(), domain, Partition::one_rank(), &[u32::MAX], reach, None)
    }
}

/// What a settle before the shot did (every value agreed over the ranks).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SettleReport {
    pub steps: u64,
    /// [s]
    pub time_s: f64,
    /// [1/s]
    pub damping_per_s: f64,
    /// largest force on a free fibre node as built, and after the settle [N]
    pub largest_force_before_n: f64,
    pub largest_force_after_n: f64,
    /// deepest fibre contact over its contact distance, as built and after [-]
    pub largest_overlap_before: f64,
    pub largest_overlap_after: f64,
    /// how far the target's top rose, and the projectile with it [m]
    pub top_rise_m: f64,
    /// [s]
    pub wall_s: f64,
}

impl<C: Comm> Distributed<C> {
    /// Takes a domain of owned nodes (ascending global id) and fetches the ghosts, on every
    /// rank together.
    fn assemble(comm: C, domain: Domain, partition: Partition, nodes_per_fibre: &[u32], reach: f64, deformable: Option<DeformableProjectile>) -> Result<Self, DomainError> {
        let me = comm.rank();
        let mut chain: std::collections::BTreeMap<Rank, Vec<u32>> = Default::default();
        let nodes = &domain.nodes;
        for i in 0..nodes.n_owned {
            let yarn = partition.yarn_of(nodes.fibre[i]);
            let along = nodes.along[i] as i64;
            let mut needed_by: Vec<Rank> = (1..=CHAIN_STENCIL as i64)
                .flat_map(|d| [along - d, along + d])
                .filter(|&a| a >= 0 && a < nodes_per_fibre[yarn] as i64)
                .map(|a| partition.rank_of_position(yarn, a as u32))
                .filter(|&r| r != me)
                .collect();
            needed_by.sort_unstable();
            needed_by.dedup();
            for r in needed_by {
                chain.entry(r).or_default().push(i as u32);
            }
        }
        // a tie's owned end is needed by the owners of its other ends, wherever they move
        let owned = &nodes.gid[..nodes.n_owned];
        for tie in domain.ties.list() {
            let ends = [tie.fine, tie.coarse, tie.coarse_next];
            for mine in &ends {
                let Ok(i) = owned.binary_search(&mine.gid) else {
                    continue;
                };
                for other in &ends {
                    let r = partition.rank_of(other.fibre, other.along);
                    if r != me {
                        chain.entry(r).or_default().push(i as u32);
                    }
                }
            }
        }
        for list in chain.values_mut() {
            list.sort_unstable();
            list.dedup();
        }
        let mut distributed = Self {
            comm,
            domain,
            partition,
            reach,
            chain_send: chain.into_iter().collect(),
            halo: HaloPlan::default(),
            timer: StageTimer::default(),
            halo_bytes: 0,
            halo_steps: 0,
            rebuilds: 0,
            requests: [false; 2],
            agreed: [false; 2],
            layer_of_yarn: Vec::new(),
            fibres: 0,
            reaction_words: Vec::new(),
            reactions: Vec::new(),
            deformable,
            projectile_words: Vec::new(),
            surface: Vec::new(),
            settled: None,
        };
        distributed.rebuild()?;
        Ok(distributed)
    }

    /// [`Self::assemble`], then the initial forces: a fresh run.
    pub fn new(comm: C, domain: Domain, partition: Partition, nodes_per_fibre: &[u32], reach: f64, deformable: Option<DeformableProjectile>) -> Result<Self, DomainError> {
        let mut distributed = Self::assemble(comm, domain, partition, nodes_per_fibre, reach, deformable)?;
        let forces = compute_forces(&mut distributed.domain, &mut distributed.timer);
        distributed.agree(forces)?;
        distributed.gather_projectile_load();
        Ok(distributed)
    }

    /// Lets the target settle for `duration` before the shot, on every rank together: the
    /// projectile is set aside, friction and failure are off, and the nodes are damped at
    /// `damping`; then the shot starts from the settled positions at rest with fresh
    /// contact histories ([`Domain::start_afresh`]), the projectile raised by as much as the
    /// target's top rose. Deterministic like any step: the same bits on any number of ranks.
    pub fn settle(&mut self, duration: f64, damping: f64) -> Result<SettleReport, DomainError> {
        let clock = Instant::now();
        let agreed = |run: &Self, values: [f64; 2]| {
            let mut values = values;
            run.comm.max_f64(&mut values);
            values
        };
        let [force_before, overlap_before] = agreed(self, [self.domain.largest_free_force(), self.domain.largest_overlap_ratio()]);
        let (_, top_before) = self.z_range();
        let projectile = self.domain.projectile.take();
        let body = self.deformable.take();
        let (friction, failure) = (self.domain.contact.friction_coefficient, self.domain.failure.enabled);
        self.domain.contact.friction_coefficient = 0.0;
        self.domain.failure.enabled = false;
        self.domain.damping = damping;
        let steps = (duration / self.domain.time_step).ceil() as u64;
        let mut result = Ok(());
        for _ in 0..steps {
            result = self.step();
            if result.is_err() {
                break;
            }
        }
        self.domain.damping = 0.0;
        self.domain.contact.friction_coefficient = friction;
        self.domain.failure.enabled = failure;
        self.domain.projectile = projectile;
        self.deformable = body;
        result?;
        let [force_after, overlap_after] = agreed(self, [self.domain.largest_free_force(), self.domain.largest_overlap_ratio()]);
        let (_, top_after) = self.z_range();
        let rise = (top_after - top_before).max(0.0);
        if let Some(p) = &mut self.domain.projectile {
            p.position.z += rise;
        }
        if let Some(body) = &mut self.deformable {
            body.body.position.iter_mut().for_each(|x| x.z += rise);
        }
        self.domain.start_afresh();
        let forces = compute_forces(&mut self.domain, &mut self.timer);
        self.agree(forces)?;
        self.gather_projectile_load();
        let report = SettleReport {
            steps,
            time_s: steps as f64 * self.domain.time_step,
            damping_per_s: damping,
            largest_force_before_n: force_before,
            largest_force_after_n: force_after,
            largest_overlap_before: overlap_before,
            largest_overlap_after: overlap_after,
            top_rise_m: rise,
            wall_s: clock.elapsed().as_secs_f64(),
        };
        self.settled = Some(report);
        Ok(report)
    }

    /// A deformable projectile's substeps of this step (rank 0): the body's own elements,
    /// with the fibres' last reactions held, then the last substep's first half; the fibres
    /// meet its surface once per step.
    pub(crate) fn subcycle_deformable(&mut self) {
        let Some(body) = &mut self.deformable else { return };
        let substep = self.domain.time_step / body.substeps as f64;
        for _ in 1..body.substeps {
            body.body.kick(0.5 * substep);
            body.body.drift(substep);
            body.forces(&self.reactions);
            body.body.kick(0.5 * substep);
        }
        body.body.kick(0.5 * substep);
        body.body.drift(substep);
    }

    /// The last half kick of a deformable projectile's last substep.
    pub(crate) fn kick_deformable(&mut self) {
        if let Some(body) = &mut self.deformable {
            body.body.kick(0.5 * self.domain.time_step / body.substeps as f64);
        }
    }

    /// The largest motions of a node over every rank; the run loop's requests ride on the
    /// same reduction and are agreed in [`Self::agreed`].
    pub(crate) fn agree_on_motion(&mut self, motion: NodeMotion) -> NodeMotion {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let mut largest = [motion.since_build, motion.step, flag(self.requests[0]), flag(self.requests[1])];
        self.comm.max_f64(&mut largest);
        self.agreed = [largest[2] > 0.0, largest[3] > 0.0];
        NodeMotion { since_build: largest[0], step: largest[1] }
    }

    /// Rebuilds the ghosts and lists when some rank's lists may miss a pair, given the
    /// `largest` motions over every rank: on one rank only the rows around the nodes that
    /// moved (no ghosts to choose again). Stamps the ghost exchange and the list build.
    pub(crate) fn rebuild_if_due(&mut self, largest: NodeMotion) -> Result<(), DomainError> {
        let alone = self.comm.size() == 1;
        let verdict = self.domain.lists_may_miss_a_pair(largest, (!alone).then(|| self.ghost_margin()));
        let rebuild = match verdict {
            None => false,
            Some(local) if alone => local,
            Some(local) => self.any(local),
        };
        self.timer.stamp(Stage::GhostExchange);
        if rebuild && alone {
            let built = self.domain.rebuild_neighbours_around_moved();
            self.rebuilds += 1;
            self.timer.stamp(Stage::NeighbourRebuild);
            self.agree(built)?;
        } else if rebuild {
            self.rebuild()?;
        }
        self.timer.stamp(Stage::ErrorAgreement);
        Ok(())
    }

    /// Makes a rank's error everyone's: every rank returns the error of the lowest node id
    /// any rank reported, with the same message.
    pub(crate) fn agree(&mut self, local: Result<(), DomainError>) -> Result<(), DomainError> {
        let code = match &local {
            Ok(()) => u64::MAX,
            Err(DomainError::NonFinite { gid, .. }) => (1 << 60) | gid.0,
            Err(DomainError::MissingGhost { gid, .. }) => (2 << 60) | gid.0,
            Err(DomainError::TimeStep { gid, .. }) => (3 << 60) | gid.0,
            Err(DomainError::ProjectileInverted { element, .. }) => (4 << 60) | *element as u64,
            Err(DomainError::MissingTiePartner { gid, .. }) => (5 << 60) | gid.0,
        };
        let mut agreed = [code];
        self.comm.min_u64(&mut agreed);
        let agreed = agreed[0];
        let result = if agreed == u64::MAX {
            Ok(())
        } else {
            let gid = GlobalNodeId(agreed & ((1 << 60) - 1));
            // the detail only the reporting rank knows travels in a second reduction
            let mut detail = [match &local {
                Err(DomainError::MissingGhost { along, .. }) if code == agreed => *along as u64,
                Err(DomainError::TimeStep { limit, .. }) if code == agreed => limit.to_bits(),
                Err(DomainError::MissingTiePartner { partner, .. }) if code == agreed => partner.0,
                _ => u64::MAX,
            }];
            self.comm.min_u64(&mut detail);
            match agreed >> 60 {
                1 => Err(DomainError::NonFinite { step: self.domain.step, gid }),
                2 => Err(DomainError::MissingGhost { gid, along: detail[0] as u32 }),
                4 => Err(DomainError::ProjectileInverted { step: self.domain.step, element: gid.0 as usize }),
                5 => Err(DomainError::MissingTiePartner { gid, partner: GlobalNodeId(detail[0]) }),
                _ => Err(DomainError::TimeStep { step: self.domain.step, gid, time_step: self.domain.time_step, limit: f64::from_bits(detail[0]) }),
            }
        };
        result
    }

    /// Rank 0's projectile state on every rank; for a deformable body also its surface
    /// (relative to its centre of mass), which every rank's meshed proxy then takes, and
    /// whether an element has inverted (then every rank stops here).
    pub(crate) fn broadcast_projectile(&mut self) -> Result<(), DomainError> {
        let Some(projectile) = self.domain.projectile.as_mut() else { return Ok(()) };
        let vertices = projectile.shape.deforming_mesh().map(|mesh| mesh.surface.vertices.len());
        let surface = &mut self.surface;
        if let Some(body) = &self.deformable {
            body.fill_proxy(projectile, surface);
        }
        let words = &mut self.projectile_words;
        words.clear();
        words.extend_from_slice(&projectile_words(projectile));
        match (vertices, &self.deformable) {
            (Some(_), Some(body)) => {
                words.extend(surface.iter().flat_map(|v| [v.x, v.y, v.z]));
                words.push(body.inverted.map_or(0.0, |e| (e + 1) as f64));
            }
            // the other ranks receive into a buffer of the same length
            (Some(n), None) => words.resize(PROJECTILE_WORDS + 3 * n + 1, 0.0),
            (None, _) => {}
        }
        self.comm.broadcast_f64(words);
        if self.comm.rank() != Rank(0) {
            set_projectile_words(projectile, words);
        }
        if vertices.is_some() {
            let (coordinates, status) = words[PROJECTILE_WORDS..].split_at(words.len() - PROJECTILE_WORDS - 1);
            if status[0] > 0.0 {
                return Err(DomainError::ProjectileInverted { step: self.domain.step, element: status[0] as usize - 1 });
            }
            surface.clear();
            surface.extend(coordinates.chunks_exact(3).map(|w| Vec3::new(w[0], w[1], w[2])));
            if let RigidShape::Mesh(mesh) = &mut projectile.shape {
                std::sync::Arc::make_mut(mesh).set_vertices(surface);
            }
        }
        Ok(())
    }

    /// The projectile's state for a checkpoint (rank 0): the rigid words, and a deformable
    /// body's nodes and element rotations after them, then the fibres' last reactions (a
    /// subcycling body holds them over the next step).
    pub fn projectile_state(&self) -> Vec<f64> {
        let mut words = self.domain.projectile.as_ref().map(|p| projectile_words(p).to_vec()).unwrap_or_default();
        if let Some(body) = &self.deformable {
            words.extend(body.body.state_words());
            words.extend(self.reactions.iter().flat_map(reaction_words));
        }
        words
    }

    /// Every rank's reactions to rank 0, merged by global id and summed in that order.
    pub(crate) fn gather_projectile_load(&mut self) {
        if self.domain.projectile.is_none() {
            return;
        }
        self.reaction_words.clear();
        self.reaction_words.extend(self.domain.projectile_reactions().flat_map(|r| reaction_words(&r)));
        if let Some(all) = self.comm.gather_f64(&self.reaction_words) {
            self.reactions.clear();
            self.reactions.extend(all.iter().flat_map(|words| words.chunks_exact(REACTION_WORDS)).map(reaction_from_words));
            self.reactions.sort_unstable_by_key(|r| r.gid);
            let load = dea_core::projectile_contact::sum_reactions(self.reactions.iter().copied());
            self.domain.set_projectile_load(load);
            if let Some(body) = &mut self.deformable {
                body.forces(&self.reactions);
            }
        }
    }

    /// Sends position and failure state of every ghost to the ranks that hold it.
    pub(crate) fn forward_halo(&mut self) {
        let nodes = &self.domain.nodes;
        let failure = &self.domain.elements.failure;
        let halo = &mut self.halo;
        for (buffer, send) in halo.send_buffers.iter_mut().zip(&halo.send_nodes) {
            buffer.clear();
            for &i in send {
                let x = &nodes.position[i as usize];
                buffer.extend_from_slice(&[x.x, x.y, x.z, word(failure[i as usize] as u64)]);
            }
        }
        self.comm.exchange(&halo.partners, &halo.send_buffers, &mut halo.receive_buffers);
        let mut g = self.domain.nodes.n_owned;
        for buffer in &halo.receive_buffers {
            for w in buffer.chunks_exact(HALO_WORDS) {
                self.domain.nodes.position[g] = Vec3::new(w[0], w[1], w[2]);
                self.domain.elements.failure[g] = FailureMode::from_code(integer(w[3]) as u8).expect("a failure code sent by a rank");
                g += 1;
            }
            self.halo_bytes += (buffer.len() * std::mem::size_of::<f64>()) as u64;
        }
        self.halo_steps += 1;
    }

    /// Collective rebuild of ghosts, halo plan and neighbour lists.
    pub fn rebuild(&mut self) -> Result<(), DomainError> {
        let me = self.comm.rank();
        let reach = self.reach + self.ghost_margin();
        let nodes = &self.domain.nodes;
        let owned = &nodes.position[..nodes.n_owned];
        let (low, high) = owned.iter().fold((Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)), |(l, h), x| (l.inf(x), h.sup(x)));
        let boxes = self.comm.all_gather_f64(&[low.x, low.y, low.z, high.x, high.y, high.z]);
        let grown = |r: usize| (Vec3::new(boxes[6 * r], boxes[6 * r + 1], boxes[6 * r + 2]).add_scalar(-reach), Vec3::new(boxes[6 * r + 3], boxes[6 * r + 4], boxes[6 * r + 5]).add_scalar(reach));
        let inside = |x: &Vec3, (l, h): &(Vec3, Vec3)| (0..3).all(|k| x[k] >= l[k] && x[k] <= h[k]);
        // partners: chain neighbours, and ranks whose region comes within reach of ours
        let mut partners: Vec<Rank> = self.chain_send.iter().map(|(r, _)| *r).collect();
        for r in (0..self.comm.size()).filter(|&r| Rank(r as u32) != me) {
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
        let offers: Vec<Vec<f64>> = cubes.iter().map(|c| c.as_ref().map_or(Vec::new(), |c| c.occupied(owned.iter()).into_iter().map(word).collect())).collect();
        let mut occupied: Vec<Vec<f64>> = offers.iter().map(|o| vec![0.0; o.len()]).collect();
        self.comm.exchange(&partners, &offers, &mut occupied);
        // candidates for each partner: its chain stencil plus our nodes inside its grown box,
        // next to its nodes where the cubes tell
        let mut candidates: Vec<Vec<u32>> = Vec::with_capacity(partners.len());
        let mut records: Vec<Vec<f64>> = Vec::with_capacity(partners.len());
        for ((&partner, cubes), occupied) in partners.iter().zip(&cubes).zip(&occupied) {
            let chain = self.chain_send.binary_search_by_key(&partner, |(r, _)| *r).map_or(&[][..], |k| &self.chain_send[k].1[..]);
            let region = grown(partner.0 as usize);
            let near = cubes.as_ref().map(|c| (c, c.next_to(&occupied.iter().map(|&w| integer(w)).collect::<Vec<u64>>())));
            let next_to_theirs = |x: &Vec3| near.as_ref().is_none_or(|(c, near)| c.cube(x).is_some_and(|k| near[k]));
            let mut list: Vec<u32> = (0..nodes.n_owned as u32).filter(|&i| inside(&nodes.position[i as usize], &region) && next_to_theirs(&nodes.position[i as usize])).collect();
            list.extend_from_slice(chain);
            list.sort_unstable();
            list.dedup();
            let mut words = Vec::with_capacity(list.len() * RECORD_WORDS);
            for &i in &list {
                let i = i as usize;
                let x = nodes.position[i];
                let mut flags = if nodes.clamped[i] { FLAG_CLAMPED } else { 0 } | if nodes.last[i] { FLAG_LAST } else { 0 };
                if chain.binary_search(&(i as u32)).is_ok() {
                    flags |= FLAG_CHAIN;
                }
                let e = &self.domain.elements;
                words.extend_from_slice(&[
                    word(nodes.gid[i].0),
                    x.x,
                    x.y,
                    x.z,
                    word(nodes.fibre[i].0 as u64),
                    word(nodes.along[i] as u64),
                    word(nodes.section[i] as u64),
                    word(flags),
                    e.rest_length[i],
                    e.tensile_strength[i],
                    word(e.failure[i] as u64),
                    nodes.rest_angle[i],
                ]);
            }
            candidates.push(list);
            records.push(words);
        }
        let mut received: Vec<Vec<f64>> = vec![Vec::new(); partners.len()];
        self.comm.exchange_sized(&partners, &records, &mut received);
        // keep what our stencil needs and what comes within reach of an owned node
        let positions: Vec<Vec3> = received.iter().flat_map(|w| w.chunks_exact(RECORD_WORDS)).map(|w| Vec3::new(w[1], w[2], w[3])).collect();
        let near = dea_core::neighbour::within_reach_of_any(owned, &positions, reach);
        let mut ghosts = Vec::with_capacity(positions.len());
        let mut masks: Vec<Vec<f64>> = Vec::with_capacity(partners.len());
        let mut receive_counts = Vec::with_capacity(partners.len());
        let mut k = 0;
        for words in &received {
            let mut mask = Vec::with_capacity(words.len() / RECORD_WORDS);
            for w in words.chunks_exact(RECORD_WORDS) {
                let flags = integer(w[7]);
                let keep = flags & FLAG_CHAIN != 0 || near[k];
                k += 1;
                mask.push(if keep { 1.0 } else { 0.0 });
                if keep {
                    ghosts.push(GhostRecord {
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
                    });
                }
            }
            receive_counts.push(mask.iter().filter(|&&m| m == 1.0).count());
            masks.push(mask);
        }
        let mut kept: Vec<Vec<f64>> = candidates.iter().map(|c| vec![0.0; c.len()]).collect();
        self.comm.exchange(&partners, &masks, &mut kept);
        let send_nodes: Vec<Vec<u32>> = candidates.iter().zip(&kept).map(|(c, m)| c.iter().zip(m).filter(|(_, &m)| m == 1.0).map(|(&i, _)| i).collect()).collect();
        self.halo = HaloPlan {
            send_buffers: send_nodes.iter().map(|s| Vec::with_capacity(s.len() * HALO_WORDS)).collect(),
            receive_buffers: receive_counts.iter().map(|&n| vec![0.0; n * HALO_WORDS]).collect(),
            partners,
            send_nodes,
        };
        self.domain.set_ghosts(&ghosts);
        self.timer.stamp(Stage::GhostExchange);
        let built = self.domain.rebuild_neighbours();
        self.rebuilds += 1;
        self.timer.stamp(Stage::NeighbourRebuild);
        self.agree(built)
    }

    /// Ghost nodes held now.
    pub fn ghosts(&self) -> usize {
        self.domain.nodes.len() - self.domain.nodes.n_owned
    }

    /// The halo plan: (partner, owned global ids sent to it each step, ghosts received).
    pub fn halo_plan(&self) -> Vec<(Rank, Vec<GlobalNodeId>, usize)> {
        let h = &self.halo;
        h.partners.iter().zip(&h.send_nodes).zip(&h.receive_buffers).map(|((&p, s), r)| (p, s.iter().map(|&i| self.domain.nodes.gid[i as usize]).collect(), r.len() / HALO_WORDS)).collect()
    }

    /// Global ids of the ghosts, in local order.
    pub fn ghost_gids(&self) -> &[GlobalNodeId] {
        &self.domain.nodes.gid[self.domain.nodes.n_owned..]
    }

    /// Every energy of the whole problem, the same bits on every rank and any partition.
    pub fn energies(&self) -> dea_core::energy::EnergyReport {
        let mut sums = self.domain.energy_sums();
        if let Some(body) = &self.deformable {
            sums.projectile_kinetic.add(body.body.kinetic_energy());
            sums.projectile_strain.add(body.strain_energy);
        }
        let mut words = sums.to_words();
        self.comm.sum_i64(&mut words);
        EnergySums::from_words(&words).report()
    }

    /// Broken elements of the whole problem.
    pub fn broken(&self) -> BrokenCount {
        let b = self.domain.broken;
        let mut counts = [b.tension as i64, b.shear as i64, b.combined as i64];
        self.comm.sum_i64(&mut counts);
        BrokenCount { tension: counts[0] as u64, shear: counts[1] as u64, combined: counts[2] as u64 }
    }

    /// Broken elements of each layer, whole problem.
    pub fn broken_by_layer(&self, layers: usize) -> Vec<u64> {
        let nodes = &self.domain.nodes;
        let mut counts = vec![0i64; layers];
        for i in 0..nodes.n_owned {
            if self.domain.elements.failure[i] != FailureMode::Intact {
                counts[self.layer_of(nodes.fibre[i]) as usize] += 1;
            }
        }
        self.comm.sum_i64(&mut counts);
        counts.into_iter().map(|c| c as u64).collect()
    }

    /// Energy each layer holds or has dissipated (kinetic, strain, bending, contact,
    /// friction, plasticity, fracture), whole problem, exact sums [J].
    pub fn energy_by_layer(&self, layers: usize) -> Vec<f64> {
        let nodes = &self.domain.nodes;
        let sums = self.domain.energy_sums_by(|i| self.layer_of(nodes.fibre[i]) as usize, layers);
        let mut words: Vec<i64> = sums.iter().flat_map(EnergySums::to_words).collect();
        self.comm.sum_i64(&mut words);
        words.chunks_exact(dea_core::energy::ENERGY_WORDS).map(|w| EnergySums::from_words(w).report().total()).collect()
    }

    /// Lowest and highest owned node along z over every rank [m].
    pub fn z_range(&self) -> (f64, f64) {
        let owned = &self.domain.nodes.position[..self.domain.nodes.n_owned];
        let mut extremes = [owned.iter().map(|p| -p.z).fold(f64::NEG_INFINITY, f64::max), owned.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max)];
        self.comm.max_f64(&mut extremes);
        (-extremes[0], extremes[1])
    }

    /// Bit set over global fibre ids: fibres with a broken element anywhere.
    pub fn fibres_with_broken_elements(&self, fibres: usize) -> Vec<u64> {
        let mut bits = vec![0u64; fibres.div_ceil(64)];
        let nodes = &self.domain.nodes;
        for i in 0..nodes.n_owned {
            if self.domain.elements.failure[i] != FailureMode::Intact {
                let f = nodes.fibre[i].0 as usize;
                bits[f / 64] |= 1 << (f % 64);
            }
        }
        self.comm.or_u64(&mut bits);
        bits
    }

    /// True on every rank when any rank says so.
    pub fn any(&self, local: bool) -> bool {
        let mut flag = [if local { 1.0 } else { 0.0 }];
        self.comm.max_f64(&mut flag);
        flag[0] > 0.0
    }

    /// How far beyond the contact search distance ghosts are taken: one skin, so that the
    /// lists can be kept until a node has moved a whole skin (not half) when nodes move
    /// together ([`Domain::lists_may_miss_a_pair`]) [m].
    fn ghost_margin(&self) -> f64 {
        self.domain.pairs.skin
    }

    /// Rank 0's values on every rank.
    pub fn from_rank0<const N: usize>(&self, mut values: [f64; N]) -> [f64; N] {
        self.comm.broadcast_f64(&mut values);
        values
    }

    /// Layer of the yarn of a fibre.
    pub fn layer_of(&self, fibre: FibreId) -> u32 {
        self.layer_of_yarn.get(self.partition.yarn_of(fibre)).copied().unwrap_or(0)
    }

    /// Sends the velocity of every ghost to the ranks that hold it (snapshots only: no
    /// force needs it).
    fn refresh_ghost_velocities(&mut self) {
        let domain = &self.domain;
        let halo = &self.halo;
        let sends: Vec<Vec<f64>> = halo.send_nodes.iter().map(|send| send.iter().flat_map(|&i| domain.velocity(i as usize).as_slice().to_vec()).collect()).collect();
        let mut receives: Vec<Vec<f64>> = halo.receive_buffers.iter().map(|r| vec![0.0; 3 * (r.len() / HALO_WORDS)]).collect();
        self.comm.exchange(&halo.partners, &sends, &mut receives);
        let mut g = self.domain.nodes.n_owned;
        for buffer in &receives {
            for v in buffer.chunks_exact(3) {
                self.domain.nodes.velocity[g] = Vec3::new(v[0], v[1], v[2]);
                g += 1;
            }
        }
    }

    /// This rank's part of a field snapshot (collective: ghost velocities are refreshed).
    // nodes, elements and stresses are indexed alike: a range loop reads plainest
    #[allow(clippy::needless_range_loop)]
    pub fn snapshot_part(&mut self) -> SnapshotPart {
        self.refresh_ghost_velocities();
        let me = self.comm.rank().0;
        let d = &self.domain;
        let nodes = &d.nodes;
        let n = nodes.n_owned;
        let stress = d.element_stress();
        let mut part = SnapshotPart::default();
        let mut point_of_ghost = std::collections::HashMap::new();
        let add_point = |part: &mut SnapshotPart, i: usize, rank: u32| {
            part.position.push(nodes.position[i]);
            part.velocity.push(d.velocity(i));
            part.gid.push(nodes.gid[i].0);
            part.layer.push(self.layer_of(nodes.fibre[i]));
            part.yarn.push(self.partition.yarn_of(nodes.fibre[i]) as u32);
            part.rank.push(rank);
        };
        for i in 0..n {
            add_point(&mut part, i, me);
        }
        for i in 0..n {
            let next = nodes.next[i];
            if next == dea_core::NONE {
                continue;
            }
            let j = next as usize;
            let point = if j < n {
                j as u32
            } else {
                *point_of_ghost.entry(j).or_insert_with(|| {
                    let owner = self.partition.rank_of(nodes.fibre[j], nodes.along[j]).0;
                    add_point(&mut part, j, owner);
                    (part.gid.len() - 1) as u32
                })
            };
            part.connectivity.push([i as u32, point]);
            part.element_gid.push(nodes.gid[i].0);
            part.strain.push(d.elements.strain[i]);
            part.stress.push(stress[i]);
            part.failure.push(d.elements.failure[i] as u8);
        }
        part
    }

    /// The state of the owned nodes for a checkpoint, ascending gid.
    pub fn checkpoint_part(&self) -> NodeState {
        let d = &self.domain;
        let n = d.nodes.n_owned;
        let contacts = &d.projectile_contacts;
        let pairs = &d.pairs;
        // every entry's history as its node sees it (a pair of two owned nodes keeps one)
        let histories: Vec<_> = (0..n).flat_map(|i| pairs.row(i).map(move |k| pairs.history(i, k))).collect();
        let (retired_length, retired_gid, retired_max_overlap) = pairs.retired_as_full_rows();
        NodeState {
            gid: d.nodes.gid[..n].iter().map(|g| g.0).collect(),
            position: d.nodes.position[..n].to_vec(),
            velocity: (0..n).map(|i| d.velocity(i)).collect(),
            force: d.nodes.force[..n].to_vec(),
            reference_position: pairs.reference_position[..n].to_vec(),
            failure: d.elements.failure[..n].iter().map(|&m| m as u8).collect(),
            tensile_strength: d.elements.tensile_strength[..n].to_vec(),
            friction_dissipated: d.ledger.friction_dissipated.clone(),
            plastic_dissipated: d.ledger.plastic_dissipated.clone(),
            fracture_released: d.ledger.fracture_released.clone(),
            projectile_anchor: contacts.anchor.clone(),
            projectile_spring_stiffness: contacts.spring_stiffness.clone(),
            projectile_touching: contacts.touching.iter().map(|&t| t as u8).collect(),
            projectile_max_overlap: contacts.max_overlap.clone(),
            projectile_anchor_triangle: contacts.anchor_triangle.clone(),
            projectile_anchor_weights: contacts.anchor_weights.iter().map(|&w| Vec3::from(w)).collect(),
            row_length: (0..n).map(|i| pairs.row(i).len() as u32).collect(),
            partner_gid: pairs.partner_gid.iter().map(|g| g.0).collect(),
            anchor: histories.iter().map(|h| h.anchor).collect(),
            spring_stiffness: histories.iter().map(|h| h.spring_stiffness).collect(),
            touching: histories.iter().map(|h| h.touching as u8).collect(),
            max_overlap: histories.iter().map(|h| h.max_overlap).collect(),
            retired_length,
            retired_gid: retired_gid.iter().map(|g| g.0).collect(),
            retired_max_overlap,
        }
    }

    /// Restarts from a checkpoint. `domain` holds this rank's owned nodes as generated, in
    /// the gid order of `state`; the projectile's state is `projectile`. The neighbour lists
    /// are rebuilt from the positions of their last build (so they are the lists of the
    /// interrupted run; later rebuilds may fall on other steps, which changes no result,
    /// theory D11), then every history, position, velocity and force is put back and the
    /// ghosts are refreshed.
    #[allow(clippy::too_many_arguments)]
    pub fn restore(comm: C, mut domain: Domain, partition: Partition, nodes_per_fibre: &[u32], reach: f64, state: &NodeState, projectile: &[f64], mut deformable: Option<DeformableProjectile>) -> Result<Self, RestoreError> {
        let mut reactions = Vec::new();
        if let Some(deformable) = &mut deformable {
            let words = projectile.get(PROJECTILE_WORDS..).unwrap_or_default();
            let (body, held) = words.split_at(deformable.body.state_words().len().min(words.len()));
            deformable.body.set_state_words(body).ok_or_else(|| RestoreError::Mismatch(format!("the checkpoint holds {} words of the deformable projectile, not those of the case's mesh", body.len())))?;
            if held.len() % REACTION_WORDS != 0 {
                return Err(RestoreError::Mismatch(format!("the checkpoint's {} words of projectile reactions are not whole records", held.len())));
            }
            reactions.extend(held.chunks_exact(REACTION_WORDS).map(reaction_from_words));
        }
        let n = domain.nodes.n_owned;
        if state.gid.len() != n || domain.nodes.gid[..n].iter().zip(&state.gid).any(|(a, &b)| a.0 != b) {
            return Err(RestoreError::Mismatch("the checkpoint's nodes are not those of the case".into()));
        }
        for i in 0..n {
            domain.nodes.position[i] = state.reference_position[i];
            domain.elements.failure[i] = FailureMode::from_code(state.failure[i]).ok_or_else(|| RestoreError::Mismatch(format!("node {}: failure code {}", state.gid[i], state.failure[i])))?;
            domain.elements.tensile_strength[i] = state.tensile_strength[i];
        }
        if let Some(p) = &mut domain.projectile {
            set_projectile_words(p, projectile);
        }
        let mut restored = Self::assemble(comm, domain, partition, nodes_per_fibre, reach, deformable)?;
        restored.reactions = reactions;
        let d = &mut restored.domain;
        // the lists rebuilt from the same positions are the interrupted run's lists
        let mut entry = 0usize;
        let mut mismatch = None;
        for i in 0..n {
            let row = d.pairs.row(i);
            let length = state.row_length[i] as usize;
            let saved = &state.partner_gid[entry..entry + length];
            if row.len() != length || d.pairs.partner_gid[row.clone()].iter().zip(saved).any(|(a, &b)| a.0 != b) {
                mismatch.get_or_insert(state.gid[i]);
            } else {
                for (k, e) in row.zip(entry..entry + length) {
                    d.pairs.anchor[k] = state.anchor[e];
                    d.pairs.spring_stiffness[k] = state.spring_stiffness[e];
                    d.pairs.touching[k] = state.touching[e] != 0;
                    d.pairs.max_overlap[k] = state.max_overlap[e];
                }
            }
            entry += length;
        }
        let mismatched = restored.any(mismatch.is_some());
        if mismatched {
            return Err(RestoreError::Mismatch("the contact lists rebuilt at the checkpoint differ from the saved ones: the checkpoint does not belong to this build or case".into()));
        }
        let d = &mut restored.domain;
        // the retired contacts are the interrupted run's (the rebuild above knew no history)
        d.pairs.retired_start = std::iter::once(0).chain(state.retired_length.iter().scan(0u32, |total, &l| {
            *total += l;
            Some(*total)
        })).collect();
        d.pairs.retired_gid = state.retired_gid.iter().map(|&g| GlobalNodeId(g)).collect();
        d.pairs.retired_max_overlap.clone_from(&state.retired_max_overlap);
        let contacts = &mut d.projectile_contacts;
        for i in 0..n {
            d.nodes.position[i] = state.position[i];
            d.nodes.velocity[i] = state.velocity[i];
            d.nodes.force[i] = state.force[i];
            d.ledger.friction_dissipated[i] = state.friction_dissipated[i];
            d.ledger.plastic_dissipated[i] = state.plastic_dissipated[i];
            d.ledger.fracture_released[i] = state.fracture_released[i];
            contacts.anchor[i] = state.projectile_anchor[i];
            contacts.spring_stiffness[i] = state.projectile_spring_stiffness[i];
            contacts.touching[i] = state.projectile_touching[i] != 0;
            contacts.max_overlap[i] = state.projectile_max_overlap[i];
            contacts.anchor_triangle[i] = state.projectile_anchor_triangle[i];
            contacts.anchor_weights[i] = state.projectile_anchor_weights[i].into();
        }
        if let Some(p) = &mut d.projectile {
            set_projectile_words(p, projectile);
        }
        restored.forward_halo();
        restored.halo_steps = 0;
        restored.halo_bytes = 0;
        Ok(restored)
    }
}

/// Why a restart failed.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    #[error("{0}")]
    Numerical(#[from] DomainError),
    #[error("{0}")]
    Mismatch(String),
}
