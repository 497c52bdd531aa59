//! `dea-mpi fabric` on 1, 2 and 4 ranks: the relaxed cell has the same bits, the panel's
//! nodes are split without loss, the cell file is reusable by a case, and a cell file that
//! is not one is refused naming the file.

use std::path::PathBuf;

use dea_io::case::{load_case, Case, TargetSpec};
use dea_io::cell::read_cell;
use dea_mpi::comm::local::run_local;
use dea_mpi::fabric::{fabric, FabricReport};
use dea_mpi::setup::{problem, SetupError};
use dea_partition::Method;

/// The 10 mm patch of four layers of style 706 (the built-in default case until session 27):
/// one woven cell, relaxed in seconds.
fn patch_case() -> Case {
    load_case(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/km2_706_patch.json")).unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dea-fabric-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn the_relaxed_cell_has_the_same_bits_on_one_two_and_four_ranks_and_is_reusable() {
    let case = patch_case();
    let dir = scratch("ranks");
    let mut reports: Vec<FabricReport> = Vec::new();
    for ranks in [1, 2, 4] {
        let out = dir.join(ranks.to_string());
        let report = run_local(ranks, |comm| fabric(&case, comm, Method::KWay, &out).expect("fabric succeeds"))
            .into_iter()
            .next()
            .flatten()
            .expect("rank 0 reports");
        assert_eq!(report.ranks.len(), ranks);
        assert_eq!(
            report.ranks.iter().map(|r| r.owned_nodes).sum::<u64>(),
            report.panel.nodes,
            "every node owned once"
        );
        reports.push(report);
    }
    let cells: Vec<_> =
        [1, 2, 4].iter().map(|r| read_cell(&dir.join(r.to_string()).join("cell.h5")).unwrap()).collect();
    assert!(cells.iter().all(|c| *c == cells[0]), "the same relaxed cell on 1, 2 and 4 ranks");
    let relaxation = reports[0].relaxation.as_ref().expect("relaxed here");
    assert!(reports
        .iter()
        .all(|r| r.relaxation.as_ref().unwrap().final_residual_n.to_bits() == relaxation.final_residual_n.to_bits()));
    assert!(relaxation.final_residual_n <= 1e-6 * relaxation.initial_residual_n);
    // style 706: within 2 % of 180 g/m^2; four layers of about a quarter millimetre
    assert!(
        reports[0].style_706_areal_density_deviation.abs() < 0.02,
        "{}",
        reports[0].style_706_areal_density_deviation
    );
    assert!(
        reports[0].cell.thickness_m > 1.5e-4 && reports[0].cell.thickness_m < 4e-4,
        "{}",
        reports[0].cell.thickness_m
    );
    assert!(dir.join("1/cell.xdmf").exists() && dir.join("1/fabric.json").exists());
    // a case naming the cell file builds the same panel without relaxing
    let mut reused = case.clone();
    let TargetSpec::WovenPanel { weave, cell_file, .. } = &mut reused.target else { panic!("the patch is woven") };
    *weave = Default::default();
    *cell_file = Some(dir.join("1/cell.h5"));
    let (fresh, again) = (problem(&case).unwrap(), problem(&reused).unwrap());
    assert!(again.relaxation.is_none());
    assert!(fresh.fabric == again.fabric, "the panel from the file is the panel relaxed on the spot");
    assert_eq!(fresh.time_step.to_bits(), again.time_step.to_bits());
    // a file that is not a cell file: exit 4, naming the file
    std::fs::write(dir.join("bad.h5"), b"not a cell").unwrap();
    *match &mut reused.target {
        TargetSpec::WovenPanel { cell_file, .. } => cell_file,
        _ => unreachable!(),
    } = Some(dir.join("bad.h5"));
    match problem(&reused) {
        Err(SetupError::Mesh(message)) => assert!(message.contains("bad.h5"), "{message}"),
        other => panic!("expected a file error, got {:?}", other.map(|_| ())),
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A 2-layer orthogonal weave of KM2 600 denier yarns (4 digital fibres; binders of half the
/// area), small enough to relax in seconds.
fn orthogonal_cell_case() -> dea_io::case::Case {
    let mut case = patch_case();
    case.name = "orthogonal-km2".into();
    let text = r#"{"pattern": "orthogonal", "filler_layers": 2, "pick_spacing_m": 1.0e-3, "end_spacing_m": 0.8e-3,
        "filler": {"area_m2": 4.63e-8, "section_aspect": 3.0}, "filler_fibres": 4,
        "binder": {"area_m2": 2.315e-8, "section_aspect": 2.0}}"#;
    case.target = TargetSpec::ThreeDWeaveCell {
        weave: serde_json::from_str(text).unwrap(),
        relaxation: serde_json::from_str(r#"{"tolerance": 1e-6, "max_iterations": 400000}"#).unwrap(),
    };
    case.validate().unwrap();
    case
}

#[test]
fn a_3d_weave_cell_is_relaxed_and_written_and_cannot_be_struck() {
    let case = orthogonal_cell_case();
    let dir = scratch("3d");
    let reports = run_local(2, |comm| dea_mpi::fabric::fabric_cell(&case, comm, &dir).expect("the cell relaxes"));
    assert!(reports[1].is_none(), "rank 0 reports");
    let report = reports.into_iter().next().flatten().expect("rank 0 reports");
    assert!(report.relaxation.final_residual_n <= 1e-6 * report.relaxation.initial_residual_n);
    assert!(report.thickness_change < 0.0, "the binder's tension compacts the cell: {}", report.thickness_change);
    assert_eq!(report.crimp_by_role.keys().map(String::as_str).collect::<Vec<_>>(), ["binder", "filler", "stuffer"]);
    // the file holds the relaxed cell bit for bit, and ParaView's description of it
    let (_, written) = dea_io::cell::read_periodic(&dir.join("cell.h5")).unwrap();
    let (relaxed, relaxation) = dea_mpi::setup::three_d_cell(&case.resolve().unwrap()).unwrap().unwrap();
    assert!(relaxation.is_some(), "relaxed here");
    assert!(written == relaxed, "cell.h5 is the relaxed cell");
    assert_eq!(written.fibres(), report.fibres);
    assert!(dir.join("cell.xdmf").exists());
    // a run refuses the cell target, and a woven panel refuses its file
    match problem(&case) {
        Err(SetupError::Case(message)) => assert!(message.contains("three_d_weave_cell"), "{message}"),
        other => panic!("expected a case error, got {:?}", other.map(|_| ())),
    }
    let error = read_cell(&dir.join("cell.h5")).unwrap_err();
    assert!(error.contains("cell.h5") && error.contains("not a plain-weave cell"), "{error}");
    // a 3-D woven panel from the file is the panel relaxed on the spot
    let TargetSpec::ThreeDWeaveCell { weave, relaxation } = case.target.clone() else { unreachable!("a cell case") };
    let panel_of = |weave, cell_file| {
        let mut panel = case.clone();
        panel.target = TargetSpec::ThreeDWovenPanel {
            weave,
            cell_file,
            relaxation: relaxation.clone(),
            side_m: 0.006,
            layers: 1,
            layer_gap_m: 0.0,
            layer_shift_m: [0.0, 0.0],
            boundary: dea_io::case::BoundarySpec::FixedEdges {},
            rest_angle_law: None,
        };
        panel.validate().unwrap();
        panel
    };
    let (fresh, again) =
        (problem(&panel_of(Some(weave), None)).unwrap(), problem(&panel_of(None, Some(dir.join("cell.h5")))).unwrap());
    assert!(fresh.relaxation.is_some() && again.relaxation.is_none());
    assert!(fresh.fabric == again.fabric, "the panel from the file is the panel relaxed on the spot");
    assert_eq!(fresh.time_step.to_bits(), again.time_step.to_bits());
    std::fs::remove_dir_all(&dir).unwrap();
}
