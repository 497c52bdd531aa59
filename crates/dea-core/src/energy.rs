//! Energy bookkeeping: every kind of energy the model stores or dissipates.

use serde::{Deserialize, Serialize};

/// Energies of a domain at one instant [J]. Pair energies count each physical pair once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergyReport {
    /// kinetic energy of the fibre nodes
    pub fibre_kinetic: f64,
    /// kinetic energy of the projectile (translation + rotation)
    pub projectile_kinetic: f64,
    /// axial strain energy of the rods
    pub axial: f64,
    /// bending energy of the torsional springs
    pub bending: f64,
    /// recoverable energy of normal contacts (fibre–fibre and fibre–projectile)
    pub contact: f64,
    /// energy in the stick springs of friction
    pub friction_stored: f64,
    /// energy dissipated by slip so far
    pub friction_dissipated: f64,
    /// energy dissipated by transverse plastic deformation so far
    pub plastic_dissipated: f64,
    /// strain energy released by broken elements so far
    pub fracture_released: f64,
}

impl EnergyReport {
    /// Sum of every term: constant for a closed system up to the integration error.
    pub fn total(&self) -> f64 {
        self.fibre_kinetic
            + self.projectile_kinetic
            + self.axial
            + self.bending
            + self.contact
            + self.friction_stored
            + self.friction_dissipated
            + self.plastic_dissipated
            + self.fracture_released
    }
}
