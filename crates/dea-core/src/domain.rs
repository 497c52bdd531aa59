//! One rank's part of the problem and the stages of an explicit step.
//!
//! A `Domain` holds the local nodes (owned first, ghosts after), element and pair state, and
//! the projectile. Its stages are the step of DESIGN.md §4 without communication; a driver
//! (the solver's step loop) calls them in order and inserts halo exchange and reductions.

use std::cell::Cell;
use std::time::Instant;

use crate::bending::{compute_bending, element_shear_force, max_shear_stress, BendingScratch};
use crate::contact::{ContactGeometry, NormalLaw};
use crate::energy::{EnergyReport, EnergySums};
use crate::failure::{combined_criterion, FailureParameters};
use crate::friction::stick_slip;
use crate::integrate;
use crate::neighbour::{LowerGhostEntry, NeighbourList};
use crate::nodes::{Elements, FailureMode, Nodes};
use crate::projectile::{RigidProjectile, RigidShape};
use crate::rod::{axial_energy, compute_element_tension, element_strain_energy, set_chain_forces};
use crate::surface::SurfacePoint;
use crate::tie::{Tie, Ties};
use crate::{FibreId, FibreMaterial, FibreSection, GlobalNodeId, Vec3, NONE};
use nalgebra::UnitQuaternion;

/// Nodes on each side of an owned node that its step reads: tension and bending need 2, and
/// the failure test of the element after a rank's last node (to book released energy once)
/// needs 3.
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
    /// Verlet skin of the neighbour lists [m]
    pub skin: f64,
}

/// A numerical failure found in a stage.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DomainError {
    #[error("non-finite force or position at node {} in step {step} (time step too large or an unstable contact)", gid.0)]
    NonFinite { step: u64, gid: GlobalNodeId },
    #[error("node {} lacks the node at position {along} of its fibre within the chain stencil of {CHAIN_STENCIL}: a ghost is missing, so its forces cannot be computed", gid.0)]
    MissingGhost { gid: GlobalNodeId, along: u32 },
    #[error("time step violated at node {} in step {step}: its current stiffness is stable only below dt = {limit:.3e} s, the run uses {time_step:.3e} s (contacts far deeper than the time step was chosen for; lower run.time_step_safety)", gid.0)]
    TimeStep { step: u64, gid: GlobalNodeId, time_step: f64, limit: f64 },
    #[error("element {element} of the deformable projectile is inverted or no longer finite in step {step}: its elements cannot follow the deformation (a body this soft at this speed deforms more than its mesh holds: stiffen it, slow it, or round its striking edges more, so that their elements are not crushed; the neo_hookean model holds larger strains than the corotational one)")]
    ProjectileInverted { step: u64, element: usize },
    #[error("node {} is tied to node {} of a hybrid yarn's transition, which is not present: a ghost is missing, so its forces cannot be computed", gid.0, partner.0)]
    MissingTiePartner { gid: GlobalNodeId, partner: GlobalNodeId },
}

/// Everything a rank needs to know of a node another rank owns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostRecord {
    pub gid: GlobalNodeId,
    /// [m]
    pub position: Vec3,
    pub fibre: FibreId,
    pub along: u32,
    pub section: u16,
    pub clamped: bool,
    pub last: bool,
    /// rest angle of the node's bending spring [rad]
    pub rest_angle: f64,
    /// rest length of the node's element [m]
    pub rest_length: f64,
    /// tensile strength of the node's element [Pa]
    pub tensile_strength: f64,
    pub failure: FailureMode,
}

/// Contact history of every node with the projectile (one body, so one entry per node).
#[derive(Clone, Debug, Default)]
pub struct ProjectileContacts {
    /// owned nodes within reach of the projectile at the last build, ascending
    pub candidates: Vec<u32>,
    /// friction anchor: the partner point relative to the node at first touch, body frame:
    /// the body origin on a rigid body, the touched material point of a deforming surface [m]
    pub anchor: Vec<Vec3>,
    /// a deforming surface's material point the friction is anchored to: the triangle and
    /// barycentric weights of the contact point at first touch (docs/theory.md I6)
    pub anchor_triangle: Vec<u32>,
    pub anchor_weights: Vec<[f64; 3]>,
    /// stiffness of the friction spring at its last evaluation [N/m]
    pub spring_stiffness: Vec<f64>,
    /// node overlaps the projectile
    pub touching: Vec<bool>,
    /// largest overlap reached [m]
    pub max_overlap: Vec<f64>,
    /// contact force on the node in this step [N]
    pub force_on_node: Vec<Vec3>,
    /// torque of the reaction about the projectile's centre in this step [N m]
    pub torque_on_projectile: Vec<Vec3>,
    /// triangle and barycentric weights of the contact point on a meshed surface
    /// ([`NONE`] on an analytic one): where a deformable body takes the reaction
    pub triangle: Vec<u32>,
    pub weights: Vec<[f64; 3]>,
    /// surface vertices (body frame) at the last refresh: a deformable body's surface moves
    pub reference_vertices: Vec<Vec3>,
    /// owned node positions at the last refresh of the candidates [m]
    pub node_reference: Vec<Vec3>,
    /// projectile position at the last refresh [m]
    pub reference_position: Vec3,
    /// projectile orientation at the last refresh
    pub reference_orientation: UnitQuaternion<f64>,
    /// per owned node, the last query of a rigid mesh that found it clear of the surface:
    /// how far clear (distance less contact radius; -inf: no such query) [m], the node's
    /// position then [m] and the surface's travel then [m]. While the node and the surface
    /// have moved less than that since, the query cannot find it touching and is skipped.
    clearance: Vec<f64>,
    clearance_position: Vec<Vec3>,
    clearance_travel: Vec<f64>,
    /// how far any point of the projectile's surface has moved since the set-up, summed over
    /// the steps (centre plus bounding radius times the turn) [m], and the projectile's pose
    /// at the last step
    surface_travel: f64,
    travel_pose: Option<(Vec3, UnitQuaternion<f64>)>,
    /// queries skipped so far for nodes known to be clear
    pub skipped_queries: u64,
}

impl ProjectileContacts {
    /// Owned node `i` is out of contact with the projectile this step.
    fn release(&mut self, i: usize) {
        self.touching[i] = false;
        self.force_on_node[i].fill(0.0);
        self.torque_on_projectile[i].fill(0.0);
    }
}

/// The margin by which a skipped query's node must be clear of the surface [m], far above
/// the rounding of a distance and far below any contact's overlap.
const CLEARANCE_MARGIN: f64 = 1e-12;

/// The reaction of one fibre node on the projectile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reaction {
    pub gid: GlobalNodeId,
    /// contact force on the projectile [N]
    pub force: Vec3,
    /// its torque about the projectile's centre [N m]
    pub torque: Vec3,
    /// triangle of a meshed surface the force acts on ([`NONE`]: analytic) and the
    /// barycentric weights that share it over the triangle's vertices (seed 4-1)
    pub triangle: u32,
    pub weights: [f64; 3],
}

/// Sum of reactions given in ascending global id: the order that makes the projectile's
/// load independent of the partition (each rank's records are merged by gid first).
pub fn sum_reactions(reactions: impl Iterator<Item = Reaction>) -> (Vec3, Vec3) {
    reactions.fold((Vec3::zeros(), Vec3::zeros()), |(f, t), r| (f + r.force, t + r.torque))
}

/// Per-owned-node running totals of dissipated and released energy [J].
#[derive(Clone, Debug, Default)]
pub struct NodeLedger {
    pub friction_dissipated: Vec<f64>,
    pub plastic_dissipated: Vec<f64>,
    pub fracture_released: Vec<f64>,
}

/// How many list entries ahead the contact sweep asks for a partner's position and, when the
/// entry touched at the last sweep, its running sums: partners lie in other fibres' stretches
/// of memory, and in a woven panel their loads missed the cache. Sixteen beat eight in paired
/// runs of the default case (docs/performance.md, session 22).
const PREFETCH_AHEAD: usize = 16;

/// Asks the memory system for the value at `index` of the array at `base` (a hint: no
/// effect on any result).
#[inline(always)]
fn prefetch<T>(base: *const T, index: usize) {
    // SAFETY: a prefetch reads nothing and cannot fault at any address, so the index is not
    // checked against the array here (the value's load, if any, is)
    #[cfg(target_arch = "x86_64")]
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(base.wrapping_add(index).cast())
    };
}

/// Where the fibre-contact sweep adds its per-node sums.
struct FibreContactSums<'a> {
    /// force on each node [N]
    force: &'a mut [Vec3],
    /// plastic and friction dissipation of each owned node [J]
    ledger: &'a mut NodeLedger,
    /// contact stiffness of each owned node, set [N/m]
    contact_stiffness: &'a mut [f64],
    /// each owned node's running sums while the sweep runs: zero between sweeps
    running: &'a mut [RunningSums],
}

/// One owned node's fibre-contact sums while the sweep runs: the terms its partners of lower
/// gid handed it (in their order), then those of its own row's upper part, so the terms come
/// in partner-gid order, as each node's full row would add them.
#[derive(Clone, Copy, Debug, Default)]
struct RunningSums {
    /// [N]
    force: Vec3,
    /// [N/m]
    stiffness: f64,
    /// plastic dissipation [J]
    plastic: f64,
    /// friction dissipation [J]
    friction: f64,
}

/// What the evaluation of a touching pair at one of its nodes gives that node. The laws are
/// odd in the relative position (the friction anchor too), so the partner's terms are exactly
/// the forces negated and the rest equal (docs/theory.md D13).
#[derive(Clone, Copy, Debug)]
struct PairTerms {
    /// the normal unit vector times the normal force: subtracted from the node's force [N]
    normal_force: Vec3,
    stiffness: f64,
    /// half the plastic dissipation, when the largest overlap grew [J]
    plastic: Option<f64>,
    /// the friction force on the node and half the friction dissipation, once the pair was
    /// touching before [N], [J]
    friction: Option<(Vec3, f64)>,
}

impl RunningSums {
    /// Adds the terms of an evaluation at this node, in the order of the full-row sweep.
    #[inline(always)]
    fn add(&mut self, terms: &PairTerms) {
        self.force -= terms.normal_force;
        self.stiffness += terms.stiffness;
        if let Some(plastic) = terms.plastic {
            self.plastic += plastic;
        }
        if let Some((force, loss)) = terms.friction {
            self.force += force;
            self.friction += loss;
        }
    }

    /// Adds the terms of an evaluation at the partner: `x - (-y)` is `x + y` exactly. Not
    /// `add` of the terms negated: LLVM keeps the negations, 6 % more instructions a sweep.
    #[inline(always)]
    fn add_mirrored(&mut self, terms: &PairTerms) {
        self.force += terms.normal_force;
        self.stiffness += terms.stiffness;
        if let Some(plastic) = terms.plastic {
            self.plastic += plastic;
        }
        if let Some((force, loss)) = terms.friction {
            self.force -= force;
            self.friction += loss;
        }
    }
}

/// The instruction sets the fibre-contact sweep is compiled for. Each runs the same source,
/// so the same operations in the same order (Rust never fuses a multiply–add): the same bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SweepCompilation {
    Baseline,
    /// VEX's three operands spare SSE's register copies: 11 % fewer instructions on the bench
    /// yarn (docs/performance.md, session 19)
    Avx2,
    /// AVX-512's 32 vector registers spare most of the sweep's spills: about 5 % less time
    /// on the bench yarn (session 20)
    Avx512,
}

impl SweepCompilation {
    /// Whether this processor runs it (std caches the answers).
    fn runs(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return match self {
            Self::Baseline => true,
            Self::Avx2 => crate::lanes::available(),
            Self::Avx512 => crate::lanes::available() && is_x86_feature_detected!("avx512f"),
        };
        #[cfg(not(target_arch = "x86_64"))]
        return self == Self::Baseline;
    }

    /// The widest compilation this processor runs.
    fn widest() -> Self {
        [Self::Avx512, Self::Avx2].into_iter().find(|c| c.runs()).unwrap_or(Self::Baseline)
    }
}

/// Runs `kernel` compiled for `compilation`, which the processor must run: the kernel, an
/// `#[inline(always)]` closure (a plain one is not inlined, and runs the baseline
/// compilation), is inlined into a function of that compilation's target features. A kernel
/// takes the arrays it loops over apart into slices at its start: read through the captured
/// references, the fibre-contact sweep's lists cost 139 instructions per touching entry
/// against 133 (docs/performance.md, session 23).
#[inline(always)]
fn in_compilation<R>(compilation: SweepCompilation, kernel: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    match compilation {
        SweepCompilation::Avx2 => {
            #[target_feature(enable = "avx2")]
            fn avx2<R>(kernel: impl FnOnce() -> R) -> R {
                kernel()
            }
            // SAFETY: the caller has checked that the processor runs AVX2
            return unsafe { avx2(kernel) };
        }
        SweepCompilation::Avx512 => {
            #[target_feature(enable = "avx2,avx512f")]
            fn avx512<R>(kernel: impl FnOnce() -> R) -> R {
                kernel()
            }
            // SAFETY: the caller has checked that the processor runs AVX2 and AVX-512F
            return unsafe { avx512(kernel) };
        }
        SweepCompilation::Baseline => {}
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = compilation;
    kernel()
}

/// Evaluates the pair of a list entry at its node, `relative` being the partner's position
/// relative to the node, and updates the pair's history: its terms for the node, or none
/// when the pair does not touch.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn evaluate_pair(law: NormalLaw, mu: f64, relative: Vec3, data: PairData, touching: &Cell<bool>, max_overlap_reached: &mut f64, anchor: &mut Vec3, spring_stiffness: &mut f64) -> Option<PairTerms> {
    let distance_squared = relative.norm_squared();
    if distance_squared >= data.reach * data.reach {
        touching.set(false);
        return None;
    }
    let distance = distance_squared.sqrt();
    let normal = relative * (1.0 / distance);
    let overlap = data.reach - distance;
    let previous_max = *max_overlap_reached;
    let (response, max_overlap) = law.evaluate(&data.geometry, overlap, previous_max);
    let mut plastic = None;
    if max_overlap > previous_max {
        // the pair's dissipation goes half to each node
        plastic = Some(0.5 * (law.dissipated(&data.geometry, max_overlap) - law.dissipated(&data.geometry, previous_max)));
        *max_overlap_reached = max_overlap;
    }
    let mut friction = None;
    if !touching.get() {
        touching.set(true);
        *anchor = relative;
        *spring_stiffness = mu * response.stiffness;
    } else if mu > 0.0 {
        let response = stick_slip(relative, normal, anchor, spring_stiffness, response.force, response.stiffness, mu);
        friction = Some((response.force, 0.5 * response.dissipated));
    }
    Some(PairTerms { normal_force: normal * response.force, stiffness: response.stiffness, plastic, friction })
}

/// The fibre-contact sweep over the rows of the `owned` nodes, with `data_of(i, j)` the
/// contact data of the pair's sections. The rows go in ascending gid (the owned nodes' order);
/// each evaluates the upper part of its row and hands each owned partner its terms, so every
/// pair of owned nodes is evaluated once and each node's terms still come in partner-gid
/// order: the bits of evaluating every entry of every row (docs/theory.md D13). A pair with a
/// ghost of lower gid is evaluated where the ghost's row would come. Every row's history is
/// sliced once, so the entries are read without bounds checks: the sweep is bound by the
/// instructions it retires (docs/performance.md, session 19).
#[inline(always)]
fn sweep_fibre_contacts(law: NormalLaw, mu: f64, positions: &[Vec3], pairs: &mut NeighbourList, sums: FibreContactSums, owned: usize, data_of: impl Fn(usize, usize) -> PairData) {
    // sliced to the owned nodes once: their per-node reads and sums need no bounds checks
    let (owned_positions, starts, uppers) = (&positions[..owned], &pairs.start[..=owned], &pairs.upper_start[..owned]);
    let (forces, plastic_sums, friction_sums, stiffnesses, running) =
        (&mut sums.force[..owned], &mut sums.ledger.plastic_dissipated[..owned], &mut sums.ledger.friction_dissipated[..owned], &mut sums.contact_stiffness[..owned], &mut sums.running[..owned]);
    let NeighbourList { lower_ghosts, partner: partners_all, touching, max_overlap: max_overlaps_all, anchor: anchors_all, spring_stiffness: springs_all, .. } = pairs;
    let (partners_all, max_overlaps_all, anchors_all, springs_all) = (&partners_all[..], &mut max_overlaps_all[..], &mut anchors_all[..], &mut springs_all[..]);
    let mut lower_ghosts = lower_ghosts.iter().peekable();
    let (anchors, max_overlaps) = (anchors_all.as_ptr(), max_overlaps_all.as_ptr());
    // shared, so the flag of the entry ahead can be read while the present one is written
    let touching_flags = Cell::from_mut(&mut touching[..]).as_slice_of_cells();
    for (i, &xi) in owned_positions.iter().enumerate() {
        while let Some(&LowerGhostEntry { row, entry, .. }) = lower_ghosts.next_if(|e| e.before_row as usize <= i) {
            let (row, k) = (row as usize, entry as usize);
            let j = partners_all[k] as usize;
            let relative = positions[j] - positions[row];
            if let Some(terms) = evaluate_pair(law, mu, relative, data_of(row, j), &touching_flags[k], &mut max_overlaps_all[k], &mut anchors_all[k], &mut springs_all[k]) {
                running[row].add(&terms);
            }
        }
        let row = uppers[i] as usize..starts[i + 1] as usize;
        let partners = &partners_all[row.clone()];
        let history = touching_flags[row.clone()].iter().zip(&mut max_overlaps_all[row.clone()]).zip(&mut anchors_all[row.clone()]).zip(&mut springs_all[row.clone()]);
        // taken, so every node's sums are zero again for the next sweep
        let mut sum = std::mem::take(&mut running[i]);
        for (e, (&j, (((touching, max_overlap_reached), anchor), spring_stiffness))) in partners.iter().zip(history).enumerate() {
            let j = j as usize;
            let k_ahead = row.start + e + PREFETCH_AHEAD;
            if let Some(&ahead) = partners_all.get(k_ahead) {
                let ahead = ahead as usize;
                prefetch(positions.as_ptr(), ahead);
                // the sums the pair ahead will hand its partner if it touches, as it mostly
                // did at the last sweep (entries apart do not pay for it); without a branch, the
                // node's own sums else. A ghost's index is past the sums: a hint cannot fault.
                prefetch(running.as_ptr(), if touching_flags[k_ahead].get() { ahead } else { i });
            }
            prefetch(anchors, k_ahead);
            prefetch(max_overlaps, k_ahead);
            if let Some(terms) = evaluate_pair(law, mu, positions[j] - xi, data_of(i, j), touching, max_overlap_reached, anchor, spring_stiffness) {
                sum.add(&terms);
                // an owned partner (of higher gid, so its row is still to come); a ghost's
                // owner evaluates the pair for it
                if let Some(partner) = running.get_mut(j) {
                    partner.add_mirrored(&terms);
                }
            }
        }
        forces[i] += sum.force;
        plastic_sums[i] += sum.plastic;
        friction_sums[i] += sum.friction;
        stiffnesses[i] = sum.stiffness;
    }
}

/// The law and friction of [`sweep_fibre_contacts`] on touching pairs packed in contiguous
/// arrays, `relative` their partners' positions relative to their nodes and `data_of(k)` the
/// data of pair `k`: each pair's terms added to one running sum and handed to the next slot
/// of `handed`, with no list, no pair apart and no partner gathered. What the sweep would
/// cost if its lists were free (`dea-mpi bench`). Returns the sum and the pairs' stiffnesses
/// summed [N/m].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sweep_packed_pairs(
    law: NormalLaw,
    mu: f64,
    relative: &[Vec3],
    touching: &[Cell<bool>],
    max_overlap: &mut [f64],
    anchor: &mut [Vec3],
    spring_stiffness: &mut [f64],
    handed: &mut [RunningSums],
    data_of: impl Fn(usize) -> PairData,
) -> RunningSums {
    let n = relative.len();
    let (touching, max_overlap, anchor, spring_stiffness, handed) = (&touching[..n], &mut max_overlap[..n], &mut anchor[..n], &mut spring_stiffness[..n], &mut handed[..n]);
    let mut sum = RunningSums::default();
    for k in 0..n {
        if let Some(terms) = evaluate_pair(law, mu, relative[k], data_of(k), &touching[k], &mut max_overlap[k], &mut anchor[k], &mut spring_stiffness[k]) {
            sum.add(&terms);
            handed[k].add_mirrored(&terms);
        }
    }
    sum
}

/// Touching pairs packed in contiguous arrays, one slot a pair, for [`sweep_packed_pairs`].
struct PackedPairs {
    /// the partner's position relative to the node [m]
    relative: Vec<Vec3>,
    data: Vec<PairData>,
    touching: Vec<bool>,
    /// [m]
    max_overlap: Vec<f64>,
    /// [m]
    anchor: Vec<Vec3>,
    /// [N/m]
    spring_stiffness: Vec<f64>,
    /// the terms handed to each pair's partner, added up over the sweeps
    handed: Vec<RunningSums>,
}

impl PackedPairs {
    /// Times `sweeps` sweeps, with `one_section` the data of every pair when the domain has
    /// one section: the seconds and the pairs' stiffnesses summed at the last sweep [N/m].
    fn time(&mut self, law: NormalLaw, mu: f64, one_section: Option<PairData>, sweeps: usize) -> (f64, f64) {
        let compilation = SweepCompilation::widest();
        let mut stiffness = 0.0;
        let clock = Instant::now();
        for _ in 0..sweeps {
            // every term is used, as the sweep's are
            stiffness = std::hint::black_box(self.sweep(compilation, law, mu, one_section)).stiffness;
        }
        (clock.elapsed().as_secs_f64(), stiffness)
    }

    /// One sweep in `compilation`, which the processor must run. Never inlined, so that
    /// `scripts/count-instructions.sh` counts it by this name.
    #[inline(never)]
    fn sweep(&mut self, compilation: SweepCompilation, law: NormalLaw, mu: f64, one_section: Option<PairData>) -> RunningSums {
        let touching = Cell::from_mut(&mut self.touching[..]).as_slice_of_cells();
        let (relative, data, max_overlap, anchor, spring_stiffness, handed) =
            (&self.relative[..], &self.data[..], &mut self.max_overlap[..], &mut self.anchor[..], &mut self.spring_stiffness[..], &mut self.handed[..]);
        match one_section {
            Some(data) => in_compilation(
                compilation,
                #[inline(always)]
                move || sweep_packed_pairs(law, mu, relative, touching, max_overlap, anchor, spring_stiffness, handed, |_| data),
            ),
            None => in_compilation(
                compilation,
                #[inline(always)]
                move || sweep_packed_pairs(law, mu, relative, touching, max_overlap, anchor, spring_stiffness, handed, |k| data[k]),
            ),
        }
    }
}

/// How element `i` breaks now under (5-6), if it does: tension `E_L eps` (4-16) and the
/// shear stress of its shear force (5-4, 5-5), against its strengths [Pa].
fn element_breaks(nodes: &Nodes, elements: &Elements, bending: &BendingScratch, sections: &[FibreSection], longitudinal_modulus: f64, shear_strength: f64, i: usize) -> Option<FailureMode> {
    if !elements.is_intact(nodes, i) {
        return None;
    }
    let sigma = longitudinal_modulus * elements.strain[i]; // (4-16)
    let area = sections[nodes.section[i] as usize].area;
    let tau = max_shear_stress(element_shear_force(nodes, elements, bending, i), area);
    combined_criterion(sigma, elements.tensile_strength[i], tau, shear_strength)
}

/// Which of elements `i..i + 4` may break now (bit `l` for element `i + l`): the criterion
/// (5-6) of [`element_breaks`] in four lanes, leaving to that scalar test every element
/// within a margin of the boundary far wider than the lanes' rounding, every NaN, and every
/// element not intact between consecutive nodes. So the elements it leaves out are ones the
/// scalar test keeps, and the same elements break.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn may_break_in_lanes(nodes: &Nodes, elements: &Elements, bending: &BendingScratch, sections: &[FibreSection], longitudinal_modulus: f64, shear_strength: f64, i: usize) -> u32 {
    use crate::lanes::{F4, V4};
    let plain = (0..4).filter(|&l| nodes.next[i + l] == (i + l) as u32 + 1 && elements.failure[i + l] == FailureMode::Intact).fold(0, |bits, l| bits | 1 << l);
    let sigma = F4::splat(longitudinal_modulus).mul(F4::load(&elements.strain, i));
    let tension = sigma.max_with(F4::splat(0.0)).div(F4::load(&elements.tensile_strength, i));
    // (5-4), (5-5): the shear force from the jump of the moment along the element
    let jump = V4::load(&bending.moment, i).sub(V4::load(&bending.moment, i + 1));
    let shear_force = jump.dot(jump).sqrt().div(F4::load(&elements.rest_length, i));
    let area = F4::gather(i, |k| sections[nodes.section[k] as usize].area);
    let shear = F4::splat(4.0).mul(shear_force).div(F4::splat(3.0).mul(area)).div(F4::splat(shear_strength));
    let total = tension.mul(tension).add(shear.mul(shear));
    let clear = total.lt(F4::splat(1.0 - 1e-9)).bits();
    !(clear & plain) & 0b1111
}

/// Wall time spent in each stage [s].
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StageTimes {
    pub integrate: f64,
    pub rebuild: f64,
    pub rods: f64,
    pub fibre_contacts: f64,
    pub projectile_contacts: f64,
    pub failure: f64,
}

/// The largest motion of a node [m].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeMotion {
    /// in the last step
    pub step: f64,
    /// since the fibre lists were built (infinite when they were built for other nodes)
    pub since_build: f64,
}

/// Broken elements by mode, cumulative.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrokenCount {
    pub tension: u64,
    pub shear: u64,
    pub combined: u64,
}

impl BrokenCount {
    pub fn total(&self) -> u64 {
        self.tension + self.shear + self.combined
    }
}

/// Precomputed contact data for a pair of sections.
#[derive(Clone, Copy, Debug)]
struct PairData {
    reach: f64,
    geometry: ContactGeometry,
}

/// One rank's nodes, elements, contacts and projectile.
pub struct Domain {
    pub material: FibreMaterial,
    pub sections: Vec<FibreSection>,
    pub nodes: Nodes,
    pub elements: Elements,
    pub contact: ContactParameters,
    pub failure: FailureParameters,
    pub pairs: NeighbourList,
    /// rods joining fine fibres to coarse ones along hybrid yarns (docs/theory.md F12)
    pub ties: Ties,
    pub projectile: Option<RigidProjectile>,
    pub projectile_contacts: ProjectileContacts,
    pub bending: BendingScratch,
    pub ledger: NodeLedger,
    pub broken: BrokenCount,
    /// time step [s]
    pub time_step: f64,
    /// simulated time [s]
    pub time: f64,
    pub step: u64,
    pub times: StageTimes,
    /// this domain integrates the projectile and counts its energy (rank 0); the others
    /// hold a copy that the driver overwrites every step
    pub owns_projectile: bool,
    /// mass-proportional damping rate of the fibre nodes: nonzero only while a target
    /// settles before the shot [1/s]
    pub damping: f64,
    pair_data: Vec<PairData>,
    /// chain stiffness of each section (stability check) [N/m]
    chain_stiffness: Vec<f64>,
    /// stiffness the ties add to each owned node (stability check) [N/m]
    tie_stiffness: Vec<f64>,
    /// contact stiffness summed over each owned node's touching contacts this step [N/m]
    contact_stiffness: Vec<f64>,
    /// the fibre-contact sweep's running sums of each owned node
    running_contact_sums: Vec<RunningSums>,
    newly_broken: Vec<(u32, FailureMode)>,
    /// the last step's closing kick of the owned nodes, left for the next step's opening one
    /// to apply in the same pass ([`Self::defer_kick`]): its half step [s]. While it waits,
    /// `nodes.velocity` is half a step behind the positions, and [`Self::velocity`] gives
    /// the velocities of the present step.
    deferred_kick: Option<f64>,
}

impl Domain {
    /// Assembles a domain of owned nodes without computing anything: a distributed driver
    /// adds the ghosts ([`Self::set_ghosts`]) before the first forces; a whole domain
    /// continues with [`Self::initialize`].
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
        let pair_data = sections
            .iter()
            .flat_map(|a| sections.iter().map(move |b| (a, b)))
            .map(|(a, b)| {
                let (ra, rb) = (0.5 * a.diameter, 0.5 * b.diameter);
                PairData {
                    reach: 0.5 * (a.contact_diameter + b.contact_diameter),
                    geometry: ContactGeometry::new(2.0 * ra * rb / (ra + rb), 0.5 * (a.element_length + b.element_length), ra + rb),
                }
            })
            .collect();
        let mut bending = BendingScratch::default();
        bending.resize(n);
        let chain_stiffness = sections.iter().map(|s| crate::stability::chain_stiffness(&material, s)).collect();
        Self {
            material,
            sections,
            ledger: NodeLedger {
                friction_dissipated: vec![0.0; nodes.n_owned],
                plastic_dissipated: vec![0.0; nodes.n_owned],
                fracture_released: vec![0.0; nodes.n_owned],
            },
            projectile_contacts: ProjectileContacts {
                anchor: vec![Vec3::zeros(); n_owned],
                spring_stiffness: vec![0.0; n_owned],
                touching: vec![false; n_owned],
                max_overlap: vec![0.0; n_owned],
                force_on_node: vec![Vec3::zeros(); n_owned],
                torque_on_projectile: vec![Vec3::zeros(); n_owned],
                triangle: vec![NONE; n_owned],
                weights: vec![[0.0; 3]; n_owned],
                anchor_triangle: vec![NONE; n_owned],
                anchor_weights: vec![[0.0; 3]; n_owned],
                clearance: vec![f64::NEG_INFINITY; n_owned],
                clearance_position: vec![Vec3::zeros(); n_owned],
                clearance_travel: vec![0.0; n_owned],
                ..Default::default()
            },
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
            times: StageTimes::default(),
            owns_projectile: true,
            damping: 0.0,
            pair_data,
            chain_stiffness,
            tie_stiffness: vec![0.0; n_owned],
            contact_stiffness: vec![0.0; n_owned],
            running_contact_sums: vec![RunningSums::default(); n_owned],
            newly_broken: Vec::new(),
            deferred_kick: None,
        }
    }

    /// Joins the owned nodes of the ties in `ties` that have one (the rest are dropped).
    /// Call before the ghosts are set: their ends are found again at every change.
    pub fn set_ties(&mut self, ties: Vec<Tie>) {
        self.ties = Ties::new(ties, &self.nodes);
        self.tie_stiffness = self.ties.stiffness_on_owned(self.nodes.n_owned, &self.material);
    }

    /// Lists, forces and projectile load of the initial state of a whole domain (no ghosts),
    /// so that the first half-kick uses a(0).
    pub fn initialize(mut self) -> Result<Self, DomainError> {
        self.rebuild_neighbours()?;
        self.compute_forces()?;
        self.set_projectile_load(self.projectile_load());
        Ok(self)
    }

    /// Replaces the ghosts by `ghosts` (any order) and relinks the chains. Call
    /// [`Self::rebuild_neighbours`] next: it checks the chain stencil.
    pub fn set_ghosts(&mut self, ghosts: &[GhostRecord]) {
        let n_owned = self.nodes.n_owned;
        self.nodes.truncate_to_owned();
        self.elements.truncate(n_owned);
        for g in ghosts {
            self.nodes.push(g.gid, g.position, Vec3::zeros(), 0.0, g.fibre, g.along, g.section, g.clamped, g.last);
            *self.nodes.rest_angle.last_mut().expect("just pushed") = g.rest_angle;
            self.elements.push(g.rest_length, g.tensile_strength, g.failure);
        }
        self.nodes.link_chains();
        self.ties.link(&self.nodes);
        self.bending.resize(self.nodes.len());
    }

    /// One explicit step on a single domain: kick–drift, rebuild when due, forces, failure,
    /// projectile load, kick.
    pub fn step(&mut self) -> Result<(), DomainError> {
        let half = 0.5 * self.time_step;
        let clock = Instant::now();
        let motion = self.kick_drift(half, self.time_step);
        self.times.integrate += clock.elapsed().as_secs_f64();
        if self.lists_may_miss_a_pair(motion, None) == Some(true) {
            self.rebuild_neighbours()?;
        }
        self.compute_forces()?;
        self.set_projectile_load(self.projectile_load());
        let clock = Instant::now();
        self.kick(half);
        self.time += self.time_step;
        self.step += 1;
        self.times.integrate += clock.elapsed().as_secs_f64();
        Ok(())
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
        if self.damping > 0.0 {
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
        let (step, since_build) = integrate::kick_drift(&mut self.nodes, self.deferred_kick.take(), half_dt, dt, reference);
        if let Some(projectile) = self.projectile.as_mut().filter(|_| self.owns_projectile) {
            projectile.kick(half_dt);
            projectile.drift(dt);
        }
        NodeMotion { step, since_build }
    }

    /// The damping of a settle over a half step (none in a shot).
    fn damp(&mut self, half_dt: f64) {
        if self.damping > 0.0 {
            integrate::damp(&mut self.nodes, (-self.damping * half_dt).exp());
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
        let contacts = &mut self.projectile_contacts;
        contacts.touching.fill(false);
        contacts.max_overlap.fill(0.0);
        contacts.node_reference.clear();
        for ledger in [&mut self.ledger.friction_dissipated, &mut self.ledger.plastic_dissipated, &mut self.ledger.fracture_released] {
            ledger.fill(0.0);
        }
        self.broken = BrokenCount::default();
        self.time = 0.0;
        self.step = 0;
    }

    /// Largest force on an owned node that is free to move [N].
    pub fn largest_free_force(&self) -> f64 {
        (0..self.nodes.n_owned).filter(|&i| !self.nodes.clamped[i]).map(|i| self.nodes.force[i].norm()).fold(0.0, f64::max)
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

    /// Rebuilds fibre neighbour lists and the projectile's candidate nodes, after checking
    /// that every owned node has its chain stencil.
    pub fn rebuild_neighbours(&mut self) -> Result<(), DomainError> {
        self.build_neighbours(NeighbourList::rebuild)
    }

    /// [`Self::rebuild_neighbours`] with the lists rebuilt only around the nodes that moved
    /// ([`NeighbourList::rebuild_around_moved`]): for a domain whose ghosts are those of the
    /// last build.
    pub fn rebuild_neighbours_around_moved(&mut self) -> Result<(), DomainError> {
        self.build_neighbours(NeighbourList::rebuild_around_moved)
    }

    fn build_neighbours(&mut self, build: fn(&mut NeighbourList, &Nodes, &[FibreSection])) -> Result<(), DomainError> {
        if let Some((gid, along)) = self.nodes.missing_chain_neighbour(CHAIN_STENCIL) {
            return Err(DomainError::MissingGhost { gid, along });
        }
        if let Some((gid, partner)) = self.ties.missing_end(self.nodes.n_owned) {
            return Err(DomainError::MissingTiePartner { gid, partner });
        }
        let clock = Instant::now();
        build(&mut self.pairs, &self.nodes, &self.sections);
        self.refresh_projectile_candidates();
        self.times.rebuild += clock.elapsed().as_secs_f64();
        Ok(())
    }

    /// True when an owned node may have come within contact of the projectile without being
    /// a candidate: node and projectile surface together moved more than the skin since the
    /// last refresh. The surface moved no more than the centre plus the turn times the
    /// shape's reach.
    fn projectile_refresh_due(&self) -> bool {
        let Some(projectile) = &self.projectile else { return false };
        let contacts = &self.projectile_contacts;
        if contacts.node_reference.len() != self.nodes.n_owned {
            return true;
        }
        let mut surface = projectile.surface_moved_since(&contacts.reference_position, &contacts.reference_orientation);
        if let Some(mesh) = projectile.shape.deforming_mesh() {
            // a deformable body's surface also moves against its frame
            surface += mesh.surface.vertices.iter().zip(&contacts.reference_vertices).map(|(v, r)| (v - r).norm_squared()).fold(0.0, f64::max).sqrt();
        }
        let node = contacts.node_reference.iter().zip(&self.nodes.position).map(|(r, x)| (x - r).norm_squared()).fold(0.0, f64::max).sqrt();
        node + surface > self.pairs.skin
    }

    /// Chooses the owned nodes within the skin of touching the projectile's surface (a mesh
    /// finds them through its cubes, whose reach covers the contact radius plus the skin).
    /// A node that is not a candidate cannot touch, so the choice and its timing never
    /// change a result: each rank refreshes on its own.
    fn refresh_projectile_candidates(&mut self) {
        let Some(projectile) = &self.projectile else { return };
        let contacts = &mut self.projectile_contacts;
        let max_contact_radius = self.sections.iter().map(|s| 0.5 * s.contact_diameter).fold(0.0, f64::max);
        let reach = max_contact_radius + self.pairs.skin;
        let bounding = projectile.shape.bounding_radius() + reach;
        contacts.candidates.clear();
        for i in 0..self.nodes.n_owned {
            let x = self.nodes.position[i];
            if (x - projectile.position).norm_squared() < bounding * bounding && projectile.shape.contact_point(&projectile.to_body(&x), contacts.triangle[i]).distance < reach {
                contacts.candidates.push(i as u32);
            } else {
                // a node leaving the candidate set is out of contact
                contacts.release(i);
            }
        }
        contacts.node_reference.clear();
        contacts.node_reference.extend_from_slice(&self.nodes.position[..self.nodes.n_owned]);
        contacts.reference_position = projectile.position;
        contacts.reference_orientation = projectile.orientation;
        contacts.reference_vertices.clear();
        if let Some(mesh) = projectile.shape.deforming_mesh() {
            contacts.reference_vertices.extend_from_slice(&mesh.surface.vertices);
        }
    }

    /// Forces on owned nodes, element failure and the projectile's contact load.
    pub fn compute_forces(&mut self) -> Result<(), DomainError> {
        let clock = Instant::now();
        compute_element_tension(&self.nodes, &mut self.elements, &self.sections, &self.material);
        compute_bending(&self.nodes, &self.elements, &self.sections, &mut self.bending);
        set_chain_forces(&mut self.nodes, &self.elements, &self.bending);
        self.ties.add_forces(&mut self.nodes, &self.material);
        let rods_done = Instant::now();
        self.times.rods += (rods_done - clock).as_secs_f64();
        self.add_fibre_contacts();
        let contacts_done = Instant::now();
        self.times.fibre_contacts += (contacts_done - rods_done).as_secs_f64();
        if self.projectile_refresh_due() {
            self.refresh_projectile_candidates();
        }
        self.add_projectile_contacts();
        let projectile_done = Instant::now();
        self.times.projectile_contacts += (projectile_done - contacts_done).as_secs_f64();
        self.break_elements();
        let checked = self.check_state();
        self.times.failure += projectile_done.elapsed().as_secs_f64();
        checked
    }

    /// Fibre–fibre contact and friction on owned nodes (seed 3-1…3-3, 4-4…4-15), summed per
    /// node in partner-gid order.
    fn add_fibre_contacts(&mut self) {
        self.add_fibre_contacts_compiled_for(SweepCompilation::widest());
    }

    /// [`Self::add_fibre_contacts`] by the sweep in `compilation`, which the processor must
    /// run. Never inlined (one call a step), so `scripts/count-instructions.sh` counts the
    /// sweep, with its callees, by this name; a flat profile of a run shows the sweep as the
    /// compilation's function, `in_compilation::avx512` (or `::avx2`), which only it calls
    /// there.
    #[inline(never)]
    fn add_fibre_contacts_compiled_for(&mut self, compilation: SweepCompilation) {
        let n_sections = self.sections.len();
        let (law, mu) = (self.contact.law, self.contact.friction_coefficient);
        self.running_contact_sums.resize(self.nodes.n_owned, RunningSums::default());
        let sums = FibreContactSums { force: &mut self.nodes.force, ledger: &mut self.ledger, contact_stiffness: &mut self.contact_stiffness, running: &mut self.running_contact_sums };
        let (positions, section) = (&self.nodes.position[..], &self.nodes.section[..]);
        let (pairs, owned) = (&mut self.pairs, self.nodes.n_owned);
        if n_sections == 1 {
            // most cases: one pair of sections, its data held in registers for the sweep
            let data = self.pair_data[0];
            in_compilation(
                compilation,
                #[inline(always)]
                move || sweep_fibre_contacts(law, mu, positions, pairs, sums, owned, |_, _| data),
            );
        } else {
            let pair_data = &self.pair_data[..];
            in_compilation(
                compilation,
                #[inline(always)]
                move || sweep_fibre_contacts(law, mu, positions, pairs, sums, owned, |i, j| pair_data[section[i] as usize * n_sections + section[j] as usize]),
            );
        }
    }

    /// The contact data of the pair of owned or ghost nodes `i` and `j`.
    fn pair_data_of(&self, i: usize, j: usize) -> PairData {
        self.pair_data[self.nodes.section[i] as usize * self.sections.len() + self.nodes.section[j] as usize]
    }

    /// Times `sweeps` evaluations of the fibre-contact law and friction on this domain's
    /// touching pairs, packed in contiguous arrays ([`PackedPairs`]): the floor the sweep
    /// stands on, without its lists. The pairs are those the sweep evaluates here (a pair with
    /// a ghost on both its ranks), with copies of their histories; the domain is not changed.
    /// Returns the pairs, the seconds, and the pairs' stiffnesses summed at the last
    /// evaluation [N/m].
    pub fn time_packed_contact_law(&self, sweeps: usize) -> (usize, f64, f64) {
        let pairs = &self.pairs;
        let evaluated: Vec<(usize, usize)> = pairs.evaluated_touching().collect();
        let partner = |k: usize| pairs.partner[k] as usize;
        let mut packed = PackedPairs {
            relative: evaluated.iter().map(|&(i, k)| self.nodes.position[partner(k)] - self.nodes.position[i]).collect(),
            data: evaluated.iter().map(|&(i, k)| self.pair_data_of(i, partner(k))).collect(),
            touching: vec![true; evaluated.len()],
            max_overlap: evaluated.iter().map(|&(_, k)| pairs.max_overlap[k]).collect(),
            anchor: evaluated.iter().map(|&(_, k)| pairs.anchor[k]).collect(),
            spring_stiffness: evaluated.iter().map(|&(_, k)| pairs.spring_stiffness[k]).collect(),
            handed: vec![RunningSums::default(); evaluated.len()],
        };
        let one_section = (self.sections.len() == 1).then(|| self.pair_data[0]);
        let (seconds, stiffness) = packed.time(self.contact.law, self.contact.friction_coefficient, one_section, sweeps);
        (evaluated.len(), seconds, stiffness)
    }

    /// Geometry of the contact of fibre node `i` with the projectile surface: overlap, outward
    /// normal (body frame), body-frame position, and the contact geometry of the law.
    #[inline]
    fn projectile_contact_geometry(&self, projectile: &RigidProjectile, i: usize) -> (f64, SurfacePoint, Vec3, ContactGeometry) {
        let section = &self.sections[self.nodes.section[i] as usize];
        let body = projectile.to_body(&self.nodes.position[i]);
        // the triangle it was last in contact with: the same answer, often without a search
        let point = projectile.shape.contact_point(&body, self.projectile_contacts.triangle[i]);
        let geometry = ContactGeometry::new(0.5 * section.diameter, section.element_length, section.diameter);
        (0.5 * section.contact_diameter - point.distance, point, body, geometry)
    }

    /// Fibre–projectile contact and friction on candidate nodes; stores each node's force and
    /// the reaction torque for [`Self::projectile_load`].
    fn add_projectile_contacts(&mut self) {
        let Some(projectile) = self.projectile.take() else { return };
        let law = self.contact.law;
        let mu = self.contact.projectile_friction_coefficient;
        // a rigid mesh's query is costly: it is skipped for a node known to be clear
        let skips = matches!(projectile.shape, RigidShape::Mesh(_)) && projectile.shape.deforming_mesh().is_none();
        let contacts = &mut self.projectile_contacts;
        if skips {
            if let Some((position, orientation)) = contacts.travel_pose {
                contacts.surface_travel += projectile.surface_moved_since(&position, &orientation);
            }
            contacts.travel_pose = Some((projectile.position, projectile.orientation));
        }
        for c in 0..self.projectile_contacts.candidates.len() {
            let i = self.projectile_contacts.candidates[c] as usize;
            let contacts = &mut self.projectile_contacts;
            // the signed distance moves no faster than the node and the surface together
            if skips && contacts.clearance[i] - (self.nodes.position[i] - contacts.clearance_position[i]).norm() - (contacts.surface_travel - contacts.clearance_travel[i]) > CLEARANCE_MARGIN {
                contacts.release(i);
                contacts.skipped_queries += 1;
                continue;
            }
            let (overlap, point, body, geometry) = self.projectile_contact_geometry(&projectile, i);
            let normal = point.normal;
            let contacts = &mut self.projectile_contacts;
            if overlap <= 0.0 {
                if skips {
                    // a node beyond the mesh's reach may be deep inside: it is not known clear
                    contacts.clearance[i] = if overlap.is_finite() { -overlap } else { f64::NEG_INFINITY };
                    contacts.clearance_position[i] = self.nodes.position[i];
                    contacts.clearance_travel[i] = contacts.surface_travel;
                }
                contacts.release(i);
                continue;
            }
            let previous_max = contacts.max_overlap[i];
            let (response, max_overlap) = law.evaluate(&geometry, overlap, previous_max);
            if max_overlap > previous_max {
                self.ledger.plastic_dissipated[i] += law.dissipated(&geometry, max_overlap) - law.dissipated(&geometry, previous_max);
                contacts.max_overlap[i] = max_overlap;
            }
            // the partner of the fibre pairs: the body origin of a rigid body (its frame turns
            // with it); on a deforming surface, which moves against that frame, the material
            // point touched first, found again by its triangle and weights
            let deforming = projectile.shape.deforming_mesh();
            if !contacts.touching[i] && deforming.is_some() {
                contacts.anchor_triangle[i] = point.triangle;
                contacts.anchor_weights[i] = point.weights;
            }
            let relative = match deforming {
                Some(mesh) => mesh.surface.point_at(contacts.anchor_triangle[i], contacts.anchor_weights[i]) - body,
                None => -body,
            };
            let mut force_body = normal * response.force;
            if !contacts.touching[i] {
                contacts.touching[i] = true;
                contacts.anchor[i] = relative;
                contacts.spring_stiffness[i] = mu * response.stiffness;
            } else if mu > 0.0 {
                let friction = stick_slip(relative, normal, &mut contacts.anchor[i], &mut contacts.spring_stiffness[i], response.force, response.stiffness, mu);
                force_body += friction.force;
                self.ledger.friction_dissipated[i] += friction.dissipated;
                if let (Some(mesh), true) = (deforming, friction.dissipated > 0.0) {
                    // after a slip, anchor to the material point under the node now (where
                    // the reaction acts), keeping the spring's elastic stretch
                    let under = mesh.surface.point_at(point.triangle, point.weights) - body;
                    contacts.anchor[i] += under - relative;
                    contacts.anchor_triangle[i] = point.triangle;
                    contacts.anchor_weights[i] = point.weights;
                }
            }
            let force = projectile.to_world_vector(&force_body);
            let surface_point = self.nodes.position[i] - projectile.to_world_vector(&normal) * (0.5 * self.sections[self.nodes.section[i] as usize].contact_diameter - overlap);
            contacts.force_on_node[i] = force;
            contacts.triangle[i] = point.triangle;
            contacts.weights[i] = point.weights;
            self.contact_stiffness[i] += response.stiffness;
            contacts.torque_on_projectile[i] = (surface_point - projectile.position).cross(&(-force));
            self.nodes.force[i] += force;
        }
        self.projectile = Some(projectile);
    }

    /// Reaction records of the owned nodes touching the projectile, ascending global id
    /// (candidates are owned nodes, whose local order is gid order): the force on the
    /// projectile and its torque about the projectile's centre [N], [N m].
    pub fn projectile_reactions(&self) -> impl Iterator<Item = Reaction> + '_ {
        let contacts = &self.projectile_contacts;
        contacts.candidates.iter().filter(|&&i| contacts.touching[i as usize]).map(|&i| Reaction {
            gid: self.nodes.gid[i as usize],
            force: -contacts.force_on_node[i as usize],
            torque: contacts.torque_on_projectile[i as usize],
            triangle: contacts.triangle[i as usize],
            weights: contacts.weights[i as usize],
        })
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

    /// The failure mode element `i` reaches in this step under the combined criterion (5-6),
    /// or `None` while it holds (or is already broken). Reads this step's strains and
    /// moments, so it gives the same answer on every rank that holds the element's stencil.
    fn breaks_now(&self, i: usize) -> Option<FailureMode> {
        element_breaks(&self.nodes, &self.elements, &self.bending, &self.sections, self.material.longitudinal_modulus, self.failure.shear_strength, i)
    }

    /// Applies the combined criterion (5-6) to owned elements and books the strain and bending
    /// energy the broken ones release.
    fn break_elements(&mut self) {
        if !self.failure.enabled {
            return;
        }
        self.newly_broken.clear();
        let n_owned = self.nodes.n_owned;
        let mut i = 0;
        // almost no element is near breaking: four at a time are told so in lanes
        #[cfg(target_arch = "x86_64")]
        if crate::lanes::available() {
            // a group reads the moment after its last element
            while i + 4 <= n_owned && i + 5 <= self.bending.moment.len() {
                // SAFETY: the processor runs AVX2
                let candidates = unsafe { may_break_in_lanes(&self.nodes, &self.elements, &self.bending, &self.sections, self.material.longitudinal_modulus, self.failure.shear_strength, i) };
                for k in (i..i + 4).filter(|k| candidates & (1 << (k - i)) != 0) {
                    self.book_if_broken(k);
                }
                i += 4;
            }
        }
        for i in i..n_owned {
            self.book_if_broken(i);
        }
        for k in 0..self.newly_broken.len() {
            let i = self.newly_broken[k].0 as usize;
            let next = self.nodes.next[i] as usize;
            // strain energy of the element itself (evaluated as if intact)
            let area = self.sections[self.nodes.section[i] as usize].area;
            let mut released = axial_energy(&self.material, area, self.elements.rest_length[i], self.elements.strain[i]);
            // the spring at the first node, and the one at the second unless the element
            // after it also breaks now (then that element books it). Failure states are
            // applied after this loop, so for an owned or a ghost next element alike the
            // criterion answers from this step's state, as its owner decides it.
            released += self.spring_energy(i);
            if self.breaks_now(next).is_none() {
                released += self.spring_energy(next);
            }
            self.ledger.fracture_released[i] += released;
        }
        for &(i, mode) in &self.newly_broken {
            self.elements.failure[i as usize] = mode;
        }
    }

    /// Records element `i` among the newly broken if (5-6) breaks it now.
    fn book_if_broken(&mut self, i: usize) {
        if let Some(mode) = self.breaks_now(i) {
            self.newly_broken.push((i as u32, mode));
            match mode {
                FailureMode::Tension => self.broken.tension += 1,
                FailureMode::Shear => self.broken.shear += 1,
                _ => self.broken.combined += 1,
            }
        }
    }

    /// Energy `K_t (theta - theta_0)^2 / 2` of the spring at node `i` as computed this step.
    fn spring_energy(&self, i: usize) -> f64 {
        let k_t = self.sections[self.nodes.section[i] as usize].torsional_stiffness;
        let bent = self.bending.angle[i] - self.nodes.rest_angle[i];
        0.5 * k_t * bent * bent
    }

    /// Every owned node has finite force and position, and a stiffness the time step can
    /// integrate (central difference diverges once omega dt > 2).
    fn check_state(&self) -> Result<(), DomainError> {
        let mu = self.contact.friction_coefficient.max(self.contact.projectile_friction_coefficient);
        let nodes = &self.nodes;
        for i in 0..nodes.n_owned {
            if !(nodes.force[i].iter().all(|v| v.is_finite()) && nodes.position[i].iter().all(|v| v.is_finite())) {
                return Err(DomainError::NonFinite { step: self.step, gid: nodes.gid[i] });
            }
            if nodes.clamped[i] {
                continue;
            }
            // dt > 2 / omega, squared and without a division: this runs for every node
            let chain = self.chain_stiffness[nodes.section[i] as usize] + self.tie_stiffness[i];
            let stiffness = chain + (1.0 + mu) * self.contact_stiffness[i];
            if stiffness * self.time_step * self.time_step > 4.0 * nodes.mass[i] {
                let limit = crate::stability::node_stability_limit(chain, self.contact_stiffness[i], mu, nodes.mass[i]);
                return Err(DomainError::TimeStep { step: self.step, gid: nodes.gid[i], time_step: self.time_step, limit });
            }
        }
        Ok(())
    }

    /// Every energy of the domain as exact sums over owned nodes (pairs once each; the
    /// projectile's kinetic energy on its owner only), ready to merge across ranks. Call
    /// after [`Self::compute_forces`] so strains and angles are current.
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
    /// projectile's kinetic energy.
    pub fn energy_sums_by(&self, group: impl Fn(usize) -> usize, groups: usize) -> Vec<EnergySums> {
        let nodes = &self.nodes;
        let mut sums = vec![EnergySums::default(); groups];
        let law = self.contact.law;
        for i in 0..nodes.n_owned {
            let report = &mut sums[group(i)];
            report.fibre_kinetic.add(0.5 * nodes.mass[i] * self.velocity(i).norm_squared());
            if nodes.next[i] != NONE {
                report.axial.add(element_strain_energy(nodes, &self.elements, &self.sections, &self.material, i));
            }
            report.bending.add(self.spring_energy(i));
            report.friction_dissipated.add(self.ledger.friction_dissipated[i]);
            report.plastic_dissipated.add(self.ledger.plastic_dissipated[i]);
            report.fracture_released.add(self.ledger.fracture_released[i]);
            for k in self.pairs.row(i) {
                let j = self.pairs.partner[k] as usize;
                // a pair of owned nodes at its node of lower gid, which keeps its history
                // (D13), for both; a pair with a ghost here for the owned node. Each node takes
                // half of what the pair stores: exactly what it took at each of its entries, as
                // the sums are exact and the energies even in the relative position.
                if !self.pairs.evaluates(i, k) {
                    continue;
                }
                let data = self.pair_data_of(i, j);
                let relative = nodes.position[j] - nodes.position[i];
                let overlap = data.reach - relative.norm();
                if overlap <= 0.0 {
                    continue;
                }
                let max_overlap = self.pairs.max_overlap[k];
                let contact = law.stored_energy(&data.geometry, overlap, max_overlap);
                let mut friction_stored = 0.0;
                if self.contact.friction_coefficient > 0.0 && self.pairs.touching[k] {
                    let (response, _) = law.evaluate(&data.geometry, overlap, max_overlap);
                    let (mut anchor, mut spring) = (self.pairs.anchor[k], self.pairs.spring_stiffness[k]);
                    friction_stored = stick_slip(relative, relative.normalize(), &mut anchor, &mut spring, response.force, response.stiffness, self.contact.friction_coefficient).stored;
                }
                for node in std::iter::once(i).chain((j < nodes.n_owned).then_some(j)) {
                    sums[group(node)].contact.add(0.5 * contact);
                    sums[group(node)].friction_stored.add(0.5 * friction_stored);
                }
            }
        }
        for (i, energy) in self.ties.energies(nodes, &self.material) {
            sums[group(i)].axial.add(energy);
        }
        if let Some(projectile) = &self.projectile {
            for &i in &self.projectile_contacts.candidates {
                let i = i as usize;
                let report = &mut sums[group(i)];
                let (overlap, point, body, geometry) = self.projectile_contact_geometry(projectile, i);
                if overlap <= 0.0 {
                    continue;
                }
                let max_overlap = self.projectile_contacts.max_overlap[i];
                report.contact.add(law.stored_energy(&geometry, overlap, max_overlap));
                if self.contact.projectile_friction_coefficient > 0.0 && self.projectile_contacts.touching[i] {
                    let (response, _) = law.evaluate(&geometry, overlap, max_overlap);
                    let (mut anchor, mut spring) = (self.projectile_contacts.anchor[i], self.projectile_contacts.spring_stiffness[i]);
                    let friction = stick_slip(-body, point.normal, &mut anchor, &mut spring, response.force, response.stiffness, self.contact.projectile_friction_coefficient);
                    report.friction_stored.add(friction.stored);
                }
            }
        }
        sums
    }

    /// [`Self::energy_sums`] rounded: the energies of a whole domain [J].
    pub fn energies(&self) -> EnergyReport {
        self.energy_sums().report()
    }

    /// Axial stress E_L eps of every owned element, NaN where there is no element [Pa].
    pub fn element_stress(&self) -> Vec<f64> {
        (0..self.nodes.n_owned)
            .map(|i| if self.nodes.next[i] == NONE { f64::NAN } else if self.elements.failure[i] == FailureMode::Intact { self.material.longitudinal_modulus * self.elements.strain[i] } else { 0.0 })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::InertiaModel;

    /// A 7-fibre yarn squeezed below its contact diameter, to be shaken so that pairs touch
    /// first, stick, slip, unload, part and touch again; `sections` fibre sections (one, or
    /// two alternating: the sweep's two ways to its pair data). With `ghosts`, fibres 1, 3
    /// and 5 are ghosts, their gids interleaved with the owned ones' (as on a rank of a
    /// partitioned yarn).
    fn squeezed_yarn(sections: usize, ghosts: bool) -> Domain {
        let material = FibreMaterial::kevlar_km2();
        let l0 = 9e-6;
        let sections: Vec<_> = (0..sections).map(|s| FibreSection::new(&material, 1e-9 * (1.0 + 0.3 * s as f64), l0, InertiaModel::None, 0.3)).collect();
        let pitch = 0.97 * sections[0].contact_diameter;
        let (mut nodes, mut elements) = (Nodes::default(), Elements::default());
        let centres = [(0.0, 0.0), (1.0, 0.0), (0.5, 0.866), (-0.5, 0.866), (-1.0, 0.0), (-0.5, -0.866), (0.5, -0.866)];
        let per_fibre = 40;
        let is_ghost = |fibre: usize| ghosts && fibre % 2 == 1;
        // owned fibres first, then the ghosts
        for fibre in (0..centres.len()).filter(|&f| !is_ghost(f)).chain((0..centres.len()).filter(|&f| is_ghost(f))) {
            let (y, z) = centres[fibre];
            for along in 0..per_fibre {
                let gid = GlobalNodeId((fibre * per_fibre + along) as u64);
                let position = Vec3::new(along as f64 * l0, y * pitch, z * pitch);
                nodes.push(gid, position, Vec3::zeros(), 1e-12, FibreId(fibre as u32), along as u32, (fibre % sections.len()) as u16, false, along + 1 == per_fibre);
                elements.push(l0, 3.4e9, FailureMode::Intact);
            }
        }
        nodes.n_owned = (0..centres.len()).filter(|&f| !is_ghost(f)).count() * per_fibre;
        nodes.link_chains();
        let contact = ContactParameters { law: NormalLaw::ElastoPlasticKm2, friction_coefficient: 0.3, projectile_friction_coefficient: 0.0, skin: 0.5 * sections[0].contact_diameter };
        let failure = FailureParameters { shear_strength: 0.7672e9, enabled: false };
        let mut domain = Domain::assemble(material, sections, nodes, elements, contact, failure, None, 1e-9);
        domain.rebuild_neighbours().unwrap();
        domain
    }

    /// The sweep the half rows replace, kept as the reference: every entry of every owned
    /// row evaluated at its node with its own copy of the pair's history, summed in the row's
    /// partner-gid order.
    struct FullRowSweep {
        histories: Vec<crate::neighbour::PairHistory>,
        force: Vec<Vec3>,
        stiffness: Vec<f64>,
        plastic: Vec<f64>,
        friction: Vec<f64>,
    }

    impl FullRowSweep {
        fn new(domain: &Domain) -> Self {
            let owned = domain.nodes.n_owned;
            let histories = (0..owned).flat_map(|i| domain.pairs.row(i).map(move |k| domain.pairs.history(i, k))).collect();
            Self { histories, force: vec![Vec3::zeros(); owned], stiffness: vec![0.0; owned], plastic: vec![0.0; owned], friction: vec![0.0; owned] }
        }

        fn sweep(&mut self, domain: &Domain) {
            for i in 0..domain.nodes.n_owned {
                let mut sum = RunningSums::default();
                for k in domain.pairs.row(i) {
                    let j = domain.pairs.partner[k] as usize;
                    let data = domain.pair_data_of(i, j);
                    let h = &mut self.histories[k];
                    let relative = domain.nodes.position[j] - domain.nodes.position[i];
                    if let Some(terms) =
                        evaluate_pair(domain.contact.law, domain.contact.friction_coefficient, relative, data, Cell::from_mut(&mut h.touching), &mut h.max_overlap, &mut h.anchor, &mut h.spring_stiffness)
                    {
                        sum.add(&terms);
                    }
                }
                self.force[i] = sum.force;
                self.stiffness[i] = sum.stiffness;
                self.plastic[i] += sum.plastic;
                self.friction[i] += sum.friction;
            }
        }
    }

    /// Each pair of owned nodes is evaluated once, at its node of lower gid, which hands the
    /// partner its terms; a pair with a ghost of lower gid is evaluated where the ghost's row
    /// would come. Every force, stiffness, ledger and history has the bits of every row
    /// evaluating all its entries, with ghosts or without, one section or two, in every
    /// compilation the processor runs.
    #[test]
    fn the_half_row_sweep_gives_the_bits_of_full_rows() {
        let bits = |values: &[f64]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let vector_bits = |values: &[Vec3]| values.iter().flat_map(|v| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>()).collect::<Vec<_>>();
        let history_bits = |h: &crate::neighbour::PairHistory| (vector_bits(&[h.anchor]), h.spring_stiffness.to_bits(), h.touching, h.max_overlap.to_bits());
        // the first word that differs, if any (the vectors are long)
        let first_difference = |a: Vec<u64>, b: Vec<u64>| if a.len() != b.len() { Some(a.len().min(b.len())) } else { a.iter().zip(&b).position(|(x, y)| x != y) };
        let compilations: Vec<_> = [SweepCompilation::Baseline, SweepCompilation::Avx2, SweepCompilation::Avx512].into_iter().filter(|c| c.runs()).collect();
        let cases: Vec<_> = [1, 2].into_iter().flat_map(|s| [false, true].map(|g| (s, g))).flat_map(|(s, g)| compilations.iter().map(move |&c| (s, g, c))).collect();
        for (sections, ghosts, compilation) in cases {
            let case = format!("sections {sections}, ghosts {ghosts}, compiled for {compilation:?}");
            let mut domain = squeezed_yarn(sections, ghosts);
            let owned = domain.nodes.n_owned;
            assert_eq!(domain.pairs.lower_ghosts.is_empty(), !ghosts, "{case}");
            let mut reference = FullRowSweep::new(&domain);
            let mut state = 11u64;
            let mut uniform = move || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let shake = 0.04 * domain.sections[0].contact_diameter;
            let (mut first_touches, mut slipped, mut unloading) = (0, false, false);
            for sweep in 0..60 {
                for i in 0..domain.nodes.len() {
                    domain.nodes.position[i] += Vec3::new(uniform(), uniform(), uniform()) * shake;
                }
                domain.nodes.force.iter_mut().for_each(|f| *f = Vec3::zeros());
                let touching_before: Vec<bool> = reference.histories.iter().map(|h| h.touching).collect();
                domain.add_fibre_contacts_compiled_for(compilation);
                reference.sweep(&domain);
                first_touches += reference.histories.iter().zip(&touching_before).filter(|(now, before)| now.touching && !**before).count();
                assert_eq!(first_difference(vector_bits(&domain.nodes.force[..owned]), vector_bits(&reference.force)), None, "forces, {case}, sweep {sweep}");
                assert_eq!(first_difference(bits(&domain.contact_stiffness), bits(&reference.stiffness)), None, "stiffness, {case}, sweep {sweep}");
                assert_eq!(first_difference(bits(&domain.ledger.plastic_dissipated), bits(&reference.plastic)), None, "plastic work, {case}, sweep {sweep}");
                assert_eq!(first_difference(bits(&domain.ledger.friction_dissipated), bits(&reference.friction)), None, "friction work, {case}, sweep {sweep}");
                for i in 0..owned {
                    for k in domain.pairs.row(i) {
                        assert_eq!(history_bits(&domain.pairs.history(i, k)), history_bits(&reference.histories[k]), "history of entry {k}, {case}, sweep {sweep}");
                    }
                }
                assert_eq!(domain.pairs.touching_entries(), reference.histories.iter().filter(|h| h.touching).count(), "{case}");
                slipped |= reference.friction.iter().any(|&w| w > 0.0);
                unloading |= (0..owned).any(|i| domain.pairs.row(i).any(|k| reference.histories[k].touching && reference.histories[k].max_overlap > contact_overlap(&domain, i, k)));
            }
            // every path of the sweep was taken: first touches after partings, slip, unloading
            let touching = reference.histories.iter().filter(|h| h.touching).count();
            assert!(first_touches > touching && slipped && unloading, "{case}: {first_touches} first touches, slip {slipped}, unloading {unloading}");
        }
    }

    /// The bench's floor measurement evaluates the pairs the sweep evaluates, with their
    /// histories and data: its stiffnesses add up to the law's at every touching pair the
    /// sweep evaluates here (a pair with a ghost at its owned node), with one section or two.
    #[test]
    fn the_packed_law_evaluates_the_pairs_the_sweep_does() {
        for (sections, ghosts) in [(1, false), (2, true)] {
            let mut domain = squeezed_yarn(sections, ghosts);
            // the first sweep touches, the second sticks: friction is evaluated
            for _ in 0..2 {
                domain.add_fibre_contacts();
            }
            let (law, pairs) = (domain.contact.law, &domain.pairs);
            let evaluated: Vec<(usize, usize)> = (0..domain.nodes.n_owned).flat_map(|i| pairs.row(i).map(move |k| (i, k))).filter(|&(i, k)| pairs.evaluates(i, k) && pairs.touching[k]).collect();
            let expected: f64 =
                evaluated.iter().map(|&(i, k)| law.evaluate(&domain.pair_data_of(i, pairs.partner[k] as usize).geometry, contact_overlap(&domain, i, k), pairs.max_overlap[k]).0.stiffness).sum();
            let (count, seconds, stiffness) = domain.time_packed_contact_law(3);
            assert_eq!(count, evaluated.len(), "sections {sections}, ghosts {ghosts}");
            assert!(count > 100 && seconds > 0.0);
            assert!((stiffness - expected).abs() <= 1e-12 * expected, "sections {sections}, ghosts {ghosts}: {stiffness} against {expected}");
            if !ghosts {
                assert_eq!(2 * count, pairs.touching_entries(), "each pair of owned nodes once");
            }
        }
    }

    fn contact_overlap(domain: &Domain, i: usize, k: usize) -> f64 {
        let j = domain.pairs.partner[k] as usize;
        crate::neighbour::contact_distance(&domain.sections, &domain.nodes, i, j) - (domain.nodes.position[j] - domain.nodes.position[i]).norm()
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_lanes_leave_out_only_elements_the_scalar_test_keeps() {
        if !crate::lanes::available() {
            return;
        }
        let material = FibreMaterial::kevlar_km2();
        let l0 = 25e-6;
        let sections = vec![FibreSection::new(&material, 2.4e-9, l0, InertiaModel::Effective { k1: 0.8, k2: 1.0 }, 0.3), FibreSection::new(&material, 1.2e-9, l0, InertiaModel::None, 0.3)];
        let (shear_strength, strength) = (0.7672e9, 3.4e9);
        let mut state = 5u64;
        let mut uniform = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut nodes, mut elements, mut bending) = (Nodes::default(), Elements::default(), BendingScratch::default());
        let per_fibre = 203;
        for fibre in 0..5u32 {
            for along in 0..per_fibre {
                let gid = GlobalNodeId((fibre * per_fibre + along) as u64);
                nodes.push(gid, Vec3::new(along as f64 * l0, fibre as f64 * 1e-4, 0.0), Vec3::zeros(), 1e-12, FibreId(fibre), along, (fibre % 2) as u16, false, along + 1 == per_fibre);
                let failure = if along % 37 == 5 { FailureMode::Tension } else { FailureMode::Intact };
                elements.push(l0, strength * (0.9 + 0.2 * uniform()), failure);
            }
        }
        nodes.link_chains();
        let n = nodes.len();
        let area = |k: usize| sections[nodes.section[k] as usize].area;
        // the moment jumps by the drawn shear force along each element (5-4)
        let mut moment = Vec3::zeros();
        for k in 0..n {
            // states spread over the criterion, a quarter within rounding of its boundary, some NaN
            let (tension, shear) = (uniform(), uniform());
            let scale = match k % 4 {
                0 => 1.0 + (uniform() - 0.5) * 1e-13,
                _ => 2.0 * uniform(),
            } / (tension * tension + shear * shear).sqrt();
            let sigma = tension * scale * elements.tensile_strength[k];
            elements.strain[k] = if k % 53 == 7 { f64::NAN } else { sigma / material.longitudinal_modulus };
            let shear_force = shear * scale * shear_strength * 3.0 * area(k) / 4.0;
            bending.moment.push(moment);
            moment -= Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize() * shear_force * l0;
        }
        let (mut breaking, mut candidates) = (0, 0);
        for i in (0..n - 4).step_by(4) {
            // SAFETY: AVX2 is present (checked above)
            let bits = unsafe { may_break_in_lanes(&nodes, &elements, &bending, &sections, material.longitudinal_modulus, shear_strength, i) };
            for k in i..i + 4 {
                let breaks = element_breaks(&nodes, &elements, &bending, &sections, material.longitudinal_modulus, shear_strength, k).is_some();
                assert!(!breaks || bits & (1 << (k - i)) != 0, "element {k} breaks but the lanes left it out");
                breaking += breaks as usize;
                candidates += (bits & (1 << (k - i)) != 0) as usize;
            }
        }
        assert!(breaking > n / 4 && candidates < 3 * n / 4, "{breaking} break, {candidates} of {n} left to the scalar test");
    }
}
