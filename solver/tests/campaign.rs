//! V50 campaigns in process: a campaign interrupted mid-shot and run again equals one run
//! without a break, shot for shot and bit for bit; a bisection closes on its bracket.

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

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dea-campaign-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// What must not depend on how the campaign was run.
fn outcome(r: &ShotRecord) -> (String, u64, u64, bool, u64, u64) {
    (r.id.clone(), r.velocity_m_s.to_bits(), r.seed, r.perforated, r.residual_velocity_m_s.to_bits(), r.steps)
}

#[test]
fn an_interrupted_campaign_resumes_to_the_same_shots() {
    let (campaign, case) = load_campaign(&cases().join("v50_tiny_monte_carlo.json")).unwrap();
    let dir = scratch("resume");
    let group = Group { index: 0, count: 1 };
    // uninterrupted, on 2 ranks
    run_local(2, |comm| run_group(&campaign, &case, comm, group, &dir.join("whole"), None, None).unwrap());
    let whole = report(&campaign, &dir.join("whole")).unwrap();
    assert_eq!(whole.shots.len(), 12);
    assert!(whole.partials > 0 && whole.completes > 0, "the spread straddles the limit");
    // two shots, then a signal that stops the third in its first step (it checkpoints),
    // then the rest on 1 rank
    let out = dir.join("interrupted");
    let paused = run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, Some(2), None).unwrap());
    assert_eq!(paused[0], Progress::Paused, "two shots fired, ten to go");
    let stop = Arc::new(AtomicBool::new(true));
    let first = run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, None, Some(stop.clone())));
    assert!(matches!(first[0], Err(CampaignError::Run { error: RunError::Interrupted(_), .. })), "{:?}", first[0].as_ref().err().map(|e| e.to_string()));
    let checkpoint = out.join("shots/r000-00002/checkpoint");
    assert!(checkpoint.join("manifest.h5").exists(), "the third shot left a checkpoint");
    assert_eq!(report(&campaign, &out).unwrap().shots.len(), 2, "two shots on record");
    stop.store(false, Ordering::SeqCst);
    run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, None, Some(stop.clone())).unwrap());
    let resumed = report(&campaign, &out).unwrap();
    assert_eq!(resumed.shots.iter().map(outcome).collect::<Vec<_>>(), whole.shots.iter().map(outcome).collect::<Vec<_>>());
    let differences = dea_io::results::compare_results(&dir.join("whole/shots/r000-00002/results.h5"), &out.join("shots/r000-00002/results.h5")).unwrap();
    assert!(differences.is_empty(), "the resumed shot: {differences:#?}");
    // a third run finds nothing to do
    let before = std::fs::metadata(out.join("shots/r000-00005.json")).unwrap().modified().unwrap();
    run_local(1, |comm| run_group(&campaign, &case, comm, group, &out, None, None).unwrap());
    assert_eq!(std::fs::metadata(out.join("shots/r000-00005.json")).unwrap().modified().unwrap(), before);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_bisection_closes_on_the_limit() {
    let (campaign, case) = load_campaign(&cases().join("v50_tiny_bisection.json")).unwrap();
    let dir = scratch("bisection");
    run_local(1, |comm| run_group(&campaign, &case, comm, Group { index: 0, count: 1 }, &dir, None, None).unwrap());
    let result = report(&campaign, &dir).unwrap();
    let (low, high) = result.bisection_brackets[0];
    assert!(high - low <= 15.0 && high > low, "{low} {high}");
    assert!(result.shots.iter().all(|s| s.perforated == (s.velocity_m_s >= high)), "one strength realisation: perforation is monotone in velocity");
    std::fs::remove_dir_all(&dir).unwrap();
}
