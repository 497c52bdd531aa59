//! Stable time step of the central-difference scheme (seed §4.2.5): below the critical step
//! of the stiffest of rod axial, bending and contact stiffness.

use crate::contact::{ContactGeometry, NormalLaw};
use crate::{FibreMaterial, FibreSection};

/// Neighbours a node may touch at once (close packing of parallel fibres plus crossings).
pub const DESIGN_CONTACTS_PER_NODE: f64 = 12.0;
/// Transverse strain at which the contact stiffness enters the estimate (30 % of a diameter).
pub const DESIGN_CONTACT_STRAIN: f64 = 0.3;

/// Largest `ω_z dt` the run's step gives any section's bending zigzag, `ω_z` of
/// [`bending_zigzag_frequency`] (docs/theory.md I11c). The linear limit is 2, and `safety`
/// 0.5 keeps the sum of every term's stiffness within it with a factor of two; but where
/// the elements are short the bending springs alone take up most of that sum (their zigzag
/// term grows as `l0⁻⁴` against the rods' `l0⁻²`), and at `ω_z dt` 0.93 (style 706's
/// digital fibre at l0/d 0.125) the central difference fed energy into the bending zigzag of
/// a struck panel until it broke the 1 % budget (+1.04 % at 24.6 µs), where at 0.78
/// (l0/d 0.25) and 0.80 it kept it: a measured bound, below the leapfrog's resonances of
/// order 6 and 7 (`ω dt = 2 sin(π/6)`, `2 sin(π/7)`: 1.0, 0.87).
pub const BENDING_ZIGZAG_LIMIT: f64 = 0.8;

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

/// Angular frequency of the bending zigzag of a straight chain of `section` alone,
/// `sqrt(16 K_t / l0² / m)` [rad/s]: the bending term of [`highest_frequency`].
pub fn bending_zigzag_frequency(material: &FibreMaterial, section: &FibreSection) -> f64 {
    let l0 = section.element_length;
    (16.0 * section.torsional_stiffness / (l0 * l0) / section.node_mass(material)).sqrt()
}

/// The longest step the bending zigzag of `section` allows, [`BENDING_ZIGZAG_LIMIT`] over its
/// [`bending_zigzag_frequency`] [s] (infinite for fibres without bending rigidity).
pub fn zigzag_step_limit(material: &FibreMaterial, section: &FibreSection) -> f64 {
    BENDING_ZIGZAG_LIMIT / bending_zigzag_frequency(material, section)
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

/// The run's step [s] from the [`stable_time_step`] `stable` of `sections`: no longer than
/// [`BENDING_ZIGZAG_LIMIT`] over their highest [`bending_zigzag_frequency`]; and, where that
/// bound holds, the stable step it shortened. Where it does not, the step is `stable` to the
/// bit.
pub fn run_time_step(material: &FibreMaterial, sections: &[FibreSection], stable: f64) -> (f64, Option<f64>) {
    let bound = sections.iter().map(|s| zigzag_step_limit(material, s)).fold(f64::INFINITY, f64::min);
    if stable > bound {
        (bound, Some(stable))
    } else {
        (stable, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::InertiaModel;

    /// Style 706's digital fibre at 4 per yarn (area [m²]) under the default bending model
    /// (effective, k1 0.8, k2 1, μ 0.3), its elements `ratio` diameters long.
    fn style_706_fibre(ratio: f64) -> FibreSection {
        let material = FibreMaterial::kevlar_km2();
        let area = 1.1575e-8;
        let diameter = (4.0 * area / std::f64::consts::PI).sqrt();
        let inertia = InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3);
        FibreSection::new(&material, area, ratio * diameter, inertia)
    }

    #[test]
    fn the_bending_zigzag_bounds_the_step_only_where_the_elements_are_short() {
        let material = FibreMaterial::kevlar_km2();
        let law = NormalLaw::ElastoPlasticKm2;
        let step = |section: &FibreSection, safety: f64| {
            let sections = std::slice::from_ref(section);
            let stable = stable_time_step(&material, sections, &law, 0.3, DESIGN_CONTACT_STRAIN, safety);
            (run_time_step(&material, sections, stable), stable)
        };
        // l0/d 0.5 and 0.25 at the default safety: the stable step to the bit (the results
        // fired before the bound keep theirs); the zigzag at 0.52 and 0.78 of its 2
        for (ratio, zigzag) in [(0.5, 0.52), (0.25, 0.78)] {
            let section = style_706_fibre(ratio);
            let ((run, shortened), stable) = step(&section, 0.5);
            assert_eq!((run.to_bits(), shortened), (stable.to_bits(), None), "l0/d {ratio}");
            let product = run * bending_zigzag_frequency(&material, &section);
            assert!((product - zigzag).abs() < 0.005, "l0/d {ratio}: omega_z dt {product}");
        }
        // l0/d 0.125: the stable step would give the zigzag 0.93; the bound takes it to 0.8
        let fine = style_706_fibre(0.125);
        let ((run, shortened), stable) = step(&fine, 0.5);
        assert_eq!(shortened, Some(stable));
        assert!((stable * bending_zigzag_frequency(&material, &fine) - 0.93).abs() < 0.005);
        let product = run * bending_zigzag_frequency(&material, &fine);
        assert!((product - BENDING_ZIGZAG_LIMIT).abs() < 1e-14, "{product}");
        // a shorter safety below the bound is the stable step's again, and a mix of sections
        // takes the stiffest zigzag
        let ((low, none), stable_low) = step(&fine, 0.25);
        assert_eq!((low.to_bits(), none), (stable_low.to_bits(), None));
        let both = [style_706_fibre(0.5), fine];
        let stable_both = stable_time_step(&material, &both, &law, 0.3, DESIGN_CONTACT_STRAIN, 0.5);
        let (mixed, _) = run_time_step(&material, &both, stable_both);
        assert_eq!(mixed.to_bits(), run.to_bits());
        // fibres without bending rigidity have no zigzag to bound, however short the elements
        let material = FibreMaterial::kevlar_km2();
        let limp = FibreSection::new(&material, 1.1575e-8, 2e-6, InertiaModel::None {}.with_friction(0.3));
        assert_eq!(bending_zigzag_frequency(&material, &limp), 0.0);
        assert_eq!(run_time_step(&material, std::slice::from_ref(&limp), 1e-9).1, None);
    }

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
