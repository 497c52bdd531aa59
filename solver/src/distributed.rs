//! One rank of a distributed run: its [`Domain`] (owned nodes, then ghosts), its halo plan and
//! chain-stencil sends, its timer and counters, and the collectives around the kernels that
//! the step (`step.rs`) calls: the projectile's broadcast from rank 0 and its load gathered
//! there in global-id order, the motion agreement, the rebuild (`comm::halo`), and error
//! agreement (`comm::agree`). Rank 0 owns the projectile: it integrates it, broadcasts its
//! state every step, and sums the reactions of every rank's nodes in global-id order.
//! Diagnostics, snapshots, checkpoints and the settle are in modules of their own.

use dea_core::projectile::RigidShape;
use dea_core::{Domain, DomainError, FibreId, GlobalNodeId, NodeMotion, Rank, Reaction, Vec3};
use dea_partition::Partition;

use crate::comm::agree;
use crate::comm::codec::{
    projectile_words, reaction_from_words, reaction_words, set_projectile_words, PROJECTILE_WORDS, REACTION_WORDS,
};
use crate::comm::halo::HaloPlan;
use crate::comm::local::LocalComm;
use crate::comm::Comm;
use crate::deformable::DeformableProjectile;
use crate::step::{compute_forces, Stage, StageTimer};

/// Ghosts a rank may gain between two [`HaloPlan::borders`] beyond half of those it held
/// after the first, before the next rebuild chooses them all again: the halo of a rank with
/// few ghosts may grow by this many.
const GHOST_GROWTH_ALLOWANCE: usize = 1024;

/// What the run loop asks of every rank, carried by the step's motion agreement.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunRequests {
    /// a signal asked the job to stop (after a checkpoint)
    pub stop: bool,
    /// rank 0's wall-clock checkpoint interval has passed
    pub checkpoint: bool,
}

/// One rank of a distributed run. The domain and the communicator are what the kernels and
/// collectives work on, and the run loop, tests and diagnostics read them directly; the
/// rest is this rank's bookkeeping, read through methods and set within the solver.
pub struct Distributed<C: Comm> {
    /// the communicator of this run's ranks
    pub comm: C,
    /// this rank's nodes, elements, contacts and projectile
    pub domain: Domain,
    pub(crate) partition: Partition,
    /// contact search distance: largest contact diameter plus the skin [m]
    reach: f64,
    /// owned nodes each rank needs for its chain stencil, by rank (static: the partition
    /// never changes), ascending rank
    chain_send: Vec<(Rank, Vec<u32>)>,
    pub(crate) halo: HaloPlan,
    /// the one timer of this rank's stages
    pub timer: StageTimer,
    /// bytes of forward halo received so far
    pub(crate) halo_bytes: u64,
    /// steps that sent the forward halo (every step: the rebuild check reads the ghosts)
    pub(crate) halo_steps: u64,
    /// ghost and list rebuilds so far
    pub(crate) rebuilds: u64,
    /// ghosts held after the last [`HaloPlan::borders`]
    ghosts_at_borders: usize,
    /// rebuilds that extended the halo around moved nodes rather than choosing it again
    halo_extensions: u64,
    /// this rank's requests for the next step's reduction
    pub(crate) requests: RunRequests,
    /// the requests of any rank, agreed in the last step
    pub(crate) agreed: RunRequests,
    /// layer of each yarn (for snapshots and per-layer diagnostics); empty: all in layer 0
    pub(crate) layer_of_yarn: Vec<u32>,
    /// fibres of the whole target
    pub(crate) fibres: usize,
    /// reaction records of this rank, and (rank 0) of all ranks: reused every step
    reaction_words: Vec<f64>,
    pub(crate) reactions: Vec<Reaction>,
    /// a deformable projectile's body, on rank 0 (the other ranks see its meshed proxy)
    pub(crate) deformable: Option<DeformableProjectile>,
    /// projectile broadcast buffer, and a deformable body's surface decoded from it
    projectile_words: Vec<f64>,
    surface: Vec<Vec3>,
    /// how the target settled before the shot (none: no settle, or a restart)
    pub(crate) settled: Option<crate::settle::SettleReport>,
    /// each owned node's position as built, before any settle (displacements are measured
    /// from it) [m]
    pub(crate) as_built: Vec<Vec3>,
    /// where the back-face deflection is measured
    pub(crate) back_face: crate::deflection::BackFaceProbe,
}

impl Distributed<LocalComm> {
    /// A whole domain of owned nodes (ascending gid) on one rank in the calling thread, its
    /// lists built and its initial forces computed: how the physics tests run the production
    /// step on hand-made targets.
    pub fn whole(domain: Domain) -> Result<Self, DomainError> {
        let reach = domain.sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max) + domain.pairs.skin;
        let axis = domain.projectile.as_ref().map(crate::deflection::line_of_flight);
        let mut whole = Self::new(LocalComm::alone(), domain, Partition::one_rank(), &[u32::MAX], reach, None)?;
        let (point, direction) = axis.unwrap_or((Vec3::zeros(), -Vec3::z()));
        whole.locate_back_face(point, direction);
        Ok(whole)
    }
}

impl<C: Comm> Distributed<C> {
    /// Takes a domain of owned nodes (ascending global id) and fetches the ghosts, on every
    /// rank together.
    pub(crate) fn assemble(
        comm: C,
        domain: Domain,
        partition: Partition,
        nodes_per_fibre: &[u32],
        reach: f64,
        deformable: Option<DeformableProjectile>,
    ) -> Result<Self, DomainError> {
        let me = comm.rank();
        let mut chain: std::collections::BTreeMap<Rank, Vec<u32>> = Default::default();
        let nodes = &domain.nodes;
        let stencil = domain.chain_stencil();
        for i in 0..nodes.n_owned {
            let yarn = partition.yarn_of(nodes.fibre[i]);
            let along = nodes.along[i] as i64;
            let mut needed_by: Vec<Rank> = (1..=stencil as i64)
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
            ghosts_at_borders: 0,
            halo_extensions: 0,
            requests: RunRequests::default(),
            agreed: RunRequests::default(),
            layer_of_yarn: Vec::new(),
            fibres: 0,
            reaction_words: Vec::new(),
            reactions: Vec::new(),
            deformable,
            projectile_words: Vec::new(),
            surface: Vec::new(),
            settled: None,
            as_built: Vec::new(),
            back_face: Default::default(),
        };
        distributed.as_built = distributed.domain.nodes.position[..distributed.domain.nodes.n_owned].to_vec();
        distributed.rebuild()?;
        Ok(distributed)
    }

    /// `Self::assemble`, then the initial forces: a fresh run.
    pub fn new(
        comm: C,
        domain: Domain,
        partition: Partition,
        nodes_per_fibre: &[u32],
        reach: f64,
        deformable: Option<DeformableProjectile>,
    ) -> Result<Self, DomainError> {
        let mut distributed = Self::assemble(comm, domain, partition, nodes_per_fibre, reach, deformable)?;
        let instant = distributed.domain.step;
        let forces = compute_forces(&mut distributed.domain, &mut distributed.timer, instant);
        distributed.agree_on_forces(forces)?;
        distributed.gather_projectile_load();
        Ok(distributed)
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
        let mut largest = [motion.since_build, motion.step, flag(self.requests.stop), flag(self.requests.checkpoint)];
        self.comm.max_f64(&mut largest);
        self.agreed = RunRequests { stop: largest[2] > 0.0, checkpoint: largest[3] > 0.0 };
        NodeMotion { since_build: largest[0], step: largest[1] }
    }

    /// Rebuilds the ghosts and lists when some rank's lists may miss a pair, given the
    /// `largest` motions over every rank: on one rank only the rows around the nodes that
    /// moved (no ghosts to choose again). Stamps the list check, the ghost exchange and the
    /// list build.
    pub(crate) fn rebuild_if_due(&mut self, largest: NodeMotion) -> Result<(), DomainError> {
        let alone = self.comm.size() == 1;
        let verdict = self.domain.lists_may_miss_a_pair(largest, (!alone).then(|| self.ghost_margin()));
        self.timer.stamp(Stage::ListCheck);
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
            self.rebuild_around_moved(largest)?;
        }
        if rebuild {
            let pairs = &self.domain.pairs;
            tracing::debug!(
                "step {}: neighbour lists rebuilt (rebuild {}; largest motion since the last {:.3e} m; {:.1} % of the nodes relisted so far; {} pairs listed, {:.2} per owned node, {} of them touching)",
                self.domain.step,
                self.rebuilds,
                largest.since_build,
                100.0 * pairs.searched_nodes as f64 / pairs.held_nodes.max(1) as f64,
                pairs.len(),
                pairs.len() as f64 / self.domain.nodes.n_owned.max(1) as f64,
                pairs.touching_entries()
            );
        }
        self.timer.stamp(Stage::ErrorAgreement);
        Ok(())
    }

    /// The agreement after the force stages: a rank's error everyone's, and when any rank
    /// broke an element that unloads at its break, the ghosts' failure states of this step
    /// brought in and the broken elements' forces taken out of the owned nodes' (theory I7;
    /// one reduction either way, the halo only in such steps).
    pub(crate) fn agree_on_forces(&mut self, forces: Result<(), DomainError>) -> Result<(), DomainError> {
        let (step, time_step) = (self.domain.step, self.domain.time_step);
        let unload = agree::agree_and_any(&self.comm, forces, self.domain.unloads_now(), step, time_step)?;
        self.timer.stamp(Stage::ErrorAgreement);
        if unload {
            // positions are those sent at the start of the step; the failure states are new
            self.halo_bytes += self.halo.forward(&self.comm, &mut self.domain.nodes, &mut self.domain.elements.failure);
            self.timer.stamp(Stage::HaloForward);
            self.domain.unload_broken();
            self.timer.stamp(Stage::Failure);
        }
        Ok(())
    }

    /// Makes a rank's error everyone's ([`agree::agree`]).
    pub(crate) fn agree(&mut self, local: Result<(), DomainError>) -> Result<(), DomainError> {
        agree::agree(&self.comm, local, self.domain.step, self.domain.time_step)
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
                return Err(DomainError::ProjectileInverted {
                    step: self.domain.step,
                    element: status[0] as usize - 1,
                });
            }
            surface.clear();
            surface.extend(coordinates.chunks_exact(3).map(|w| Vec3::new(w[0], w[1], w[2])));
            if let RigidShape::Mesh(mesh) = &mut projectile.shape {
                std::sync::Arc::make_mut(mesh).set_vertices(surface);
            }
        }
        Ok(())
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
            self.reactions
                .extend(all.iter().flat_map(|words| words.chunks_exact(REACTION_WORDS)).map(reaction_from_words));
            self.reactions.sort_unstable_by_key(|r| r.gid);
            let load = dea_core::projectile_contact::sum_reactions(self.reactions.iter().copied());
            self.domain.set_projectile_load(load);
            if let Some(body) = &mut self.deformable {
                body.forces(&self.reactions);
            }
        }
    }

    /// Sends position and failure state of every ghost to the ranks that hold it
    /// ([`HaloPlan::forward`]).
    pub(crate) fn forward_halo(&mut self) {
        self.halo_bytes += self.halo.forward(&self.comm, &mut self.domain.nodes, &mut self.domain.elements.failure);
        self.halo_steps += 1;
    }

    /// Collective rebuild of ghosts ([`HaloPlan::borders`]), halo plan and neighbour lists.
    pub fn rebuild(&mut self) -> Result<(), DomainError> {
        let reach = self.reach + self.ghost_margin();
        let (plan, ghosts) = HaloPlan::borders(&self.comm, &self.domain, &self.chain_send, reach);
        self.halo = plan;
        self.domain.set_ghosts(&ghosts);
        self.ghosts_at_borders = ghosts.len();
        self.timer.stamp(Stage::GhostExchange);
        let built = self.domain.rebuild_neighbours();
        self.rebuilds += 1;
        self.timer.stamp(Stage::NeighbourRebuild);
        self.agree(built)
    }

    /// Collective rebuild on several ranks around the nodes that moved (theory M2): the halo
    /// extended around every rank's moved owned nodes ([`HaloPlan::extend`]), then each
    /// rank's lists rebuilt around its moved nodes and the new ghosts. The whole
    /// [`Self::rebuild`] instead when any rank's ghosts may be stale (`largest` motion since
    /// the last build), when most of its owned nodes moved, or when its ghosts have grown by
    /// half since the last [`HaloPlan::borders`] (ghosts are never dropped in between).
    fn rebuild_around_moved(&mut self, largest: NodeMotion) -> Result<(), DomainError> {
        let skin = self.domain.pairs.skin;
        let stale = 2.0 * largest.since_build >= skin + self.ghost_margin();
        let moved = if self.domain.pairs.holds_numbering_of(&self.domain.nodes) {
            Some(self.domain.moved_owned())
        } else {
            None
        };
        let whole = stale
            || moved.as_ref().is_none_or(|m| 2 * m.len() > self.domain.nodes.n_owned)
            || 2 * self.ghosts() > 3 * self.ghosts_at_borders + 2 * GHOST_GROWTH_ALLOWANCE;
        match moved {
            Some(moved) if !self.any(whole) => {
                let reach = self.reach + self.ghost_margin();
                let extension = self.halo.extend(&self.comm, &self.domain, &moved, reach);
                self.domain.append_ghosts(&extension.ghosts);
                self.timer.stamp(Stage::GhostExchange);
                let built =
                    self.domain.rebuild_neighbours_only_around_moved(&extension.moved_ghosts, &extension.references);
                self.rebuilds += 1;
                self.halo_extensions += 1;
                self.timer.stamp(Stage::NeighbourRebuild);
                self.agree(built)
            }
            _ => self.rebuild(),
        }
    }

    /// Ghost and list rebuilds so far.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// Rebuilds so far that extended the halo around the moved nodes ([`HaloPlan::extend`]).
    pub fn halo_extensions(&self) -> u64 {
        self.halo_extensions
    }

    /// Ghost nodes held now.
    pub fn ghosts(&self) -> usize {
        self.domain.nodes.len() - self.domain.nodes.n_owned
    }

    /// The halo plan: (partner, owned global ids sent to it each step, global ids of the
    /// ghosts received from it).
    pub fn halo_plan(&self) -> Vec<(Rank, Vec<GlobalNodeId>, Vec<GlobalNodeId>)> {
        self.halo.summary(&self.domain.nodes.gid)
    }

    /// Global ids of the ghosts, in local order.
    pub fn ghost_gids(&self) -> &[GlobalNodeId] {
        &self.domain.nodes.gid[self.domain.nodes.n_owned..]
    }

    /// True on every rank when any rank says so.
    pub fn any(&self, local: bool) -> bool {
        agree::any(&self.comm, local)
    }

    /// How far beyond the contact search distance ghosts are taken: one skin, so that the
    /// lists can be kept until a node has moved a whole skin (not half) when nodes move
    /// together ([`Domain::lists_may_miss_a_pair`]) [m].
    fn ghost_margin(&self) -> f64 {
        self.domain.pairs.skin
    }

    /// Rank 0's values on every rank.
    pub fn from_rank0<const N: usize>(&self, values: [f64; N]) -> [f64; N] {
        agree::from_rank0(&self.comm, values)
    }

    /// Sends the velocity of every ghost to the ranks that hold it (snapshots only: no
    /// force needs it).
    pub(crate) fn refresh_ghost_velocities(&mut self) {
        self.halo.forward_velocities(&self.comm, &mut self.domain);
    }

    /// Layer of the yarn of a fibre.
    pub fn layer_of(&self, fibre: FibreId) -> u32 {
        self.layer_of_yarn.get(self.partition.yarn_of(fibre)).copied().unwrap_or(0)
    }
}
