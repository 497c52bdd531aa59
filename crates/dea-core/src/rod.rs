//! Axial rod forces, seed eqs (4-2), (4-3).

use crate::ids::NONE;
use crate::nodes::{Elements, Nodes};
use crate::{FibreMaterial, FibreSection};

/// Computes strain and axial force of every intact element whose first node is local
/// (seed 4-2: `f = E_L A (l - l0) / l0`; in compression the stiffness is scaled by
/// `compressive_stiffness_ratio`). Stores the force on the first node in `elements.tension`.
pub fn compute_element_tension(nodes: &Nodes, elements: &mut Elements, sections: &[FibreSection], material: &FibreMaterial) {
    for i in 0..nodes.len() {
        let j = nodes.next[i];
        if j == NONE {
            continue;
        }
        let axis = nodes.position[j as usize] - nodes.position[i];
        let length = axis.norm();
        let rest = elements.rest_length[i];
        let strain = (length - rest) / rest;
        elements.strain[i] = strain;
        if !elements.is_intact(nodes, i) {
            elements.tension[i].fill(0.0);
            continue;
        }
        let stiffness = material.longitudinal_modulus * sections[nodes.section[i] as usize].area;
        let scale = if strain >= 0.0 { 1.0 } else { material.compressive_stiffness_ratio };
        // force on the first node points along the element when stretched (4-2)
        elements.tension[i] = axis * (scale * stiffness * strain / length);
    }
}

/// Adds the axial forces to owned nodes: `F_i = f_m - f_n` (seed 4-3), gathered per node in
/// the fixed order (element to the next node, then element from the previous node).
pub fn add_rod_forces(nodes: &mut Nodes, elements: &Elements) {
    for i in 0..nodes.n_owned {
        let mut force = elements.tension[i];
        let p = nodes.prev[i];
        if p != NONE {
            force -= elements.tension[p as usize];
        }
        nodes.force[i] += force;
    }
}

/// Axial strain energy of element `i`: `E A l0 eps^2 / 2` (scaled in compression) [J].
pub fn element_strain_energy(nodes: &Nodes, elements: &Elements, sections: &[FibreSection], material: &FibreMaterial, i: usize) -> f64 {
    if !elements.is_intact(nodes, i) {
        return 0.0;
    }
    axial_energy(material, sections[nodes.section[i] as usize].area, elements.rest_length[i], elements.strain[i])
}

/// `E A l0 eps^2 / 2`, with the compressive stiffness ratio below zero strain [J].
#[inline]
pub fn axial_energy(material: &FibreMaterial, area: f64, rest_length: f64, strain: f64) -> f64 {
    let scale = if strain >= 0.0 { 1.0 } else { material.compressive_stiffness_ratio };
    0.5 * scale * material.longitudinal_modulus * area * rest_length * strain * strain
}
