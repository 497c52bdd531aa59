//! One explicit step on every rank (DESIGN.md §4), as a flat list of named stages, each
//! stamped on one timer when it ends (LAMMPS `Verlet::run` with `timer->stamp`). The physics
//! of each stage is a kernel of `dea_core` that never sees a communicator; the stages that
//! talk to other ranks are the comm layer's operations on [`Distributed`].

use std::time::Instant;

use dea_core::{Domain, DomainError};
use serde::ser::{Serialize, SerializeMap, Serializer};

use crate::comm::Comm;
use crate::distributed::Distributed;

/// The stages of a run, in the order a step runs them (output between steps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// the opening half kick (with the last step's closing one) and the drift of the owned
    /// nodes and of the projectile on its owner
    KickDrift,
    /// a deformable projectile's own substeps on rank 0
    DeformableSubcycles,
    /// rank 0's projectile state to every rank
    ProjectileBroadcast,
    /// the largest motions of a node and the run loop's requests, agreed over the ranks
    MotionAgreement,
    /// owned positions and failure states to the ranks that hold them as ghosts
    HaloForward,
    /// whether this rank's lists may miss a pair: its nodes' motions since the last build
    /// against the skin (LAMMPS `check_distance`; no message)
    ListCheck,
    /// whether any rank's lists may miss a pair, and at a rebuild the new ghosts (LAMMPS
    /// `borders`)
    GhostExchange,
    /// the neighbour lists, around the nodes that moved
    NeighbourRebuild,
    /// axial rod forces and bending springs
    Rods,
    /// ties of hybrid yarns
    Ties,
    /// fibre–fibre contact and friction
    FibreContacts,
    /// the projectile's candidates when due, then fibre–projectile contact and friction
    ProjectileContacts,
    /// the single-yarn fixture's guides, on the whole load: its ends' friction and its
    /// lateral hold (nothing for other targets)
    Guides,
    /// the combined tension–shear criterion and the energy broken elements release
    Failure,
    /// finite values and the stable time step at every owned node
    StateCheck,
    /// a numerical failure of any rank made every rank's
    ErrorAgreement,
    /// every rank's reactions to rank 0, summed in gid order: the projectile's load
    ProjectileLoad,
    /// the closing half kick
    Kick,
    /// histories, snapshots, checkpoints and results
    Output,
}

impl Stage {
    /// Stages of a step.
    pub const COUNT: usize = 19;
    /// Every stage, in the order a step runs them.
    pub const ALL: [Stage; Self::COUNT] = [
        Stage::KickDrift,
        Stage::DeformableSubcycles,
        Stage::ProjectileBroadcast,
        Stage::MotionAgreement,
        Stage::HaloForward,
        Stage::ListCheck,
        Stage::GhostExchange,
        Stage::NeighbourRebuild,
        Stage::Rods,
        Stage::Ties,
        Stage::FibreContacts,
        Stage::ProjectileContacts,
        Stage::Guides,
        Stage::Failure,
        Stage::StateCheck,
        Stage::ErrorAgreement,
        Stage::ProjectileLoad,
        Stage::Kick,
        Stage::Output,
    ];

    /// The stage's key in `summary.json` and in the bench report.
    pub fn name(self) -> &'static str {
        match self {
            Stage::KickDrift => "kick_drift",
            Stage::DeformableSubcycles => "deformable_subcycles",
            Stage::ProjectileBroadcast => "projectile_broadcast",
            Stage::MotionAgreement => "motion_agreement",
            Stage::HaloForward => "halo_forward",
            Stage::ListCheck => "list_check",
            Stage::GhostExchange => "ghost_exchange",
            Stage::NeighbourRebuild => "neighbour_rebuild",
            Stage::Rods => "rods",
            Stage::Ties => "ties",
            Stage::FibreContacts => "fibre_contacts",
            Stage::ProjectileContacts => "projectile_contacts",
            Stage::Guides => "guides",
            Stage::Failure => "failure",
            Stage::StateCheck => "state_check",
            Stage::ErrorAgreement => "error_agreement",
            Stage::ProjectileLoad => "projectile_load",
            Stage::Kick => "kick",
            Stage::Output => "output",
        }
    }

    /// Work a rank does alone (no message, no output): what the load imbalance compares.
    pub fn is_computation(self) -> bool {
        matches!(
            self,
            Stage::KickDrift
                | Stage::DeformableSubcycles
                | Stage::ListCheck
                | Stage::NeighbourRebuild
                | Stage::Rods
                | Stage::Ties
                | Stage::FibreContacts
                | Stage::ProjectileContacts
                | Stage::Guides
                | Stage::Failure
                | Stage::StateCheck
                | Stage::Kick
        )
    }
}

/// Wall time of each stage [s], serialised as an object keyed by [`Stage::name`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageSeconds(pub [f64; Stage::COUNT]);

impl StageSeconds {
    /// The seconds booked to `stage` [s].
    pub fn get(&self, stage: Stage) -> f64 {
        self.0[stage as usize]
    }

    /// The stages a rank runs alone, summed [s].
    pub fn computation(&self) -> f64 {
        Stage::ALL.iter().filter(|s| s.is_computation()).map(|&s| self.get(s)).sum()
    }

    /// Every stage summed [s].
    pub fn total(&self) -> f64 {
        self.0.iter().sum()
    }
}

impl Serialize for StageSeconds {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(Stage::COUNT))?;
        for stage in Stage::ALL {
            map.serialize_entry(stage.name(), &self.get(stage))?;
        }
        map.end()
    }
}

/// The one timer of a rank: [`Self::stamp`] books the time since the last stamp (or
/// [`Self::start`]) to a stage.
#[derive(Clone, Debug)]
pub struct StageTimer {
    /// the seconds booked to each stage so far
    pub seconds: StageSeconds,
    last: Instant,
}

impl Default for StageTimer {
    fn default() -> Self {
        Self { seconds: StageSeconds::default(), last: Instant::now() }
    }
}

impl StageTimer {
    /// Starts the clock of the next stage now (what ran since the last stamp is booked to
    /// none).
    pub fn start(&mut self) {
        self.last = Instant::now();
    }

    /// Books the time since the last stamp to `stage`.
    pub fn stamp(&mut self, stage: Stage) {
        let now = Instant::now();
        self.seconds.0[stage as usize] += (now - self.last).as_secs_f64();
        self.last = now;
    }

    /// Forgets every booked time (a benchmark's warm-up).
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// The forces of the present positions on the owned nodes, then failure and the state
/// check: the force stages of a step, each stamped. The order is the physics': the rods set
/// each node's force, the rest add to it; failure reads this step's strains and moments.
/// `instant` is the present positions' count of steps since the shot began: under
/// multi-rate stepping it decides which terms fire ([`Domain::fire_at`]).
pub fn compute_forces(domain: &mut Domain, timer: &mut StageTimer, instant: u64) -> Result<(), DomainError> {
    domain.fire_at(instant);
    domain.add_rod_forces();
    timer.stamp(Stage::Rods);
    domain.add_tie_forces();
    timer.stamp(Stage::Ties);
    domain.add_fibre_contacts();
    timer.stamp(Stage::FibreContacts);
    domain.add_projectile_contacts();
    timer.stamp(Stage::ProjectileContacts);
    domain.add_guide_forces();
    timer.stamp(Stage::Guides);
    domain.break_elements();
    timer.stamp(Stage::Failure);
    let checked = domain.check_state();
    timer.stamp(Stage::StateCheck);
    checked
}

impl<C: Comm> Distributed<C> {
    /// One explicit step on every rank: the velocity-Verlet kick–drift–kick of seed
    /// (4-18)…(4-20) with the forces of the new positions between the kicks.
    pub fn step(&mut self) -> Result<(), DomainError> {
        let time_step = self.domain.time_step;
        let half = 0.5 * time_step;
        self.timer.start();
        let motion = self.domain.kick_drift(half, time_step);
        self.timer.stamp(Stage::KickDrift);
        self.subcycle_deformable();
        self.timer.stamp(Stage::DeformableSubcycles);
        self.broadcast_projectile()?;
        self.timer.stamp(Stage::ProjectileBroadcast);
        let largest = self.agree_on_motion(motion);
        self.timer.stamp(Stage::MotionAgreement);
        // the ghosts' present positions, which the check for missed pairs reads
        self.forward_halo();
        self.timer.stamp(Stage::HaloForward);
        self.rebuild_if_due(largest)?;
        // the drift above brought the positions to the next step's instant
        let instant = self.domain.step + 1;
        let forces = compute_forces(&mut self.domain, &mut self.timer, instant);
        self.agree_on_forces(forces)?;
        self.gather_projectile_load();
        self.timer.stamp(Stage::ProjectileLoad);
        // the nodes' part of the closing kick rides on the next step's first pass
        self.domain.defer_kick(half);
        self.kick_deformable();
        self.domain.time += time_step;
        self.domain.step += 1;
        self.timer.stamp(Stage::Kick);
        Ok(())
    }
}
