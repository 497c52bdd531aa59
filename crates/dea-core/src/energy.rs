//! Energy bookkeeping: every kind of energy the model stores or dissipates.

use serde::{Deserialize, Serialize};

use crate::bending::spring_energy;
use crate::domain::Domain;
use crate::exact::{ExactSum, LIMBS};
use crate::friction::stick_slip;
use crate::rod::element_strain_energy;
use crate::NONE;

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
    /// The names of the terms, in field order (the results' dataset names).
    pub const KINDS: [&'static str; 10] = [
        "fibre_kinetic",
        "projectile_kinetic",
        "projectile_strain",
        "axial",
        "bending",
        "contact",
        "friction_stored",
        "friction_dissipated",
        "plastic_dissipated",
        "fracture_released",
    ];

    /// The terms' values, in the order of [`Self::KINDS`] [J].
    pub fn values(&self) -> [f64; 10] {
        [
            self.fibre_kinetic,
            self.projectile_kinetic,
            self.projectile_strain,
            self.axial,
            self.bending,
            self.contact,
            self.friction_stored,
            self.friction_dissipated,
            self.plastic_dissipated,
            self.fracture_released,
        ]
    }

    /// The names of the terms that are not finite (none in a sound run).
    pub fn non_finite_kinds(&self) -> Vec<&'static str> {
        Self::KINDS.iter().zip(self.values()).filter(|(_, value)| !value.is_finite()).map(|(&name, _)| name).collect()
    }

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
    /// kinetic energy of the fibre nodes [J]
    pub fibre_kinetic: ExactSum,
    /// kinetic energy of the projectile, translation and rotation [J]
    pub projectile_kinetic: ExactSum,
    /// strain energy of a deformable projectile [J]
    pub projectile_strain: ExactSum,
    /// axial strain energy of the fibre elements and ties [J]
    pub axial: ExactSum,
    /// energy stored in the bending springs [J]
    pub bending: ExactSum,
    /// elastic energy stored in the normal contacts [J]
    pub contact: ExactSum,
    /// energy stored in the friction springs [J]
    pub friction_stored: ExactSum,
    /// friction work dissipated so far [J]
    pub friction_dissipated: ExactSum,
    /// plastic work of the contact law dissipated so far [J]
    pub plastic_dissipated: ExactSum,
    /// elastic energy released by broken elements so far [J]
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
        EnergyReport {
            fibre_kinetic,
            projectile_kinetic,
            projectile_strain,
            axial,
            bending,
            contact,
            friction_stored,
            friction_dissipated,
            plastic_dissipated,
            fracture_released,
        }
    }

    /// Integer words whose element-wise sum over ranks is the words of the total.
    pub fn to_words(&self) -> Vec<i64> {
        self.kinds().iter().flat_map(|s| s.to_words()).collect()
    }

    /// The sums whose words [`Self::to_words`] gave (or their element-wise sum over ranks).
    pub fn from_words(words: &[i64]) -> Self {
        let [fibre_kinetic, projectile_kinetic, projectile_strain, axial, bending, contact, friction_stored, friction_dissipated, plastic_dissipated, fracture_released] =
            std::array::from_fn(|k| ExactSum::from_words(&words[k * (LIMBS + 2)..(k + 1) * (LIMBS + 2)]));
        Self {
            fibre_kinetic,
            projectile_kinetic,
            projectile_strain,
            axial,
            bending,
            contact,
            friction_stored,
            friction_dissipated,
            plastic_dissipated,
            fracture_released,
        }
    }
}

/// The energies the fibres hold or dissipated, as exact sums per group of owned nodes
/// (`group(i)` < `groups`; a layer, say): everything of [`Domain::energy_sums`] but the
/// projectile's kinetic energy.
pub fn fibre_energy_sums(domain: &Domain, group: impl Fn(usize) -> usize, groups: usize) -> Vec<EnergySums> {
    let nodes = &domain.nodes;
    let mut sums = vec![EnergySums::default(); groups];
    let law = domain.contact.law;
    for i in 0..nodes.n_owned {
        let report = &mut sums[group(i)];
        report.fibre_kinetic.add(0.5 * nodes.mass[i] * domain.velocity(i).norm_squared());
        if nodes.next[i] != NONE {
            report.axial.add(element_strain_energy(nodes, &domain.elements, &domain.sections, &domain.material, i));
        }
        report.bending.add(spring_energy(nodes, &domain.bending, &domain.sections, i));
        report.friction_dissipated.add(domain.ledger.friction_dissipated[i]);
        report.plastic_dissipated.add(domain.ledger.plastic_dissipated[i]);
        report.fracture_released.add(domain.ledger.fracture_released[i]);
        for k in domain.pairs.row(i) {
            let j = domain.pairs.partner[k] as usize;
            // a pair of owned nodes at its node of lower gid, which keeps its history
            // (D13), for both; a pair with a ghost here for the owned node. Each node takes
            // half of what the pair stores: exactly what it took at each of its entries, as
            // the sums are exact and the energies even in the relative position.
            if !domain.pairs.evaluates(i, k) {
                continue;
            }
            let data = domain.pair_data_of(i, j);
            let relative = nodes.position[j] - nodes.position[i];
            let overlap = data.reach - relative.norm();
            if overlap <= 0.0 {
                continue;
            }
            let max_overlap = domain.pairs.max_overlap[k];
            let contact = law.stored_energy(&data.geometry, overlap, max_overlap);
            let mut friction_stored = 0.0;
            if domain.friction_coefficient() > 0.0 && domain.pairs.touching[k] {
                let (response, _) = law.evaluate(&data.geometry, overlap, max_overlap);
                let (mut anchor, mut spring) = (domain.pairs.anchor[k], domain.pairs.spring_stiffness[k]);
                friction_stored = stick_slip(
                    relative,
                    relative.normalize(),
                    &mut anchor,
                    &mut spring,
                    response.force,
                    response.stiffness,
                    domain.friction_coefficient(),
                )
                .stored;
            }
            for node in std::iter::once(i).chain((j < nodes.n_owned).then_some(j)) {
                sums[group(node)].contact.add(0.5 * contact);
                sums[group(node)].friction_stored.add(0.5 * friction_stored);
            }
        }
    }
    for (i, energy) in domain.ties.energies(nodes, &domain.material) {
        sums[group(i)].axial.add(energy);
    }
    if let Some(projectile) = &domain.projectile {
        for i in domain.projectile_contacts.candidates.iter().map(|i| i.index()) {
            let report = &mut sums[group(i)];
            let (overlap, point, body, geometry) =
                domain.projectile_contacts.geometry(projectile, nodes, &domain.sections, i);
            if overlap <= 0.0 {
                continue;
            }
            let max_overlap = domain.projectile_contacts.max_overlap[i];
            report.contact.add(law.stored_energy(&geometry, overlap, max_overlap));
            if domain.contact.projectile_friction_coefficient > 0.0 && domain.projectile_contacts.touching[i] {
                let (response, _) = law.evaluate(&geometry, overlap, max_overlap);
                let contacts = &domain.projectile_contacts;
                // the partner the forces use: on a deforming surface its anchored material point
                let relative = contacts.friction_partner(projectile, i, &body);
                report.friction_stored.add(contacts.friction_stored(
                    i,
                    domain.contact.projectile_friction_spring,
                    relative,
                    point.normal,
                    response.force,
                    response.stiffness,
                    domain.contact.projectile_friction_coefficient,
                ));
            }
        }
    }
    sums
}
