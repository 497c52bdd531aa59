//! Golden references: small shipped cases run by the binary as a user runs them, their time
//! histories and summaries compared bit for bit with the copies checked in under
//! `tests/golden/<case>/`. A change of any result fails here, whatever the rank count.
//!
//! Each case runs twice: as shipped (its results in `tests/golden/<case>/`) and with the seed's
//! forms as written where the defaults depart from them, `failure.shear_measure` and
//! `failure.tension_measure` "element", `contact.projectile_friction_spring` "anchored",
//! `failure.unload` "next_step" and a woven panel's `target.rest_angle_law` "cone" (in
//! `tests/golden/<case>/seed/`: the results every case gave before the gauges, the rotating
//! spring, the unloading at the break and the smooth rest-angle law became the defaults, kept
//! to show that the named options reproduce them bit for bit; docs/theory.md I9b, I9c, I6c,
//! I7, F4b).
//!
//! To re-bless after a change that is meant to change results, run
//! `DEA_BLESS_GOLDEN=1 cargo test --release -p dea-mpi --test golden` and commit the new files
//! with a message that says why the results moved. Never re-bless to make a refactor pass.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The cases: together they take every path of the step that carries state (a meshed oblique
/// and yawed FSP with tension, shear and combined breaks under Weibull strengths; a woven
/// panel in a clamp; a hybrid disc with ties, settled before the shot; a deformable
/// projectile that subcycles).
const CASES: [&str; 4] =
    ["four_layer_fsp", "woven_two_layer_clamp", "hybrid_disc_two_layer_settle", "four_layer_deformable_sphere"];

/// Summary fields that measure the machine or how the work was split (`relisted_share`),
/// not the physics: never compared.
const TIMING_FIELDS: [&str; 5] =
    ["wall_s", "node_steps_per_s_per_core", "stage_seconds", "load_imbalance", "relisted_share"];

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The summary without its timings, one field a line, numbers as serde_json prints them
/// (the shortest text that reads back to the same bits).
fn physics_of_summary(summary: &str) -> String {
    let mut value: serde_json::Value = serde_json::from_str(summary).expect("summary.json is JSON");
    let object = value.as_object_mut().expect("the summary is an object");
    for field in TIMING_FIELDS {
        object.remove(field);
    }
    if let Some(settle) = object.get_mut("settle").and_then(|s| s.as_object_mut()) {
        settle.remove("wall_s");
    }
    serde_json::to_string_pretty(&value).expect("serialises") + "\n"
}

/// The first line where two texts differ, for the failure message.
fn first_difference(expected: &str, found: &str) -> String {
    let line = expected
        .lines()
        .zip(found.lines())
        .position(|(a, b)| a != b)
        .unwrap_or_else(|| expected.lines().count().min(found.lines().count()));
    format!(
        "line {}:\n  golden: {}\n  now:    {}",
        line + 1,
        expected.lines().nth(line).unwrap_or("(end)"),
        found.lines().nth(line).unwrap_or("(end)")
    )
}

#[test]
fn the_golden_cases_keep_their_bits() {
    let bless = std::env::var_os("DEA_BLESS_GOLDEN").is_some();
    let scratch = std::env::temp_dir().join(format!("dea-golden-{}", std::process::id()));
    let mut failures = Vec::new();
    for (case, variant) in CASES.iter().flat_map(|&case| [(case, None), (case, Some("seed"))]) {
        let label = format!("{case}{}", variant.map(|m| format!("/{m}")).unwrap_or_default());
        let out = scratch.join(case).join(variant.unwrap_or("shipped"));
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out).unwrap();
        let mut case_path = repository().join("cases").join(format!("{case}.json"));
        if let Some(variant) = variant {
            let text = std::fs::read_to_string(&case_path).unwrap();
            let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
            value["failure"]["shear_measure"] = serde_json::Value::from("element");
            value["contact"]["projectile_friction_spring"] = serde_json::Value::from("anchored");
            value["failure"]["unload"] = serde_json::Value::from("next_step");
            value["failure"]["tension_measure"] = serde_json::Value::from("element");
            // a woven panel's springs rest bent (as woven): the seed's cone below the rest angle
            if value["target"]["kind"] == "woven_panel" {
                value["target"]["rest_angle_law"] = serde_json::Value::from("cone");
            }
            case_path = scratch.join(format!("{case}-{variant}.json"));
            std::fs::write(&case_path, serde_json::to_string_pretty(&value).unwrap()).unwrap();
        }
        let run = Command::new(env!("CARGO_BIN_EXE_dea-mpi"))
            .arg("run")
            .arg(&case_path)
            .arg("--out")
            .arg(&out)
            .output()
            .expect("dea-mpi starts");
        assert!(run.status.success(), "{label}: {}", String::from_utf8_lossy(&run.stderr));
        let golden = repository().join("tests/golden").join(case).join(variant.unwrap_or(""));
        let found = [
            ("history.csv", std::fs::read_to_string(out.join("history.csv")).expect("history.csv written")),
            (
                "summary.json",
                physics_of_summary(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json written")),
            ),
        ];
        for (file, text) in found {
            if bless {
                std::fs::create_dir_all(&golden).unwrap();
                std::fs::write(golden.join(file), &text).unwrap();
                continue;
            }
            let expected = std::fs::read_to_string(golden.join(file))
                .unwrap_or_else(|e| panic!("{label}/{file}: {e} (bless with DEA_BLESS_GOLDEN=1)"));
            if expected != text {
                failures
                    .push(format!("{label}/{file} differs from tests/golden, {}", first_difference(&expected, &text)));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    assert!(
        failures.is_empty(),
        "{}\nA result changed. If that is meant, re-bless (DEA_BLESS_GOLDEN=1) in a commit that says why.",
        failures.join("\n")
    );
}

/// The comparison can fail: one changed bit of a number is found and reported.
#[test]
fn a_changed_bit_is_a_difference() {
    let summary =
        r#"{"case":"x","wall_s":1.5,"residual_velocity_m_s":253.38174755090085,"settle":{"steps":3,"wall_s":0.1}}"#;
    let nudged =
        summary.replace("253.38174755090085", &f64::from_bits(253.38174755090085f64.to_bits() + 1).to_string());
    assert_ne!(physics_of_summary(summary), physics_of_summary(&nudged));
    // timings are not physics
    assert_eq!(physics_of_summary(summary), physics_of_summary(&summary.replace("1.5", "9.0").replace("0.1", "0.2")));
    assert!(
        first_difference(&physics_of_summary(summary), &physics_of_summary(&nudged)).contains("residual_velocity_m_s")
    );
}
