//! From a validated case to a ready domain.

use dea_core::domain::ContactParameters;
use dea_core::failure::FailureParameters;
use dea_core::projectile::{RigidProjectile, RigidShape};
use dea_core::stability::stable_time_step;
use dea_core::weibull::element_strength;
use dea_core::{Domain, DomainError, Vec3, NONE};
use dea_fabric::StraightBundle;
use dea_io::case::{yarn_area, Case, Strength, TargetSpec};
use nalgebra::UnitQuaternion;

/// Gap between the projectile and the nearest fibre surface at time zero [m].
pub const INITIAL_GAP: f64 = 1e-6;

/// Builds the domain of a case on one rank.
pub fn build_domain(case: &Case) -> Result<Domain, DomainError> {
    let material = case.material().expect("validated case");
    let law = case.normal_law(&material).expect("validated case");
    let strength = case.strength().expect("validated case");
    let deterministic = match strength {
        Strength::Deterministic(s) => s,
        _ => f64::INFINITY,
    };
    let (length, fibres, fibre_area, element_length_ratio) = match &case.target {
        TargetSpec::SingleFibre { length_m, diameter_m, element_length_ratio } => (*length_m, 1, std::f64::consts::PI * diameter_m * diameter_m / 4.0, *element_length_ratio),
        TargetSpec::StraightYarn { yarn, fibres_per_yarn, length_m, element_length_ratio } => {
            (*length_m, *fibres_per_yarn, yarn_area(yarn).expect("validated case") / *fibres_per_yarn as f64, *element_length_ratio)
        }
    };
    let bundle = StraightBundle {
        length,
        fibres,
        fibre_area,
        element_length_ratio,
        inertia: case.bending,
        friction_coefficient: case.contact.friction_coefficient,
        tensile_strength: deterministic,
        clamp_ends: true,
    };
    let mut built = bundle.build(&material);
    if let Strength::Weibull(law, seed) = &strength {
        for i in 0..built.nodes.len() {
            if built.nodes.next[i] != NONE {
                built.elements.tensile_strength[i] = element_strength(law, *seed, built.nodes.gid[i], built.elements.rest_length[i]);
            }
        }
    }
    let max_contact_diameter = built.sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max);
    let contact = ContactParameters {
        law,
        friction_coefficient: case.contact.friction_coefficient,
        projectile_friction_coefficient: case.contact.projectile_friction_coefficient,
        skin: case.contact.skin_m.unwrap_or(0.25 * max_contact_diameter),
    };
    let failure = FailureParameters { shear_strength: case.shear_strength().expect("validated case"), enabled: !matches!(strength, Strength::None) };
    let projectile = case.projectile().expect("validated case");
    let top = built.nodes.position.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max) + 0.5 * max_contact_diameter;
    let reach_below_centre = match projectile.shape {
        RigidShape::Sphere { radius } => radius,
        RigidShape::Cylinder { height, .. } => 0.5 * height,
    };
    let start = Vec3::new(projectile.offset[0], projectile.offset[1], top + reach_below_centre + INITIAL_GAP);
    let body = RigidProjectile::new(projectile.shape, projectile.mass, start, Vec3::new(0.0, 0.0, -projectile.speed), UnitQuaternion::identity());
    let dt = stable_time_step(&material, &built.sections, &contact.law, contact.friction_coefficient.max(contact.projectile_friction_coefficient), case.run.time_step_safety);
    Domain::new(material, built.sections, built.nodes, built.elements, contact, failure, Some(body), dt)
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
