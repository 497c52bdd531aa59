//! Small domains the kernels' tests (here and in the solver) share.

use crate::contact::NormalLaw;
use crate::domain::{ContactParameters, Domain};
use crate::failure::FailureParameters;
use crate::material::InertiaModel;
use crate::nodes::{Elements, FailureMode, Nodes};
use crate::shear_gauge::ShearMeasure;
use crate::{FibreId, FibreMaterial, FibreSection, GlobalNodeId, Vec3};

/// A reproducible stream of numbers uniform in [0, 1) from `seed` (a linear congruential
/// generator: the tests' random clouds and motions, the same on every machine).
pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A 7-fibre yarn squeezed below its contact diameter, to be shaken so that pairs touch
/// first, stick, slip, unload, part and touch again; `sections` fibre sections (one, or
/// two alternating: the sweep's two ways to its pair data). With `ghosts`, fibres 1, 3
/// and 5 are ghosts, their gids interleaved with the owned ones' (as on a rank of a
/// partitioned yarn).
pub fn squeezed_yarn(sections: usize, ghosts: bool) -> Domain {
    let material = FibreMaterial::kevlar_km2();
    let l0 = 9e-6;
    let sections: Vec<_> = (0..sections)
        .map(|s| {
            FibreSection::new(&material, 1e-9 * (1.0 + 0.3 * s as f64), l0, InertiaModel::None {}.with_friction(0.3))
        })
        .collect();
    let pitch = 0.97 * sections[0].contact_diameter;
    let (mut nodes, mut elements) = (Nodes::default(), Elements::default());
    let centres = [(0.0, 0.0), (1.0, 0.0), (0.5, 0.866), (-0.5, 0.866), (-1.0, 0.0), (-0.5, -0.866), (0.5, -0.866)];
    let per_fibre = 40;
    let is_ghost = |fibre: usize| ghosts && fibre % 2 == 1;
    // owned fibres first, then the ghosts
    for fibre in (0..centres.len()).filter(|&f| !is_ghost(f)).chain((0..centres.len()).filter(|&f| is_ghost(f))) {
        let (y, z) = centres[fibre];
        for along in 0..per_fibre {
            let gid = GlobalNodeId((fibre * per_fibre + along) as u64);
            let position = Vec3::new(along as f64 * l0, y * pitch, z * pitch);
            nodes.push(
                gid,
                position,
                Vec3::zeros(),
                1e-12,
                FibreId(fibre as u32),
                along as u32,
                (fibre % sections.len()) as u16,
                false,
                along + 1 == per_fibre,
            );
            elements.push(l0, 3.4e9, FailureMode::Intact);
        }
    }
    nodes.n_owned = (0..centres.len()).filter(|&f| !is_ghost(f)).count() * per_fibre;
    nodes.link_chains();
    let contact = ContactParameters {
        law: NormalLaw::ElastoPlasticKm2,
        friction_coefficient: 0.3,
        projectile_friction_coefficient: 0.0,
        projectile_friction_spring: crate::friction::FrictionSpring::Rotating,
        fibre_friction_spring: crate::friction::FibreFrictionSpring::Anchored,
        skin: 0.5 * sections[0].contact_diameter,
    };
    let mut domain = Domain::assemble(material, sections, nodes, elements, contact, no_failure(), None, 1e-9);
    domain.rebuild_neighbours().unwrap();
    domain
}

/// Failure off (the seed's shear strength kept for a test that turns it on).
pub fn no_failure() -> FailureParameters {
    FailureParameters {
        shear_strength: 0.7672e9,
        enabled: false,
        shear_measure: ShearMeasure::Element,
        tension_measure: crate::tension_gauge::TensionMeasure::Element,
        unload: crate::failure::Unload::AtBreak,
    }
}

/// The overlap of the pair of list entry `k` of node `i` [m].
pub fn contact_overlap(domain: &Domain, i: usize, k: usize) -> f64 {
    let j = domain.pairs.partner[k] as usize;
    crate::neighbour::contact_distance(&domain.sections, &domain.nodes, i, j)
        - (domain.nodes.position[j] - domain.nodes.position[i]).norm()
}

/// One fibre of digital fibre diameter `diameter` [m] and elements `l0` [m] laid along
/// `shape` (arc length to position), from arc length `-half` to `half` [m].
pub fn fibre_along(
    shape: impl Fn(f64) -> Vec3,
    half: f64,
    l0: f64,
    diameter: f64,
) -> (Nodes, Elements, Vec<FibreSection>) {
    let material = FibreMaterial::kevlar_km2();
    let area = std::f64::consts::PI * diameter * diameter / 4.0;
    let sections =
        vec![FibreSection::new(&material, area, l0, InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3))];
    let count = (2.0 * half / l0).round() as u32 + 1;
    let (mut nodes, mut elements) = (Nodes::default(), Elements::default());
    for along in 0..count {
        let s = -half + along as f64 * l0;
        nodes.push(
            GlobalNodeId(along as u64),
            shape(s),
            Vec3::zeros(),
            1e-12,
            FibreId(0),
            along,
            0,
            false,
            along + 1 == count,
        );
        elements.push(l0, 3.8e9, FailureMode::Intact);
    }
    nodes.n_owned = nodes.len();
    nodes.link_chains();
    (nodes, elements, sections)
}
