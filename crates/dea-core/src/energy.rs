//! Energy bookkeeping: every kind of energy the model stores or dissipates.

use serde::{Deserialize, Serialize};

use crate::exact::{ExactSum, LIMBS};

/// Energies of a domain at one instant [J]. Pair energies count each physical pair once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergyReport {
    /// kinetic energy of the fibre nodes
    pub fibre_kinetic: f64,
    /// kinetic energy of the projectile (translation + rotation, or of every node of a
    /// deformable one)
    pub projectile_kinetic: f64,
    /// strain energy of a deformable projectile
    pub projectile_strain: f64,
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
            + self.projectile_strain
            + self.axial
            + self.bending
            + self.contact
            + self.friction_stored
            + self.friction_dissipated
            + self.plastic_dissipated
            + self.fracture_released
    }
}

/// Exact sums of every energy kind over a set of nodes: partial sums from any partition
/// merge into the same bits (see [`ExactSum`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EnergySums {
    pub fibre_kinetic: ExactSum,
    pub projectile_kinetic: ExactSum,
    pub projectile_strain: ExactSum,
    pub axial: ExactSum,
    pub bending: ExactSum,
    pub contact: ExactSum,
    pub friction_stored: ExactSum,
    pub friction_dissipated: ExactSum,
    pub plastic_dissipated: ExactSum,
    pub fracture_released: ExactSum,
}

/// Number of i64 words of [`EnergySums::to_words`].
pub const ENERGY_WORDS: usize = 10 * (LIMBS + 2);

impl EnergySums {
    fn kinds(&self) -> [&ExactSum; 10] {
        [
            &self.fibre_kinetic,
            &self.projectile_kinetic,
            &self.projectile_strain,
            &self.axial,
            &self.bending,
            &self.contact,
            &self.friction_stored,
            &self.friction_dissipated,
            &self.plastic_dissipated,
            &self.fracture_released,
        ]
    }

    /// The sums rounded to f64.
    pub fn report(&self) -> EnergyReport {
        let [fibre_kinetic, projectile_kinetic, projectile_strain, axial, bending, contact, friction_stored, friction_dissipated, plastic_dissipated, fracture_released] =
            self.kinds().map(ExactSum::value);
        EnergyReport { fibre_kinetic, projectile_kinetic, projectile_strain, axial, bending, contact, friction_stored, friction_dissipated, plastic_dissipated, fracture_released }
    }

    /// Integer words whose element-wise sum over ranks is the words of the total.
    pub fn to_words(&self) -> Vec<i64> {
        self.kinds().iter().flat_map(|s| s.to_words()).collect()
    }

    pub fn from_words(words: &[i64]) -> Self {
        let [fibre_kinetic, projectile_kinetic, projectile_strain, axial, bending, contact, friction_stored, friction_dissipated, plastic_dissipated, fracture_released] =
            std::array::from_fn(|k| ExactSum::from_words(&words[k * (LIMBS + 2)..(k + 1) * (LIMBS + 2)]));
        Self { fibre_kinetic, projectile_kinetic, projectile_strain, axial, bending, contact, friction_stored, friction_dissipated, plastic_dissipated, fracture_released }
    }
}
