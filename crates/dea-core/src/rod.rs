//! Axial rod forces, seed eqs (4-2), (4-3).

use crate::bending::BendingScratch;
use crate::ids::NONE;
use crate::nodes::{Elements, FailureMode, Nodes};
use crate::{FibreMaterial, FibreSection};

/// Computes strain and axial force of every intact element whose first node is local
/// (seed 4-2: `f = E_L A (l - l0) / l0`; in compression the stiffness is scaled by
/// `compressive_stiffness_ratio`). Stores the force in `elements.axial_force`, and the
/// element's direction and inverse length for the bending pass and the chain forces (the
/// force is stored as a magnitude: the step moves a third of the bytes it would as a vector).
pub fn compute_element_tension(
    nodes: &Nodes,
    elements: &mut Elements,
    sections: &[FibreSection],
    material: &FibreMaterial,
) {
    compute_element_tension_over(nodes, elements, sections, material, 0..nodes.len());
}

/// [`compute_element_tension`] of the elements whose first node is in `range` (the elements
/// of the sections whose terms fire at a multi-rate instant, [`crate::multi_rate`]).
pub fn compute_element_tension_over(
    nodes: &Nodes,
    elements: &mut Elements,
    sections: &[FibreSection],
    material: &FibreMaterial,
    range: std::ops::Range<usize>,
) {
    if crate::in_avx2_lanes!(tension_in_lanes(nodes, elements, sections, material, range.clone())).is_some() {
        return;
    }
    for i in range {
        element_tension(nodes, elements, sections, material, i);
    }
}

/// [`compute_element_tension`] of element `i`.
#[inline]
pub(crate) fn element_tension(
    nodes: &Nodes,
    elements: &mut Elements,
    sections: &[FibreSection],
    material: &FibreMaterial,
    i: usize,
) {
    let j = nodes.next[i];
    if j == NONE {
        return;
    }
    let axis = nodes.position[j as usize] - nodes.position[i];
    let length = axis.norm();
    let rest = elements.rest_length[i];
    let strain = (length - rest) / rest;
    elements.strain[i] = strain;
    if !elements.is_intact(nodes, i) {
        // the two loose ends of a broken element may meet exactly (length 0): a direction
        // of 0/0 would turn its zero force into NaN, so a broken element has none
        elements.direction[i] = crate::Vec3::zeros();
        elements.inverse_length[i] = 0.0;
        elements.axial_force[i] = 0.0;
        return;
    }
    let inverse_length = 1.0 / length;
    elements.direction[i] = axis * inverse_length;
    elements.inverse_length[i] = inverse_length;
    // force on the first node points along the element when stretched (4-2)
    elements.axial_force[i] = axial_force(material, sections[nodes.section[i] as usize].area, strain);
}

/// [`compute_element_tension`] four elements at a time where four intact elements follow
/// each other along a fibre in memory (almost everywhere), with the scalar code's bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn tension_in_lanes(
    nodes: &Nodes,
    elements: &mut Elements,
    sections: &[FibreSection],
    material: &FibreMaterial,
    range: std::ops::Range<usize>,
) {
    use crate::lanes::{F4, V4};
    let (n, end) = (nodes.len(), range.end);
    let stiffness_of = |k: usize| material.longitudinal_modulus * sections[nodes.section[k] as usize].area;
    let mut i = range.start;
    // a group reads the position after its last element
    while i + 5 <= n && i + 4 <= end {
        if (i..i + 4).all(|k| nodes.next[k] == k as u32 + 1 && elements.failure[k] == FailureMode::Intact) {
            let axis = V4::load(&nodes.position, i + 1).sub(V4::load(&nodes.position, i));
            let length = axis.dot(axis).sqrt();
            let inverse_length = F4::splat(1.0).div(length);
            axis.scale(inverse_length).store(&mut elements.direction, i);
            inverse_length.store(&mut elements.inverse_length, i);
            let rest = F4::load(&elements.rest_length, i);
            let strain = length.sub(rest).div(rest);
            strain.store(&mut elements.strain, i);
            // axial_force: the compressive ratio below zero strain
            let scale =
                F4::select(strain.ge(F4::splat(0.0)), F4::splat(1.0), F4::splat(material.compressive_stiffness_ratio));
            let stiffness = F4::gather(i, stiffness_of);
            scale.mul(stiffness).mul(strain).store(&mut elements.axial_force, i);
        } else {
            for k in i..i + 4 {
                element_tension(nodes, elements, sections, material, k);
            }
        }
        i += 4;
    }
    for k in i..end {
        element_tension(nodes, elements, sections, material, k);
    }
}

/// Sets the chain force of every owned node: the axial forces `F_i = f_m - f_n` (seed 4-3),
/// then the bending springs (own spring, spring at the previous node, spring at the next
/// node), gathered per node in that fixed order. Overwrites `nodes.force` of owned nodes, so
/// it is the first force stage of a step.
pub fn set_chain_forces(nodes: &mut Nodes, elements: &Elements, bending: &BendingScratch) {
    for i in 0..nodes.n_owned {
        nodes.force[i] = chain_force(nodes, elements, bending, i);
    }
}

/// The chain force of node `i`: its elements' axial forces, then the springs (own, at the
/// previous node, at the next node), in that order [N].
#[inline(always)]
fn chain_force(nodes: &Nodes, elements: &Elements, bending: &BendingScratch, i: usize) -> crate::Vec3 {
    let (p, n) = (nodes.prev[i], nodes.next[i]);
    let mut axial = elements.direction[i] * elements.axial_force[i];
    if p != NONE {
        axial -= elements.direction[p as usize] * elements.axial_force[p as usize];
    }
    let mut spring = -(bending.on_prev[i] + bending.on_next[i]);
    if p != NONE {
        spring += bending.on_next[p as usize];
    }
    if n != NONE {
        spring += bending.on_prev[n as usize];
    }
    axial + spring
}

/// [`set_chain_forces`] at a multi-rate instant ([`crate::multi_rate`]): the chain force of
/// each owned node times its section's factor `section_scale`; zero where the section's terms
/// do not fire now (factor 0), so the terms that fire add to it.
pub fn set_scaled_chain_forces(
    nodes: &mut Nodes,
    elements: &Elements,
    bending: &BendingScratch,
    section_scale: &[f64],
) {
    for i in 0..nodes.n_owned {
        let scale = section_scale[nodes.section[i] as usize];
        nodes.force[i] =
            if scale == 0.0 { crate::Vec3::zeros() } else { chain_force(nodes, elements, bending, i) * scale };
    }
}

/// The chain force every owned node gets from the present scratch of the rods stage, as
/// [`set_chain_forces`] sets it (`section_scale`: as [`set_scaled_chain_forces`] does), into
/// `forces` [N].
pub fn chain_forces(
    nodes: &Nodes,
    elements: &Elements,
    bending: &BendingScratch,
    section_scale: Option<&[f64]>,
    forces: &mut Vec<crate::Vec3>,
) {
    forces.clear();
    forces.extend((0..nodes.n_owned).map(|i| scaled_chain_force(nodes, elements, bending, section_scale, i)));
}

/// Replaces in each owned node's force the chain force `before` (of [`chain_forces`], what
/// the rods stage set) by the one of the present scratch, where the two differ: the node's
/// other forces stay as the later stages added them (theory I7, an element broken in this
/// step). A node whose chain force did not change keeps its bits.
pub fn replace_chain_forces(
    nodes: &mut Nodes,
    elements: &Elements,
    bending: &BendingScratch,
    section_scale: Option<&[f64]>,
    before: &[crate::Vec3],
) {
    for (i, &before) in before.iter().enumerate() {
        let after = scaled_chain_force(nodes, elements, bending, section_scale, i);
        if after != before {
            nodes.force[i] = (nodes.force[i] - before) + after;
        }
    }
}

#[inline]
fn scaled_chain_force(
    nodes: &Nodes,
    elements: &Elements,
    bending: &BendingScratch,
    section_scale: Option<&[f64]>,
    i: usize,
) -> crate::Vec3 {
    match section_scale.map(|s| s[nodes.section[i] as usize]) {
        None => chain_force(nodes, elements, bending, i),
        Some(scale) if scale == 0.0 => crate::Vec3::zeros(),
        Some(scale) => chain_force(nodes, elements, bending, i) * scale,
    }
}

/// Axial force of an element of section area `area` at `strain` (4-2): `E_L A eps`, scaled
/// in compression [N].
#[inline]
pub fn axial_force(material: &FibreMaterial, area: f64, strain: f64) -> f64 {
    let stiffness = material.longitudinal_modulus * area;
    let scale = if strain >= 0.0 { 1.0 } else { material.compressive_stiffness_ratio };
    scale * stiffness * strain
}

/// Axial strain energy of element `i`: `E A l0 eps^2 / 2` (scaled in compression) [J].
pub fn element_strain_energy(
    nodes: &Nodes,
    elements: &Elements,
    sections: &[FibreSection],
    material: &FibreMaterial,
    i: usize,
) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::{FibreId, GlobalNodeId};
    use crate::material::InertiaModel;
    use crate::Vec3;

    /// A broken element whose two loose ends meet exactly has length 0; its force must
    /// stay zero and finite, not 0/0 (a 36-digital-fibre shot stopped on that NaN).
    #[test]
    fn a_broken_element_of_zero_length_gives_finite_forces() {
        let material = FibreMaterial::kevlar_km2();
        let l0 = 25e-6;
        let sections = vec![FibreSection::new(
            &material,
            2.4e-9,
            l0,
            InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3),
        )];
        let (mut nodes, mut elements) = (Nodes::default(), Elements::default());
        // nodes 1 and 2 at the same point: the ends of the broken element 1
        let x = [0.0, 1.01 * l0, 1.01 * l0, 2.02 * l0];
        for (along, &xk) in x.iter().enumerate() {
            let last = along + 1 == x.len();
            nodes.push(
                GlobalNodeId(along as u64),
                Vec3::new(xk, 0.0, 0.0),
                Vec3::zeros(),
                1e-12,
                FibreId(0),
                along as u32,
                0,
                false,
                last,
            );
            let failure = if along == 1 { FailureMode::Shear } else { FailureMode::Intact };
            elements.push(l0, 3.9e9, failure);
        }
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        compute_element_tension(&nodes, &mut elements, &sections, &material);
        let mut bending = BendingScratch::default();
        bending.resize(nodes.len());
        crate::bending::compute_bending(&nodes, &elements, &sections, &mut bending);
        let mut forces = Vec::new();
        chain_forces(&nodes, &elements, &bending, None, &mut forces);
        assert!(forces.iter().all(|f| f.iter().all(|c| c.is_finite())), "{forces:?}");
        assert_eq!(elements.axial_force[1], 0.0);
        // the intact neighbours, stretched 1 %, still pull their loose ends back
        let pull = material.longitudinal_modulus * sections[0].area * 0.01;
        assert!((forces[1].x + pull).abs() < 1e-9 * pull && (forces[2].x - pull).abs() < 1e-9 * pull, "{forces:?}");
    }
}
