//! One rank's part of the problem and the stages of an explicit step.
//!
//! A `Domain` holds the local nodes (owned first, ghosts after), element and pair state, and
//! the projectile. Its stages are the step of DESIGN.md §4 without communication; a driver
//! (the solver's step loop) calls them in order and inserts halo exchange and reductions.

use std::time::Instant;

use crate::bending::{compute_bending, element_shear_force, max_shear_stress, BendingScratch};
use crate::contact::{ContactGeometry, NormalLaw};
use crate::energy::EnergyReport;
use crate::failure::{combined_criterion, FailureParameters};
use crate::friction::stick_slip;
use crate::integrate;
use crate::neighbour::NeighbourList;
use crate::nodes::{Elements, FailureMode, Nodes};
use crate::projectile::RigidProjectile;
use crate::rod::{axial_energy, compute_element_tension, element_strain_energy, set_chain_forces};
use crate::{FibreMaterial, FibreSection, GlobalNodeId, Vec3, NONE};

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
    #[error("non-finite force or position at node {gid:?} in step {step} (time step too large or an unstable contact)")]
    NonFinite { step: u64, gid: GlobalNodeId },
}

/// Contact history of every node with the projectile (one body, so one entry per node).
#[derive(Clone, Debug, Default)]
pub struct ProjectileContacts {
    /// owned nodes within reach of the projectile at the last build, ascending
    pub candidates: Vec<u32>,
    /// friction anchor: body origin relative to the node at first touch, body frame [m]
    pub anchor: Vec<Vec3>,
    /// node overlaps the projectile
    pub touching: Vec<bool>,
    /// largest overlap reached [m]
    pub max_overlap: Vec<f64>,
    /// contact force on the node in this step [N]
    pub force_on_node: Vec<Vec3>,
    /// torque of the reaction about the projectile's centre in this step [N m]
    pub torque_on_projectile: Vec<Vec3>,
    /// projectile position at the last build [m]
    pub reference_position: Vec3,
}

/// Per-owned-node running totals of dissipated and released energy [J].
#[derive(Clone, Debug, Default)]
pub struct NodeLedger {
    pub friction_dissipated: Vec<f64>,
    pub plastic_dissipated: Vec<f64>,
    pub fracture_released: Vec<f64>,
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
    pair_data: Vec<PairData>,
    newly_broken: Vec<u32>,
}

impl Domain {
    /// Assembles a domain; forces of the initial state are computed so that the first
    /// half-kick uses a(0).
    pub fn new(
        material: FibreMaterial,
        sections: Vec<FibreSection>,
        nodes: Nodes,
        elements: Elements,
        contact: ContactParameters,
        failure: FailureParameters,
        projectile: Option<RigidProjectile>,
        time_step: f64,
    ) -> Result<Self, DomainError> {
        let n = nodes.len();
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
        let mut domain = Self {
            material,
            sections,
            ledger: NodeLedger {
                friction_dissipated: vec![0.0; nodes.n_owned],
                plastic_dissipated: vec![0.0; nodes.n_owned],
                fracture_released: vec![0.0; nodes.n_owned],
            },
            projectile_contacts: ProjectileContacts {
                anchor: vec![Vec3::zeros(); n],
                touching: vec![false; n],
                max_overlap: vec![0.0; n],
                force_on_node: vec![Vec3::zeros(); n],
                torque_on_projectile: vec![Vec3::zeros(); n],
                ..Default::default()
            },
            nodes,
            elements,
            pairs: NeighbourList::new(contact.skin),
            contact,
            failure,
            projectile,
            bending,
            broken: BrokenCount::default(),
            time_step,
            time: 0.0,
            step: 0,
            times: StageTimes::default(),
            pair_data,
            newly_broken: Vec::new(),
        };
        domain.rebuild_neighbours();
        domain.compute_forces()?;
        domain.set_projectile_load(domain.projectile_load());
        Ok(domain)
    }

    /// One explicit step on a single domain: kick–drift, rebuild when due, forces, failure,
    /// projectile load, kick.
    pub fn step(&mut self) -> Result<(), DomainError> {
        let half = 0.5 * self.time_step;
        let clock = Instant::now();
        self.kick_drift(half, self.time_step);
        self.times.integrate += clock.elapsed().as_secs_f64();
        if self.rebuild_due() {
            self.rebuild_neighbours();
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

    /// Half-step velocity update of owned nodes and the projectile.
    pub fn kick(&mut self, half_dt: f64) {
        integrate::kick(&mut self.nodes, half_dt);
        if let Some(projectile) = &mut self.projectile {
            projectile.kick(half_dt);
        }
    }

    /// Half-step velocity update, then position update, of owned nodes and the projectile.
    pub fn kick_drift(&mut self, half_dt: f64, dt: f64) {
        integrate::kick_drift(&mut self.nodes, half_dt, dt);
        if let Some(projectile) = &mut self.projectile {
            projectile.kick(half_dt);
            projectile.drift(dt);
        }
    }

    /// True when a node may have come within reach of a partner not in its list: a node
    /// moved more than half the skin, or node plus projectile moved more than the skin.
    pub fn rebuild_due(&self) -> bool {
        let node = self.pairs.max_displacement_squared(&self.nodes).sqrt();
        let projectile = self.projectile.as_ref().map_or(0.0, |p| (p.position - self.projectile_contacts.reference_position).norm());
        2.0 * node > self.pairs.skin || node + projectile > self.pairs.skin
    }

    /// Rebuilds fibre neighbour lists and the projectile's candidate nodes.
    pub fn rebuild_neighbours(&mut self) {
        let clock = Instant::now();
        self.pairs.rebuild(&self.nodes, &self.sections);
        if let Some(projectile) = &self.projectile {
            let contacts = &mut self.projectile_contacts;
            let max_contact_radius = self.sections.iter().map(|s| 0.5 * s.contact_diameter).fold(0.0, f64::max);
            let reach = projectile.shape.bounding_radius() + max_contact_radius + self.pairs.skin;
            contacts.candidates.clear();
            for i in 0..self.nodes.n_owned {
                if (self.nodes.position[i] - projectile.position).norm_squared() < reach * reach {
                    contacts.candidates.push(i as u32);
                } else {
                    // a node leaving the candidate set is out of contact
                    contacts.touching[i] = false;
                    contacts.force_on_node[i].fill(0.0);
                    contacts.torque_on_projectile[i].fill(0.0);
                }
            }
            contacts.reference_position = projectile.position;
        }
        self.times.rebuild += clock.elapsed().as_secs_f64();
    }

    /// Forces on owned nodes, element failure and the projectile's contact load.
    pub fn compute_forces(&mut self) -> Result<(), DomainError> {
        let clock = Instant::now();
        compute_element_tension(&self.nodes, &mut self.elements, &self.sections, &self.material);
        compute_bending(&self.nodes, &self.elements, &self.sections, &mut self.bending);
        set_chain_forces(&mut self.nodes, &self.elements, &self.bending);
        let rods_done = Instant::now();
        self.times.rods += (rods_done - clock).as_secs_f64();
        self.add_fibre_contacts();
        let contacts_done = Instant::now();
        self.times.fibre_contacts += (contacts_done - rods_done).as_secs_f64();
        self.add_projectile_contacts();
        let projectile_done = Instant::now();
        self.times.projectile_contacts += (projectile_done - contacts_done).as_secs_f64();
        self.break_elements();
        self.times.failure += projectile_done.elapsed().as_secs_f64();
        self.check_finite()
    }

    /// Fibre–fibre contact and friction on owned nodes (seed 3-1…3-3, 4-4…4-15), summed per
    /// node in partner-gid order.
    fn add_fibre_contacts(&mut self) {
        let n_sections = self.sections.len();
        let law = self.contact.law;
        let mu = self.contact.friction_coefficient;
        let nodes = &mut self.nodes;
        let pairs = &mut self.pairs;
        for i in 0..nodes.n_owned {
            let xi = nodes.position[i];
            let si = nodes.section[i] as usize * n_sections;
            let mut force = Vec3::zeros();
            for k in pairs.start[i] as usize..pairs.start[i + 1] as usize {
                let j = pairs.partner[k] as usize;
                let data = &self.pair_data[si + nodes.section[j] as usize];
                let relative = nodes.position[j] - xi;
                let distance_squared = relative.norm_squared();
                if distance_squared >= data.reach * data.reach {
                    pairs.touching[k] = false;
                    continue;
                }
                let distance = distance_squared.sqrt();
                let normal = relative * (1.0 / distance);
                let overlap = data.reach - distance;
                let previous_max = pairs.max_overlap[k];
                let (response, max_overlap) = law.evaluate(&data.geometry, overlap, previous_max);
                if max_overlap > previous_max {
                    // each pair is evaluated by both of its nodes: half the dissipation each
                    self.ledger.plastic_dissipated[i] +=
                        0.5 * (law.dissipated(&data.geometry, max_overlap) - law.dissipated(&data.geometry, previous_max));
                    pairs.max_overlap[k] = max_overlap;
                }
                force -= normal * response.force;
                if !pairs.touching[k] {
                    pairs.touching[k] = true;
                    pairs.anchor[k] = relative;
                } else if mu > 0.0 {
                    let friction = stick_slip(relative, normal, &mut pairs.anchor[k], response.force, response.stiffness, mu);
                    force += friction.force;
                    self.ledger.friction_dissipated[i] += 0.5 * friction.dissipated;
                }
            }
            nodes.force[i] += force;
        }
    }

    /// Geometry of the contact of fibre node `i` with the projectile surface: overlap, outward
    /// normal (body frame), body-frame position, and the contact geometry of the law.
    #[inline]
    fn projectile_contact_geometry(&self, projectile: &RigidProjectile, i: usize) -> (f64, Vec3, Vec3, ContactGeometry) {
        let section = &self.sections[self.nodes.section[i] as usize];
        let body = projectile.to_body(&self.nodes.position[i]);
        let (distance, normal) = projectile.shape.distance_and_normal(&body);
        let geometry = ContactGeometry::new(0.5 * section.diameter, section.element_length, section.diameter);
        (0.5 * section.contact_diameter - distance, normal, body, geometry)
    }

    /// Fibre–projectile contact and friction on candidate nodes; stores each node's force and
    /// the reaction torque for [`Self::projectile_load`].
    fn add_projectile_contacts(&mut self) {
        let Some(projectile) = self.projectile.take() else { return };
        let law = self.contact.law;
        let mu = self.contact.projectile_friction_coefficient;
        for c in 0..self.projectile_contacts.candidates.len() {
            let i = self.projectile_contacts.candidates[c] as usize;
            let (overlap, normal, body, geometry) = self.projectile_contact_geometry(&projectile, i);
            let contacts = &mut self.projectile_contacts;
            if overlap <= 0.0 {
                contacts.touching[i] = false;
                contacts.force_on_node[i].fill(0.0);
                contacts.torque_on_projectile[i].fill(0.0);
                continue;
            }
            let previous_max = contacts.max_overlap[i];
            let (response, max_overlap) = law.evaluate(&geometry, overlap, previous_max);
            if max_overlap > previous_max {
                self.ledger.plastic_dissipated[i] += law.dissipated(&geometry, max_overlap) - law.dissipated(&geometry, previous_max);
                contacts.max_overlap[i] = max_overlap;
            }
            // body origin relative to the node plays the partner's role of the fibre pairs
            let relative = -body;
            let mut force_body = normal * response.force;
            if !contacts.touching[i] {
                contacts.touching[i] = true;
                contacts.anchor[i] = relative;
            } else if mu > 0.0 {
                let friction = stick_slip(relative, normal, &mut contacts.anchor[i], response.force, response.stiffness, mu);
                force_body += friction.force;
                self.ledger.friction_dissipated[i] += friction.dissipated;
            }
            let force = projectile.to_world_vector(&force_body);
            let surface_point = self.nodes.position[i] - projectile.to_world_vector(&normal) * (0.5 * self.sections[self.nodes.section[i] as usize].contact_diameter - overlap);
            contacts.force_on_node[i] = force;
            contacts.torque_on_projectile[i] = (surface_point - projectile.position).cross(&(-force));
            self.nodes.force[i] += force;
        }
        self.projectile = Some(projectile);
    }

    /// Contact force and torque on the projectile from this domain's owned nodes, summed in
    /// ascending global id (the candidates are owned nodes in local = gid order) [N], [N m].
    pub fn projectile_load(&self) -> (Vec3, Vec3) {
        let contacts = &self.projectile_contacts;
        contacts.candidates.iter().fold((Vec3::zeros(), Vec3::zeros()), |(f, t), &i| {
            (f - contacts.force_on_node[i as usize], t + contacts.torque_on_projectile[i as usize])
        })
    }

    /// Sets the contact force and torque the projectile feels in this step (the total over
    /// all ranks, reduced in global-id order by the driver).
    pub fn set_projectile_load(&mut self, (force, torque): (Vec3, Vec3)) {
        if let Some(projectile) = &mut self.projectile {
            projectile.force = force;
            projectile.torque = torque;
        }
    }

    /// Applies the combined criterion (5-6) to owned elements and books the strain and bending
    /// energy the broken ones release.
    fn break_elements(&mut self) {
        if !self.failure.enabled {
            return;
        }
        let nodes = &self.nodes;
        self.newly_broken.clear();
        for i in 0..nodes.n_owned {
            if !self.elements.is_intact(nodes, i) {
                continue;
            }
            let sigma = self.material.longitudinal_modulus * self.elements.strain[i]; // (4-16)
            let area = self.sections[nodes.section[i] as usize].area;
            let shear = element_shear_force(nodes, &self.elements, &self.bending, i);
            let tau = max_shear_stress(shear, area);
            if let Some(mode) = combined_criterion(sigma, self.elements.tensile_strength[i], tau, self.failure.shear_strength) {
                self.newly_broken.push(i as u32);
                match mode {
                    FailureMode::Tension => self.broken.tension += 1,
                    FailureMode::Shear => self.broken.shear += 1,
                    _ => self.broken.combined += 1,
                }
                self.elements.failure[i] = mode;
            }
        }
        for &i in &self.newly_broken {
            let i = i as usize;
            let next = nodes.next[i] as usize;
            // strain energy of the element itself (evaluated as if intact)
            let area = self.sections[nodes.section[i] as usize].area;
            let mut released = axial_energy(&self.material, area, self.elements.rest_length[i], self.elements.strain[i]);
            // the spring at the first node, and the one at the second unless the element
            // after it also broke now (then that element books it). When that element is
            // owned by another rank its new state is only known after the next halo
            // exchange: the domain-decomposition work must settle this booking.
            released += self.spring_energy(i);
            let next_also_broke = self.elements.failure[next] != FailureMode::Intact && self.newly_broken.binary_search(&(next as u32)).is_ok();
            if !next_also_broke {
                released += self.spring_energy(next);
            }
            self.ledger.fracture_released[i] += released;
        }
    }

    /// Energy `K_t theta^2 / 2` of the spring at node `i` as computed this step.
    fn spring_energy(&self, i: usize) -> f64 {
        let k_t = self.sections[self.nodes.section[i] as usize].torsional_stiffness;
        0.5 * k_t * self.bending.angle[i] * self.bending.angle[i]
    }

    fn check_finite(&self) -> Result<(), DomainError> {
        for i in 0..self.nodes.n_owned {
            if !(self.nodes.force[i].iter().all(|v| v.is_finite()) && self.nodes.position[i].iter().all(|v| v.is_finite())) {
                return Err(DomainError::NonFinite { step: self.step, gid: self.nodes.gid[i] });
            }
        }
        Ok(())
    }

    /// Every energy of the domain (owned nodes; pairs once each). Call after
    /// [`Self::compute_forces`] so strains and angles are current.
    pub fn energies(&self) -> EnergyReport {
        let nodes = &self.nodes;
        let mut report = EnergyReport::default();
        let law = self.contact.law;
        let n_sections = self.sections.len();
        for i in 0..nodes.n_owned {
            report.fibre_kinetic += 0.5 * nodes.mass[i] * nodes.velocity[i].norm_squared();
            if nodes.next[i] != NONE {
                report.axial += element_strain_energy(nodes, &self.elements, &self.sections, &self.material, i);
            }
            report.bending += self.spring_energy(i);
            report.friction_dissipated += self.ledger.friction_dissipated[i];
            report.plastic_dissipated += self.ledger.plastic_dissipated[i];
            report.fracture_released += self.ledger.fracture_released[i];
            for k in self.pairs.row(i) {
                let j = self.pairs.partner[k] as usize;
                let data = &self.pair_data[nodes.section[i] as usize * n_sections + nodes.section[j] as usize];
                let relative = nodes.position[j] - nodes.position[i];
                let overlap = data.reach - relative.norm();
                if overlap <= 0.0 {
                    continue;
                }
                let (response, _) = law.evaluate(&data.geometry, overlap, self.pairs.max_overlap[k]);
                report.contact += 0.5 * law.stored_energy(&data.geometry, overlap, self.pairs.max_overlap[k]);
                if self.contact.friction_coefficient > 0.0 && self.pairs.touching[k] {
                    let mut anchor = self.pairs.anchor[k];
                    let friction = stick_slip(relative, relative.normalize(), &mut anchor, response.force, response.stiffness, self.contact.friction_coefficient);
                    report.friction_stored += 0.5 * friction.stored;
                }
            }
        }
        if let Some(projectile) = &self.projectile {
            report.projectile_kinetic = projectile.kinetic_energy();
            for &i in &self.projectile_contacts.candidates {
                let i = i as usize;
                let (overlap, normal, body, geometry) = self.projectile_contact_geometry(projectile, i);
                if overlap <= 0.0 {
                    continue;
                }
                let max_overlap = self.projectile_contacts.max_overlap[i];
                report.contact += law.stored_energy(&geometry, overlap, max_overlap);
                if self.contact.projectile_friction_coefficient > 0.0 && self.projectile_contacts.touching[i] {
                    let (response, _) = law.evaluate(&geometry, overlap, max_overlap);
                    let mut anchor = self.projectile_contacts.anchor[i];
                    let friction = stick_slip(-body, normal, &mut anchor, response.force, response.stiffness, self.contact.projectile_friction_coefficient);
                    report.friction_stored += friction.stored;
                }
            }
        }
        report
    }

    /// Axial stress E_L eps of every owned element, NaN where there is no element [Pa].
    pub fn element_stress(&self) -> Vec<f64> {
        (0..self.nodes.n_owned)
            .map(|i| if self.nodes.next[i] == NONE { f64::NAN } else if self.elements.failure[i] == FailureMode::Intact { self.material.longitudinal_modulus * self.elements.strain[i] } else { 0.0 })
            .collect()
    }
}
