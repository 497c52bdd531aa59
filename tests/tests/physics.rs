//! Physics validation of the core against closed forms and seed §6.1, stepped by the
//! production step on one rank ([`Distributed::whole`]).

use dea_core::contact::NormalLaw;
use dea_core::domain::ContactParameters;
use dea_core::failure::FailureParameters;
use dea_core::friction::FrictionSpring;
use dea_core::material::InertiaModel;
use dea_core::projectile::{RigidProjectile, RigidShape};
use dea_core::shear_gauge::ShearMeasure;
use dea_core::stability::stable_time_step;
use dea_core::{Domain, FibreMaterial, Vec3};
use dea_fabric::StraightFabric;
use dea_mpi::comm::local::LocalComm;
use dea_mpi::distributed::Distributed;
use nalgebra::{Rotation3, UnitQuaternion};

const NO_FAILURE: FailureParameters = FailureParameters {
    shear_strength: 0.7672e9,
    enabled: false,
    shear_measure: ShearMeasure::Element,
    tension_measure: dea_core::tension_gauge::TensionMeasure::Element,
    unload: dea_core::failure::Unload::AtBreak,
};

fn elastic_frictionless(material: &FibreMaterial) -> ContactParameters {
    ContactParameters {
        law: NormalLaw::Elastic { transverse_modulus: material.transverse_modulus },
        friction_coefficient: 0.0,
        projectile_friction_coefficient: 0.0,
        projectile_friction_spring: FrictionSpring::Rotating,
        fibre_friction_spring: dea_core::friction::FibreFrictionSpring::Anchored,
        skin: 5e-6,
    }
}

/// The seed §6.1 fibre: 0.1016 m KM2, 50 µm, ends fixed, optionally struck at its centre by
/// the 5.56 mm, 5e-6 kg sphere at 100 m/s.
fn single_fibre(element_length_ratio: f64, with_sphere: bool, inertia: InertiaModel) -> Distributed<LocalComm> {
    let material = FibreMaterial::kevlar_km2();
    let diameter: f64 = 50e-6;
    let bundle = StraightFabric::single_yarn(
        0.1016,
        1,
        std::f64::consts::PI * diameter * diameter / 4.0,
        element_length_ratio,
        inertia.with_friction(0.3),
        3.8e9,
    );
    let built = bundle.build_all(&material);
    let contact = elastic_frictionless(&material);
    let stable = stable_time_step(
        &material,
        &built.sections,
        &contact.law,
        0.0,
        dea_core::stability::DESIGN_CONTACT_STRAIN,
        0.5,
    );
    // the run's step: at l0/d 0.125 the bending zigzag's bound (docs/theory.md I11c)
    let (dt, _) = dea_core::stability::run_time_step(&material, &built.sections, stable);
    let projectile = with_sphere.then(|| {
        let radius = 5.56e-3 / 2.0;
        let start = radius + 0.5 * built.sections[0].contact_diameter + 1e-7;
        RigidProjectile::new(
            RigidShape::Sphere { radius },
            5e-6,
            Vec3::new(0.0, 0.0, start),
            Vec3::new(0.0, 0.0, -100.0),
            UnitQuaternion::identity(),
        )
    });
    whole(Domain::assemble(material, built.sections, built.nodes, built.elements, contact, NO_FAILURE, projectile, dt))
}

/// A whole domain on one rank, its lists and initial forces made.
fn whole(domain: Domain) -> Distributed<LocalComm> {
    Distributed::whole(domain).unwrap()
}

/// Time at which `signal` first crosses `level`, linearly interpolated between steps.
fn crossing_time(history: &[(f64, f64)], level: f64) -> f64 {
    let k = history.iter().position(|&(_, s)| s >= level).expect("the front arrives");
    let ((t0, s0), (t1, s1)) = (history[k - 1], history[k]);
    t0 + (level - s0) / (s1 - s0) * (t1 - t0)
}

#[test]
fn longitudinal_wave_travels_at_bar_speed_and_doubles_at_a_fixed_end() {
    let mut run = single_fibre(0.5, false, InertiaModel::None {});
    let domain = &mut run.domain;
    let n = domain.nodes.len();
    // pull the left end at constant speed: a huge mass is a prescribed velocity
    let pull = 1.0;
    domain.nodes.clamped[0] = false;
    domain.nodes.mass[0] = 1e30;
    domain.nodes.velocity[0] = Vec3::new(-pull, 0.0, 0.0);
    let c = domain.material.wave_speed();
    let incident = pull / c;
    let (a, b) = (n / 4, n / 2);
    let (xa, xb) = (domain.nodes.position[a].x, domain.nodes.position[b].x);
    let mut history_a = Vec::new();
    let mut history_b = Vec::new();
    let length = 0.1016;
    while run.domain.time < 1.3 * length / c {
        run.step().unwrap();
        history_a.push((run.domain.time, run.domain.elements.strain[a]));
        history_b.push((run.domain.time, run.domain.elements.strain[b]));
    }
    let domain = &run.domain;
    let speed = (xb - xa) / (crossing_time(&history_b, 0.5 * incident) - crossing_time(&history_a, 0.5 * incident));
    eprintln!("wave speed {speed:.1} m/s against sqrt(E/rho) = {c:.1} m/s ({:+.3}%)", 100.0 * (speed / c - 1.0));
    assert!((speed / c - 1.0).abs() < 0.01, "wave speed {speed} vs sqrt(E/rho) = {c}");
    // after reflection at the clamped right end, the strain there is twice the incident one
    let tail = n - 1 - n / 10..n - 1;
    let reflected: f64 = tail.clone().map(|i| domain.elements.strain[i]).sum::<f64>() / tail.len() as f64;
    eprintln!("strain at the fixed end after reflection: {:.4} x the incident strain", reflected / incident);
    assert!((reflected / (2.0 * incident) - 1.0).abs() < 0.03, "reflected {reflected} vs 2 x {incident}");
}

#[test]
fn a_deferred_closing_kick_changes_no_bit_of_the_motion_or_the_energies() {
    // the fibre struck by the sphere, stepped with its closing kicks applied at once and with
    // them deferred to the next step's first pass (the production step's way)
    let mut at_once = single_fibre(0.5, true, InertiaModel::Locked {});
    at_once.domain.defer_closing_kick = false;
    let mut deferred = single_fibre(0.5, true, InertiaModel::Locked {});
    let bits = |vectors: &mut dyn Iterator<Item = Vec3>| {
        vectors.flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).collect::<Vec<u64>>()
    };
    let mut lagged = 0;
    for step in 0..400 {
        at_once.step().unwrap();
        deferred.step().unwrap();
        let (at_once, deferred) = (&at_once.domain, &deferred.domain);
        assert_eq!(
            bits(&mut deferred.nodes.position.iter().copied()),
            bits(&mut at_once.nodes.position.iter().copied()),
            "step {step}"
        );
        let n = deferred.nodes.n_owned;
        assert_eq!(
            bits(&mut (0..n).map(|i| deferred.velocity(i))),
            bits(&mut at_once.nodes.velocity[..n].iter().copied()),
            "step {step}"
        );
        assert_eq!(deferred.energies().total().to_bits(), at_once.energies().total().to_bits(), "step {step}");
        lagged += (0..n).filter(|&i| deferred.nodes.velocity[i] != at_once.nodes.velocity[i]).count();
    }
    // the deferred velocities were half a step behind: the test compared two different paths
    assert!(lagged > 0);
}

#[test]
fn elastic_frictionless_fibre_struck_by_sphere_conserves_energy() {
    let mut run = single_fibre(0.5, true, InertiaModel::Locked {});
    let initial = run.domain.energies().total();
    let mut worst: f64 = 0.0;
    let mut worst_of_exchanged: f64 = 0.0;
    let mut peak_contact: f64 = 0.0;
    for step in 0..10_000 {
        run.step().unwrap();
        if step % 50 == 0 {
            let report = run.domain.energies();
            let drift = (report.total() - initial).abs();
            worst = worst.max(drift / initial);
            // the projectile holds most of the energy: judge the drift against what it gave away too
            let exchanged = initial - report.projectile_kinetic;
            if exchanged > 1e-3 * initial {
                worst_of_exchanged = worst_of_exchanged.max(drift / exchanged);
            }
            peak_contact = peak_contact.max(report.contact);
        }
    }
    let report = run.domain.energies();
    eprintln!(
        "energy drift over 10^4 steps: {worst:.2e} of the total, {worst_of_exchanged:.2e} of the energy exchanged"
    );
    assert!(peak_contact > 0.0 && report.axial > 1e-3 * initial, "the sphere really loads the fibre: {report:?}");
    assert!(report.projectile_kinetic < 0.999 * initial, "the sphere slows down");
    assert!(worst < 0.005, "energy drift {worst} of the total");
    assert!(worst_of_exchanged < 0.005, "energy drift {worst_of_exchanged} of the energy exchanged");
}

/// Seed §6.1: stress profiles for l0/d = 0.5 and 0.125 agree. The seed records them at
/// output steps 5…40 with the wave reaching the fixed end between steps 30 and 40; here the
/// instants are those fractions of the transit time (L/2)/c.
#[test]
fn section_6_1_stress_profiles_converge_in_element_length() {
    let mut coarse = single_fibre(0.5, true, InertiaModel::Effective { k1: 0.8, k2: 1.0 });
    let mut fine = single_fibre(0.125, true, InertiaModel::Effective { k1: 0.8, k2: 1.0 });
    let ratio = (coarse.domain.sections[0].element_length / fine.domain.sections[0].element_length).round() as usize;
    assert_eq!(ratio, 4);
    let transit = 0.5 * 0.1016 / coarse.domain.material.wave_speed();
    for output_step in [10.0, 20.0, 30.0, 40.0] {
        let instant = output_step / 35.0 * transit;
        for run in [&mut coarse, &mut fine] {
            while run.domain.time + run.domain.time_step <= instant {
                run.step().unwrap();
            }
        }
        let coarse_stress = coarse.domain.element_stress();
        let fine_stress = fine.domain.element_stress();
        let (mut difference, mut norm) = (0.0, 0.0);
        for (e, &sigma) in coarse_stress.iter().enumerate().filter(|(_, s)| s.is_finite()) {
            let averaged: f64 = fine_stress[e * ratio..(e + 1) * ratio].iter().sum::<f64>() / ratio as f64;
            difference += (sigma - averaged).powi(2);
            norm += averaged * averaged;
        }
        let relative = (difference / norm).sqrt();
        eprintln!(
            "§6.1 output step {output_step}: l0/d 0.5 and 0.125 stress profiles differ by {:.2}% (relative L2)",
            100.0 * relative
        );
        assert!(norm > 0.0);
        assert!(relative < 0.05, "output step {output_step}: profiles differ by {:.1}%", 100.0 * relative);
    }
}

/// A 7-fibre bundle, squeezed and sheared so that contacts, friction and bending all act.
fn loaded_bundle(rotation: &Rotation3<f64>) -> Domain {
    let material = FibreMaterial::kevlar_km2();
    let bundle = StraightFabric {
        clamp_ends: false,
        ..StraightFabric::single_yarn(1.5e-3, 7, 4.63e-8 / 7.0, 0.5, InertiaModel::Locked {}.with_friction(0.3), 3.8e9)
    };
    let mut built = bundle.build_all(&material);
    // squeeze the section by 3% and bend the fibres: overlaps everywhere
    for p in &mut built.nodes.position {
        *p = Vec3::new(p.x, 0.97 * p.y + 1e-3 * (p.x * 2000.0).sin() * 1e-2, 0.97 * p.z);
    }
    for p in &mut built.nodes.position {
        *p = rotation * *p;
    }
    let contact = ContactParameters {
        law: NormalLaw::ElastoPlasticKm2,
        friction_coefficient: 0.3,
        projectile_friction_coefficient: 0.3,
        projectile_friction_spring: FrictionSpring::Rotating,
        fibre_friction_spring: dea_core::friction::FibreFrictionSpring::Anchored,
        skin: 5e-6,
    };
    let mut run =
        whole(Domain::assemble(material, built.sections, built.nodes, built.elements, contact, NO_FAILURE, None, 1e-9));
    let domain = &mut run.domain;
    // a tangential shift of every other fibre activates friction against the first anchors
    for i in 0..domain.nodes.len() {
        if domain.nodes.fibre[i].0 % 2 == 1 {
            domain.nodes.position[i] += rotation * Vec3::new(2e-7, 0.0, 0.0);
        }
    }
    let instant = run.domain.step;
    dea_mpi::step::compute_forces(&mut run.domain, &mut run.timer, instant).unwrap();
    run.domain
}

#[test]
fn internal_forces_sum_to_zero_and_rotate_with_the_body() {
    let identity = Rotation3::identity();
    let reference = loaded_bundle(&identity);
    let total: Vec3 = reference.nodes.force.iter().sum();
    let scale: f64 = reference.nodes.force.iter().map(|f| f.norm()).sum();
    assert!(scale > 0.0 && reference.pairs.touching.iter().any(|&t| t));
    assert!(total.norm() < 1e-12 * scale, "net internal force {total:?} of {scale}");
    let rotation = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    let rotated = loaded_bundle(&rotation);
    for i in 0..reference.nodes.len() {
        let expected = rotation * reference.nodes.force[i];
        assert!(
            (rotated.nodes.force[i] - expected).norm()
                < 1e-9 * scale / reference.nodes.len() as f64 + 1e-9 * expected.norm(),
            "node {i}"
        );
    }
}

/// A panel tiled from a relaxed cell starts in equilibrium in the solver: its interior nodes
/// (a cell away from the fixed edges) feel no more force than the relaxation left, with the
/// solver's own rods, bending springs, contact lists and the KM2 law, across stacked and
/// shifted layers. The panel's thickness is the cell's, stacked touching.
#[test]
fn a_woven_panel_starts_in_the_equilibrium_of_its_relaxed_cell() {
    use dea_fabric::panel::{Boundary, Tiling, WovenPanel};
    use dea_fabric::relax::{relax, RelaxOptions};
    use dea_fabric::weave::PlainWeave;
    let material = FibreMaterial::kevlar_km2();
    let law = NormalLaw::ElastoPlasticKm2;
    let mut cell = PlainWeave::km2_style_706(4).unit_cell(&material).unwrap();
    let report = relax(
        &mut cell,
        &material,
        &law,
        &RelaxOptions { tolerance: 1e-7, max_iterations: 100_000, ..Default::default() },
    )
    .unwrap();
    let period = cell.period();
    let panel = WovenPanel::new(
        std::sync::Arc::new(cell),
        None,
        5,
        2,
        0.0,
        [0.3 * period, 0.1 * period],
        Boundary::FixedEdges,
        3.8e9,
    );
    let built = panel.build_all(&material);
    let contact = ContactParameters {
        law,
        friction_coefficient: 0.3,
        projectile_friction_coefficient: 0.3,
        projectile_friction_spring: FrictionSpring::Rotating,
        fibre_friction_spring: dea_core::friction::FibreFrictionSpring::Anchored,
        skin: 5e-6,
    };
    let dt = stable_time_step(&material, &built.sections, &contact.law, 0.3, 0.5, 0.5);
    let domain =
        whole(Domain::assemble(material, built.sections, built.nodes, built.elements, contact, NO_FAILURE, None, dt))
            .domain;
    let nodes = &domain.nodes;
    let (centre, half) = (panel.plan_centre(), 0.5 * panel.side() - period);
    let interior: Vec<usize> = (0..nodes.n_owned)
        .filter(|&i| (nodes.position[i].x - centre).abs() < half && (nodes.position[i].y - centre).abs() < half)
        .collect();
    assert!(interior.len() > nodes.n_owned / 5);
    let largest = interior.iter().map(|&i| nodes.force[i].norm()).fold(0.0, f64::max);
    assert!(
        largest < 10.0 * report.final_residual_n,
        "largest interior force {largest:.3e} N, relaxation left {:.3e} N",
        report.final_residual_n
    );
    // and the layers do touch: some node pair across them is in contact range
    assert!(report.final_residual_n < 1e-6 * report.initial_residual_n);
}

/// A panel tiled from a relaxed 3-D woven cell starts, away from its edges, in the
/// equilibrium of the cell: the solver's forces at interior nodes of both stacked panels are
/// the relaxation's residual (docs/theory.md F11).
#[test]
fn a_3d_woven_panel_starts_in_the_equilibrium_of_its_relaxed_cell() {
    use dea_fabric::panel::{Boundary, Tiling};
    use dea_fabric::relax::{relax, BendingAtRest, RelaxOptions};
    use dea_fabric::tiled::TiledPanel;
    use dea_fabric::weave3d::{Pattern, ThreeDWeave, YarnKind};
    let material = FibreMaterial::kevlar_km2();
    let law = NormalLaw::ElastoPlasticKm2;
    let yarn = YarnKind { area_m2: 4.63e-8, section_aspect: 3.0 };
    let weave = ThreeDWeave::of_pattern(
        Pattern::Orthogonal,
        2,
        1.0e-3,
        0.8e-3,
        yarn,
        4,
        yarn,
        YarnKind { area_m2: 2.315e-8, section_aspect: 2.0 },
    );
    let mut cell = weave.unit_cell(&material).unwrap();
    let report = relax(
        &mut cell,
        &material,
        &law,
        &RelaxOptions { tolerance: 1e-7, max_iterations: 400_000, bending_at_rest: BendingAtRest::Straight },
    )
    .unwrap();
    let period = cell.period;
    let panel = TiledPanel::new(std::sync::Arc::new(cell), [4, 3], 2, 0.0, [0.0, 0.0], Boundary::FixedEdges, 3.8e9);
    let built = panel.build_all(&material);
    let contact = ContactParameters {
        law,
        friction_coefficient: 0.3,
        projectile_friction_coefficient: 0.3,
        projectile_friction_spring: FrictionSpring::Rotating,
        fibre_friction_spring: dea_core::friction::FibreFrictionSpring::Anchored,
        skin: 5e-6,
    };
    let dt = stable_time_step(&material, &built.sections, &contact.law, 0.3, 0.5, 0.5);
    let domain =
        whole(Domain::assemble(material, built.sections, built.nodes, built.elements, contact, NO_FAILURE, None, dt))
            .domain;
    let nodes = &domain.nodes;
    let half = panel.size().map(|s| 0.5 * s);
    let interior: Vec<usize> = (0..nodes.n_owned)
        .filter(|&i| nodes.position[i].x.abs() < half[0] - period[0] && nodes.position[i].y.abs() < half[1] - period[1])
        .collect();
    assert!(interior.len() > nodes.n_owned / 10);
    let largest = interior.iter().map(|&i| nodes.force[i].norm()).fold(0.0, f64::max);
    assert!(
        largest < 10.0 * report.final_residual_n,
        "largest interior force {largest:.3e} N, relaxation left {:.3e} N",
        report.final_residual_n
    );
}

/// A woven fibre's bending springs rest in its relaxed crimp: the panel starts without
/// bending moments, so without shear stress (5-4, 5-5); with springs straight at rest the
/// crimp holds them bent and the elements start sheared (docs/theory.md F4).
#[test]
fn woven_fibres_rest_in_their_crimp_unless_asked_to_rest_straight() {
    use dea_fabric::panel::{Boundary, Tiling, WovenPanel};
    use dea_fabric::relax::{relax, BendingAtRest, RelaxOptions};
    use dea_fabric::weave::PlainWeave;
    let material = FibreMaterial::kevlar_km2();
    let law = NormalLaw::ElastoPlasticKm2;
    let largest_shear = |bending_at_rest| {
        let mut cell = PlainWeave::km2_style_706(1).unit_cell(&material).unwrap();
        relax(&mut cell, &material, &law, &RelaxOptions { tolerance: 1e-7, max_iterations: 100_000, bending_at_rest })
            .unwrap();
        let panel =
            WovenPanel::new(std::sync::Arc::new(cell), None, 3, 1, 0.0, [0.0, 0.0], Boundary::FixedEdges, 3.8e9);
        let built = panel.build_all(&material);
        let area = built.sections[0].area;
        let contact = ContactParameters {
            law,
            friction_coefficient: 0.3,
            projectile_friction_coefficient: 0.3,
            projectile_friction_spring: FrictionSpring::Rotating,
            fibre_friction_spring: dea_core::friction::FibreFrictionSpring::Anchored,
            skin: 5e-6,
        };
        let dt = stable_time_step(&material, &built.sections, &contact.law, 0.3, 0.5, 0.5);
        let domain = whole(Domain::assemble(
            material.clone(),
            built.sections,
            built.nodes,
            built.elements,
            contact,
            NO_FAILURE,
            None,
            dt,
        ))
        .domain;
        let nodes = &domain.nodes;
        (0..nodes.n_owned)
            .filter(|&i| {
                nodes.prev[i] != dea_core::NONE
                    && nodes.next[i] != dea_core::NONE
                    && nodes.next[nodes.next[i] as usize] != dea_core::NONE
            })
            .map(|i| {
                dea_core::bending::max_shear_stress(
                    dea_core::bending::element_shear_force(nodes, &domain.elements, &domain.bending.moment, i),
                    area,
                )
            })
            .fold(0.0, f64::max)
    };
    let (as_woven, straight) = (largest_shear(BendingAtRest::AsWoven), largest_shear(BendingAtRest::Straight));
    assert!(as_woven < 1e-6 * 0.7672e9, "as woven: {as_woven:.3e} Pa");
    assert!(straight > 0.3 * 0.7672e9, "straight at rest: {straight:.3e} Pa");
}

/// A straight yarn of `fine` digital fibres (x < 0) continued by one of `coarse` fibres
/// (x > gap), the same yarn area, every fine fibre's last node tied to a coarse fibre's first
/// (the nearest, as a hybrid panel ties them): the transition of docs/theory.md F12 without
/// the weave. Nothing is clamped; contacts are elastic and frictionless. The fine elements are
/// half a fibre diameter long, the coarse ones `coarse_ratio` of theirs (a hybrid's
/// `hybrid.element_length_ratio`).
fn tied_yarn(fine: usize, coarse: usize, coarse_ratio: f64, length: f64, multi_rate: bool) -> Distributed<LocalComm> {
    let material = FibreMaterial::kevlar_km2();
    let yarn_area = 4.63e-8;
    let inertia = InertiaModel::Effective { k1: 0.8, k2: 1.0 };
    let kind = |fibres: usize, ratio: f64| {
        let mut yarn = StraightFabric::single_yarn(
            length,
            fibres,
            yarn_area / fibres as f64,
            ratio,
            inertia.with_friction(0.0),
            3.8e9,
        );
        yarn.clamp_ends = false;
        yarn.build_all(&material)
    };
    let (fine_built, coarse_built) = (kind(fine, 0.5), kind(coarse, coarse_ratio));
    let reach = 0.5 * (fine_built.sections[0].contact_diameter + coarse_built.sections[0].contact_diameter);
    let stride = fine_built.nodes.len().max(coarse_built.nodes.len()) as u64;
    let mut nodes = dea_core::Nodes::default();
    let mut elements = dea_core::Elements::default();
    for (section, built, shift, first_fibre) in
        [(0u16, &fine_built, -0.5 * length, 0u32), (1, &coarse_built, 0.5 * length + 1.05 * reach, fine as u32)]
    {
        let n = &built.nodes;
        for i in 0..n.len() {
            let fibre = dea_core::FibreId(first_fibre + n.fibre[i].0);
            let gid = dea_core::GlobalNodeId(fibre.0 as u64 * stride + n.along[i] as u64);
            nodes.push(
                gid,
                n.position[i] + Vec3::new(shift, 0.0, 0.0),
                Vec3::zeros(),
                n.mass[i],
                fibre,
                n.along[i],
                section,
                false,
                n.last[i],
            );
            let e = &built.elements;
            elements.push(e.rest_length[i], e.tensile_strength[i], e.failure[i]);
        }
    }
    let sections = vec![fine_built.sections[0].clone(), coarse_built.sections[0].clone()];
    // the fine areas shared out as a hybrid panel shares them; each tie stands for the fine
    // fibre the gap left out
    use dea_fabric::transition::{transition_ties, EndNode};
    let at = |i: usize| EndNode {
        end: dea_core::tie::TieEnd { gid: nodes.gid[i], fibre: nodes.fibre[i], along: nodes.along[i] },
        at: nodes.position[i],
    };
    let fine_ends: Vec<(EndNode, f64)> =
        (0..nodes.len()).filter(|&i| nodes.section[i] == 0 && nodes.last[i]).map(|i| (at(i), 1.05 * reach)).collect();
    let coarse_ends: Vec<(EndNode, EndNode)> = (0..nodes.len())
        .filter(|&i| nodes.section[i] == 1 && nodes.along[i] == 0)
        .map(|i| (at(i), at(i + 1)))
        .collect();
    let ties = transition_ties(&fine_ends, &coarse_ends, sections[0].area, 2.0 * sections[0].contact_diameter);
    for tie in &ties {
        for gid in [tie.fine.gid, tie.coarse.gid] {
            let i = nodes.gid.binary_search(&gid).unwrap();
            nodes.mass[i] += 0.5 * tie.mass(&material);
        }
    }
    nodes.n_owned = nodes.len();
    nodes.link_chains();
    let contact = elastic_frictionless(&material);
    let dt = stable_time_step(&material, &sections, &contact.law, 0.0, dea_core::stability::DESIGN_CONTACT_STRAIN, 0.5);
    let limits: Vec<f64> = sections
        .iter()
        .map(|s| {
            stable_time_step(
                &material,
                std::slice::from_ref(s),
                &contact.law,
                0.0,
                dea_core::stability::DESIGN_CONTACT_STRAIN,
                0.5,
            )
        })
        .collect();
    let mut domain = Domain::assemble(material, sections, nodes, elements, contact, NO_FAILURE, None, dt);
    domain.set_ties(ties);
    if multi_rate {
        domain.set_rates(dea_core::multi_rate::rates_for(&limits, dt));
    }
    whole(domain)
}

#[test]
fn a_tensile_pulse_crosses_a_hybrid_transition_with_its_energy() {
    // 4 mm of fine fibres, then 4 mm of coarse ones: the same yarn area, so the same
    // impedance rho c A_yarn. A smooth velocity pulse in the fine part splits into two
    // halves; the one running to the transition is tensile and carries half the energy.
    // Where both kinds' fibres are centred alike (full rings of 1, 7, 19) the pulse crosses
    // whole. Four coarse fibres are centred off the seven fine ones' centre: the force line
    // jumps, its moment bends the coarse ends and a third of the pulse reflects
    // (docs/validation.md).
    // A coarse part of elements a whole fibre diameter long (a hybrid's
    // `element_length_ratio` 1: four times the fine elements' length for one coarse fibre)
    // crosses whole a pulse eight coarse elements wide; of one four elements wide (1 mm) it
    // loses 1.5-2 %, the coarse chain's dispersion of what it barely resolves (docs/theory.md
    // F12).
    // Multi-rate stepping (docs/theory.md T1), the coarse part's terms firing every second or
    // fourth step, lets the pulse cross as single-rate stepping does.
    for (fine, coarse, coarse_ratio, width, crossing, multi_rate) in [
        (7, 1, 0.5, 1e-3, 0.97, false),
        (19, 1, 0.5, 1e-3, 0.97, false),
        (7, 7, 0.5, 1e-3, 0.97, false),
        (19, 7, 0.5, 1e-3, 0.97, false),
        (7, 4, 0.5, 1e-3, 0.5, false),
        (7, 1, 1.0, 1e-3, 0.975, false),
        (19, 1, 1.0, 1e-3, 0.975, false),
        (19, 1, 1.0, 2e-3, 0.99, false),
        (7, 1, 0.5, 1e-3, 0.99, true),
        (19, 1, 0.5, 1e-3, 0.99, true),
        (19, 1, 1.0, 2e-3, 0.99, true),
    ] {
        let length = 4e-3;
        let mut run = tied_yarn(fine, coarse, coarse_ratio, length, multi_rate);
        let rates = run.domain.rates().to_vec();
        assert_eq!(rates[1] > 1, multi_rate, "{fine} -> {coarse}: rates {rates:?}");
        let largest = rates.iter().copied().max().unwrap() as u64;
        let domain = &mut run.domain;
        let c = domain.material.wave_speed();
        let (centre, speed) = (-2.5e-3, 2.0);
        for i in 0..domain.nodes.len() {
            let x = domain.nodes.position[i].x;
            if (x - centre).abs() < 0.5 * width {
                let shape = (std::f64::consts::PI * (x - centre) / width).cos().powi(2);
                domain.nodes.velocity[i] = Vec3::new(-speed * shape, 0.0, 0.0);
            }
        }
        let initial = domain.energies().total();
        let momentum = |d: &Domain| {
            (0..d.nodes.n_owned).map(|i| d.velocity(i) * d.nodes.mass[i]).fold(Vec3::zeros(), |a, b| a + b)
        };
        let initial_momentum = momentum(domain);
        // until the pulse's tail is 1 mm past the transition; its front stays in the coarse part
        let end = (-centre + 0.5 * width + 1e-3) / c;
        let mut worst: f64 = 0.0;
        // energies at the instants every section's terms share
        while run.domain.time < end || !run.domain.step.is_multiple_of(largest) {
            run.step().unwrap();
            if run.domain.step.is_multiple_of(largest) {
                worst = worst.max((run.domain.energies().total() - initial).abs() / initial);
            }
        }
        let domain = &run.domain;
        let coarse_nodes = |i: usize| usize::from(domain.nodes.section[i] == 1);
        let across = domain.energy_sums_by(coarse_nodes, 2)[1].report().total();
        let transmitted = across / (0.5 * initial);
        eprintln!(
            "{fine} -> {coarse} fibres (coarse l0/d {coarse_ratio}, pulse {width} m, rates {rates:?}): {:.2} % of the incident pulse's energy crossed, energy drift {worst:.1e}",
            100.0 * transmitted
        );
        // the drift is the central difference's own over a pulse a few elements wide
        assert!(worst < 0.01, "{fine} -> {coarse}: energy drift {worst}");
        // each term's forces are equal and opposite at any rate: momentum is kept to rounding
        let change = (momentum(domain) - initial_momentum).norm();
        assert!(change <= 1e-12 * initial_momentum.norm(), "{fine} -> {coarse}: momentum changed by {change:e}");
        assert!(
            transmitted >= crossing && transmitted < 1.01,
            "{fine} -> {coarse}: {transmitted} of the pulse crossed"
        );
    }
}
