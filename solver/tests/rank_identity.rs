//! Rank identity as a property (issue 34): small random cases, each run in process on 1, 2,
//! 3 and 4 ranks, every dataset and field snapshot compared bit for bit; the first also under
//! a real `mpirun` on 3 ranks. A failure prints the case, which `dea-mpi run` repeats.
//!
//! The cases vary what has broken rank identity before or could: panel size (down to a
//! panel the 17-grain FSP nearly spans), layers, digital fibres per yarn, a hybrid fine disc,
//! fixed edges or the clamp, the projectile (FSP, sphere, cylinder), its speed, obliquity
//! and yaw, deterministic or Weibull strengths and their seed, the shear and tension measures; each runs
//! long enough for contact, failure, fragments and many list rebuilds.
//!
//! `DEA_RANK_IDENTITY_CASES` (default 3) and `DEA_RANK_IDENTITY_SEED` (default 34) choose
//! the sample; `scripts/rank-identity.sh` runs a longer one.

use std::path::{Path, PathBuf};
use std::process::Command;

use dea_io::case::{parse_case, Case};
use dea_io::results::compare_results;
use dea_mpi::comm::local::run_local;
use dea_mpi::run::{run, RunOptions};
use dea_mpi::setup::build;
use dea_partition::Method;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn setting(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().map_or(default, |v| v.parse().unwrap_or_else(|_| panic!("{name}={v} is not a count")))
}

/// A small random case drawn from `rng`, as JSON: the 10 mm style 706 patch changed.
fn random_case(rng: &mut ChaCha8Rng, index: u64) -> serde_json::Value {
    let text = std::fs::read_to_string(repository().join("cases/km2_706_patch.json")).unwrap();
    let mut case: serde_json::Value = serde_json::from_str(&text).unwrap();
    case["name"] = format!("rank-identity-{index}").into();
    let side = rng.random_range(4.5e-3..7.5e-3);
    let fibres: u64 = rng.random_range(2..=4);
    let target = &mut case["target"];
    target["side_m"] = side.into();
    target["layers"] = rng.random_range(1..=2u64).into();
    target["weave"]["fibres_per_yarn"] = fibres.into();
    if rng.random_bool(0.3) {
        target["hybrid"] =
            serde_json::json!({ "fine_radius_m": rng.random_range(0.3..0.4) * side, "fibres_per_yarn": 1 });
    }
    if rng.random_bool(0.3) {
        target["boundary"] = serde_json::json!({ "kind": "clamp", "opening_m": rng.random_range(0.7..0.9) * side });
    }
    let projectile = &mut case["projectile"];
    match rng.random_range(0..3) {
        0 => {} // the 17-grain FSP of the default case
        1 => {
            let diameter: f64 = rng.random_range(1.0e-3..3.0e-3);
            *projectile = serde_json::json!({
                "shape": "sphere", "diameter_m": diameter,
                "mass_kg": 7850.0 * std::f64::consts::PI * diameter.powi(3) / 6.0,
            });
        }
        _ => {
            let diameter: f64 = rng.random_range(1.5e-3..3.0e-3);
            *projectile = serde_json::json!({
                "shape": "cylinder", "diameter_m": diameter, "height_m": diameter, "edge_radius_m": 0.1 * diameter,
                "mass_kg": 7850.0 * std::f64::consts::PI * diameter.powi(3) / 4.0,
            });
        }
    }
    projectile["velocity_m_s"] = rng.random_range(250.0..600.0).into();
    projectile["obliquity_deg"] = if rng.random_bool(0.5) { rng.random_range(0.0..30.0) } else { 0.0 }.into();
    projectile["yaw_deg"] = if rng.random_bool(0.5) { rng.random_range(0.0..10.0) } else { 0.0 }.into();
    let failure = &mut case["failure"];
    failure["seed"] = rng.random_range(0..1000u64).into();
    if rng.random_bool(0.5) {
        failure["mode"] = "weibull".into();
        failure["tensile_strength_pa"] = serde_json::Value::Null;
        failure["weibull"] = serde_json::json!({
            "gauge_length_m": 0.01, "shape_1": 5.0, "scale_1_pa": 2.5e9, "shape_2": 12.0, "scale_2_pa": 4.0e9
        });
    }
    if rng.random_bool(0.3) {
        failure["shear_measure"] = "element".into();
    }
    if rng.random_bool(0.3) {
        failure["tension_measure"] = "gauge".into();
    }
    case["run"]["end_time_s"] = rng.random_range(8e-6..1.2e-5).into();
    case["run"]["snapshot_interval_steps"] = 1000.into();
    case
}

/// Runs `case` on `ranks` in process into `out`, as the binary would.
fn run_in_process(case: &Case, json: &str, ranks: usize, out: &Path) {
    run_local(ranks, |comm| {
        let mut state = build(case, comm, Method::KWay, None).expect("set-up succeeds");
        let options = RunOptions::for_case(case, json, out, &state, None, None);
        run(&mut state, &options).expect("the run succeeds");
    });
}

#[test]
fn small_random_cases_give_the_same_bits_on_one_to_four_ranks() {
    let cases = setting("DEA_RANK_IDENTITY_CASES", 3);
    let seed = setting("DEA_RANK_IDENTITY_SEED", 34);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scratch = std::env::temp_dir().join(format!("dea-rank-identity-{}", std::process::id()));
    for index in 0..cases {
        let value = random_case(&mut rng, index);
        let json = serde_json::to_string_pretty(&value).unwrap();
        let case = parse_case(&json, "random case").unwrap_or_else(|e| panic!("{e}\n{json}"));
        let dir = scratch.join(index.to_string());
        std::fs::create_dir_all(&dir).unwrap();
        let case_path = dir.join("case.json");
        std::fs::write(&case_path, &json).unwrap();
        run_in_process(&case, &json, 1, &dir.join("1"));
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("1/summary.json")).unwrap()).unwrap();
        eprintln!(
            "case {index}: {} nodes, {} steps, {} rebuilds, broken {}/{}/{}, perforated {}; shear {}, tension {}",
            summary["nodes"],
            summary["steps"],
            summary["neighbour_rebuilds"],
            summary["broken_elements_tension"],
            summary["broken_elements_shear"],
            summary["broken_elements_combined"],
            summary["perforated"],
            value["failure"]["shear_measure"].as_str().unwrap_or("gauge"),
            value["failure"]["tension_measure"].as_str().unwrap_or("element")
        );
        let mut differing = Vec::new();
        for ranks in 2..=4 {
            run_in_process(&case, &json, ranks, &dir.join(ranks.to_string()));
            let differences =
                compare_results(&dir.join("1/results.h5"), &dir.join(format!("{ranks}/results.h5"))).unwrap();
            if !differences.is_empty() {
                differing.push(format!("{ranks} ranks: {}", differences.join("; ")));
            }
        }
        if index == 0 {
            // the same case under a real mpirun (scripts/mpi-env.sh lets it run as root)
            let out = dir.join("mpirun");
            let done = Command::new("mpirun")
                .args(["--oversubscribe", "-np", "3"])
                .arg(env!("CARGO_BIN_EXE_dea-mpi"))
                .arg("run")
                .arg(&case_path)
                .arg("--out")
                .arg(&out)
                .output()
                .expect("mpirun starts (source scripts/mpi-env.sh first, as scripts/test.sh does)");
            assert!(done.status.success(), "mpirun -np 3: {}", String::from_utf8_lossy(&done.stderr));
            let differences = compare_results(&dir.join("1/results.h5"), &out.join("results.h5")).unwrap();
            if !differences.is_empty() {
                differing.push(format!("mpirun -np 3: {}", differences.join("; ")));
            }
        }
        assert!(
            differing.is_empty(),
            "case {index} of seed {seed} differs:\n{}\nthe case:\n{json}",
            differing.join("\n")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
    let _ = std::fs::remove_dir_all(&scratch);
}
