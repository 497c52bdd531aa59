//! The command line as users and scripts see it: exit codes, error messages, outputs.

mod common;

use common::Scratch;
use std::path::PathBuf;
use std::process::{Command, Output};

fn dea(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dea-mpi")).args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().unwrap()
}

/// A case file of `cases/`, to be changed by a test.
fn case_file(name: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(format!("../cases/{name}")).unwrap()).unwrap()
}

/// Runs dea-mpi, checks that it exits with `code`, and gives what it wrote to stderr.
fn stderr_of_exit(code: i32, args: &[&str]) -> String {
    let out = dea(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(code), "{stderr}");
    stderr
}

/// The summary.json a run wrote into `out`.
fn summary_in(out: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// The projectile surface's vertex velocities at `step` of the run in `out` are the rigid
/// body's `v + w x (x - c)` of its last history sample.
fn assert_rigid_surface_velocities(out: &std::path::Path, step: u64) {
    let file = hdf5::File::open(out.join("results.h5")).unwrap();
    let surface = hdf5::File::open(out.join("fields/projectile.h5")).unwrap();
    let group = surface.group(&format!("snapshot-{step:010}")).unwrap();
    let velocity: Vec<f64> = group.dataset("velocity").unwrap().read_raw().unwrap();
    let position: Vec<f64> = group.dataset("position").unwrap().read_raw().unwrap();
    let read = |name: &str| -> Vec<f64> { file.dataset(name).unwrap().read_raw().unwrap() };
    let (v, c, w) = (
        read("history/projectile_velocity"),
        read("history/projectile_position"),
        read("history/projectile_angular_velocity"),
    );
    let (v, c, w) = (&v[v.len() - 3..], &c[c.len() - 3..], &w[w.len() - 3..]);
    assert_eq!(velocity.len(), position.len());
    for (u, x) in velocity.chunks_exact(3).zip(position.chunks_exact(3)) {
        let r = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
        let expected =
            [v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2], v[2] + w[0] * r[1] - w[1] * r[0]];
        assert!((0..3).all(|k| (u[k] - expected[k]).abs() < 1e-9), "vertex velocity {u:?}, rigid {expected:?}");
    }
}

/// Writes `case` to `dir/case.json`, runs it into `dir/out` on one rank, checks that the
/// run succeeded, and gives the output directory.
fn run_changed(dir: &std::path::Path, case: &serde_json::Value) -> PathBuf {
    let path = dir.join("case.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let out = dir.join("out");
    let done = dea(&["run", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    out
}

fn scratch(name: &str) -> Scratch {
    Scratch::new(format!("dea-cli-{}-{name}", std::process::id()), true)
}

#[test]
fn bad_case_names_the_field_and_exits_3() {
    let dir = scratch("bad");
    let mut case = case_file("single_fibre_short.json");
    case["target"]["element_length_ratio"] = (-1.0).into();
    let path = dir.join("bad.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", path.to_str().unwrap()]);
    assert!(stderr.contains("target.element_length_ratio") && stderr.contains("bad.json"), "{stderr}");
    std::fs::write(&path, "{\"name\": 3}").unwrap();
    let stderr = stderr_of_exit(3, &["run", path.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert!(stderr.contains("name"));
}

#[test]
fn check_resolves_a_campaign_and_its_shot_case_and_names_a_bad_design_field() {
    let out = dea(&["check", "../cases/v50_tiny_bisection.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed["campaign"]["design"]["kind"], "bisection");
    assert_eq!(printed["case"]["name"], "v50-tiny-shot");
    assert!(printed["resolved"]["nodes"].as_u64().unwrap() > 0);
    // a case is printed without a campaign
    let case: serde_json::Value =
        serde_json::from_slice(&dea(&["check", "../cases/single_fibre_short.json"]).stdout).unwrap();
    assert!(case.get("campaign").is_none());
    let dir = scratch("campaign");
    let mut campaign = case_file("v50_tiny_monte_carlo.json");
    campaign["case_file"] = std::fs::canonicalize("../cases/v50_tiny_shot.json").unwrap().to_str().unwrap().into();
    campaign["design"]["kind"] = "sideways".into();
    let path = dir.join("bad.json");
    std::fs::write(&path, campaign.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", path.to_str().unwrap()]);
    assert!(stderr.contains("design"), "{stderr}");
}

#[test]
fn a_target_too_large_for_the_host_exits_3_before_it_is_made() {
    let dir = scratch("huge");
    let mut case = case_file("km2_706_patch.json");
    // 6.9e10 nodes: a case, but not one for this machine
    case["target"]["side_m"] = 10.0.into();
    let path = dir.join("huge.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["run", path.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert!(
        stderr.contains("target: its 68807466816 nodes need about") && stderr.contains("GB between them"),
        "{stderr}"
    );
    // past the 32-bit numbering of a fibre's nodes, even a check refuses it
    case["target"]["side_m"] = 1e300.into();
    std::fs::write(&path, case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", path.to_str().unwrap()]);
    assert!(stderr.contains("target.side_m: a fibre would have"));
}

#[test]
fn missing_file_exits_4_and_usage_errors_exit_2() {
    let stderr = stderr_of_exit(4, &["check", "/nonexistent/case.json"]);
    assert!(stderr.contains("/nonexistent/case.json"));
    assert_eq!(dea(&["frobnicate"]).status.code(), Some(2));
    assert_eq!(dea(&["run", "--bogus"]).status.code(), Some(2));
    let help = dea(&["run", "--help"]);
    assert!(help.status.success() && String::from_utf8_lossy(&help.stdout).contains("Examples"));
}

#[test]
fn a_fifo_or_a_device_is_refused_not_waited_on() {
    let dir = scratch("fifo");
    let fifo = dir.join("case.json");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    std::os::unix::fs::symlink("/dev/urandom", dir.join("random.json")).unwrap();
    for path in [fifo, dir.join("random.json")] {
        let path = path.to_str().unwrap();
        for args in [vec!["check", path], vec!["run", path, "--out", dir.join("out").to_str().unwrap()]] {
            let stderr = stderr_of_exit(3, &args);
            assert!(stderr.contains(path) && stderr.contains("not a regular file"), "{stderr}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_target_beyond_the_address_space_limit_is_refused_before_it_is_built() {
    // a 6 cm panel of the 10 mm patch case has 2.46 million nodes, 4.6 GB: a process
    // limited to 2 GB of address space cannot hold it, whatever the host's memory
    let dir = scratch("rlimit");
    let mut case = case_file("km2_706_patch.json");
    case["target"]["side_m"] = 0.06.into();
    let path = dir.join("wide.json");
    std::fs::write(&path, case.to_string()).unwrap();
    // `check` refuses what `run` refuses
    for verb in
        [format!("run {} --out {}", path.display(), dir.join("out").display()), format!("check {}", path.display())]
    {
        let command = format!("ulimit -v 2000000 && exec {} {verb}", env!("CARGO_BIN_EXE_dea-mpi"));
        let out = Command::new("bash").args(["-c", &command]).current_dir(env!("CARGO_MANIFEST_DIR")).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{verb}: {stderr}");
        assert!(stderr.contains("address space a process may take here (ulimit -v)"), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn check_refuses_what_run_on_the_meant_ranks_would() {
    // side_m 0.6 where 0.006 was meant: 248 million nodes, 462 GB on one rank; `check`
    // accepted it with exit 0 while `run` refused it (issue 34)
    let dir = scratch("meant-ranks");
    let mut case = case_file("km2_706_patch.json");
    case["target"]["side_m"] = 0.6.into();
    let path = dir.join("wide.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let path = path.to_str().unwrap();
    for args in [vec!["check", path], vec!["run", path, "--out", dir.join("out").to_str().unwrap()]] {
        let stderr = stderr_of_exit(3, &args);
        assert!(stderr.contains("248249472 nodes need about 462.5 GB on each of the 1 ranks"), "{stderr}");
    }
    // 4 of 64 ranks on a host: 29 GB, more than a CI machine's 24 GiB
    let stderr = stderr_of_exit(3, &["check", path, "--ranks", "64", "--ranks-per-host", "4"]);
    assert!(stderr.contains("--ranks N --ranks-per-host M") && stderr.contains("here 64, 4 per host"), "{stderr}");
    // one share of 256 per host: 1.8 GB, checked and described
    let out = dea(&["check", path, "--ranks", "256", "--ranks-per-host", "1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let memory = &printed["resolved"]["memory"];
    assert_eq!((memory["ranks"].as_u64(), memory["ranks_per_host"].as_u64()), (Some(256), Some(1)));
    let share = memory["bytes_per_rank"].as_f64().unwrap();
    assert!((share / (248249472.0 * 1863.0 / 256.0) - 1.0).abs() < 1e-12, "{share}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_meshed_projectile_too_large_for_the_fibre_is_refused_before_its_search_is_made() {
    // a 0.1 m cube (one hexahedron in a Gmsh file) against a 12 um fibre: its contact
    // search would have listed the surface 7e8 times, 24 GB and minutes (issue 34)
    let dir = scratch("huge-mesh");
    let corners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];
    let mut mesh = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 8 1 8\n3 1 0 8\n");
    mesh += &(1..=8).map(|k| format!("{k}\n")).collect::<String>();
    mesh += &corners
        .iter()
        .map(|c| format!("{} {} {}\n", 0.1 * c[0] as f64 - 0.05, 0.1 * c[1] as f64 - 0.05, 0.1 * c[2] as f64))
        .collect::<String>();
    mesh += "$EndNodes\n$Elements\n1 1 1 1\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n";
    std::fs::write(dir.join("cube.msh"), mesh).unwrap();
    let mut case = case_file("single_fibre_short.json");
    case["target"]["diameter_m"] = 12e-6.into();
    case["projectile"] =
        serde_json::json!({ "shape": "file", "mesh_file": "cube.msh", "mass_kg": 0.5, "velocity_m_s": 100.0 });
    let path = dir.join("case.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let path = path.to_str().unwrap();
    for args in [vec!["check", path], vec!["run", path, "--out", dir.join("out").to_str().unwrap()]] {
        let started = std::time::Instant::now();
        let stderr = stderr_of_exit(3, &args);
        assert!(stderr.contains("cube.msh") && stderr.contains("contact search") && stderr.contains("GB"), "{stderr}");
        assert!(started.elapsed().as_secs() < 20, "{args:?} took {:?}", started.elapsed());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_error_found_while_building_names_the_case_file() {
    let dir = scratch("built");
    let mut case = case_file("single_fibre_short.json");
    case["target"]["length_m"] = 1e19.into();
    let path = dir.join("long.json");
    std::fs::write(&path, case.to_string()).unwrap();
    for args in [
        vec!["check", path.to_str().unwrap()],
        vec!["run", path.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()],
    ] {
        let stderr = stderr_of_exit(3, &args);
        assert!(
            stderr.contains("target.length_m") && stderr.contains("(in ") && stderr.contains("long.json"),
            "{stderr}"
        );
    }
    case["target"]["length_m"] = 0.01.into();
    case["target"]["element_length_ratio"] = 5e-324.into();
    std::fs::write(&path, case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", path.to_str().unwrap()]);
    assert!(stderr.contains("target.element_length_ratio: must be in [0.01, 4]"), "{stderr}");
    case["target"]["element_length_ratio"] = 0.5.into();
    case["target"]["diameter_m"] = 5e-324.into();
    std::fs::write(&path, case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", path.to_str().unwrap()]);
    assert!(stderr.contains("target.diameter_m: must be in"), "{stderr}");
    assert!(stderr_of_exit(2, &["partition", "--segment-nodes", "0"]).contains("--segment-nodes"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_projectile_as_wide_as_the_free_span_is_warned_of() {
    let dir = scratch("narrow");
    let mut case = case_file("km2_706_patch.json");
    case["target"]["side_m"] = 0.006.into();
    case["target"]["layers"] = 1.into();
    case["run"]["end_time_s"] = 2e-8.into();
    let path = dir.join("narrow.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let out = dea(&["run", path.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && stderr.contains("as wide as the panel's free span (6.0 mm)"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn check_prints_the_resolved_case() {
    let out = dea(&["check", "../cases/single_fibre_short.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed["case"]["name"], "single-fibre-short");
    assert_eq!(printed["resolved"]["material"]["longitudinal_modulus"], 84.6e9);
    assert!(printed["resolved"]["nodes"].as_u64().unwrap() > 1000);
    assert!(printed["resolved"]["time_step_s"].as_f64().unwrap() > 0.0);
    // the friction spring the case leaves unsaid is named as resolved
    assert!(printed["case"]["contact"]["projectile_friction_spring"].is_null());
    assert_eq!(printed["resolved"]["projectile_friction_spring"], "rotating");
    assert!(printed["case"]["contact"]["fibre_friction_spring"].is_null());
    assert_eq!(printed["resolved"]["fibre_friction_spring"], "anchored");
    assert_eq!(printed["resolved"]["unload"], "at_break");
    // a straight fibre's springs all rest straight, where the two rest laws coincide
    assert_eq!(printed["resolved"]["rest_angle_law"], "cone");
    assert_eq!(printed["resolved"]["tension_measure"], "gauge");
    assert_eq!(printed["resolved"]["tension_gauge_diameters"], 1.0);
    assert_eq!(printed["resolved"]["shear_measure"], "gauge");
    assert_eq!(printed["resolved"]["shear_gauge_diameters"], 1.0);
    // the measures a case names are printed with their gauge lengths
    let dir = scratch("measures");
    let mut case = case_file("single_fibre_short.json");
    case["failure"]["shear_measure"] = "element".into();
    case["failure"]["tension_measure"] = "gauge".into();
    case["failure"]["tension_gauge_diameters"] = 2.0.into();
    let path = dir.join("measures.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let out = dea(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed["resolved"]["shear_measure"], "element");
    assert!(printed["resolved"]["shear_gauge_diameters"].is_null());
    assert_eq!(printed["resolved"]["tension_measure"], "gauge");
    assert_eq!(printed["resolved"]["tension_gauge_diameters"], 2.0);
    // a woven panel's springs bent at rest take the smooth law unless the case names another
    let out = dea(&["check", "../cases/default.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed["resolved"]["rest_angle_law"], "smooth");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn check_says_when_a_case_uses_unsourced_weibull_strengths() {
    let out = dea(&["check", "../cases/v50_tiny_shot.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(&format!("note: {}", dea_io::case::UNSOURCED_WEIBULL)), "{stderr}");
    let out = dea(&["check", "../cases/default.json"]);
    assert!(out.status.success() && !String::from_utf8_lossy(&out.stderr).contains("note:"));
}

#[test]
fn run_writes_summary_and_hdf5_histories() {
    let dir = scratch("run");
    let out = dea(&["run", "../cases/single_fibre_short.json", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for key in [
        "steps",
        "simulated_time_s",
        "wall_s",
        "perforated",
        "residual_velocity_m_s",
        "max_projectile_force_n",
        "node_steps_per_s_per_core",
    ] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    assert!(summary["steps"].as_u64().unwrap() > 100);
    assert!(summary["max_projectile_force_n"].as_f64().unwrap() > 0.0, "the sphere reached the fibre");
    assert!(summary["energy_balance_error"].as_f64().unwrap() < 1e-3);
    // progress.json ends finished, with the outcome and nothing left to wait for
    let progress: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("progress.json")).unwrap()).unwrap();
    assert_eq!((progress["state"].as_str(), progress["eta_s"].as_f64()), (Some("finished"), Some(0.0)), "{progress}");
    assert_eq!(progress["outcome"], summary["outcome"]);
    assert!(progress["checkpoint_time_s"].is_null(), "no checkpoint was written: {progress}");
    // what made the outputs, and what each file is
    let provenance: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("provenance.json")).unwrap()).unwrap();
    assert_eq!(provenance["case"]["name"], summary["case"]);
    let segment = &provenance["segments"][0];
    assert!(segment["git_commit"].is_string() && segment["host"].is_string() && segment["ranks"] == 1, "{segment}");
    assert!(segment["started_utc"].as_str().is_some_and(|t| t.len() == 20 && t.ends_with('Z')), "{segment}");
    assert!(std::fs::read_to_string(dir.join("README.txt")).unwrap().contains("summary.json"));
    let file = hdf5::File::open(dir.join("results.h5")).unwrap();
    let time: Vec<f64> = file.dataset("history/time").unwrap().read_raw().unwrap();
    assert!(time.len() > 2);
    for name in ["history/projectile_position", "history/projectile_velocity", "history/projectile_force"] {
        assert_eq!(file.dataset(name).unwrap().shape(), vec![time.len(), 3], "{name}");
    }
    for kind in [
        "fibre_kinetic",
        "projectile_kinetic",
        "axial",
        "bending",
        "contact",
        "friction_dissipated",
        "plastic_dissipated",
        "total",
    ] {
        let values: Vec<f64> = file.dataset(&format!("history/energy/{kind}")).unwrap().read_raw().unwrap();
        assert_eq!(values.len(), time.len(), "{kind}");
    }
    // the final state is the last snapshot, one part per rank, listed in fields.xdmf
    let snapshots = dea_io::snapshot::index(&dir, 1, u64::MAX).unwrap();
    let last = snapshots.last().expect("a final snapshot");
    assert_eq!(last.step, summary["steps"].as_u64().unwrap());
    assert_eq!(last.parts[0].points as u64, summary["nodes"].as_u64().unwrap());
    assert!(std::fs::read_to_string(dir.join("fields.xdmf")).unwrap().contains(&format!("step {}", last.step)));
    // the projectile's surface (the analytic sphere tessellated) at the same steps
    let projectile = std::fs::read_to_string(dir.join("projectile.xdmf")).unwrap();
    assert_eq!(projectile.matches("<Time ").count(), snapshots.len());
    assert!(projectile.contains(&format!("step {}", last.step)) && projectile.contains("TopologyType=\"Triangle\""));
    assert_rigid_surface_velocities(&dir, last.step);
    assert!(projectile.contains("/velocity</DataItem>"));
    // history.csv has a row per sample
    assert_eq!(std::fs::read_to_string(dir.join("history.csv")).unwrap().lines().count(), time.len() + 1);
}

#[test]
fn bench_json_has_the_documented_keys() {
    let out = dea(&["bench", "--json", "--nodes", "4000", "--steps", "20"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "nodes",
        "steps",
        "ranks",
        "wall_s",
        "ns_per_node_step",
        "ns_per_contact_pair",
        "ns_per_contact_pair_packed",
        "ns_per_contact_entry",
        "ns_per_node_rods",
        "ns_per_node_rebuild",
        "ns_per_node_rebuild_in_run",
        "contacts_per_node",
    ] {
        assert!(report.get(key).is_some(), "bench lacks {key}");
    }
    assert!(report["nodes"].as_u64().unwrap() >= 4000);
    assert!(report["contacts_per_node"].as_f64().unwrap() > 1.0, "the bench yarn is in contact");
}

#[test]
fn partition_reports_owned_and_ghost_nodes_per_rank() {
    let out = dea(&["partition", "../cases/single_fibre_short.json", "--ranks", "3", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ranks = report["ranks"].as_array().unwrap();
    assert_eq!(ranks.len(), 3);
    let owned: u64 = ranks.iter().map(|r| r["owned_nodes"].as_u64().unwrap()).sum();
    let check: serde_json::Value =
        serde_json::from_slice(&dea(&["check", "../cases/single_fibre_short.json"]).stdout).unwrap();
    assert_eq!(owned, check["resolved"]["nodes"].as_u64().unwrap(), "every node owned exactly once");
    assert!(report["load_imbalance"].as_f64().unwrap() < 1.05);
    assert!(ranks.iter().all(|r| r["ghost_nodes"].as_u64().unwrap() > 0), "a cut fibre needs ghosts on both sides");
    // the memory side: the largest rank's stored nodes, and their balance
    let stored: Vec<u64> =
        ranks.iter().map(|r| r["owned_nodes"].as_u64().unwrap() + r["ghost_nodes"].as_u64().unwrap()).collect();
    assert_eq!(report["largest_stored_nodes"].as_u64(), stored.iter().max().copied());
    let mean = stored.iter().sum::<u64>() as f64 / 3.0;
    assert!((report["memory_imbalance"].as_f64().unwrap() - *stored.iter().max().unwrap() as f64 / mean).abs() < 1e-12);
    let text = String::from_utf8_lossy(&dea(&["partition", "../cases/single_fibre_short.json", "--ranks", "3"]).stdout)
        .into_owned();
    assert!(text.contains("memory imbalance") && text.contains("largest rank:"), "{text}");
    assert_eq!(dea(&["partition", "../cases/single_fibre_short.json", "--ranks", "0"]).status.code(), Some(2));
    assert_eq!(dea(&["partition", "../cases/single_fibre_short.json", "--ranks", "100000"]).status.code(), Some(2));
}

#[test]
fn fabric_share_builds_one_rank_of_a_larger_job_alone() {
    let dir = scratch("share");
    let out_dir = dir.join("share");
    let out = dea(&[
        "fabric",
        "../cases/hybrid_disc_two_layer_settle.json",
        "--share",
        "1/3",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let share: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("share.json")).unwrap()).unwrap();
    let check: serde_json::Value =
        serde_json::from_slice(&dea(&["check", "../cases/hybrid_disc_two_layer_settle.json"]).stdout).unwrap();
    // the rank built exactly what the partition gives it, of the whole the case describes
    assert_eq!(share["panel_nodes"], check["resolved"]["nodes"]);
    assert_eq!(share["ties"], check["resolved"]["hybrid"]["ties"]);
    let ranks = share["partition"]["ranks"].as_array().unwrap();
    assert_eq!(ranks.len(), 3);
    assert_eq!(share["owned_nodes"], ranks[1]["owned_nodes"]);
    let owned = share["owned_nodes"].as_u64().unwrap();
    assert!(owned > 0 && owned < share["panel_nodes"].as_u64().unwrap());
    assert!(share["contact_entries"].as_u64().unwrap() > 0);
    for bad in ["3/3", "1", "x/4", "0/0"] {
        assert_eq!(
            dea(&["fabric", "../cases/hybrid_disc_two_layer_settle.json", "--share", bad]).status.code(),
            Some(2),
            "--share {bad}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_fine_disc_without_a_crossing_exits_3_naming_its_radius() {
    let dir = scratch("disc");
    let mut case = case_file("hybrid_disc_two_layer_settle.json");
    case["target"]["hybrid"]["fine_radius_m"] = 0.3e-3.into();
    let path = dir.join("case.json");
    std::fs::write(&path, case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", path.to_str().unwrap()]);
    assert!(stderr.contains("target.hybrid.fine_radius_m") && stderr.contains("no crossing"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A surface as ASCII STL.
fn stl(vertices: &[dea_core::Vec3], triangles: &[[u32; 3]]) -> String {
    let mut text = String::from("solid projectile\n");
    for t in triangles {
        text += "facet normal 0 0 0\nouter loop\n";
        for &v in t {
            let x = vertices[v as usize];
            text += &format!("vertex {:?} {:?} {:?}\n", x.x, x.y, x.z);
        }
        text += "endloop\nendfacet\n";
    }
    text + "endsolid projectile\n"
}

#[test]
fn an_stl_projectile_strikes_like_the_generated_mesh_it_was_written_from() {
    let dir = scratch("stl");
    let (radius, height, edge) = (1.7e-3, 3.7e-3, 0.2e-3);
    let (vertices, triangles) =
        dea_projectile::generate::Solid::Cylinder { radius, height, edge_radius: edge }.mesh(4).boundary();
    std::fs::write(dir.join("rcc.stl"), stl(&vertices, &triangles)).unwrap();
    let mut case = case_file("single_fibre_short.json");
    case["projectile"] = serde_json::json!({ "shape": "cylinder", "diameter_m": 2.0 * radius, "height_m": height, "edge_radius_m": edge, "mesh_divisions": 4, "mass_kg": 5e-6, "velocity_m_s": 100.0 });
    std::fs::write(dir.join("generated.json"), case.to_string()).unwrap();
    // the file's vertices are the generator's, written exactly, in the same order
    case["projectile"] =
        serde_json::json!({ "shape": "file", "mesh_file": "rcc.stl", "mass_kg": 5e-6, "velocity_m_s": 100.0 });
    std::fs::write(dir.join("file.json"), case.to_string()).unwrap();
    let checked = dea(&["check", dir.join("file.json").to_str().unwrap()]);
    assert!(checked.status.success(), "{}", String::from_utf8_lossy(&checked.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&checked.stdout).unwrap();
    assert_eq!(printed["resolved"]["projectile"]["shape"]["mesh"]["triangles"], triangles.len());
    for name in ["generated", "file"] {
        let out = dea(&[
            "run",
            dir.join(format!("{name}.json")).to_str().unwrap(),
            "--out",
            dir.join(name).to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("file/summary.json")).unwrap()).unwrap();
    assert!(summary["max_projectile_force_n"].as_f64().unwrap() > 0.0, "the meshed cylinder reached the fibre");
    let compared = dea(&[
        "compare",
        dir.join("generated/results.h5").to_str().unwrap(),
        dir.join("file/results.h5").to_str().unwrap(),
    ]);
    assert!(compared.status.success(), "{}", String::from_utf8_lossy(&compared.stdout));
    // a damaged file: exit 4, naming the file and the line
    std::fs::write(dir.join("rcc.stl"), stl(&vertices, &triangles).replacen("vertex", "vertex nan-ish", 1)).unwrap();
    let stderr = stderr_of_exit(
        4,
        &["run", dir.join("file.json").to_str().unwrap(), "--out", dir.join("bad").to_str().unwrap()],
    );
    assert!(stderr.contains("rcc.stl:4:"), "{stderr}");
    // an open surface is refused by name too
    std::fs::write(dir.join("rcc.stl"), stl(&vertices, &triangles[1..])).unwrap();
    let stderr = stderr_of_exit(4, &["check", dir.join("file.json").to_str().unwrap()]);
    assert!(stderr.contains("not closed"), "{stderr}");
}

#[test]
fn a_deformable_projectile_that_turns_inside_out_stops_the_run_with_exit_5() {
    let dir = scratch("inverted");
    let mut case = case_file("four_layer_deformable_sphere.json");
    // a body as soft as rubber at 50 m/s: far beyond linear elasticity
    case["projectile"]["deformable"]["youngs_modulus_pa"] = 2.09e7.into();
    case["projectile"]["velocity_m_s"] = 50.0.into();
    case["run"]["end_time_s"] = 1.2e-5.into();
    std::fs::write(dir.join("soft.json"), case.to_string()).unwrap();
    let stderr = stderr_of_exit(
        5,
        &["run", dir.join("soft.json").to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()],
    );
    assert!(stderr.contains("deformable projectile is inverted"), "{stderr}");
    // a deformable body needs hexahedra: an analytic sphere is refused by field
    case["projectile"].as_object_mut().unwrap().remove("mesh_divisions");
    std::fs::write(dir.join("analytic.json"), case.to_string()).unwrap();
    let stderr = stderr_of_exit(3, &["check", dir.join("analytic.json").to_str().unwrap()]);
    assert!(stderr.contains("projectile.deformable"));
}

#[test]
fn a_closed_pipe_ends_the_output_quietly() {
    use std::process::{Command, Stdio};
    // the reader goes away before dea-mpi prints: it must stop without a panic
    let mut child = Command::new(env!("CARGO_BIN_EXE_dea-mpi"))
        .args(["check", "cases/km2_706_patch.json"])
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// The top-level help lists each subcommand on a line of its own, and every file a help text
/// names as an example exists in the repository.
#[test]
fn help_texts_list_subcommands_briefly_and_name_files_that_exist() {
    let top = String::from_utf8(dea(&["--help"]).stdout).unwrap();
    let commands: Vec<&str> =
        top.lines().skip_while(|l| !l.starts_with("Commands:")).skip(1).take_while(|l| !l.is_empty()).collect();
    assert_eq!(commands.len(), 9, "{top}");
    assert!(commands.iter().all(|l| l.len() <= 100), "{top}");
    for subcommand in ["run", "fabric", "v50", "fit", "check", "partition", "compare", "bench"] {
        let help = String::from_utf8(dea(&[subcommand, "--help"]).stdout).unwrap();
        assert!(help.contains("Example"), "{subcommand}: {help}");
        for word in help.split_whitespace().filter(|w| {
            (w.starts_with("cases/") || w.starts_with("jobs/")) && w.ends_with(".json") || w.starts_with("validation/")
        }) {
            assert!(
                std::path::Path::new("..").join(word).exists(),
                "`dea-mpi {subcommand} --help` names {word}, which does not exist"
            );
        }
    }
}

/// An oblique shot reports its residual velocity along its line of flight, and the component
/// along the panel's normal (the direction the outcome is judged in) under its own name.
#[test]
fn an_oblique_shot_reports_its_residual_velocity_along_the_line_of_flight() {
    let dir = scratch("oblique");
    let out = dir.join("fsp");
    let status = dea(&["run", "../cases/four_layer_fsp.json", "--out", out.to_str().unwrap()]);
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let obliquity = case_file("four_layer_fsp.json")["projectile"]["obliquity_deg"].as_f64().unwrap().to_radians();
    assert!(obliquity > 0.1, "the case is oblique");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    // the last history row is the end state the summary reports
    let csv = std::fs::read_to_string(out.join("history.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let last: Vec<f64> = csv.lines().last().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    let column =
        |name: &str| last[header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"))];
    let velocity =
        [column("projectile_velocity_x_m_s"), column("projectile_velocity_y_m_s"), column("projectile_velocity_z_m_s")];
    let flight = [-obliquity.sin(), 0.0, -obliquity.cos()];
    let along_flight: f64 = velocity.iter().zip(flight).map(|(v, d)| v * d).sum();
    let (residual, normal) =
        (summary["residual_velocity_m_s"].as_f64().unwrap(), summary["normal_velocity_m_s"].as_f64().unwrap());
    assert!(
        (residual - along_flight).abs() <= 1e-9 * along_flight.abs(),
        "residual {residual} against {along_flight} along the line of flight"
    );
    assert_eq!(normal, -velocity[2]);
    assert!(
        (residual - normal).abs() > 0.01 * residual.abs(),
        "an oblique shot's two components differ: {residual} and {normal}"
    );
    // the shot ends mid-penetration: no residual velocity is claimed, in the summary's
    // outcome or in the closing line
    assert_eq!(summary["outcome"], "undecided");
    let stdout = String::from_utf8_lossy(&status.stdout);
    assert!(
        stdout.contains(&format!(
            "undecided at the end time (still in the target; a longer run.end_time_s decides it): velocity at end time {residual:.2} m/s along the line of flight (normal component {normal:.2} m/s)"
        )) && !stdout.contains("residual velocity"),
        "{stdout}"
    );
}

/// A file that is not one JSON document is refused with the line and column of the fault
/// before any field is read: two cases back to back (the second was ignored), and a campaign
/// with a syntax error after its `case_file` (reported as "unknown field `case_file`"). A
/// UTF-8 byte-order mark, which some editors write, is read past.
#[test]
fn text_that_is_not_one_json_document_is_refused_with_its_line() {
    let dir = scratch("documents");
    let case = std::fs::read_to_string("../cases/single_fibre_short.json").unwrap();
    let two = dir.join("two.json");
    std::fs::write(&two, format!("{case}{case}")).unwrap();
    for command in ["check", "run"] {
        let stderr = stderr_of_exit(
            3,
            &[command, two.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()]
                [..if command == "check" { 2 } else { 4 }],
        );
        assert!(stderr.contains("two.json") && stderr.contains("trailing characters at line"), "{command}: {stderr}");
    }
    let campaign = dir.join("campaign.json");
    let case_file = std::fs::canonicalize("../cases/v50_tiny_shot.json").unwrap();
    std::fs::write(
        &campaign,
        format!(
            "{{\"name\": \"c\", \"case_file\": {:?}, \"design\": {{ \"kind\": \"bisection\",, }} }}",
            case_file.to_str().unwrap()
        ),
    )
    .unwrap();
    let stderr = stderr_of_exit(3, &["check", campaign.to_str().unwrap()]);
    assert!(
        stderr.contains("campaign.json") && stderr.contains("line 1 column") && !stderr.contains("unknown field"),
        "{stderr}"
    );
    let bom = dir.join("bom.json");
    std::fs::write(&bom, format!("\u{feff}{case}")).unwrap();
    let out = dea(&["check", bom.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Counts that cannot be zero are refused as usage errors (exit 2) naming the option.
#[test]
fn zero_counts_on_the_command_line_are_usage_errors() {
    for args in [
        &["bench", "--nodes", "0"][..],
        &["bench", "--steps", "0"],
        &["partition", "--ranks", "2", "--segment-nodes", "0"],
    ] {
        let stderr = stderr_of_exit(2, args);
        assert!(stderr.contains(args[args.len() - 2]), "{args:?}: {stderr}");
    }
}

#[test]
fn compare_names_a_damaged_part_and_refuses_what_is_not_results() {
    let dir = scratch("compare");
    let mut case = case_file("single_fibre_short.json");
    case["run"]["checkpoint_interval_steps"] = 200.into();
    let case_path = dir.join("case.json");
    std::fs::write(&case_path, case.to_string()).unwrap();
    for name in ["a", "b"] {
        let out = dea(&["run", case_path.to_str().unwrap(), "--out", dir.join(name).to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let (a, b) = (dir.join("a/results.h5"), dir.join("b/results.h5"));
    assert!(dea(&["compare", a.to_str().unwrap(), b.to_str().unwrap()]).status.success());
    // a run's output directory stands for its results.h5; a directory without one is named
    let same = dea(&["compare", dir.join("a").to_str().unwrap(), dir.join("b").to_str().unwrap()]);
    assert!(same.status.success(), "{}", String::from_utf8_lossy(&same.stderr));
    assert!(String::from_utf8_lossy(&same.stdout).contains("a/results.h5"));
    let stderr =
        stderr_of_exit(4, &["compare", dir.join("a").to_str().unwrap(), dir.join("b/fields").to_str().unwrap()]);
    assert!(stderr.contains("fields: a directory without results.h5"), "{stderr}");
    // a checkpoint's manifest is not a run's results: named, not compared
    let manifest = dir.join("b/checkpoint/manifest.h5");
    let stderr = stderr_of_exit(4, &["compare", a.to_str().unwrap(), manifest.to_str().unwrap()]);
    assert!(stderr.contains("manifest.h5: not a run's results"), "{stderr}");
    // relaxed cells compare (the fabric tests use it), but not against a run's results
    let fabric = dea(&["fabric", "--out", dir.join("fabric").to_str().unwrap()]);
    assert!(fabric.status.success(), "{}", String::from_utf8_lossy(&fabric.stderr));
    let cell = dir.join("fabric/cell.h5");
    assert!(dea(&["compare", cell.to_str().unwrap(), cell.to_str().unwrap()]).status.success());
    let stderr = stderr_of_exit(4, &["compare", cell.to_str().unwrap(), a.to_str().unwrap()]);
    assert!(stderr.contains("compare two of a kind"), "{stderr}");
    // a field part cut short is named, not the results file beside it
    let part = dir.join("b/fields/ranks-00001-part-00000.h5");
    let bytes = std::fs::read(&part).unwrap();
    std::fs::write(&part, &bytes[..bytes.len() / 2]).unwrap();
    let stderr = stderr_of_exit(4, &["compare", a.to_str().unwrap(), b.to_str().unwrap()]);
    assert!(stderr.contains("field part") && stderr.contains("ranks-00001-part-00000.h5"), "{stderr}");
    assert!(!stderr.contains("results.h5"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn quiet_verbose_and_rust_log_set_what_the_log_says() {
    let dir = scratch("verbosity");
    let case = "../cases/single_fibre_short.json";
    let run = |flags: &[&str], rust_log: Option<&str>, name: &str| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_dea-mpi"));
        command.current_dir(env!("CARGO_MANIFEST_DIR")).env_remove("RUST_LOG");
        if let Some(spec) = rust_log {
            command.env("RUST_LOG", spec);
        }
        let out = dir.join(name);
        command.args(flags).args(["run", case, "--out", out.to_str().unwrap()]).output().unwrap()
    };
    let lines = |output: &Output, level: &str| String::from_utf8_lossy(&output.stderr).matches(level).count();
    let plain = run(&[], None, "plain");
    assert!(plain.status.success() && lines(&plain, "INFO") > 0 && lines(&plain, "DEBUG") == 0);
    let quiet = run(&["-q"], None, "quiet");
    assert!(quiet.status.success() && lines(&quiet, "INFO") == 0, "{}", String::from_utf8_lossy(&quiet.stderr));
    // each rebuild of the neighbour lists is a debug message
    for (flags, rust_log, name) in [(&["-v"][..], None, "verbose"), (&[][..], Some("debug"), "rust-log")] {
        let output = run(flags, rust_log, name);
        assert!(
            output.status.success() && lines(&output, "DEBUG") > 0,
            "{name}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        let stderr = String::from_utf8_lossy(&output.stderr);
        // with the list's size and its touching pairs: what docs/performance.md measures the sweep by
        assert!(stderr.contains("neighbour lists rebuilt") && stderr.contains("pairs listed"), "{name}: {stderr}");
        assert!(stderr.contains("of them touching"), "{name}: {stderr}");
    }
    let bad = run(&[], Some("dea_core=[loud"), "bad");
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("RUST_LOG=\"dea_core=[loud\""), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_output_directory_belongs_to_one_run_and_a_checkpoint_to_its_case() {
    let dir = scratch("owned");
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    let mut case = case_file("single_fibre_short.json");
    case["run"]["checkpoint_interval_steps"] = 200.into();
    let case_path = dir.join("case.json");
    std::fs::write(&case_path, case.to_string()).unwrap();
    let c = case_path.to_str().unwrap();
    let first = dea(&["run", c, "--out", o]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    // progress.json names the last checkpoint, which a rerun would go on from
    let progress: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("progress.json")).unwrap()).unwrap();
    let (checkpoint_s, steps) = (progress["checkpoint_time_s"].as_f64().unwrap(), progress["step"].as_u64().unwrap());
    let last = (steps / 200 * 200) as f64 / steps as f64 * progress["simulated_time_s"].as_f64().unwrap();
    assert!((checkpoint_s - last).abs() < 1e-6 * last, "{checkpoint_s} against {last}: {progress}");
    // a part an earlier run on 3 ranks left behind
    let stale = out.join("fields/ranks-00003-part-00002.h5");
    std::fs::write(&stale, "stale").unwrap();
    // a fresh run into the same directory is refused, naming what it found
    let refused = stderr_of_exit(2, &["run", c, "--out", o]);
    assert!(
        refused.contains("summary.json") && refused.contains("fields") && refused.contains("--overwrite"),
        "{refused}"
    );
    assert!(stale.exists(), "nothing was touched");
    // --overwrite clears the earlier outputs first
    let again = dea(&["run", c, "--out", o, "--overwrite"]);
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    assert!(!stale.exists() && out.join("summary.json").exists());
    // a checkpoint continues its own case only
    let checkpoint = out.join("checkpoint");
    let k = checkpoint.to_str().unwrap();
    let mut other = case.clone();
    other["projectile"]["velocity_m_s"] = 123.0.into();
    let other_path = dir.join("other.json");
    std::fs::write(&other_path, other.to_string()).unwrap();
    let wrong = stderr_of_exit(3, &["run", other_path.to_str().unwrap(), "--restart", k, "--out", o]);
    assert!(wrong.contains("continues case") && wrong.contains("differ in projectile.velocity_m_s"), "{wrong}");
    // a checkpoint at or past the case file's end time has nothing left to run
    let mut shorter = case.clone();
    shorter["run"]["end_time_s"] = (0.6 * case["run"]["end_time_s"].as_f64().unwrap()).into();
    let shorter_path = dir.join("shorter.json");
    std::fs::write(&shorter_path, shorter.to_string()).unwrap();
    assert!(checkpoint_s > shorter["run"]["end_time_s"].as_f64().unwrap());
    let passed = stderr_of_exit(3, &["run", shorter_path.to_str().unwrap(), "--restart", k, "--out", o]);
    assert!(passed.contains("nothing is left to run") && passed.contains("shorter.json's run.end_time_s"), "{passed}");
    let continued = dea(&["run", c, "--restart", k, "--out", o]);
    assert!(continued.status.success(), "{}", String::from_utf8_lossy(&continued.stderr));
    // ...but for how long it runs: a run ended early goes on to the case file's later end
    // time, with the bits of a run straight through
    let early = dir.join("early");
    let e = early.to_str().unwrap();
    let first = dea(&["run", shorter_path.to_str().unwrap(), "--out", e]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let steps = |out: &std::path::Path| summary_in(out)["steps"].as_u64().unwrap();
    assert!(steps(&early) < steps(&out), "{} < {}", steps(&early), steps(&out));
    let longer = dea(&["run", c, "--restart", early.join("checkpoint").to_str().unwrap(), "--out", e]);
    assert!(longer.status.success(), "{}", String::from_utf8_lossy(&longer.stderr));
    assert_eq!(steps(&early), steps(&out));
    // (the histories; the fields hold one more snapshot, the state at the earlier end)
    let differences = dea_io::results::compare_results(&early.join("results.h5"), &out.join("results.h5")).unwrap();
    assert!(differences.is_empty(), "{differences:#?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_spliced_checkpoint_is_refused() {
    let dir = scratch("spliced");
    let mut case = case_file("single_fibre_short.json");
    case["run"]["checkpoint_interval_steps"] = 150.into();
    let case_path = dir.join("case.json");
    std::fs::write(&case_path, case.to_string()).unwrap();
    // two checkpoints of one run: one written 150 steps before the other
    let (early, late) = (dir.join("early"), dir.join("late"));
    let steps = |out: &PathBuf| summary_in(out)["steps"].as_u64().unwrap();
    let full = dea(&["run", case_path.to_str().unwrap(), "--out", late.to_str().unwrap()]);
    assert!(full.status.success(), "{}", String::from_utf8_lossy(&full.stderr));
    let mut shorter = case.clone();
    let end = case["run"]["end_time_s"].as_f64().unwrap();
    shorter["run"]["end_time_s"] = (end * (steps(&late) - 160) as f64 / steps(&late) as f64).into();
    let shorter_path = dir.join("shorter.json");
    std::fs::write(&shorter_path, shorter.to_string()).unwrap();
    let first = dea(&["run", shorter_path.to_str().unwrap(), "--out", early.to_str().unwrap()]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    // the late manifest over the early parts: its bytes no longer match the CRC-32 kept
    // beside it...
    std::fs::copy(late.join("checkpoint/manifest.h5"), early.join("checkpoint/manifest.h5")).unwrap();
    let restart =
        || dea(&["run", "--restart", early.join("checkpoint").to_str().unwrap(), "--out", early.to_str().unwrap()]);
    let out = restart();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{stderr}");
    assert!(stderr.contains("manifest.h5: damaged"), "{stderr}");
    // ...and copied with it, the manifest does not know the early parts
    std::fs::copy(late.join("checkpoint/manifest.h5.crc32"), early.join("checkpoint/manifest.h5.crc32")).unwrap();
    let out = restart();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{stderr}");
    assert!(stderr.contains("part-00000.h5") && stderr.contains("not the part"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_projectile_at_rest_has_a_meaningful_energy_balance() {
    // nothing moves: the energies are rounding noise, which once made the balance 239
    let dir = scratch("at-rest");
    let mut case = case_file("single_fibre_short.json");
    case["projectile"]["velocity_m_s"] = 0.0.into();
    let out = run_changed(&dir, &case);
    let error = summary_in(&out)["energy_balance_error"].as_f64().expect("a number");
    assert!(error < 1e-9, "{error}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn broken_elements_are_drawn_apart_and_displacements_and_the_back_face_are_measured() {
    let dir = scratch("back-face");
    let mut case = case_file("four_layer_fsp.json");
    case["run"]["snapshot_interval_steps"] = 200.into();
    let out = run_changed(&dir, &case);
    let summary = summary_in(&out);
    let snapshots = dea_io::snapshot::index(&out, 1, u64::MAX).unwrap();
    let (first, last) = (snapshots.first().unwrap(), snapshots.last().unwrap());
    let (start, end) = (dea_io::snapshot::merged(&out, first).unwrap(), dea_io::snapshot::merged(&out, last).unwrap());
    // no settle: nothing has moved at the first snapshot, and the last one's displacement is
    // the motion since, to the bit
    assert!(start.points.iter().all(|p| p.3 == [0; 3]));
    for (a, b) in start.points.iter().zip(&end.points) {
        assert_eq!(a.0, b.0);
        for k in 0..3 {
            assert_eq!((f64::from_bits(b.1[k]) - f64::from_bits(a.1[k])).to_bits(), b.3[k], "node {}", a.0);
        }
    }
    // the broken elements are drawn apart from the intact ones, each element once
    let broken = ["broken_elements_tension", "broken_elements_shear", "broken_elements_combined"]
        .iter()
        .map(|k| summary[k].as_u64().unwrap() as usize)
        .sum::<usize>();
    assert!(broken > 0, "the FSP broke nothing");
    let (intact_cells, broken_cells) = last.parts.iter().fold((0, 0), |(i, b), p| (i + p.cells, b + p.broken_cells));
    assert_eq!((broken_cells, intact_cells + broken_cells), (broken, end.cells.len()));
    assert_eq!(end.cells.iter().filter(|c| c.3 != 0).count(), broken);
    let part = hdf5::File::open(out.join("fields").join(&last.parts[0].file)).unwrap();
    let group = part.group(&format!("snapshot-{:010}", last.step)).unwrap();
    let failure: Vec<u8> = group.dataset("failure").unwrap().read_raw().unwrap();
    let broken_failure: Vec<u8> = group.dataset("broken/failure").unwrap().read_raw().unwrap();
    assert!(failure.iter().all(|&f| f == 0) && broken_failure.iter().all(|&f| f != 0));
    let drawn = std::fs::read_to_string(out.join("fields.xdmf")).unwrap();
    let broken_view = std::fs::read_to_string(out.join("broken-elements.xdmf")).unwrap();
    assert!(drawn.contains("/displacement<") && !drawn.contains("/broken/"));
    assert!(broken_view.contains(&format!("snapshot-{:010}/broken/connectivity", last.step)));
    // the spinning FSP's surface moves as a rigid body: v + w x (x - c) at every vertex
    assert_rigid_surface_velocities(&out, last.step);
    // the back face: at rest at first; it moves toward the back; the largest deflection is at
    // least the axis node's while the back layer is whole; the axis node is never ahead of
    // the projectile, which pushes it through the layers above
    let results = hdf5::File::open(out.join("results.h5")).unwrap();
    let read = |name: &str| -> Vec<f64> { results.dataset(name).unwrap().read_raw().unwrap() };
    let (largest, at_axis) = (read("history/back_face/largest"), read("history/back_face/at_axis"));
    let projectile: Vec<f64> = read("history/projectile_position");
    let by_layer: Vec<u64> = results.dataset("history/broken/by_layer").unwrap().read_raw().unwrap();
    assert_eq!((largest[0].to_bits(), at_axis[0].to_bits()), (0, 0));
    assert!(*at_axis.last().unwrap() > 1e-5, "the back face did not move: {at_axis:?}");
    for s in 0..largest.len() {
        let travel = projectile[2] - projectile[3 * s + 2];
        assert!(
            at_axis[s] < travel.max(0.0) + 1e-9,
            "sample {s}: back face {} ahead of the projectile's {travel}",
            at_axis[s]
        );
        if by_layer[4 * s + 3] == 0 {
            assert!(largest[s] >= at_axis[s], "sample {s}: largest {} < at the axis {}", largest[s], at_axis[s]);
        }
    }
    let csv = std::fs::read_to_string(out.join("history.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(",back_face_largest_m,back_face_at_axis_m"));
}

#[test]
fn a_deformable_projectile_draws_its_surface_nodes_velocities() {
    let dir = scratch("deformable-surface");
    let mut case = case_file("four_layer_deformable_sphere.json");
    case["run"]["snapshot_interval_steps"] = 200.into();
    let out = run_changed(&dir, &case);
    let snapshots = dea_io::snapshot::index(&out, 1, u64::MAX).unwrap();
    let surface = hdf5::File::open(out.join("fields/projectile.h5")).unwrap();
    let last = surface.group(&format!("snapshot-{:010}", snapshots.last().unwrap().step)).unwrap();
    let velocity: Vec<f64> = last.dataset("velocity").unwrap().read_raw().unwrap();
    let position: Vec<f64> = last.dataset("position").unwrap().read_raw().unwrap();
    assert_eq!(velocity.len(), position.len());
    // the struck body deforms: its surface nodes no longer share one velocity, and their
    // mean along the flight stays near the body's
    let normal: Vec<f64> = velocity.chunks_exact(3).map(|v| v[2]).collect();
    let (low, high) = normal.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
    assert!(high - low > 1.0, "surface velocities {low}..{high} m/s along z");
    let results = hdf5::File::open(out.join("results.h5")).unwrap();
    let history: Vec<f64> = results.dataset("history/projectile_velocity").unwrap().read_raw().unwrap();
    let mean = normal.iter().sum::<f64>() / normal.len() as f64;
    let body = history[history.len() - 1];
    assert!((mean - body).abs() < 0.2 * body.abs(), "surface mean {mean} m/s, body {body} m/s");
}

#[test]
fn check_prices_a_case_on_the_ranks_meant_and_a_campaign_by_its_shots() {
    let priced = |args: &[&str]| -> serde_json::Value {
        let out = dea(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(stderr.lines().any(|l| l.starts_with("cost: about ")), "{stderr}");
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let printed = priced(&["check", "../cases/default.json", "--ranks", "2"]);
    let resolved = &printed["resolved"];
    let cost = &resolved["cost"];
    let number = |key: &str| cost[key].as_f64().unwrap_or_else(|| panic!("cost.{key} in {cost}"));
    // the settle's steps and the shot's to its end time
    let time_step = resolved["time_step_s"].as_f64().unwrap();
    let settle = printed["case"]["run"]["settle"]["time_s"].as_f64().unwrap();
    let end = printed["case"]["run"]["end_time_s"].as_f64().unwrap();
    assert_eq!(number("settle_steps"), (settle / time_step).ceil());
    assert_eq!(number("shot_steps"), (end / time_step).ceil());
    assert_eq!(number("steps"), number("settle_steps") + number("shot_steps"));
    assert_eq!(resolved["steps"].as_f64().unwrap(), number("shot_steps"));
    // wall is the slowest rank's step times the steps; core-hours are wall times ranks
    assert!((number("wall_s") / (number("step_s") * number("steps")) - 1.0).abs() < 1e-12);
    assert!((number("core_hours") / (number("wall_s") * 2.0 / 3600.0) - 1.0).abs() < 1e-12);
    assert!(number("imbalance") >= 1.0 && number("step_s") > 0.0);
    assert_eq!((number("network_s"), cost["ranks"].as_u64()), (0.0, Some(2)), "one host: no network");
    assert!(cost["calibration"].as_str().unwrap().contains("reference-shot"));
    // the largest share is reported, and no rank holds more than it
    let memory = &resolved["memory"];
    assert!(memory["largest_rank_nodes"].as_u64().unwrap() >= resolved["nodes"].as_u64().unwrap() / 2);
    // two ranks on two hosts pay their messages between them
    let spread = priced(&["check", "../cases/default.json", "--ranks", "2", "--ranks-per-host", "1"]);
    let network = spread["resolved"]["cost"]["network_s"].as_f64().unwrap();
    assert!(network > 0.0, "{}", spread["resolved"]["cost"]);
    assert!(spread["resolved"]["cost"]["interconnect"].as_str().unwrap().contains("ASSUMED"));
    // one rank costs more wall than two and about as many core-hours
    let one = priced(&["check", "../cases/default.json"]);
    let one = &one["resolved"]["cost"];
    assert!(one["wall_s"].as_f64().unwrap() > number("wall_s"));
    // a campaign is priced by its shots: the tiny bisection's bounds [50, 500] by 25 m/s
    // halve five times, and it may fire one bound: 6
    let campaign = priced(&["check", "../cases/v50_tiny_bisection.json"]);
    let cost = &campaign["resolved"]["cost"];
    assert_eq!(cost["campaign"]["shots"].as_u64(), Some(6), "{cost}");
    let per_shot = cost["core_hours"].as_f64().unwrap();
    assert!((cost["campaign"]["core_hours"].as_f64().unwrap() / (6.0 * per_shot) - 1.0).abs() < 1e-12);
}

#[test]
fn the_cost_scripts_print_what_check_prices() {
    let script = |args: &[&str]| -> Output {
        Command::new("python3").args(args).current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).output().unwrap()
    };
    let binary = env!("CARGO_BIN_EXE_dea-mpi");
    let check = |args: &[&str]| -> serde_json::Value {
        let out =
            Command::new(binary).args(args).current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).output().unwrap();
        serde_json::from_slice(&out.stdout).unwrap()
    };
    // a plain case (it stopped with a KeyError traceback before): check's price, quoted
    let out =
        script(&["jobs/cost.py", "cases/default.json", "--ranks-per-shot", "2", "--tasks", "4", "--binary", binary]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let cost = check(&["check", "cases/default.json", "--ranks", "2"])["resolved"]["cost"].clone();
    let hours = cost["core_hours"].as_f64().unwrap();
    // three figures of check's core-hours in the per-shot line
    let quoted: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("per shot on 2 rank(s), 2 per host: about ")?.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("{text}"));
    assert!((quoted / hours - 1.0).abs() < 5e-3, "{text} / {hours}");
    assert!(text.contains("2 group(s) of 2") && !text.contains("campaign:"), "{text}");
    // beside it, what whole shots of a woven panel have cost against the price: measured,
    // from docs/benchmarks/whole-shots.json, in check's JSON and quoted by the script
    let whole = &cost["whole_shots"];
    assert_eq!(whole["target_kind"], "woven_panel", "{cost}");
    let (low, high) = (whole["factor_low"].as_f64().unwrap(), whole["factor_high"].as_f64().unwrap());
    assert!(1.0 < low && low <= high, "{whole}");
    assert!((whole["core_hours_high"].as_f64().unwrap() / (high * hours) - 1.0).abs() < 1e-12, "{whole}");
    assert!(text.contains(&format!("whole shots: woven_panel shots have cost {low:.2}-{high:.2} times")), "{text}");
    // a kind no whole shot was measured on: no band, and the script says so
    let out = script(&["jobs/cost.py", "cases/single_fibre_short.json", "--ranks-per-shot", "1", "--binary", binary]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(check(&["check", "cases/single_fibre_short.json"])["resolved"]["cost"]["whole_shots"].is_null());
    assert!(text.contains("whole shots: no single_fibre shot has been measured against the price"), "{text}");
    // a campaign: its shots and their core-hours
    let out = script(&[
        "jobs/cost.py",
        "cases/v50_tiny_bisection.json",
        "--ranks-per-shot",
        "1",
        "--tasks",
        "2",
        "--binary",
        binary,
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("campaign: 6 shots") && text.contains("3 round(s)"), "{text}");
    // what check refuses, refused with its message and code, no traceback
    let out = script(&["jobs/cost.py", "no-such-case.json", "--binary", binary]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{stderr}");
    assert!(stderr.contains("no-such-case.json") && !stderr.contains("Traceback"), "{stderr}");
    let out =
        script(&["jobs/cost.py", "cases/default.json", "--tasks", "4", "--ranks-per-shot", "8", "--binary", binary]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot hold one shot's 8 ranks"));
    // the table over rank counts: one row each, from check
    let out = script(&["scripts/cost-model.py", "cases/four_layer_panel.json", "--ranks", "1,2,3", "--binary", binary]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("| ") && !l.starts_with("| ranks")).collect();
    assert_eq!(rows.len(), 3, "{text}");
    assert!(rows[2].starts_with("| 3 | 1 |"), "{text}");
}

/// A campaign directory as `dea-mpi v50` leaves it (provenance.json and shot records) for the
/// tiny Monte Carlo campaign named `name`, its case changed by `change`, with `shots`
/// (velocity, perforated) on record.
fn fired_campaign(dir: &std::path::Path, name: &str, change: impl Fn(&mut serde_json::Value), shots: &[(f64, bool)]) {
    let checked = dea(&["check", "../cases/v50_tiny_monte_carlo.json"]);
    assert!(checked.status.success(), "{}", String::from_utf8_lossy(&checked.stderr));
    let checked: serde_json::Value = serde_json::from_slice(&checked.stdout).unwrap();
    let mut campaign = case_file("v50_tiny_monte_carlo.json");
    campaign["name"] = name.into();
    let mut case = checked["case"].clone();
    change(&mut case);
    std::fs::create_dir_all(dir.join("shots")).unwrap();
    let provenance = serde_json::json!({ "campaign": campaign, "case": case });
    std::fs::write(dir.join("provenance.json"), provenance.to_string()).unwrap();
    for (index, &(velocity, perforated)) in shots.iter().enumerate() {
        let id = format!("r000-{index:05}");
        let record = serde_json::json!({
            "id": id, "replicate": 0, "index": index, "velocity_m_s": velocity, "seed": case["failure"]["seed"],
            "perforated": perforated, "residual_velocity_m_s": if perforated { 0.3 * velocity } else { -0.5 },
            "stopped_by": if perforated { "perforated" } else { "stopped" }, "steps": 1000, "wall_s": 1.0,
            "ranks": 1, "max_projectile_force_n": 100.0, "unload": "at_break",
            "projectile_friction_spring": "rotating", "fibre_friction_spring": "anchored",
        });
        std::fs::write(dir.join("shots").join(format!("{id}.json")), record.to_string()).unwrap();
    }
}

#[test]
fn fit_pools_campaigns_of_one_target_and_refuses_any_other() {
    let dir = scratch("fit");
    let (first, finer) = (dir.join("first"), dir.join("finer"));
    // a coarse series that separates cleanly, and a finer one with its own seed and end time
    fired_campaign(&first, "first", |_| {}, &[(150.0, false), (175.0, true), (150.0, false), (175.0, true)]);
    let other_draws = |case: &mut serde_json::Value| {
        case["failure"]["seed"] = 7.into();
        case["run"]["end_time_s"] = 2.0e-5.into();
    };
    fired_campaign(&finer, "finer", other_draws, &[(162.5, true), (156.25, false), (168.75, false), (175.0, true)]);
    let (a, b) = (first.to_str().unwrap(), finer.to_str().unwrap());
    // alone, the first has no zone of mixed results; pooled, the finer one gives it one
    let alone = dea(&["fit", a]);
    assert!(alone.status.success(), "{}", String::from_utf8_lossy(&alone.stderr));
    let alone = String::from_utf8_lossy(&alone.stdout).into_owned();
    assert!(alone.contains("logistic: no zone of mixed results"), "{alone}");
    // Firth's penalised fit still has one: two of each outcome at two speeds put it at their
    // midpoint (the log-odds ln(1/5) and ln(5) with a half added to each count)
    assert!(alone.contains("Firth: V50 162.5 m/s") && alone.contains("Firth's penalised likelihood"), "{alone}");
    let pooled = dea(&["fit", a, b, "--json"]);
    assert!(pooled.status.success(), "{}", String::from_utf8_lossy(&pooled.stderr));
    let report: serde_json::Value = serde_json::from_slice(&pooled.stdout).unwrap();
    assert_eq!(report["campaign"], "first + finer");
    assert_eq!((report["partials"].as_u64(), report["completes"].as_u64()), (Some(4), Some(4)));
    assert_eq!(report["shots"][4]["id"], "finer/r000-00000");
    let v50 = report["logistic"]["Ok"]["v50"]["velocity"].as_f64().expect("a pooled logistic V50");
    assert!(v50 > 150.0 && v50 < 175.0, "{v50}");
    let printed = dea(&["fit", a, b]);
    assert!(String::from_utf8_lossy(&printed.stdout).starts_with("first + finer: 8 shots (4 partial, 4 complete)"));
    // a partial undecided at its end time is named, with how to decide it
    let record = finer.join("shots/r000-00001.json");
    let text = std::fs::read_to_string(&record).unwrap().replace(r#""stopped""#, r#""end_time_s""#);
    std::fs::write(&record, text).unwrap();
    let held = String::from_utf8_lossy(&dea(&["fit", a, b]).stdout).into_owned();
    assert!(
        held.contains("1 partial(s) were still undecided at the case's end time (finer/r000-00001)")
            && held.contains("remove their records (shots/<id>.json) and run the campaign again"),
        "{held}"
    );

    // another target: refused, naming the field
    let rougher = dir.join("rougher");
    fired_campaign(&rougher, "rougher", |case| case["contact"]["friction_coefficient"] = 0.5.into(), &[(160.0, true)]);
    let stderr = stderr_of_exit(3, &["fit", a, rougher.to_str().unwrap()]);
    assert!(
        stderr.contains("cannot be pooled: their shot cases differ at case.contact.friction_coefficient"),
        "{stderr}"
    );
    // another model choice on record: refused, naming it
    let unloaded = dir.join("unloaded");
    fired_campaign(&unloaded, "unloaded", |_| {}, &[(160.0, true)]);
    let record = unloaded.join("shots/r000-00000.json");
    let text = std::fs::read_to_string(&record).unwrap().replace("at_break", "next_step");
    std::fs::write(&record, text).unwrap();
    let stderr = stderr_of_exit(3, &["fit", a, unloaded.to_str().unwrap()]);
    assert!(stderr.contains("was fired with unload \"next_step\""), "{stderr}");
    // one campaign twice, or a copy of it under another directory
    let stderr = stderr_of_exit(3, &["fit", a, b, a]);
    assert!(stderr.contains("are the same campaign (first): its shots would count twice"), "{stderr}");
    let copy = dir.join("copy");
    fired_campaign(&copy, "first", |_| {}, &[(150.0, false)]);
    let stderr = stderr_of_exit(3, &["fit", a, copy.to_str().unwrap()]);
    assert!(stderr.contains("are the same campaign (first)"), "{stderr}");
    // not a campaign directory
    let stderr = stderr_of_exit(4, &["fit", a, dir.join("nothing").to_str().unwrap()]);
    assert!(stderr.contains("nothing: no provenance.json"), "{stderr}");
    // a campaign directory whose shot records are gone: a file error too
    let bare = dir.join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    std::fs::copy(dir.join("first/provenance.json"), bare.join("provenance.json")).unwrap();
    let stderr = stderr_of_exit(4, &["fit", a, bare.to_str().unwrap()]);
    assert!(stderr.contains("bare: no shots/ directory"), "{stderr}");
}
