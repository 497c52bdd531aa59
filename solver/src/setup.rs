//! From a validated case to a running rank: the problem's description, its partition, and
//! the rank's own nodes (each rank generates only what it owns; ghosts come from their
//! owners).

use dea_core::domain::ContactParameters;
use dea_core::failure::FailureParameters;
use dea_core::projectile::{RigidProjectile, RigidShape};
use dea_core::stability::stable_time_step;
use dea_core::weibull::element_strength;
use std::path::Path;

use dea_core::domain::BrokenCount;
use dea_core::{Domain, DomainError, FibreId, FibreMaterial, Nodes, Rank, Vec3};
use dea_io::checkpoint::{manifest_path, part_path, read_manifest, read_part, GlobalState, NodeState};
use dea_fabric::StraightFabric;
use dea_io::case::{parse_case, yarn_area, Case, Strength, TargetSpec};
use dea_partition::{Method, Partition, PartitionError, SegmentGraph, ShotLine};
use nalgebra::UnitQuaternion;

use crate::comm::Comm;
use crate::distributed::{Distributed, RestoreError};

/// Gap between the projectile and the nearest fibre surface at time zero [m].
pub const INITIAL_GAP: f64 = 1e-6;

/// Everything about a case that needs no node: material, fabric, laws, projectile, time step.
pub struct Problem {
    pub material: FibreMaterial,
    pub fabric: StraightFabric,
    pub contact: ContactParameters,
    pub failure: FailureParameters,
    pub strength: Strength,
    pub projectile: RigidProjectile,
    /// [s]
    pub time_step: f64,
    /// contact search distance: largest contact diameter plus the skin [m]
    pub reach: f64,
}

impl Problem {
    /// Layer of each yarn.
    pub fn layer_of_yarn(&self) -> Vec<u32> {
        self.fabric.yarns.iter().map(|y| y.layer).collect()
    }

    /// Layers of the target.
    pub fn layers(&self) -> usize {
        self.fabric.yarns.iter().map(|y| y.layer as usize + 1).max().unwrap_or(1)
    }

    /// Fibres of the whole target.
    pub fn fibres(&self) -> usize {
        self.fabric.first_fibres().last().copied().unwrap_or(0) as usize
    }
}

/// Why a rank could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("{0}")]
    Partition(String),
    #[error("{0}")]
    Numerical(#[from] DomainError),
    /// a checkpoint that cannot be read or does not fit the case
    #[error("{0}")]
    Checkpoint(String),
}

/// Resolves a validated case.
pub fn problem(case: &Case) -> Problem {
    let material = case.material().expect("validated case");
    let law = case.normal_law(&material).expect("validated case");
    let strength = case.strength().expect("validated case");
    let deterministic = match strength {
        Strength::Deterministic(s) => s,
        _ => f64::INFINITY,
    };
    let mu = case.contact.friction_coefficient;
    let fabric = match &case.target {
        TargetSpec::SingleFibre { length_m, diameter_m, element_length_ratio } => {
            StraightFabric::single_yarn(*length_m, 1, std::f64::consts::PI * diameter_m * diameter_m / 4.0, *element_length_ratio, case.bending, mu, deterministic)
        }
        TargetSpec::StraightYarn { yarn, fibres_per_yarn, length_m, element_length_ratio } => {
            let area = yarn_area(yarn).expect("validated case") / *fibres_per_yarn as f64;
            StraightFabric::single_yarn(*length_m, *fibres_per_yarn, area, *element_length_ratio, case.bending, mu, deterministic)
        }
        TargetSpec::StraightYarnLayers { yarn, fibres_per_yarn, layers, yarns_per_layer, length_m, element_length_ratio } => {
            let area = yarn_area(yarn).expect("validated case") / *fibres_per_yarn as f64;
            StraightFabric::cross_ply(*layers, *yarns_per_layer, *fibres_per_yarn, *length_m, area, *element_length_ratio, case.bending, mu, deterministic, &material)
        }
    };
    let section = fabric.section(&material);
    let contact = ContactParameters {
        law,
        friction_coefficient: mu,
        projectile_friction_coefficient: case.contact.projectile_friction_coefficient,
        skin: case.contact.skin_m.unwrap_or(0.25 * section.contact_diameter),
    };
    let failure = FailureParameters { shear_strength: case.shear_strength().expect("validated case"), enabled: !matches!(strength, Strength::None) };
    let resolved = case.projectile().expect("validated case");
    let top = fabric.top(&material) + 0.5 * section.contact_diameter;
    let reach_below_centre = match resolved.shape {
        RigidShape::Sphere { radius } => radius,
        RigidShape::Cylinder { height, .. } => 0.5 * height,
    };
    let start = Vec3::new(resolved.offset[0], resolved.offset[1], top + reach_below_centre + INITIAL_GAP);
    let projectile = RigidProjectile::new(resolved.shape, resolved.mass, start, Vec3::new(0.0, 0.0, -resolved.speed), UnitQuaternion::identity());
    let sections = [section];
    let time_step = stable_time_step(&material, &sections, &contact.law, contact.friction_coefficient.max(contact.projectile_friction_coefficient), case.run.time_step_safety);
    let reach = sections[0].contact_diameter + contact.skin;
    Problem { material, fabric, contact, failure, strength, projectile, time_step, reach }
}

/// The yarn-segment graph of a problem, weighted for a shot along its projectile's line.
pub fn segment_graph(problem: &Problem, ranks: usize, segment_positions: Option<u32>) -> SegmentGraph {
    let p = &problem.projectile;
    let shot = ShotLine { x: p.position.x, y: p.position.y, radius: p.shape.bounding_radius() + problem.reach };
    let positions = segment_positions.unwrap_or_else(|| dea_partition::default_segment_positions(&problem.fabric, ranks));
    dea_partition::segment_graph(&problem.fabric, &problem.material, problem.reach, Some(shot), positions)
}

/// Rank 0 partitions, every rank receives the result (or the same error).
fn shared_partition<C: Comm>(comm: &C, problem: &Problem, method: Method, segment_positions: Option<u32>) -> Result<Partition, SetupError> {
    let mut message = Vec::new();
    if comm.rank() == Rank(0) {
        let graph = segment_graph(problem, comm.size(), segment_positions);
        match dea_partition::partition(&graph, comm.size(), method) {
            Ok(partition) => {
                message.push(0);
                message.extend(partition.to_words().iter().flat_map(|w| w.to_le_bytes()));
            }
            Err(e) => {
                message.push(1);
                message.extend(e.to_string().bytes());
            }
        }
    }
    comm.broadcast_bytes(&mut message);
    match message.split_first() {
        Some((0, words)) => Ok(Partition::from_words(&words.chunks_exact(8).map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes"))).collect::<Vec<_>>())),
        Some((_, text)) => Err(SetupError::Partition(String::from_utf8_lossy(text).into_owned())),
        None => Err(SetupError::Partition(PartitionError::TooFewSegments { segments: 0, ranks: comm.size() }.to_string())),
    }
}

/// Sets up this rank: partition, own nodes, Weibull strengths, ghosts, initial forces.
pub fn build<C: Comm>(case: &Case, comm: C, method: Method, segment_positions: Option<u32>) -> Result<Distributed<C>, SetupError> {
    build_adjusted(case, comm, method, segment_positions, |_| {})
}

/// [`build`], with `adjust` applied to the rank's own nodes before the ghosts are fetched
/// (the benchmark squeezes its yarn this way).
pub fn build_adjusted<C: Comm>(case: &Case, comm: C, method: Method, segment_positions: Option<u32>, adjust: impl FnOnce(&mut Nodes)) -> Result<Distributed<C>, SetupError> {
    let problem = problem(case);
    let partition = shared_partition(&comm, &problem, method, segment_positions)?;
    let mut domain = own_domain(&problem, &partition, comm.rank(), adjust);
    if let Strength::Weibull(law, seed) = &problem.strength {
        let (nodes, elements) = (&domain.nodes, &mut domain.elements);
        for i in 0..nodes.n_owned {
            if !nodes.last[i] {
                elements.tensile_strength[i] = element_strength(law, *seed, nodes.gid[i], elements.rest_length[i]);
            }
        }
    }
    let mut run = Distributed::new(comm, domain, partition, problem.fabric.nodes_per_fibre(), problem.reach)?;
    run.layer_of_yarn = problem.layer_of_yarn();
    Ok(run)
}

/// This rank's nodes of `problem` as generated (`adjust` applied), in a domain without
/// ghosts; rank 0 owns the projectile.
fn own_domain(problem: &Problem, partition: &Partition, me: Rank, adjust: impl FnOnce(&mut Nodes)) -> Domain {
    let mut built = problem.fabric.build(&problem.material, |yarn, k| partition.rank_of_position(yarn, k) == me);
    adjust(&mut built.nodes);
    let mut domain = Domain::assemble(problem.material.clone(), built.sections, built.nodes, built.elements, problem.contact, problem.failure, Some(problem.projectile.clone()), problem.time_step);
    domain.owns_projectile = me == Rank(0);
    domain
}

/// A run restored from a checkpoint on this rank.
pub struct Restored<C: Comm> {
    pub case: Case,
    pub run: Distributed<C>,
    pub global: GlobalState,
}

/// Every rank learns whether any rank failed; all return the same error.
fn agree_on<C: Comm, T>(comm: &C, local: Result<T, String>) -> Result<T, SetupError> {
    let mut failed = [if local.is_err() { 1.0 } else { 0.0 }];
    comm.max_f64(&mut failed);
    match local {
        Err(message) => Err(SetupError::Checkpoint(message)),
        Ok(_) if failed[0] > 0.0 => Err(SetupError::Checkpoint("another rank could not read the checkpoint".into())),
        Ok(value) => Ok(value),
    }
}

/// Restores a run from a checkpoint directory on this job's ranks (any number of them).
pub fn restore<C: Comm>(directory: &Path, comm: C, method: Method) -> Result<Restored<C>, SetupError> {
    let global = read_manifest(directory).map_err(|e| e.to_string());
    let global = agree_on(&comm, global)?;
    let case = parse_case(&global.case_json, &manifest_path(directory).display().to_string()).map_err(|e| SetupError::Checkpoint(e.to_string()))?;
    let problem = problem(&case);
    let partition = shared_partition(&comm, &problem, method, None)?;
    let me = comm.rank();
    let nodes_per_fibre = problem.fabric.nodes_per_fibre() as u64;
    let owned = |gid: u64| partition.rank_of(FibreId((gid / nodes_per_fibre) as u32), (gid % nodes_per_fibre) as u32) == me;
    let mut state = NodeState::default();
    let mut read = Ok(());
    for part in 0..global.parts {
        match read_part(&part_path(directory, part)) {
            Ok(rows) => state.append_selected(&rows, owned),
            Err(e) => {
                read = Err(e.to_string());
                break;
            }
        }
    }
    agree_on(&comm, read)?;
    let state = state.sorted();
    let mut domain = own_domain(&problem, &partition, me, |_| {});
    let mut counts = [state.gid.len() as i64, domain.nodes.n_owned as i64];
    comm.sum_i64(&mut counts);
    if counts[0] != counts[1] || counts[0] as u64 != global.nodes {
        return Err(SetupError::Checkpoint(format!("{}: holds {} nodes, of which {} belong to the case's {} nodes", directory.display(), global.nodes, counts[0], counts[1])));
    }
    domain.step = global.step;
    domain.time = global.time;
    if me == Rank(0) {
        domain.broken = BrokenCount { tension: global.broken[0], shear: global.broken[1], combined: global.broken[2] };
    }
    let mut run = Distributed::restore(comm, domain, partition, nodes_per_fibre as u32, problem.reach, &state, &global.projectile, global.projectile_reference).map_err(|e| match e {
        RestoreError::Numerical(e) => SetupError::Numerical(e),
        RestoreError::Mismatch(m) => SetupError::Checkpoint(format!("{}: {m}", directory.display())),
    })?;
    run.layer_of_yarn = problem.layer_of_yarn();
    run.rebuilds = global.rebuilds;
    run.domain.pairs.builds = global.list_builds;
    Ok(Restored { case, run, global })
}

/// Lowest point of the projectile along z [m] (its bounding sphere: exact for a sphere,
/// conservative for a tilted cylinder).
pub fn projectile_bottom(projectile: &RigidProjectile) -> f64 {
    projectile.position.z - projectile.shape.bounding_radius()
}

/// Highest point of the projectile along z [m] (its bounding sphere).
pub fn projectile_top(projectile: &RigidProjectile) -> f64 {
    projectile.position.z + projectile.shape.bounding_radius()
}
