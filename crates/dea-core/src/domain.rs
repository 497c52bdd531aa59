//! One rank's part of the problem and the stages of an explicit step.
//!
//! A `Domain` holds the local nodes (owned first, ghosts after), element and pair state, and
//! the projectile. Its stages are the step of DESIGN.md §4 without communication; a driver
//! (the solver's step loop) calls them in order and inserts halo exchange and reductions.

use crate::bending::{compute_bending, compute_bending_over, BendingScratch};
use crate::contact::NormalLaw;
use crate::dispatch::Compilation;
use crate::energy::{EnergyReport, EnergySums};
use crate::failure::{self, BrokenCount, FailureParameters};
use crate::fibre_contact::{self, FibreContactSums, RunningSums};
use crate::friction::{FibreFrictionSpring, FrictionSpring};
use crate::guides::Guides;
use crate::integrate;
use crate::multi_rate::{section_runs, Firing, SectionRun};
use crate::neighbour::NeighbourList;
use crate::nodes::{Elements, FailureMode, Nodes};
use crate::pair_data::{PairData, PairDataTable};
use crate::projectile::RigidProjectile;
use crate::projectile_contact::{sum_reactions, ProjectileContacts, Reaction};
use crate::rod::{
    chain_forces, compute_element_tension, compute_element_tension_over, replace_chain_forces, set_chain_forces,
    set_scaled_chain_forces,
};
use crate::tie::{Tie, Ties};
use crate::{FibreId, FibreMaterial, FibreSection, GlobalNodeId, Vec3, NONE};

/// Nodes on each side of an owned node that its step reads with the seed's shear measure:
/// tension and bending need 2, and the failure test of the element after a rank's last node
/// (to book released energy once) needs 3. A gauge measure of shear or tension reads further
/// ([`Domain::chain_stencil`]).
pub const CHAIN_STENCIL: u32 = 3;

/// Contact parameters of a case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParameters {
    /// normal law for fibre–fibre and fibre–projectile contact
    pub law: NormalLaw,
    /// inter-fibre friction coefficient mu [-]
    pub friction_coefficient: f64,
    /// fibre–projectile friction coefficient [-]
    pub projectile_friction_coefficient: f64,
    /// how the fibre–projectile friction spring keeps its stretch
    pub projectile_friction_spring: FrictionSpring,
    /// how the fibre–fibre friction spring keeps its stretch
    pub fibre_friction_spring: FibreFrictionSpring,
    /// Verlet skin of the neighbour lists [m]
    pub skin: f64,
}

/// A numerical failure found in a stage.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DomainError {
    /// A force or position is not finite.
    #[error("non-finite force or position at node {} in step {step} (time step too large or an unstable contact)", gid.0)]
    NonFinite {
        /// the step it was found in
        step: u64,
        /// the node
        gid: GlobalNodeId,
    },
    /// A node's chain stencil lacks a node.
    #[error("node {} lacks the node at position {along} of its fibre within the chain stencil of {CHAIN_STENCIL}: a ghost is missing, so its forces cannot be computed", gid.0)]
    MissingGhost {
        /// the node whose stencil is incomplete
        gid: GlobalNodeId,
        /// the position along its fibre of the missing node
        along: u32,
    },
    /// A node's stiffness needs a shorter time step than the run's.
    #[error("time step violated at node {} in step {step}: its current stiffness is stable only below dt = {limit:.3e} s, the run uses {time_step:.3e} s (contacts far deeper than the time step was chosen for; lower run.time_step_safety)", gid.0)]
    TimeStep {
        /// the step it was found in
        step: u64,
        /// the node
        gid: GlobalNodeId,
        /// the run's time step [s]
        time_step: f64,
        /// the largest stable time step at the node's present stiffness [s]
        limit: f64,
    },
    /// A deformable projectile's element inverted.
    #[error("element {element} of the deformable projectile is inverted or no longer finite in step {step}: its elements cannot follow the deformation (a body this soft at this speed deforms more than its mesh holds: stiffen it, slow it, or round its striking edges more, so that their elements are not crushed; the neo_hookean model holds larger strains than the corotational one)")]
    ProjectileInverted {
        /// the step it was found in
        step: u64,
        /// the projectile's element
        element: usize,
    },
    /// A tied node's partner is not held.
    #[error("node {} is tied to node {} of a hybrid yarn's transition, which is not present: a ghost is missing, so its forces cannot be computed", gid.0, partner.0)]
    MissingTiePartner {
        /// the tied node
        gid: GlobalNodeId,
        /// the node it is tied to, missing
        partner: GlobalNodeId,
    },
    /// The whole problem's energies (summed over the ranks, the same on each) are not all
    /// finite: a state no node check saw, such as the projectile's.
    #[error("the energies of step {step} are not finite ({kinds}): the run diverged (a time step too large, an unstable contact, or a state beyond the model)")]
    NonFiniteEnergy {
        /// the step
        step: u64,
        /// the energies that are not finite, named
        kinds: String,
    },
}

/// Everything a rank needs to know of a node another rank owns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostRecord {
    /// the node's global id
    pub gid: GlobalNodeId,
    /// [m]
    pub position: Vec3,
    /// the fibre it belongs to
    pub fibre: FibreId,
    /// its position along the fibre (0 at the fibre's first node)
    pub along: u32,
    /// index of its fibre section in the domain's `sections`
    pub section: u16,
    /// held fixed (a clamped edge)
    pub clamped: bool,
    /// the last node of its fibre (it starts no element)
    pub last: bool,
    /// rest angle of the node's bending spring [rad]
    pub rest_angle: f64,
    /// rest length of the node's element [m]
    pub rest_length: f64,
    /// tensile strength of the node's element [Pa]
    pub tensile_strength: f64,
    /// how the node's element failed, if it did
    pub failure: FailureMode,
}

/// Per-owned-node running totals of dissipated and released energy [J].
#[derive(Clone, Debug, Default)]
pub struct NodeLedger {
    /// friction work dissipated at each owned node's contacts [J]
    pub friction_dissipated: Vec<f64>,
    /// plastic work of the contact law dissipated at each owned node [J]
    pub plastic_dissipated: Vec<f64>,
    /// elastic energy released by each owned node's broken element [J]
    pub fracture_released: Vec<f64>,
}

/// What the steps of a domain run: the shot, or the settle before it. The settle's
/// differences from the shot are this one value; the case's parameters stay as they are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// the case's friction and failure, no damping
    Shot,
    /// dynamic relaxation before the shot (theory F9): no friction between fibres, no
    /// failure, every fibre node damped at `damping` [1/s] (`dv/dt = F/m - c v`)
    Settle {
        /// [1/s]
        damping: f64,
    },
}

impl Phase {
    /// The mass-proportional damping rate of the fibre nodes [1/s].
    pub fn damping(self) -> f64 {
        match self {
            Phase::Shot => 0.0,
            Phase::Settle { damping } => damping,
        }
    }
}

/// The largest motion of a node [m].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeMotion {
    /// in the last step
    pub step: f64,
    /// since the fibre lists were built (infinite when they were built for other nodes)
    pub since_build: f64,
}

/// One rank's nodes, elements, contacts and projectile.
pub struct Domain {
    /// the fibre's elastic and strength constants
    pub material: FibreMaterial,
    /// the fibre sections (digital fibre diameters, element lengths), indexed by a node's `section`
    pub sections: Vec<FibreSection>,
    /// owned nodes first (ascending gid), then ghosts
    pub nodes: Nodes,
    /// the element starting at each node: rest state, strain, failure
    pub elements: Elements,
    /// fibre–fibre contact and friction parameters
    pub contact: ContactParameters,
    /// failure criterion and strengths
    pub failure: FailureParameters,
    /// fibre–fibre neighbour lists with their contact histories
    pub pairs: NeighbourList,
    /// rods joining fine fibres to coarse ones along hybrid yarns (docs/theory.md F12)
    pub ties: Ties,
    /// the projectile (a copy on every rank but the one that owns it)
    pub projectile: Option<RigidProjectile>,
    /// fibre nodes near the projectile and their contact histories
    pub projectile_contacts: ProjectileContacts,
    /// the bending springs' forces, moments and angles of this step
    pub bending: BendingScratch,
    /// per-node dissipated and released energies [J]
    pub ledger: NodeLedger,
    /// elements broken so far, by mode
    pub broken: BrokenCount,
    /// time step [s]
    pub time_step: f64,
    /// simulated time [s]
    pub time: f64,
    /// steps taken since the shot began
    pub step: u64,
    /// this domain integrates the projectile and counts its energy (rank 0); the others
    /// hold a copy that the driver overwrites every step
    pub owns_projectile: bool,
    /// the shot, or the settle before it (which turns friction and failure off and damps)
    pub phase: Phase,
    /// each step's closing kick of the owned nodes waits for the next step's opening one
    /// ([`Self::defer_kick`]); false kicks at once, as a settle does (its damping falls
    /// between the kicks). The deferral changes no bit, which a test checks by this switch.
    pub defer_closing_kick: bool,
    pair_data: PairDataTable,
    /// chain stiffness of each section (stability check) [N/m]
    chain_stiffness: Vec<f64>,
    /// stiffness the ties add to each owned node (stability check) [N/m]
    tie_stiffness: Vec<f64>,
    /// contact stiffness summed over each owned node's touching contacts this step [N/m]
    pub(crate) contact_stiffness: Vec<f64>,
    /// the fibre-contact sweep's running sums of each owned node
    running_contact_sums: Vec<RunningSums>,
    /// every owned node's chain stencil and tie partners were found local since the ghosts
    /// were last replaced (appending ghosts cannot lose one)
    stencil_checked: bool,
    newly_broken: Vec<(u32, FailureMode)>,
    /// the chain forces the rods stage set, while [`Self::unload_broken`] replaces them
    /// (scratch: grows at the first step that breaks an element, then keeps its room) [N]
    chain_force_set: Vec<Vec3>,
    /// the failure stage's section hats and gauge moments (scratch of
    /// [`failure::break_elements`])
    measured_moment: crate::shear_gauge::GaugeScratch,
    /// the failure stage's gauge strains (scratch of [`failure::break_elements`]; unused
    /// under the element tension measure)
    measured_strain: crate::tension_gauge::StrainGaugeScratch,
    /// the last step's closing kick of the owned nodes, left for the next step's opening one
    /// to apply in the same pass ([`Self::defer_kick`]): its half step [s]. While it waits,
    /// `nodes.velocity` is half a step behind the positions, and [`Self::velocity`] gives
    /// the velocities of the present step.
    deferred_kick: Option<f64>,
    /// each section's rate under multi-rate stepping: its terms fire every `rate` steps
    /// ([`crate::multi_rate`]); all 1 for single-rate stepping [-]
    rates: Vec<u32>,
    /// the terms that fire at the instant of the present forces ([`Self::fire_at`])
    firing: Firing,
    /// the runs of equal section over the local nodes
    section_runs: Vec<SectionRun>,
    /// `pair_data` with the force factors of `firing`
    firing_pair_data: PairDataTable,
    /// each owned row's smallest rate over its node and its upper partners: its pairs fire
    /// only at instants this divides; and the lists' build and size it was taken for
    row_rate: Vec<u32>,
    row_rate_of: (u64, usize, usize),
    /// each owned row has a pair that fires at the present instant
    row_fires: Vec<bool>,
    /// `row_fires` is all true (single-rate stepping): it need not be refilled
    row_fires_every: bool,
    /// the single-yarn fixture's guides ([`crate::guides`]); none for other targets
    guides: Guides,
}

impl Domain {
    /// Assembles a domain of owned nodes without computing anything: the distributed step
    /// adds the ghosts ([`Self::set_ghosts`]) and lists before the first forces.
    #[allow(clippy::too_many_arguments)]
    pub fn assemble(
        material: FibreMaterial,
        sections: Vec<FibreSection>,
        nodes: Nodes,
        elements: Elements,
        contact: ContactParameters,
        failure: FailureParameters,
        projectile: Option<RigidProjectile>,
        time_step: f64,
    ) -> Self {
        let n = nodes.len();
        let n_owned = nodes.n_owned;
        let pair_data = PairDataTable::new(&sections);
        let mut bending = BendingScratch::default();
        bending.resize(n);
        let chain_stiffness = sections.iter().map(|s| crate::stability::chain_stiffness(&material, s)).collect();
        let firing = Firing::every_term(sections.len(), n);
        let section_runs = section_runs(&nodes.section);
        let rates = vec![1; sections.len()];
        Self {
            firing,
            section_runs,
            rates,
            firing_pair_data: pair_data.clone(),
            row_rate: Vec::new(),
            row_rate_of: (u64::MAX, 0, 0),
            row_fires: Vec::new(),
            row_fires_every: false,
            guides: Guides::default(),
            material,
            sections,
            ledger: NodeLedger {
                friction_dissipated: vec![0.0; nodes.n_owned],
                plastic_dissipated: vec![0.0; nodes.n_owned],
                fracture_released: vec![0.0; nodes.n_owned],
            },
            projectile_contacts: ProjectileContacts::new(n_owned),
            nodes,
            elements,
            pairs: NeighbourList::new(contact.skin),
            ties: Ties::default(),
            contact,
            failure,
            projectile,
            bending,
            broken: BrokenCount::default(),
            time_step,
            time: 0.0,
            step: 0,
            owns_projectile: true,
            phase: Phase::Shot,
            defer_closing_kick: true,
            pair_data,
            chain_stiffness,
            tie_stiffness: vec![0.0; n_owned],
            contact_stiffness: vec![0.0; n_owned],
            running_contact_sums: vec![RunningSums::default(); n_owned],
            stencil_checked: false,
            newly_broken: Vec::new(),
            chain_force_set: Vec::new(),
            measured_moment: Default::default(),
            measured_strain: Default::default(),
            deferred_kick: None,
        }
    }

    /// Joins the owned nodes of the ties in `ties` that have one (the rest are dropped).
    /// Call before the ghosts are set: their ends are found again at every change.
    pub fn set_ties(&mut self, ties: Vec<Tie>) {
        self.ties = Ties::new(ties, &self.nodes);
        self.tie_stiffness = self.ties.stiffness_on_owned(self.nodes.n_owned, &self.material);
    }

    /// Replaces the ghosts by `ghosts` (any order) and relinks the chains. Call
    /// [`Self::rebuild_neighbours`] next: it checks the chain stencil.
    pub fn set_ghosts(&mut self, ghosts: &[GhostRecord]) {
        let n_owned = self.nodes.n_owned;
        self.nodes.truncate_to_owned();
        self.elements.truncate(n_owned);
        self.stencil_checked = false;
        self.append_ghosts(ghosts);
    }

    /// Appends `ghosts` (any order) after the ghosts held, whose local indices stay, and
    /// relinks the chains: the lists then still hold their numbering
    /// ([`NeighbourList::holds_numbering_of`]). Call [`Self::rebuild_neighbours`] or
    /// [`Self::rebuild_neighbours_only_around_moved`] next.
    pub fn append_ghosts(&mut self, ghosts: &[GhostRecord]) {
        for g in ghosts {
            self.nodes.push(g.gid, g.position, Vec3::zeros(), 0.0, g.fibre, g.along, g.section, g.clamped, g.last);
            *self.nodes.rest_angle.last_mut().expect("just pushed") = g.rest_angle;
            self.elements.push(g.rest_length, g.tensile_strength, g.failure);
        }
        self.nodes.link_chains();
        self.ties.link(&self.nodes);
        self.bending.resize(self.nodes.len());
        self.section_runs = section_runs(&self.nodes.section);
    }

    /// Sets each section's rate for multi-rate stepping ([`crate::multi_rate`]; all 1:
    /// single-rate). Takes effect at the next [`Self::fire_at`].
    pub fn set_rates(&mut self, rates: Vec<u32>) {
        assert_eq!(rates.len(), self.sections.len(), "one rate per section");
        assert!(rates.iter().all(|&r| r >= 1), "rates are whole numbers of steps");
        self.rates = rates;
    }

    /// Guides the nodes as the single-yarn fixture does ([`crate::guides`]).
    pub fn set_guides(&mut self, guides: Guides) {
        self.guides = guides;
    }

    /// The fixture's guides (none for other targets).
    pub fn guides(&self) -> &Guides {
        &self.guides
    }

    /// Adds the fixture's guide forces, after every other force of the step, and books the
    /// friction of its sliding ends ([`crate::guides::add_guide_forces`]).
    pub fn add_guide_forces(&mut self) {
        crate::guides::add_guide_forces(
            &mut self.nodes,
            &self.guides,
            self.time_step,
            &mut self.ledger.friction_dissipated,
        );
    }

    /// Each section's rate [-].
    pub fn rates(&self) -> &[u32] {
        &self.rates
    }

    /// Chooses the terms the next forces evaluate: those that fire at `instant` (a count of
    /// run steps since the shot began), each with its factor ([`crate::multi_rate::Firing`]).
    /// A settle fires every term at every step.
    pub fn fire_at(&mut self, instant: u64) {
        let single_rate = self.phase != Phase::Shot || self.rates.iter().all(|&r| r == 1);
        let (nodes, owned) = (self.nodes.len(), self.nodes.n_owned);
        if single_rate {
            // the firing of every term changes only with the local node count: most steps
            // of most runs pass here and should cost nothing
            if !(self.firing.single
                && self.firing.active == [0..nodes]
                && self.firing.section_scale.len() == self.sections.len())
            {
                self.firing = Firing::every_term(self.sections.len(), nodes);
                self.firing_pair_data.set_scales(&self.firing.pair_scale);
            }
            if !self.row_fires_every || self.row_fires.len() != owned {
                self.row_fires.clear();
                self.row_fires.resize(owned, true);
                self.row_fires_every = true;
            }
            return;
        }
        self.firing.set_at(&self.rates, instant, &self.section_runs, nodes);
        self.firing_pair_data.set_scales(&self.firing.pair_scale);
        let lists = (self.pairs.builds, self.pairs.partner.len(), owned);
        if self.row_rate_of != lists {
            // once per list build: the rows' rates follow their partners
            let (rates, section, pairs) = (&self.rates, &self.nodes.section, &self.pairs);
            let rate_of = |k: usize| rates[section[k] as usize];
            self.row_rate.clear();
            self.row_rate.extend((0..owned).map(|i| {
                let upper = pairs.upper_start[i] as usize..pairs.start[i + 1] as usize;
                pairs.partner[upper].iter().map(|&j| rate_of(j as usize)).fold(rate_of(i), u32::min)
            }));
            self.row_rate_of = lists;
        }
        self.row_fires.clear();
        self.row_fires.extend(self.row_rate.iter().map(|&rate| instant.is_multiple_of(rate as u64)));
        self.row_fires_every = false;
    }

    /// The terms of the present forces.
    pub fn firing(&self) -> &Firing {
        &self.firing
    }

    /// Half-step velocity update of owned nodes and the owned projectile.
    pub fn kick(&mut self, half_dt: f64) {
        debug_assert!(self.deferred_kick.is_none(), "a kick follows a kick");
        self.damp(half_dt);
        integrate::kick(&mut self.nodes, half_dt);
        self.kick_projectile(half_dt);
    }

    /// Half-step velocity update of the projectile, on the rank that owns it.
    fn kick_projectile(&mut self, half_dt: f64) {
        if let Some(projectile) = self.projectile.as_mut().filter(|_| self.owns_projectile) {
            projectile.kick(half_dt);
        }
    }

    /// The closing kick of a step, as [`Self::kick`], but the owned nodes' part waits for
    /// the next [`Self::kick_drift`], which applies it in its own pass over the nodes with
    /// the same bits: one pass over the nodes' velocities, forces and masses less per step.
    /// The projectile is kicked now. A damped settle kicks at once: its damping falls
    /// between the two kicks.
    pub fn defer_kick(&mut self, half_dt: f64) {
        if self.phase.damping() > 0.0 || !self.defer_closing_kick {
            return self.kick(half_dt);
        }
        debug_assert!(self.deferred_kick.is_none(), "a kick follows a kick");
        self.kick_projectile(half_dt);
        self.deferred_kick = Some(half_dt);
    }

    /// The velocity of local node `i` at the present step, whether or not its last kick
    /// waits ([`Self::defer_kick`]); a ghost's as last received [m/s].
    pub fn velocity(&self, i: usize) -> Vec3 {
        match self.deferred_kick {
            Some(half_dt) if i < self.nodes.n_owned => integrate::kicked(&self.nodes, half_dt, i),
            _ => self.nodes.velocity[i],
        }
    }

    /// Half-step velocity update (after a deferred closing kick of the last step, in the
    /// same pass), then position update, of owned nodes and the owned projectile. Returns
    /// the largest motion of an owned node.
    pub fn kick_drift(&mut self, half_dt: f64, dt: f64) -> NodeMotion {
        self.damp(half_dt);
        // the reference positions of the owned nodes, if the lists were built for these nodes
        let built = &self.pairs.reference_position;
        let reference = if built.len() == self.nodes.len() { &built[..self.nodes.n_owned] } else { &[] };
        let (step, since_build) =
            integrate::kick_drift(&mut self.nodes, self.deferred_kick.take(), half_dt, dt, reference);
        self.projectile_contacts.nodes_moved_at_most(step);
        if let Some(projectile) = self.projectile.as_mut().filter(|_| self.owns_projectile) {
            projectile.kick(half_dt);
            projectile.drift(dt);
        }
        NodeMotion { step, since_build }
    }

    /// The damping of a settle over a half step (none in a shot).
    fn damp(&mut self, half_dt: f64) {
        let damping = self.phase.damping();
        if damping > 0.0 {
            integrate::damp(&mut self.nodes, (-damping * half_dt).exp());
        }
    }

    /// Starts the shot from the present positions as if they were built so: every node at
    /// rest, no contact history (each contact starts on its loading curve, as the relaxed
    /// cell's do), nothing dissipated or broken, time zero, and the projectile's candidates
    /// due for a refresh.
    pub fn start_afresh(&mut self) {
        self.nodes.velocity.fill(Vec3::zeros());
        self.deferred_kick = None;
        self.pairs.forget_history();
        self.projectile_contacts.forget();
        for ledger in [
            &mut self.ledger.friction_dissipated,
            &mut self.ledger.plastic_dissipated,
            &mut self.ledger.fracture_released,
        ] {
            ledger.fill(0.0);
        }
        self.broken = BrokenCount::default();
        self.time = 0.0;
        self.step = 0;
    }

    /// Largest force on an owned node that is free to move [N].
    pub fn largest_free_force(&self) -> f64 {
        (0..self.nodes.n_owned)
            .filter(|&i| !self.nodes.clamped[i])
            .map(|i| self.nodes.force[i].norm())
            .fold(0.0, f64::max)
    }

    /// Largest overlap of a listed fibre pair, one of whose nodes is free to move, over its
    /// contact distance [-].
    pub fn largest_overlap_ratio(&self) -> f64 {
        let nodes = &self.nodes;
        let mut largest = 0.0f64;
        for i in 0..nodes.n_owned {
            for k in self.pairs.row(i) {
                let j = self.pairs.partner[k] as usize;
                if nodes.clamped[i] && nodes.clamped[j] {
                    continue;
                }
                let reach = self.pair_data_of(i, j).reach;
                largest = largest.max((reach - (nodes.position[j] - nodes.position[i]).norm()) / reach);
            }
        }
        largest
    }

    /// Whether an owned node may have come within reach of a partner not in its list, given
    /// the largest motions of a node over every rank (the step's is recorded here). `None`
    /// while no node moved more than half the skin since the lists were built: then no pair
    /// is missed, and every rank knows it alike. Otherwise this domain's answer, true when
    /// nodes near each other here (ghosts included, at their present positions) moved apart
    /// by more than the skin ([`NeighbourList::hold_every_reachable_pair`]), or, when other
    /// ranks hold nodes, when one that is no ghost here may have come within reach: the
    /// ghosts were taken `remote_margin` beyond the search reach [m], so such a node was
    /// farther than the cutoff plus the skin plus that margin, and needs twice the largest
    /// displacement to exceed the skin plus the margin. The ranks' answers may differ; all
    /// rebuild if any needs to.
    pub fn lists_may_miss_a_pair(&mut self, motion: NodeMotion, remote_margin: Option<f64>) -> Option<bool> {
        self.pairs.moved_at_most(motion.step);
        let skin = self.pairs.skin;
        if 2.0 * motion.since_build <= skin {
            return None;
        }
        let beyond_ghosts = remote_margin.is_some_and(|margin| 2.0 * motion.since_build >= skin + margin);
        Some(beyond_ghosts || !self.pairs.hold_every_reachable_pair(&self.nodes))
    }

    /// Rebuilds the fibre neighbour lists, after checking that every owned node has its
    /// chain stencil (the projectile's candidates are refreshed when their own check says so).
    pub fn rebuild_neighbours(&mut self) -> Result<(), DomainError> {
        self.build_neighbours(NeighbourList::rebuild)
    }

    /// [`Self::rebuild_neighbours`] with the lists rebuilt only around the nodes that moved
    /// ([`NeighbourList::rebuild_around_moved`]): for a domain whose ghosts are those of the
    /// last build.
    pub fn rebuild_neighbours_around_moved(&mut self) -> Result<(), DomainError> {
        self.build_neighbours(NeighbourList::rebuild_around_moved)
    }

    /// [`Self::rebuild_neighbours_around_moved`] on a rank among several, after the halo was
    /// extended around every rank's moved nodes: it never falls back to a full build, the
    /// owned nodes given new references are [`Self::moved_owned`]'s, the ghosts
    /// `moved_ghosts` (their owners moved them) take their present positions and the
    /// appended ghosts `appended_references` [m] ([`NeighbourList::rebuild_only_around_moved`]).
    pub fn rebuild_neighbours_only_around_moved(
        &mut self,
        moved_ghosts: &[u32],
        appended_references: &[Vec3],
    ) -> Result<(), DomainError> {
        self.check_stencil()?;
        self.pairs.rebuild_only_around_moved(&self.nodes, &self.sections, moved_ghosts, appended_references);
        Ok(())
    }

    /// The owned nodes (ascending local index) whose list references a rebuild around moved
    /// nodes would move to their present positions.
    pub fn moved_owned(&self) -> Vec<u32> {
        self.pairs.moved_owned(&self.nodes)
    }

    fn build_neighbours(&mut self, build: fn(&mut NeighbourList, &Nodes, &[FibreSection])) -> Result<(), DomainError> {
        self.check_stencil()?;
        build(&mut self.pairs, &self.nodes, &self.sections);
        Ok(())
    }

    /// Every owned node's chain stencil and tie partners are local: checked once after the
    /// ghosts are replaced (the nodes' chains and ties never change otherwise).
    fn check_stencil(&mut self) -> Result<(), DomainError> {
        if self.stencil_checked {
            return Ok(());
        }
        if let Some((gid, along)) = self.nodes.missing_chain_neighbour(self.chain_stencil()) {
            return Err(DomainError::MissingGhost { gid, along });
        }
        if let Some((gid, partner)) = self.ties.missing_end(self.nodes.n_owned) {
            return Err(DomainError::MissingTiePartner { gid, partner });
        }
        self.stencil_checked = true;
        Ok(())
    }

    /// Chooses the owned nodes that may touch the projectile before the next refresh
    /// ([`ProjectileContacts::refresh_candidates`]).
    fn refresh_projectile_candidates(&mut self) {
        self.projectile_contacts.refresh_candidates(
            self.projectile.as_ref(),
            &self.nodes,
            &self.sections,
            self.pairs.skin,
        );
    }

    /// Axial rod forces (4-2, 4-3) and the bending springs (5-1…5-3) of every local element
    /// and node, the chain forces set on the owned nodes (their force starts here each step).
    /// Under multi-rate stepping only the sections whose terms fire now ([`Self::fire_at`]),
    /// their forces times the factor; the other owned nodes' forces start at zero.
    pub fn add_rod_forces(&mut self) {
        self.compute_rods();
        if self.firing.single {
            set_chain_forces(&mut self.nodes, &self.elements, &self.bending);
        } else {
            set_scaled_chain_forces(&mut self.nodes, &self.elements, &self.bending, &self.firing.section_scale);
        }
    }

    /// The elements' tensions and the springs' forces of the present positions and failure
    /// states, over the elements whose terms fire now.
    fn compute_rods(&mut self) {
        if self.firing.single {
            compute_element_tension(&self.nodes, &mut self.elements, &self.sections, &self.material);
            compute_bending(&self.nodes, &self.elements, &self.sections, &mut self.bending);
            return;
        }
        // every element first: a spring reads the elements on both sides, which on a rank
        // among several may be ghosts' in another range
        for range in &self.firing.active {
            compute_element_tension_over(
                &self.nodes,
                &mut self.elements,
                &self.sections,
                &self.material,
                range.clone(),
            );
        }
        for range in &self.firing.active {
            compute_bending_over(&self.nodes, &self.elements, &self.sections, &mut self.bending, range.clone());
        }
    }

    /// Whether the failure stage broke an owned element in this step that
    /// [`Self::unload_broken`] must take out.
    pub fn unloads_now(&self) -> bool {
        self.failure.unload == failure::Unload::AtBreak && !self.newly_broken.is_empty()
    }

    /// Takes the forces of the elements broken in this step out of the owned nodes' forces
    /// when the case unloads them at the break ([`failure::Unload::AtBreak`], theory I7):
    /// the chain force the rods stage set is replaced by the one of the present failure
    /// states, at the nodes where the two differ. Run it after the failure stage on every
    /// rank once any rank broke an element, with the ghosts' failure states of this step:
    /// an owned node's chain force reads elements and springs up to two positions away,
    /// which another rank may own. Each node's result is a function of its own stencil,
    /// so it has the same bits on any ranks.
    pub fn unload_broken(&mut self) {
        if self.failure.unload != failure::Unload::AtBreak {
            return;
        }
        // held aside while the rods stage borrows the domain (it reads only the ranges)
        let section_scale = std::mem::take(&mut self.firing.section_scale);
        let scale = (!self.firing.single).then_some(&section_scale[..]);
        let mut set = std::mem::take(&mut self.chain_force_set);
        chain_forces(&self.nodes, &self.elements, &self.bending, scale, &mut set);
        self.compute_rods();
        replace_chain_forces(&mut self.nodes, &self.elements, &self.bending, scale, &set);
        self.chain_force_set = set;
        self.firing.section_scale = section_scale;
    }

    /// The forces of the rods tying fine fibres to coarse ones in hybrid yarns (theory F12).
    pub fn add_tie_forces(&mut self) {
        if self.firing.single {
            return self.ties.add_forces(&mut self.nodes, &self.material);
        }
        let firing = &self.firing;
        self.ties.add_scaled_forces(&mut self.nodes, &self.material, |a, b| firing.pair(a, b));
    }

    /// Fibre–fibre contact and friction on owned nodes (seed 3-1…3-3, 4-4…4-15), summed per
    /// node in partner-gid order.
    pub fn add_fibre_contacts(&mut self) {
        self.add_fibre_contacts_compiled_for(Compilation::widest());
    }

    /// [`Self::add_fibre_contacts`] by the sweep in `compilation`, which the processor must run.
    pub(crate) fn add_fibre_contacts_compiled_for(&mut self, compilation: Compilation) {
        let (law, mu) = (self.contact.law, self.friction_coefficient());
        self.running_contact_sums.resize(self.nodes.n_owned, RunningSums::default());
        let sums = FibreContactSums {
            force: &mut self.nodes.force,
            ledger: &mut self.ledger,
            contact_stiffness: &mut self.contact_stiffness,
            running: &mut self.running_contact_sums,
        };
        let owned = self.nodes.n_owned;
        if self.row_fires.len() != owned {
            // forces asked for without [`Self::fire_at`] (a kernel test): every row fires
            self.row_fires.clear();
            self.row_fires.resize(owned, true);
            self.row_fires_every = true;
        }
        fibre_contact::add_fibre_contacts_compiled_for(
            compilation,
            law,
            mu,
            self.contact.fibre_friction_spring,
            &self.nodes.position,
            &self.nodes.section,
            &mut self.pairs,
            &self.firing_pair_data,
            sums,
            owned,
            &self.row_fires,
        );
    }

    /// The inter-fibre friction coefficient of this phase: the case's in the shot, none while
    /// the target settles [-].
    pub fn friction_coefficient(&self) -> f64 {
        match self.phase {
            Phase::Shot => self.contact.friction_coefficient,
            Phase::Settle { .. } => 0.0,
        }
    }

    /// The contact data of the pair of owned or ghost nodes `i` and `j`.
    pub fn pair_data_of(&self, i: usize, j: usize) -> PairData {
        self.pair_data.of(self.nodes.section[i], self.nodes.section[j])
    }

    /// Fibre–projectile contact and friction on the candidate nodes
    /// ([`ProjectileContacts::add_forces`]).
    /// The candidates are refreshed first when node and surface may have moved a skin.
    pub fn add_projectile_contacts(&mut self) {
        if self.projectile_contacts.refresh_due(self.projectile.as_ref(), &self.nodes, self.pairs.skin) {
            self.refresh_projectile_candidates();
        }
        let Some(projectile) = &self.projectile else { return };
        let (law, mu) = (self.contact.law, self.contact.projectile_friction_coefficient);
        self.projectile_contacts.add_forces(
            projectile,
            &mut self.nodes,
            &self.sections,
            law,
            mu,
            self.contact.projectile_friction_spring,
            &mut self.ledger,
            &mut self.contact_stiffness,
        );
    }

    /// Reaction records of the owned nodes touching the projectile, ascending global id
    /// (candidates are owned nodes, whose local order is gid order): the force on the
    /// projectile and its torque about the projectile's centre [N], [N m].
    pub fn projectile_reactions(&self) -> impl Iterator<Item = Reaction> + '_ {
        self.projectile_contacts.reactions(&self.nodes)
    }

    /// Contact force and torque on the projectile from this domain's owned nodes [N], [N m].
    pub fn projectile_load(&self) -> (Vec3, Vec3) {
        sum_reactions(self.projectile_reactions())
    }

    /// Sets the contact force and torque the projectile feels in this step (the total over
    /// all ranks, reduced in global-id order by the driver).
    pub fn set_projectile_load(&mut self, (force, torque): (Vec3, Vec3)) {
        if let Some(projectile) = &mut self.projectile {
            projectile.force = force;
            projectile.torque = torque;
        }
    }

    /// Nodes on each side of an owned node that its step reads along its fibre: the
    /// [`CHAIN_STENCIL`] and the reach of the failure stage's gauges. Every rank holds
    /// these as ghosts (chosen by topology), so each decides its elements from the same window.
    pub fn chain_stencil(&self) -> u32 {
        CHAIN_STENCIL + self.failure.stencil_beyond_element(&self.sections)
    }

    /// The failure stage ([`failure::break_elements`]); none while the target settles.
    pub fn break_elements(&mut self) {
        if self.phase != Phase::Shot {
            self.newly_broken.clear();
            return;
        }
        failure::break_elements(
            &self.nodes,
            &mut self.elements,
            &self.bending,
            &self.sections,
            &self.material,
            &self.failure,
            &mut self.ledger.fracture_released,
            &mut self.broken,
            &mut self.newly_broken,
            &mut self.measured_moment,
            &mut self.measured_strain,
            &self.firing.active,
        );
    }

    /// Every owned node has finite force and position, and a stiffness the time step can
    /// integrate (central difference diverges once omega dt > 2).
    pub fn check_state(&self) -> Result<(), DomainError> {
        let mu = self.friction_coefficient().max(self.contact.projectile_friction_coefficient);
        let nodes = &self.nodes;
        // a section's nodes are checked at its own step, when its terms fire (every node at
        // every step under single-rate stepping), with every term's stiffness counted at that
        // step; a value gone non-finite between is caught at the next one, from the position
        for i in self.firing.active_below(nodes.n_owned).flatten() {
            if !(nodes.force[i].iter().all(|v| v.is_finite()) && nodes.position[i].iter().all(|v| v.is_finite())) {
                return Err(DomainError::NonFinite { step: self.step, gid: nodes.gid[i] });
            }
            let rate = self.firing.section_scale[nodes.section[i] as usize];
            if nodes.clamped[i] {
                continue;
            }
            let time_step = rate * self.time_step;
            // dt > 2 / omega, squared and without a division: this runs for every node
            let chain = self.chain_stiffness[nodes.section[i] as usize] + self.tie_stiffness[i];
            let stiffness = chain + (1.0 + mu) * self.contact_stiffness[i];
            if stiffness * time_step * time_step > 4.0 * nodes.mass[i] {
                let limit = crate::stability::node_stability_limit(chain, self.contact_stiffness[i], mu, nodes.mass[i]);
                return Err(DomainError::TimeStep { step: self.step, gid: nodes.gid[i], time_step, limit });
            }
        }
        Ok(())
    }

    /// Every energy of the domain as exact sums over owned nodes (pairs once each; the
    /// projectile's kinetic energy on its owner only), ready to merge across ranks. Call
    /// after the forces of a step so strains and angles are current.
    pub fn energy_sums(&self) -> EnergySums {
        let mut sums = self.energy_sums_by(|_| 0, 1);
        let mut report = sums.pop().expect("one group");
        if let Some(projectile) = self.projectile.as_ref().filter(|_| self.owns_projectile) {
            report.projectile_kinetic.add(projectile.kinetic_energy());
        }
        report
    }

    /// The energies the fibres hold or dissipated, as exact sums per group of owned nodes
    /// (`group(i)` < `groups`; a layer, say): everything of [`Self::energy_sums`] but the
    /// projectile's kinetic energy ([`crate::energy::fibre_energy_sums`]).
    pub fn energy_sums_by(&self, group: impl Fn(usize) -> usize, groups: usize) -> Vec<EnergySums> {
        crate::energy::fibre_energy_sums(self, group, groups)
    }

    /// [`Self::energy_sums`] rounded: the energies of a whole domain [J].
    pub fn energies(&self) -> EnergyReport {
        self.energy_sums().report()
    }

    /// Axial stress E_L eps of every owned element, NaN where there is no element [Pa].
    pub fn element_stress(&self) -> Vec<f64> {
        (0..self.nodes.n_owned)
            .map(|i| {
                if self.nodes.next[i] == NONE {
                    f64::NAN
                } else if self.elements.failure[i] == FailureMode::Intact {
                    self.material.longitudinal_modulus * self.elements.strain[i]
                } else {
                    0.0
                }
            })
            .collect()
    }
}
