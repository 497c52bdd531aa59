//! Fibre material and digital-fibre cross-section properties.

use serde::{Deserialize, Serialize};

/// Orthotropic fibre material (seed Table 4-1 for Kevlar KM2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FibreMaterial {
    /// longitudinal (axial) Young's modulus E_L [Pa]
    pub longitudinal_modulus: f64,
    /// transverse modulus E_T used by the elastic contact law (4-8) [Pa]
    pub transverse_modulus: f64,
    /// density [kg/m^3]
    pub density: f64,
    /// axial stiffness in compression as a fraction of E_L [-]; 0 = tension-only rod.
    /// The seed is silent; the preset keeps 1 and lets the bending springs buckle a
    /// compressed fibre (docs/theory.md, I1)
    pub compressive_stiffness_ratio: f64,
    /// diameter of one real filament d_a [m]; enters I_0 (5-7)
    pub filament_diameter: f64,
}

impl FibreMaterial {
    /// Kevlar KM2, seed Table 4-1 (E_L = 84.6 GPa, E_T = 1.34 GPa, rho = 1440 kg/m^3) with
    /// 12 µm filaments (seed §2.2.3; PHYSICS.md §6); linear elastic in axial compression.
    pub fn kevlar_km2() -> Self {
        Self {
            longitudinal_modulus: 84.6e9,
            transverse_modulus: 1.34e9,
            density: 1440.0,
            compressive_stiffness_ratio: 1.0,
            filament_diameter: 12.0e-6,
        }
    }

    /// Longitudinal bar wave speed sqrt(E_L / rho) [m/s].
    pub fn wave_speed(&self) -> f64 {
        (self.longitudinal_modulus / self.density).sqrt()
    }
}

/// Which moment of inertia the bending springs use (seed §5.2.3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "model", deny_unknown_fields)]
pub enum InertiaModel {
    /// I_0 = n pi d_a^4 / 64, filaments bend independently (5-7)
    Free {},
    /// I_inf = pi d_d^4 / 64, the bundle bends as one rod (5-8)
    Locked {},
    /// I_e = (mu/k2)^k1 I_inf + (1 - (mu/k2)^k1) I_0 (5-10); seed §5.3: k1 = 0.8, k2 = 1
    Effective {
        /// the exponent k1 [-]
        k1: f64,
        /// the friction coefficient k2 at which the bundle locks [-]
        k2: f64,
    },
    /// no bending stiffness (the original DEA with frictionless pins)
    None {},
}

impl InertiaModel {
    /// The model with the inter-fibre friction coefficient `mu` [-] that (5-10) weighs the
    /// locked bundle by, applied: what a section's moment of inertia needs, made once where
    /// the case is resolved (the friction coefficient travels no further).
    pub fn with_friction(self, mu: f64) -> SectionInertia {
        match self {
            InertiaModel::Free {} => SectionInertia::Free,
            InertiaModel::Locked {} => SectionInertia::Locked,
            InertiaModel::None {} => SectionInertia::None,
            // mu/k2 capped at 1: above k2 the bundle is locked (seed §5.2.3)
            InertiaModel::Effective { k1, k2 } => {
                SectionInertia::Weighted { locked_share: (mu / k2).clamp(0.0, 1.0).powf(k1) }
            }
        }
    }
}

/// The bending model of a section, its friction weight applied ([`InertiaModel::with_friction`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SectionInertia {
    /// I_0 = n pi d_a^4 / 64 (5-7)
    Free,
    /// I_inf = pi d_d^4 / 64 (5-8)
    Locked,
    /// I_e = w I_inf + (1 - w) I_0 (5-10) with `locked_share` w = (mu/k2)^k1 [-]
    Weighted {
        /// w [-]
        locked_share: f64,
    },
    /// no bending stiffness
    None,
}

/// Cross-section of one class of digital fibre (all fibres of a yarn share one).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FibreSection {
    /// digital fibre diameter d_d = sqrt(4 A_d / pi) [m]
    pub diameter: f64,
    /// digital fibre area A_d = A_yarn / n_d [m^2]
    pub area: f64,
    /// nominal element length l0 [m]
    pub element_length: f64,
    /// modified contact diameter d_m = d_d sqrt(1 + (l0 / (2 d_d))^2), eqs (3-1)…(3-3) [m]
    pub contact_diameter: f64,
    /// effective area moment of inertia I_e (5-7)…(5-10) [m^4]
    pub moment_of_inertia: f64,
    /// torsional spring rigidity K_t = E I_e / l0 (5-1), (5-3) [N m / rad]
    pub torsional_stiffness: f64,
    /// real filaments represented by one digital fibre n = N_a / n_d [-]
    pub filaments_per_fibre: f64,
}

impl FibreSection {
    /// Builds a section from the digital fibre area [m^2], element length [m] and bending model.
    pub fn new(material: &FibreMaterial, area: f64, element_length: f64, inertia: SectionInertia) -> Self {
        let diameter = (4.0 * area / std::f64::consts::PI).sqrt();
        let filament_area = std::f64::consts::PI * material.filament_diameter.powi(2) / 4.0;
        let filaments_per_fibre = (area / filament_area).max(1.0);
        let moment_of_inertia =
            effective_moment_of_inertia(diameter, material.filament_diameter, filaments_per_fibre, inertia);
        Self {
            diameter,
            area,
            element_length,
            contact_diameter: modified_contact_diameter(diameter, element_length),
            moment_of_inertia,
            torsional_stiffness: material.longitudinal_modulus * moment_of_inertia / element_length,
            filaments_per_fibre,
        }
    }

    /// Lumped mass of an interior node rho A l0 [kg] (chain ends carry half).
    pub fn node_mass(&self, material: &FibreMaterial) -> f64 {
        material.density * self.area * self.element_length
    }
}

/// Modified contact diameter, seed eqs (3-1)–(3-3): `d_m = d0 sqrt(1 + (L0 / (2 d0))^2)`.
/// Node-to-node contact misses the point halfway between nodes; the larger diameter makes a
/// crossing fibre touch where a continuous fibre would.
pub fn modified_contact_diameter(diameter: f64, element_length: f64) -> f64 {
    let element_coefficient = element_length / diameter; // (3-1)
    let diameter_coefficient = (1.0 + (element_coefficient / 2.0).powi(2)).sqrt(); // (3-2)
    diameter * diameter_coefficient // (3-3)
}

/// Effective moment of inertia of a digital fibre, seed (5-7)…(5-10).
///
/// `I_0 = n pi d_a^4/64` (free filaments), `I_inf = pi d_d^4/64` (locked bundle),
/// `I_e = w I_inf + (1 - w) I_0` with `w = (mu/k2)^k1` ([`InertiaModel::with_friction`]).
pub fn effective_moment_of_inertia(
    fibre_diameter: f64,
    filament_diameter: f64,
    filaments_per_fibre: f64,
    model: SectionInertia,
) -> f64 {
    let pi = std::f64::consts::PI;
    let free = filaments_per_fibre * pi * filament_diameter.powi(4) / 64.0; // (5-7)
    let locked = pi * fibre_diameter.powi(4) / 64.0; // (5-8)
    match model {
        SectionInertia::Free => free,
        SectionInertia::Locked => locked,
        SectionInertia::None => 0.0,
        SectionInertia::Weighted { locked_share: weight } => weight * locked + (1.0 - weight) * free, // (5-10)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modified_diameter_matches_3_2_for_half_diameter_elements() {
        let d = 50e-6;
        let dm = modified_contact_diameter(d, d / 2.0);
        assert!((dm / d - (1.0f64 + 1.0 / 16.0).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn effective_inertia_interpolates_between_free_and_locked() {
        let (d, da, n) = (120e-6, 12e-6, 100.0);
        let free = effective_moment_of_inertia(d, da, n, InertiaModel::Free {}.with_friction(0.3));
        let locked = effective_moment_of_inertia(d, da, n, InertiaModel::Locked {}.with_friction(0.3));
        // (5-9): I_inf / I_0 = A_d / A_a = n when the digital fibre carries n filaments' area
        assert!((locked / free - n).abs() / n < 1e-12);
        let at =
            |mu| effective_moment_of_inertia(d, da, n, InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(mu));
        assert_eq!(at(0.0), free);
        assert!((at(1.0) - locked).abs() < 1e-12 * locked);
        assert!((at(2.0) - locked).abs() < 1e-12 * locked, "mu beyond k2 stays locked");
        let expected = 0.3f64.powf(0.8) * locked + (1.0 - 0.3f64.powf(0.8)) * free;
        assert!((at(0.3) - expected).abs() < 1e-12 * expected);
    }
}
