//! V50 campaigns in process: a campaign interrupted mid-shot and run again equals one run
//! without a break, shot for shot and bit for bit; a bisection closes on its bracket.

mod common;

use common::Scratch;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use dea_io::campaign::load_campaign;
use dea_mpi::campaign::{report, run_group, CampaignError, Group, Progress, ShotRecord};
use dea_mpi::comm::local::run_local;
use dea_mpi::run::RunError;

fn cases() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases")
}

fn scratch(name: &str) -> Scratch {
    Scratch::new(format!("dea-campaign-{name}-{}", std::process::id()), false)
}

/// What must not depend on how the campaign was run.
fn outcome(r: &ShotRecord) -> (String, u64, u64, bool, u64, u64, [u64; 4]) {
    let drawn =
        [r.aim_offset_m[0].to_bits(), r.aim_offset_m[1].to_bits(), r.yaw_deg.to_bits(), r.obliquity_deg.to_bits()];
    (r.id.clone(), r.velocity_m_s.to_bits(), r.seed, r.perforated, r.residual_velocity_m_s.to_bits(), r.steps, drawn)
}

#[test]
fn an_interrupted_campaign_resumes_to_the_same_shots() {
    let (campaign, case) = load_campaign(&cases().join("v50_tiny_monte_carlo.json")).unwrap();
    let dir = scratch("resume");
    let group = Group { index: 0, count: 1 };
    // uninterrupted, on 2 ranks
    run_local(2, |comm| run_group(&campaign, &case, comm, group, &dir.join("whole"), None, None).unwrap());
    let whole = report(&campaign, &dir.join("whole")).unwrap();
    assert_eq!(whole.shots.len(), 16);
    // every shot decided: a partial as soon as the projectile turned back (docs/theory.md V1)
    assert_eq!(whole.held_at_end, 0, "{:?}", whole.shots.iter().map(|s| &s.stopped_by).collect::<Vec<_>>());
    for partial in whole.shots.iter().filter(|s| !s.perforated) {
        assert!(partial.stopped_by == "stopped" || partial.stopped_by == "rebounded", "{partial:?}");
        assert!(partial.residual_velocity_m_s <= 0.0, "moving back: {partial:?}");
    }
    assert!(whole.partials > 0 && whole.completes > 0, "the spread straddles the limit");
    // shots that scatter in aim (and strength) leave a zone of mixed results, so the fits
    // give a V50 with an interval
    let lowest_complete =
        whole.shots.iter().filter(|s| s.perforated).map(|s| s.velocity_m_s).fold(f64::INFINITY, f64::min);
    let highest_partial = whole.shots.iter().filter(|s| !s.perforated).map(|s| s.velocity_m_s).fold(0.0, f64::max);
    assert!(lowest_complete < highest_partial, "a mixed zone: {lowest_complete} < {highest_partial}");
    for fit in [&whole.logistic, &whole.probit, &whole.firth_logistic] {
        let v50 = fit.as_ref().expect("a fitted V50").v50;
        assert!(v50.low < v50.velocity && v50.velocity < v50.high && (145.0..205.0).contains(&v50.velocity), "{v50:?}");
    }
    // every shot lists what it drew: an aim within one unit cell of the centre
    let aims: Vec<[f64; 2]> = whole.shots.iter().map(|s| s.aim_offset_m).collect();
    assert!(
        aims.iter().all(|a| a[0].abs() < 1e-3 && a[1].abs() < 1e-3) && aims.windows(2).all(|w| w[0] != w[1]),
        "{aims:?}"
    );
    assert!(whole.shots.iter().all(|s| s.yaw_deg.abs() <= 3.0 && s.obliquity_deg == 0.0));
    // and the energy balance its run ended with (docs/theory.md I11b)
    for s in &whole.shots {
        let run: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("whole/shots/{}/summary.json", s.id))).unwrap(),
        )
        .unwrap();
        assert_eq!(s.energy_balance_error, run["energy_balance_error"].as_f64(), "{}", s.id);
    }
    // two groups share the shots out and fire the same bits
    let halves = dir.join("groups");
    for index in [1, 0] {
        run_local(1, |comm| run_group(&campaign, &case, comm, Group { index, count: 2 }, &halves, None, None).unwrap());
    }
    let split = report(&campaign, &halves).unwrap();
    assert_eq!(
        split.shots.iter().map(outcome).collect::<Vec<_>>(),
        whole.shots.iter().map(outcome).collect::<Vec<_>>()
    );
    // two shots, then a signal that stops the third in its first step (it checkpoints),
    // then the rest on 1 rank
    let out = dir.join("interrupted");
    let paused = run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, Some(2), None).unwrap());
    assert_eq!(paused[0], Progress::Paused, "two shots fired, ten to go");
    let stop = Arc::new(AtomicBool::new(true));
    let first = run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, None, Some(stop.clone())));
    assert!(
        matches!(first[0], Err(CampaignError::Run { error: RunError::Interrupted(_), .. })),
        "{:?}",
        first[0].as_ref().err().map(|e| e.to_string())
    );
    let checkpoint = out.join("shots/r000-00002/checkpoint");
    assert!(checkpoint.join("manifest.h5").exists(), "the third shot left a checkpoint");
    // and its progress.json says it was stopped there, not that it still steps
    let progress: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("shots/r000-00002/progress.json")).unwrap()).unwrap();
    assert_eq!(progress["state"], "interrupted", "{progress}");
    assert_eq!(progress["checkpoint_time_s"], progress["simulated_time_s"], "{progress}");
    assert!(progress["eta_s"].is_null(), "{progress}");
    let first_segment = dea_io::checkpoint::read_manifest(&checkpoint).unwrap().run_scalars[3];
    assert!(first_segment > 0.0, "the checkpoint keeps the wall time so far");
    // a checkpoint names the unloading of broken elements it was stepped with; one that does
    // not was written before the choice existed, with "next_step", and a campaign unloading
    // at the break does not continue it
    let manifest = dea_io::checkpoint::read_manifest(&checkpoint).unwrap();
    assert!(manifest.case_json.contains(r#""unload":"at_break""#), "{}", manifest.case_json);
    let mut unnamed = manifest.clone();
    let mut stored: serde_json::Value = serde_json::from_str(&unnamed.case_json).unwrap();
    stored["failure"].as_object_mut().unwrap().remove("unload");
    unnamed.case_json = stored.to_string();
    let manifest_path = dea_io::checkpoint::manifest_path(&checkpoint);
    dea_io::checkpoint::write_manifest(&manifest_path, &unnamed).unwrap();
    // the error a group of `shot` is refused with on the records so far ("" if it runs)
    let refusal = |shot: &dea_io::case::Case| {
        let refused = run_local(1, |comm| run_group(&campaign, shot, comm, group, &out, None, None));
        refused[0].as_ref().err().map(|e| e.to_string()).unwrap_or_default()
    };
    // every shot record as written before it named `keys`
    let strip_records = |keys: &[&str]| {
        let records = std::fs::read_dir(out.join("shots")).unwrap().map(|e| e.unwrap().path());
        for path in records.filter(|p| p.extension().is_some_and(|e| e == "json")) {
            let mut record: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            for key in keys {
                record.as_object_mut().unwrap().remove(*key);
            }
            std::fs::write(&path, record.to_string()).unwrap();
        }
    };
    let message = refusal(&case);
    assert!(message.contains(r#"stepped with failure.unload "next_step""#), "{message}");
    dea_io::checkpoint::write_manifest(&manifest_path, &manifest).unwrap();
    assert_eq!(report(&campaign, &out).unwrap().shots.len(), 2, "two shots on record");
    // a checkpoint continues under the campaign's end time (in a copy: half the time the
    // third shot takes ends it there, undecided)...
    let straight: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("whole/shots/r000-00002/summary.json")).unwrap())
            .unwrap();
    let (steps, time_step) = (straight["steps"].as_u64().unwrap(), straight["time_step_s"].as_f64().unwrap());
    let mut shorter = case.clone();
    shorter.run.end_time_s = 0.5 * steps as f64 * time_step;
    let copy = dir.join("copy");
    copy_tree(&out, &copy);
    run_local(1, |comm| run_group(&campaign, &shorter, comm, group, &copy, Some(1), None).unwrap());
    let cut = report(&campaign, &copy).unwrap().shots[2].clone();
    assert!(cut.stopped_by == "end_time_s" && cut.steps.abs_diff(steps / 2) <= 1, "{cut:?} of {steps} steps");
    // and an undecided shot checkpoints at its end: its record withdrawn, the campaign's
    // own end time takes it on from there to the shot fired straight through
    let at_end = dea_io::checkpoint::read_manifest(&copy.join("shots/r000-00002/checkpoint")).unwrap();
    assert_eq!(at_end.step, cut.steps, "the checkpoint is the shot's last step");
    std::fs::remove_file(copy.join("shots/r000-00002.json")).unwrap();
    run_local(1, |comm| run_group(&campaign, &case, comm, group, &copy, Some(1), None).unwrap());
    assert_eq!(outcome(&report(&campaign, &copy).unwrap().shots[2]), outcome(&whole.shots[2]));
    let differences = dea_io::results::compare_results(
        &dir.join("whole/shots/r000-00002/results.h5"),
        &copy.join("shots/r000-00002/results.h5"),
    )
    .unwrap();
    assert!(differences.is_empty(), "the shot taken on: {differences:#?}");
    // ...but under nothing else the campaign changed since it was written
    let mut rougher = case.clone();
    rougher.contact.friction_coefficient += 0.1;
    let message = refusal(&rougher);
    assert!(message.contains("stepped with another contact.friction_coefficient"), "{message}");
    stop.store(false, Ordering::SeqCst);
    run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, None, Some(stop.clone())).unwrap());
    let resumed = report(&campaign, &out).unwrap();
    let third = &resumed.shots[2];
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("shots/r000-00002/summary.json")).unwrap()).unwrap();
    assert!(third.wall_s >= first_segment && summary["wall_s"].as_f64() == Some(third.wall_s), "every segment counts");
    assert_eq!(
        resumed.shots.iter().map(outcome).collect::<Vec<_>>(),
        whole.shots.iter().map(outcome).collect::<Vec<_>>()
    );
    let differences = dea_io::results::compare_results(
        &dir.join("whole/shots/r000-00002/results.h5"),
        &out.join("shots/r000-00002/results.h5"),
    )
    .unwrap();
    assert!(differences.is_empty(), "the resumed shot: {differences:#?}");
    // a third run finds nothing to do
    let before = std::fs::metadata(out.join("shots/r000-00005.json")).unwrap().modified().unwrap();
    run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, None, None).unwrap());
    assert_eq!(std::fs::metadata(out.join("shots/r000-00005.json")).unwrap().modified().unwrap(), before);
    // a campaign changed since its shots were fired is refused, not mixed in
    let mut changed = campaign.clone();
    changed.scatter = Some(dea_ballistic::scatter::Scatter {
        yaw_deg: dea_ballistic::scatter::Spread::Fixed {},
        ..campaign.scatter()
    });
    let refused = run_local(1, |comm| run_group(&changed, &case, comm, group, &out, None, None));
    let message = refused[0].as_ref().err().map(|e| e.to_string()).unwrap_or_default();
    assert!(message.contains("r000-00000") && message.contains("the campaign changed since"), "{message}");
    // so is a case whose fibre–projectile friction spring is not the one its shots were fired
    // with, and a record from before the spring was named counts as the seed's anchored one
    let mut other_spring = case.clone();
    other_spring.contact.projectile_friction_spring = Some("anchored".into());
    let message = refusal(&other_spring);
    assert!(
        message.contains("r000-00000")
            && message.contains("fired with the fibre–projectile friction spring \"rotating\"")
            && message.contains("now asks for \"anchored\"")
            && message.contains("contact.projectile_friction_spring"),
        "{message}"
    );
    let record = out.join("shots/r000-00000.json");
    let mut value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&record).unwrap()).unwrap();
    assert_eq!(value["projectile_friction_spring"], "rotating");
    value.as_object_mut().unwrap().remove("projectile_friction_spring");
    std::fs::write(&record, value.to_string()).unwrap();
    let message = refusal(&case);
    assert!(message.contains("fired with the fibre–projectile friction spring \"anchored\""), "{message}");
    // the fibre–fibre spring likewise: the record names the seed's anchored one, and a case
    // asking for the projected one is refused
    value["projectile_friction_spring"] = "rotating".into();
    assert_eq!(value["fibre_friction_spring"], "anchored");
    std::fs::write(&record, value.to_string()).unwrap();
    let mut projected = case.clone();
    projected.contact.fibre_friction_spring = Some("projected".into());
    let message = refusal(&projected);
    assert!(
        message.contains("r000-00000")
            && message.contains("fired with the fibre–fibre friction spring \"anchored\"")
            && message.contains("now asks for \"projected\""),
        "{message}"
    );
    // and the unloading of broken elements: a record names it, one from before it was named
    // was fired with "next_step", which a campaign may go on with only by naming it
    assert_eq!(value["unload"], "at_break");
    let mut next_step = case.clone();
    next_step.failure.unload = Some("next_step".into());
    let message = refusal(&next_step);
    assert!(
        message.contains("unloading of broken elements \"at_break\"") && message.contains("failure.unload"),
        "{message}"
    );
    value.as_object_mut().unwrap().remove("unload");
    std::fs::write(&record, value.to_string()).unwrap();
    let message = refusal(&case);
    assert!(message.contains("\"next_step\", but the campaign now asks for \"at_break\""), "{message}");
    strip_records(&["unload"]);
    run_local(1, |comm| run_group(&campaign, &next_step, comm, group, &out, None, None).unwrap());
    // and the tension measure and rest-angle law, whose defaults changed on 2026-12-03: a
    // record names them; one from before was fired with "element" and "cone" where its case
    // left them unsaid, which a campaign may go on with only by naming them
    let mut value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&record).unwrap()).unwrap();
    assert_eq!((&value["tension_measure"], &value["rest_angle_law"]), (&"gauge".into(), &"smooth".into()));
    let mut element = next_step.clone();
    element.failure.tension_measure = Some("element".into());
    let message = refusal(&element);
    assert!(
        message.contains("fired with the tension measure \"gauge\", but the campaign now asks for \"element\"")
            && message.contains("failure.tension_measure"),
        "{message}"
    );
    value.as_object_mut().unwrap().remove("tension_measure");
    std::fs::write(&record, value.to_string()).unwrap();
    let message = refusal(&next_step);
    assert!(
        message.contains("r000-00000")
            && message.contains("fired with the tension measure \"element\", but the campaign now asks for \"gauge\"")
            && message.contains("before 2026-12-03"),
        "{message}"
    );
    value.as_object_mut().unwrap().remove("rest_angle_law");
    std::fs::write(&record, value.to_string()).unwrap();
    let message = refusal(&element);
    assert!(
        message.contains("fired with the rest-angle law \"cone\", but the campaign now asks for \"smooth\"")
            && message.contains("target.rest_angle_law"),
        "{message}"
    );
    strip_records(&["tension_measure", "rest_angle_law"]);
    let mut as_before = element.clone();
    if let dea_io::case::TargetSpec::WovenPanel { rest_angle_law, .. } = &mut as_before.target {
        *rest_angle_law = Some("cone".into());
    }
    run_local(1, |comm| run_group(&campaign, &as_before, comm, group, &out, None, None).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_unit_cell_aim_needs_a_woven_target() {
    let (mut campaign, _) = load_campaign(&cases().join("v50_tiny_monte_carlo.json")).unwrap();
    let case = dea_io::case::load_case(&cases().join("single_fibre_short.json")).unwrap();
    campaign.scatter = Some(dea_ballistic::scatter::Scatter::default());
    let refused = run_local(1, |comm| {
        run_group(&campaign, &case, comm, Group { index: 0, count: 1 }, &scratch("straight"), None, None)
    });
    assert!(matches!(&refused[0], Err(CampaignError::Scatter(m)) if m.starts_with("scatter.aim")));
}

#[test]
fn a_bisection_closes_on_the_limit() {
    let (campaign, case) = load_campaign(&cases().join("v50_tiny_bisection.json")).unwrap();
    let dir = scratch("bisection");
    run_local(1, |comm| run_group(&campaign, &case, comm, Group { index: 0, count: 1 }, &dir, None, None).unwrap());
    let result = report(&campaign, &dir).unwrap();
    let (low, high) = result.bisection_brackets[0];
    assert!(high - low <= 15.0 && high > low, "{low} {high}");
    assert!(
        result.shots.iter().all(|s| s.perforated == (s.velocity_m_s >= high)),
        "one strength realisation: perforation is monotone in velocity"
    );
    assert_eq!(result.held_at_end, 0, "every shot decided");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `from` copied into `to`, directories and files.
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &to.join(entry.file_name()));
        } else {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
}

#[test]
fn a_record_written_before_the_energy_balance_was_kept_has_none_and_keeps_its_text() {
    let old = r#"{"id": "r000-00000", "replicate": 0, "index": 0, "velocity_m_s": 212.5, "seed": 2,
        "perforated": true, "residual_velocity_m_s": 120.2, "stopped_by": "perforated", "steps": 64600,
        "wall_s": 3876.0, "ranks": 2, "max_projectile_force_n": 2809.4}"#;
    let record: ShotRecord = serde_json::from_str(old).unwrap();
    assert_eq!(record.energy_balance_error, None);
    assert!(!serde_json::to_string(&record).unwrap().contains("energy_balance"), "none is not written");
    let kept = ShotRecord { energy_balance_error: Some(0.0252), ..record };
    let again: ShotRecord = serde_json::from_str(&serde_json::to_string(&kept).unwrap()).unwrap();
    assert_eq!(again.energy_balance_error, Some(0.0252));
}
