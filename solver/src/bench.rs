//! `dea-mpi bench`: a dense 19-fibre yarn with contacts and friction active and a sphere
//! pressing in; reports the cost of each part of the step.

use std::time::Instant;

use dea_core::contact::NormalLaw;
use dea_core::domain::ContactParameters;
use dea_core::failure::FailureParameters;
use dea_core::material::InertiaModel;
use dea_core::projectile::{RigidProjectile, RigidShape};
use dea_core::stability::stable_time_step;
use dea_core::{Domain, FibreMaterial, Vec3};
use dea_fabric::StraightBundle;
use dea_io::case::KM2_600_DENIER_AREA;
use nalgebra::UnitQuaternion;
use serde::Serialize;

/// Bench results (JSON keys are part of the interface).
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub nodes: usize,
    pub steps: u64,
    pub ranks: i32,
    pub wall_s: f64,
    pub ns_per_node_step: f64,
    /// fibre-contact stage time per touching pair entry, on the squeezed yarn held still
    /// (every pair in reach touches; friction evaluated, sticking)
    pub ns_per_contact_pair: f64,
    /// touching pair entries per node in that static measurement
    pub static_contacts_per_node: f64,
    /// fibre-contact stage time per neighbour-list entry per step
    pub ns_per_listed_pair: f64,
    /// tension + bending + integration per node-step
    pub ns_per_node_rods: f64,
    /// one neighbour-list rebuild per node
    pub ns_per_node_rebuild: f64,
    /// touching pair entries per owned node during the run (each pair counted at both nodes)
    pub contacts_per_node: f64,
    pub listed_pairs_per_node: f64,
    pub node_steps_per_s_per_core: f64,
    pub rebuilds: u64,
}

/// Builds the bench yarn: 19 KM2 fibres squeezed to 97% of their packing pitch, so every
/// neighbour pair is in contact, with the Table 4-2 sphere resting on it at 50 m/s.
pub fn bench_domain(min_nodes: usize) -> Domain {
    let material = FibreMaterial::kevlar_km2();
    let fibres = 19;
    let fibre_area = KM2_600_DENIER_AREA / fibres as f64;
    let diameter = (4.0 * fibre_area / std::f64::consts::PI).sqrt();
    let length = (min_nodes as f64 / fibres as f64) * 0.5 * diameter;
    let bundle = StraightBundle {
        length,
        fibres,
        fibre_area,
        element_length_ratio: 0.5,
        inertia: InertiaModel::Effective { k1: 0.8, k2: 1.0 },
        friction_coefficient: 0.3,
        tensile_strength: f64::INFINITY,
        clamp_ends: true,
    };
    let mut built = bundle.build(&material);
    for p in &mut built.nodes.position {
        p.y *= 0.97;
        p.z *= 0.97;
    }
    let contact = ContactParameters { law: NormalLaw::ElastoPlasticKm2, friction_coefficient: 0.3, projectile_friction_coefficient: 0.3, skin: 0.25 * built.sections[0].contact_diameter };
    let top = built.nodes.position.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
    let radius = 5.56e-3 / 2.0;
    let sphere = RigidProjectile::new(RigidShape::Sphere { radius }, 0.692e-3, Vec3::new(0.0, 0.0, top + radius), Vec3::new(0.0, 0.0, -50.0), UnitQuaternion::identity());
    let dt = stable_time_step(&material, &built.sections, &contact.law, 0.3, 0.5);
    let failure = FailureParameters { shear_strength: f64::INFINITY, enabled: false };
    Domain::new(material, built.sections, built.nodes, built.elements, contact, failure, Some(sphere), dt).expect("bench state is finite")
}

/// Runs the benchmark.
pub fn bench(min_nodes: usize, steps: u64, ranks: i32) -> Result<BenchReport, dea_core::DomainError> {
    let mut domain = bench_domain(min_nodes);
    let nodes = domain.nodes.n_owned;
    // rebuild cost, measured on its own
    let rebuild_samples = 10;
    let clock = Instant::now();
    for _ in 0..rebuild_samples {
        domain.rebuild_neighbours();
    }
    let ns_per_node_rebuild = clock.elapsed().as_secs_f64() * 1e9 / (rebuild_samples as f64 * nodes as f64);
    let static_evaluations = 20;
    domain.times = Default::default();
    for _ in 0..static_evaluations {
        domain.compute_forces()?;
    }
    let static_touching = domain.pairs.touching.iter().filter(|&&t| t).count() as f64;
    let ns_per_contact_pair = domain.times.fibre_contacts * 1e9 / (static_touching * static_evaluations as f64);
    domain.times = Default::default();
    let builds_before = domain.pairs.builds;
    let (mut touching, mut listed, mut samples) = (0usize, 0usize, 0usize);
    let start = Instant::now();
    for step in 0..steps {
        domain.step()?;
        if step % 10 == 0 {
            touching += domain.pairs.touching.iter().filter(|&&t| t).count();
            listed += domain.pairs.len();
            samples += 1;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let node_steps = nodes as f64 * steps as f64;
    let mean_touching = touching as f64 / samples.max(1) as f64;
    let mean_listed = listed as f64 / samples.max(1) as f64;
    let times = domain.times;
    Ok(BenchReport {
        nodes,
        steps,
        ranks,
        wall_s: wall,
        ns_per_node_step: wall * 1e9 / node_steps,
        ns_per_contact_pair,
        static_contacts_per_node: static_touching / nodes as f64,
        ns_per_listed_pair: times.fibre_contacts * 1e9 / (mean_listed * steps as f64),
        ns_per_node_rods: (times.rods + times.integrate) * 1e9 / node_steps,
        ns_per_node_rebuild,
        contacts_per_node: mean_touching / nodes as f64,
        listed_pairs_per_node: mean_listed / nodes as f64,
        node_steps_per_s_per_core: node_steps / wall / ranks as f64,
        rebuilds: domain.pairs.builds - builds_before,
    })
}
