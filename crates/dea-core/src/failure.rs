//! Combined tension–shear failure of rod elements, seed eq. (5-6):
//! `(sigma/sigma_u)^2 + (tau/tau_u)^2 > 1`, with `sigma = E eps` (4-16) and `tau = 4Q/(3A)` (5-5),
//! each measured as the parameters say ([`TensionMeasure`], [`ShearMeasure`]),
//! and the failure stage of a step: which owned elements break now, and the strain and bending
//! energy they release.

use crate::bending::{element_shear_force, max_shear_stress, spring_energy, BendingScratch};
use crate::nodes::{Elements, FailureMode, Nodes};
use crate::rod::axial_energy;
use crate::shear_gauge::{gauge_moments, GaugeScratch, ShearMeasure};
use crate::tension_gauge::{gauge_strains, StrainGaugeScratch, TensionMeasure};
use crate::{FibreMaterial, FibreSection, Vec3};

/// Failure parameters shared by all elements (the tensile strength is per element).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FailureParameters {
    /// fibre shear strength tau_u [Pa] (seed §5.2.2: 0.7672 GPa)
    pub shear_strength: f64,
    /// false disables failure entirely (elastic verification runs)
    pub enabled: bool,
    /// how an element's shear force is measured ([`ShearMeasure`])
    pub shear_measure: ShearMeasure,
    /// how an element's tension is measured ([`TensionMeasure`])
    pub tension_measure: TensionMeasure,
    /// when an element that breaks stops acting ([`Unload`])
    pub unload: Unload,
}

/// When a broken element's forces leave its nodes (docs/theory.md I7). The failure stage
/// reads the strains and moments of the forces just computed, so an element found broken
/// has already loaded its nodes for the step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Unload {
    /// in the step of the break: its axial force and the springs it disables are taken out
    /// of the step's forces before the closing kick, so an element whose energy is booked as
    /// released does no more work (the default)
    #[default]
    AtBreak,
    /// from the next step on: the element's forces of the step of its break stay for that
    /// step's closing half-kick and the next one's opening (the order of every result before
    /// the choice was named, kept to reproduce them)
    NextStep,
}

impl Unload {
    /// The name a case gives it (`failure.unload`).
    pub fn name(self) -> &'static str {
        match self {
            Unload::AtBreak => "at_break",
            Unload::NextStep => "next_step",
        }
    }

    /// The choice of a name, if it is one.
    pub fn from_name(name: &str) -> Option<Self> {
        [Unload::AtBreak, Unload::NextStep].into_iter().find(|u| u.name() == name)
    }
}

impl FailureParameters {
    /// How many positions along a fibre, beyond the element's own two and the next element's,
    /// the failure stage reads about an owned element: the widest gauge reach over `sections`
    /// (a tension gauge reaching `q` elements reads `q - 1` positions beyond those, a shear
    /// gauge reaching `r` nodes `r`; the larger count serves both).
    pub fn stencil_beyond_element(&self, sections: &[FibreSection]) -> u32 {
        if !self.enabled {
            return 0;
        }
        let reach =
            |s: &FibreSection| self.shear_measure.reach(s).max(self.tension_measure.reach(s));
        sections.iter().map(reach).max().unwrap_or(0)
    }
}

/// Classifies a state against (5-6); `None` while the element survives.
/// Compression does not break a fibre (sigma counts only when positive).
#[inline]
pub fn combined_criterion(sigma: f64, sigma_u: f64, tau: f64, tau_u: f64) -> Option<FailureMode> {
    let tension = (sigma.max(0.0) / sigma_u).powi(2);
    let shear = (tau / tau_u).powi(2);
    let total = tension + shear;
    if total <= 1.0 {
        return None;
    }
    Some(if shear < 0.1 * total {
        FailureMode::Tension
    } else if tension < 0.1 * total {
        FailureMode::Shear
    } else {
        FailureMode::Combined
    })
}

/// Broken elements by mode, cumulative.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrokenCount {
    /// broken in tension (the shear term below 10 % of the criterion)
    pub tension: u64,
    /// broken in shear (the tension term below 10 % of the criterion)
    pub shear: u64,
    /// broken with both terms of the combined criterion significant
    pub combined: u64,
}

impl BrokenCount {
    /// Every broken element.
    pub fn total(&self) -> u64 {
        self.tension + self.shear + self.combined
    }

    fn book(&mut self, mode: FailureMode) {
        match mode {
            FailureMode::Tension => self.tension += 1,
            FailureMode::Shear => self.shear += 1,
            _ => self.combined += 1,
        }
    }
}

/// The failure stage: applies the combined criterion (5-6) to the owned elements in `firing`
/// (ascending ranges of local indices: all of them, or at a multi-rate instant those of the
/// sections whose terms fire, [`crate::multi_rate`]; the gauges are taken over the same
/// ranges) with this step's strains (`elements`, taken as the parameters' tension measure says
/// into the scratch `measured_strain`) and moments (`bending`, taken as the parameters' shear
/// measure says into the scratch `measured_moment`), counts the broken ones in `broken`, books the
/// strain and bending energy each releases in `fracture_released` [J] at its first node, and
/// then marks them broken. `newly_broken` is scratch. The decisions read only this step's
/// state, so every rank that holds an element's stencil decides it alike.
#[allow(clippy::too_many_arguments)]
pub fn break_elements(
    nodes: &Nodes,
    elements: &mut Elements,
    bending: &BendingScratch,
    sections: &[FibreSection],
    material: &FibreMaterial,
    parameters: &FailureParameters,
    fracture_released: &mut [f64],
    broken: &mut BrokenCount,
    newly_broken: &mut Vec<(u32, FailureMode)>,
    measured_moment: &mut GaugeScratch,
    measured_strain: &mut StrainGaugeScratch,
    firing: &[std::ops::Range<usize>],
) {
    newly_broken.clear();
    if !parameters.enabled {
        return;
    }
    let moment: &[Vec3] = match parameters.shear_measure {
        ShearMeasure::Element => &bending.moment,
        measure => {
            gauge_moments(nodes, elements, &bending.moment, sections, measure, measured_moment, firing);
            &measured_moment.gauge_moment
        }
    };
    let strain: &[f64] = match parameters.tension_measure {
        TensionMeasure::Element => &elements.strain,
        measure => {
            gauge_strains(nodes, elements, sections, measure, measured_strain, firing);
            &measured_strain.gauge_strain
        }
    };
    let (modulus, shear_strength) = (material.longitudinal_modulus, parameters.shear_strength);
    let breaks_now = |elements: &Elements, i: usize| {
        element_breaks(nodes, elements, strain, moment, sections, modulus, shear_strength, i)
    };
    let mut book_if_broken = |i: usize| {
        if let Some(mode) = breaks_now(elements, i) {
            newly_broken.push((i as u32, mode));
            broken.book(mode);
        }
    };
    for range in firing {
        let (mut i, end) = (range.start, range.end.min(nodes.n_owned));
        // almost no element is near breaking: four at a time are told so in lanes; a group
        // reads the moment after its last element
        while i + 4 <= end && i + 5 <= moment.len() {
            let Some(candidates) = crate::in_avx2_lanes!(may_break_in_lanes(
                nodes,
                elements,
                strain,
                moment,
                sections,
                modulus,
                shear_strength,
                i
            )) else {
                break;
            };
            for k in (i..i + 4).filter(|k| candidates & (1 << (k - i)) != 0) {
                book_if_broken(k);
            }
            i += 4;
        }
        for i in i..end {
            book_if_broken(i);
        }
    }
    for &(i, _) in newly_broken.iter() {
        let i = i as usize;
        let next = nodes.next[i] as usize;
        // strain energy of the element itself (evaluated as if intact)
        let area = sections[nodes.section[i] as usize].area;
        let mut released = axial_energy(material, area, elements.rest_length[i], elements.strain[i]);
        // the spring at the first node, and the one at the second unless the element
        // after it also breaks now (then that element books it). Failure states are
        // applied after this loop, so for an owned or a ghost next element alike the
        // criterion answers from this step's state, as its owner decides it.
        released += spring_energy(nodes, bending, sections, i);
        if breaks_now(elements, next).is_none() {
            released += spring_energy(nodes, bending, sections, next);
        }
        fracture_released[i] += released;
    }
    for &(i, mode) in newly_broken.iter() {
        elements.failure[i as usize] = mode;
    }
}

/// How element `i` breaks now under (5-6), if it does: tension `E_L eps` (4-16) of its
/// `strain` [-] (the elements' own, or the gauge strains of [`gauge_strains`]) and the
/// shear stress (5-5) of its shear force, the jump of `moment` [N m] along it (5-4: the
/// springs' moments, or the gauge moments of [`gauge_moments`]), against its strengths [Pa].
#[allow(clippy::too_many_arguments)]
pub fn element_breaks(
    nodes: &Nodes,
    elements: &Elements,
    strain: &[f64],
    moment: &[Vec3],
    sections: &[FibreSection],
    longitudinal_modulus: f64,
    shear_strength: f64,
    i: usize,
) -> Option<FailureMode> {
    if !elements.is_intact(nodes, i) {
        return None;
    }
    let sigma = longitudinal_modulus * strain[i]; // (4-16)
    let area = sections[nodes.section[i] as usize].area;
    let tau = max_shear_stress(element_shear_force(nodes, elements, moment, i), area);
    combined_criterion(sigma, elements.tensile_strength[i], tau, shear_strength)
}

/// Which of elements `i..i + 4` may break now (bit `l` for element `i + l`): the criterion
/// (5-6) of [`element_breaks`] in four lanes, leaving to that scalar test every element
/// within a margin of the boundary far wider than the lanes' rounding, every NaN, and every
/// element not intact between consecutive nodes. So the elements it leaves out are ones the
/// scalar test keeps, and the same elements break.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn may_break_in_lanes(
    nodes: &Nodes,
    elements: &Elements,
    strain: &[f64],
    moment: &[Vec3],
    sections: &[FibreSection],
    longitudinal_modulus: f64,
    shear_strength: f64,
    i: usize,
) -> u32 {
    use crate::lanes::{F4, V4};
    let plain = (0..4)
        .filter(|&l| nodes.next[i + l] == (i + l) as u32 + 1 && elements.failure[i + l] == FailureMode::Intact)
        .fold(0, |bits, l| bits | 1 << l);
    let sigma = F4::splat(longitudinal_modulus).mul(F4::load(strain, i));
    let tension = sigma.max_with(F4::splat(0.0)).div(F4::load(&elements.tensile_strength, i));
    // (5-4), (5-5): the shear force from the jump of the moment along the element
    let jump = V4::load(moment, i).sub(V4::load(moment, i + 1));
    let shear_force = jump.dot(jump).sqrt().div(F4::load(&elements.rest_length, i));
    let area = F4::gather(i, |k| sections[nodes.section[k] as usize].area);
    let shear = F4::splat(4.0).mul(shear_force).div(F4::splat(3.0).mul(area)).div(F4::splat(shear_strength));
    let total = tension.mul(tension).add(shear.mul(shear));
    let clear = total.lt(F4::splat(1.0 - 1e-9)).bits();
    !(clear & plain) & 0b1111
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The centre fibre of the squeezed yarn with bending springs, element 10 stretched 10 %
    /// (beyond 3.4 GPa) and node 12 pushed aside so the springs about it act; the rods and
    /// the fibre contacts have set the step's forces. With `broken_before`, element 10 is
    /// marked broken first (the step after its break).
    fn stretched_fibre(unload: Unload, broken_before: bool) -> crate::Domain {
        let mut domain = crate::fixtures::squeezed_yarn(1, false);
        domain.sections[0].torsional_stiffness = 1e-5;
        domain.failure.enabled = true;
        domain.failure.unload = unload;
        domain.phase = crate::domain::Phase::Shot;
        let l0 = domain.elements.rest_length[0];
        for i in (11..40).filter(|&i| domain.nodes.fibre[i].0 == 0) {
            domain.nodes.position[i].x += 0.1 * l0;
        }
        domain.nodes.position[12].y += 0.02 * l0;
        if broken_before {
            domain.elements.failure[10] = FailureMode::Tension;
        }
        domain.add_rod_forces();
        domain.add_fibre_contacts();
        domain
    }

    #[test]
    fn an_element_unloaded_at_its_break_leaves_the_forces_of_its_step() {
        let after = stretched_fibre(Unload::AtBreak, true);
        let mut breaking = stretched_fibre(Unload::AtBreak, false);
        let loaded = breaking.nodes.force.clone();
        breaking.break_elements();
        assert!(breaking.unloads_now());
        assert_eq!(breaking.elements.failure[10], FailureMode::Tension);
        breaking.unload_broken();
        let largest = after.nodes.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
        for i in 0..breaking.nodes.n_owned {
            let (now, fresh) = (breaking.nodes.force[i], after.nodes.force[i]);
            assert!((now - fresh).norm() <= 1e-12 * largest, "node {i}: {now:?} against {fresh:?}");
            // only the nodes the element and its two springs reach change
            assert_eq!(now == loaded[i], !(9..=12).contains(&i), "node {i}");
        }
        // the spring at node 11 acted before the break, and is gone
        assert!((loaded[11] - after.nodes.force[11]).norm() > 1e-3 * largest);

        // the seed's order keeps them for the step
        let mut next = stretched_fibre(Unload::NextStep, false);
        next.break_elements();
        assert_eq!(next.elements.failure[10], FailureMode::Tension);
        assert!(!next.unloads_now());
        next.unload_broken();
        assert_eq!(next.nodes.force, loaded);
    }

    #[test]
    fn criterion_on_its_boundary() {
        let (su, tu) = (3.8e9, 0.7672e9);
        // exactly on the ellipse: survives; just outside: fails
        for angle in [0.0f64, 0.3, std::f64::consts::FRAC_PI_4, 1.2, std::f64::consts::FRAC_PI_2] {
            let (sigma, tau) = (su * angle.cos(), tu * angle.sin());
            assert_eq!(combined_criterion(sigma * (1.0 - 1e-9), su, tau * (1.0 - 1e-9), tu), None, "inside at {angle}");
            assert!(
                combined_criterion(sigma * (1.0 + 1e-9) + 1.0, su, tau * (1.0 + 1e-9), tu).is_some(),
                "outside at {angle}"
            );
        }
        assert_eq!(combined_criterion(su * 1.01, su, 0.0, tu), Some(FailureMode::Tension));
        assert_eq!(combined_criterion(0.0, su, tu * 1.01, tu), Some(FailureMode::Shear));
        assert_eq!(combined_criterion(su * 0.8, su, tu * 0.8, tu), Some(FailureMode::Combined));
        assert_eq!(combined_criterion(-10.0 * su, su, 0.0, tu), None, "compression does not break");
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_lanes_leave_out_only_elements_the_scalar_test_keeps() {
        if !crate::dispatch::Compilation::Avx2.runs() {
            return;
        }
        use crate::material::InertiaModel;
        use crate::{FibreId, GlobalNodeId, Vec3};
        let material = FibreMaterial::kevlar_km2();
        let l0 = 25e-6;
        let sections = vec![
            FibreSection::new(&material, 2.4e-9, l0, InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3)),
            FibreSection::new(&material, 1.2e-9, l0, InertiaModel::None {}.with_friction(0.3)),
        ];
        let (shear_strength, strength) = (0.7672e9, 3.4e9);
        let mut state = 5u64;
        let mut uniform = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut nodes, mut elements, mut bending) = (Nodes::default(), Elements::default(), BendingScratch::default());
        let per_fibre = 203;
        for fibre in 0..5u32 {
            for along in 0..per_fibre {
                let gid = GlobalNodeId((fibre * per_fibre + along) as u64);
                nodes.push(
                    gid,
                    Vec3::new(along as f64 * l0, fibre as f64 * 1e-4, 0.0),
                    Vec3::zeros(),
                    1e-12,
                    FibreId(fibre),
                    along,
                    (fibre % 2) as u16,
                    false,
                    along + 1 == per_fibre,
                );
                let failure = if along % 37 == 5 { FailureMode::Tension } else { FailureMode::Intact };
                elements.push(l0, strength * (0.9 + 0.2 * uniform()), failure);
            }
        }
        nodes.link_chains();
        let n = nodes.len();
        let area = |k: usize| sections[nodes.section[k] as usize].area;
        // the moment jumps by the drawn shear force along each element (5-4)
        let mut moment = Vec3::zeros();
        for k in 0..n {
            // states spread over the criterion, a quarter within rounding of its boundary, some NaN
            let (tension, shear) = (uniform(), uniform());
            let scale = match k % 4 {
                0 => 1.0 + (uniform() - 0.5) * 1e-13,
                _ => 2.0 * uniform(),
            } / (tension * tension + shear * shear).sqrt();
            let sigma = tension * scale * elements.tensile_strength[k];
            elements.strain[k] = if k % 53 == 7 { f64::NAN } else { sigma / material.longitudinal_modulus };
            let shear_force = shear * scale * shear_strength * 3.0 * area(k) / 4.0;
            bending.moment.push(moment);
            moment -= Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize() * shear_force * l0;
        }
        let (mut breaking, mut candidates) = (0, 0);
        for i in (0..n - 4).step_by(4) {
            let bits = crate::in_avx2_lanes!(may_break_in_lanes(
                &nodes,
                &elements,
                &elements.strain,
                &bending.moment,
                &sections,
                material.longitudinal_modulus,
                shear_strength,
                i
            ))
            .expect("AVX2 is present");
            for k in i..i + 4 {
                let breaks = element_breaks(
                    &nodes,
                    &elements,
                    &elements.strain,
                    &bending.moment,
                    &sections,
                    material.longitudinal_modulus,
                    shear_strength,
                    k,
                )
                .is_some();
                assert!(!breaks || bits & (1 << (k - i)) != 0, "element {k} breaks but the lanes left it out");
                breaking += breaks as usize;
                candidates += (bits & (1 << (k - i)) != 0) as usize;
            }
        }
        assert!(
            breaking > n / 4 && candidates < 3 * n / 4,
            "{breaking} break, {candidates} of {n} left to the scalar test"
        );
    }
}
