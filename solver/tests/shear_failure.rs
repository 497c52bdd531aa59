//! Shear failure as a user meets it (issue 31, item 1; docs/theory.md I9b): the binary runs
//! shipped cases with a field or two changed. Under the gauge shear measure (the default) a
//! blunt sphere below its perforation speed breaks nothing in shear at any element length
//! with tension taken on the element (a small minority with the tension gauge), where the
//! seed's element measure does; and the 17-grain FSP's 50 µm edge still cuts in
//! shear.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Breaks by mode (tension, shear, combined) and the residual velocity [m/s] of `case` run
/// with `edit` applied.
fn run(case: &str, label: &str, edit: impl Fn(&mut serde_json::Value)) -> ([u64; 3], f64) {
    let scratch = std::env::temp_dir().join(format!("dea-shear-{}-{label}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).unwrap();
    let text = std::fs::read_to_string(repository().join("cases").join(case)).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    edit(&mut value);
    let path = scratch.join("case.json");
    std::fs::write(&path, value.to_string()).unwrap();
    let out = scratch.join("out");
    let done =
        Command::new(env!("CARGO_BIN_EXE_dea-mpi")).arg("run").arg(&path).arg("--out").arg(&out).output().unwrap();
    assert!(done.status.success(), "{label}: {}", String::from_utf8_lossy(&done.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&scratch);
    let count = |key: &str| summary[key].as_u64().unwrap();
    (
        [count("broken_elements_tension"), count("broken_elements_shear"), count("broken_elements_combined")],
        summary["residual_velocity_m_s"].as_f64().unwrap(),
    )
}

#[test]
fn a_blunt_sphere_below_its_perforation_speed_breaks_nothing_in_shear_at_any_element_length() {
    // cases/four_layer_panel.json's 0.8 mm sphere at 200 m/s: stopped to about 40 m/s within 4 µs
    // with tension taken on the element's own strain, as when the shear gauge was built
    let slow = |measure: &'static str, ratio: f64, tension: &'static str| {
        move |v: &mut serde_json::Value| {
            v["projectile"]["velocity_m_s"] = 200.0.into();
            v["run"]["end_time_s"] = 4e-6.into();
            v["target"]["element_length_ratio"] = ratio.into();
            v["failure"]["shear_measure"] = measure.into();
            v["failure"]["tension_measure"] = tension.into();
        }
    };
    for ratio in [0.5, 0.25] {
        let ([tension, shear, _], residual) =
            run("four_layer_panel.json", &format!("gauge-{ratio}"), slow("gauge", ratio, "element"));
        assert!(residual < 100.0, "l0/d {ratio}: the sphere is being stopped ({residual} m/s)");
        assert!(tension > 0, "l0/d {ratio}: fibres under the nose break in tension");
        assert_eq!(shear, 0, "l0/d {ratio}: the gauge measure breaks nothing in shear under a blunt nose");
    }
    // the seed's element measure does, which is what the gauge measure is for
    let ([_, shear, _], _) = run("four_layer_panel.json", "element-0.5", slow("element", 0.5, "element"));
    assert!(shear > 0, "the element measure breaks fibres in shear under a blunt nose");
    // under the tension gauge too (the default since 2026-12-03) a few break in shear, 2 and 6
    // against 21 and 16 in tension at l0/d 0.5 and 0.25 (theory I9c, an open question): held
    // here to a small minority, so that a change that lets shear decide again shows
    for ratio in [0.5, 0.25] {
        let ([tension, shear, _], residual) =
            run("four_layer_panel.json", &format!("both-gauges-{ratio}"), slow("gauge", ratio, "gauge"));
        assert!(residual < 100.0, "l0/d {ratio}, both gauges: the sphere is being stopped ({residual} m/s)");
        assert!(2 * shear < tension, "l0/d {ratio}, both gauges: {shear} in shear against {tension} in tension");
    }
}

#[test]
fn the_17_grain_fsps_edge_still_cuts_in_shear() {
    // a 10 mm patch of style 706 under the 17-grain FSP at 400 m/s (the built-in default case
    // until session 27), two layers, the first 3 µs
    let ([_, shear, _], _) = run("km2_706_patch.json", "fsp", |v| {
        v["target"]["layers"] = 2.into();
        v["run"]["end_time_s"] = 3e-6.into();
    });
    assert!(shear > 0, "the FSP's edge cuts fibres in shear under the gauge measure");
}
