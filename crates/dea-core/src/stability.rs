//! Stable time step of the central-difference scheme (seed §4.2.5): below the critical step
//! of the stiffest of rod axial, bending and contact stiffness.

use crate::contact::{ContactGeometry, NormalLaw};
use crate::{FibreMaterial, FibreSection};

/// Neighbours a node may touch at once (close packing of parallel fibres plus crossings).
pub const DESIGN_CONTACTS_PER_NODE: f64 = 12.0;
/// Transverse strain at which the contact stiffness enters the estimate (30 % of a diameter).
pub const DESIGN_CONTACT_STRAIN: f64 = 0.3;

/// Highest angular frequency of a node of `section` [rad/s]:
/// `omega^2 = (4 k_axial + 16 K_t / l0^2 + n_c (1 + mu) k_contact) / m`.
/// A chain of masses m and springs k has omega_max = 2 sqrt(k/m); the bending stencil
/// (1, -2, 1) applied twice gives the factor 16; contact stiffness is the law's tangent at
/// `contact_strain` (at least [`DESIGN_CONTACT_STRAIN`]; unloading slope where that is
/// steeper), times the friction spring mu k_n, for [`DESIGN_CONTACTS_PER_NODE`] partners.
pub fn highest_frequency(
    material: &FibreMaterial,
    section: &FibreSection,
    law: &NormalLaw,
    friction_coefficient: f64,
    contact_strain: f64,
) -> f64 {
    let mass = section.node_mass(material);
    let contact = contact_stiffness_at(section, law, contact_strain.max(DESIGN_CONTACT_STRAIN));
    ((chain_stiffness(material, section) + DESIGN_CONTACTS_PER_NODE * (1.0 + friction_coefficient) * contact) / mass)
        .sqrt()
}

/// Normal stiffness of one contact of a node of `section` at [`DESIGN_CONTACT_STRAIN`]: the
/// law's loading tangent, or its unloading slope where that is steeper [N/m].
pub fn design_contact_stiffness(section: &FibreSection, law: &NormalLaw) -> f64 {
    contact_stiffness_at(section, law, DESIGN_CONTACT_STRAIN)
}

/// Normal stiffness of one contact of a node of `section` at the transverse strain
/// `strain` (overlap / diameter) [N/m], as [`design_contact_stiffness`].
pub fn contact_stiffness_at(section: &FibreSection, law: &NormalLaw, strain: f64) -> f64 {
    let geometry = ContactGeometry::new(0.5 * section.diameter, section.element_length, section.diameter);
    let overlap = strain * section.diameter;
    let (loading, _) = law.evaluate(&geometry, overlap, 0.0);
    let (unloading, _) = law.evaluate(&geometry, overlap * 0.999, overlap);
    loading.stiffness.max(unloading.stiffness)
}

/// Effective stiffness of a node's chain in its highest mode, `4 k_axial + 16 K_t / l0^2`
/// [N/m] (see [`highest_frequency`]).
pub fn chain_stiffness(material: &FibreMaterial, section: &FibreSection) -> f64 {
    let l0 = section.element_length;
    4.0 * material.longitudinal_modulus * section.area / l0 + 16.0 * section.torsional_stiffness / (l0 * l0)
}

/// Largest stable step of a node of mass `mass` whose chain and contacts give the stiffness
/// `chain + (1 + mu) contact`: `2 / omega` [s]. Central difference diverges above it.
pub fn node_stability_limit(chain: f64, contact: f64, friction_coefficient: f64, mass: f64) -> f64 {
    2.0 / ((chain + (1.0 + friction_coefficient) * contact) / mass).sqrt()
}

/// Stable time step `safety * 2 / omega_max` over all sections [s], contacts taken at
/// `contact_strain` (at least [`DESIGN_CONTACT_STRAIN`]; a relaxed fabric may start deeper).
pub fn stable_time_step(
    material: &FibreMaterial,
    sections: &[FibreSection],
    law: &NormalLaw,
    friction_coefficient: f64,
    contact_strain: f64,
    safety: f64,
) -> f64 {
    let omega = sections
        .iter()
        .map(|s| highest_frequency(material, s, law, friction_coefficient, contact_strain))
        .fold(0.0, f64::max);
    safety * 2.0 / omega
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::InertiaModel;

    #[test]
    fn axial_limit_alone_is_element_length_over_wave_speed() {
        let material = FibreMaterial::kevlar_km2();
        let section = FibreSection::new(&material, 2e-9, 25e-6, InertiaModel::None {}.with_friction(0.0));
        let no_contact = NormalLaw::Elastic { transverse_modulus: 0.0 };
        let dt =
            stable_time_step(&material, std::slice::from_ref(&section), &no_contact, 0.0, DESIGN_CONTACT_STRAIN, 1.0);
        let expected = section.element_length / material.wave_speed();
        assert!((dt - expected).abs() < 1e-12 * expected);
        // contact and bending only ever shorten it
        let with_all = FibreSection::new(&material, 2e-9, 25e-6, InertiaModel::Locked {}.with_friction(0.3));
        assert!(
            stable_time_step(&material, &[with_all], &NormalLaw::ElastoPlasticKm2, 0.3, DESIGN_CONTACT_STRAIN, 1.0)
                < dt
        );
        // the per-node check of a free node without contacts gives the same limit, and a
        // contact stiffness only lowers it
        let mass = section.node_mass(&material);
        let limit = node_stability_limit(chain_stiffness(&material, &section), 0.0, 0.3, mass);
        assert!((limit - expected).abs() < 1e-12 * expected);
        assert!(node_stability_limit(chain_stiffness(&material, &section), 1e5, 0.3, mass) < limit);
    }
}
