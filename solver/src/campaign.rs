//! `dea-mpi v50`: a campaign of shots at the velocities a design chooses, on groups of ranks
//! that fire concurrently, every shot's result persisted the moment it ends (a rerun skips
//! finished shots and resumes an interrupted one from its checkpoint), then the ballistic
//! limit estimated every way the shots allow.
//!
//! Layout of `OUT`: `shots/<id>/` is each shot's run directory (results.h5, summary.json,
//! checkpoint/); `shots/<id>.json` its record, written (atomically) when it ends;
//! `v50.json` the estimates; `provenance.json` the campaign, the shot case, the git commit
//! and every shot's velocity, strength seed and outcome.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use dea_ballistic::design::{bisection_bounds, bracket, Design};
use dea_ballistic::firth::firth_logistic;
use dea_ballistic::fit::{fit, Fit, Link};
use dea_ballistic::lambert_jonas::{lambert_jonas, LambertJonas};
use dea_ballistic::mil_std_662f::{mil_std_662f, MilStdEstimate};
use dea_ballistic::scatter::{Aim, Draws};
use dea_ballistic::Shot;
use dea_core::failure::Unload;
use dea_core::friction::{FibreFrictionSpring, FrictionSpring};
use dea_core::Rank;
use dea_io::campaign::{Campaign, MilStdSpec};
use dea_io::case::Case;
use dea_io::checkpoint::manifest_path;
use dea_partition::Method;
use serde::{Deserialize, Serialize};

use crate::comm::Comm;
use crate::run::{run, Resume, RunError, RunOptions};
use crate::setup::{build, restore, SetupError};

/// Why a campaign stopped.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    /// A shot's rank could not be set up.
    #[error("shot {id}: {error}")]
    Setup {
        /// the shot's id
        id: String,
        /// what went wrong
        error: SetupError,
    },
    /// A shot's run failed.
    #[error("shot {id}: {error}")]
    Run {
        /// the shot's id
        id: String,
        /// what went wrong
        error: RunError,
    },
    /// A record or report could not be read or written.
    #[error("{0}")]
    Output(String),
    /// the campaign asks for what its case cannot give (a unit-cell aim on straight yarns)
    #[error("{0}")]
    Scatter(String),
}

/// One finished shot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShotRecord {
    /// `r<replicate>-<shot>`: the shot's place in its sequence
    pub id: String,
    /// the replicate sequence it belongs to
    pub replicate: usize,
    /// position in its sequence (Monte Carlo: in the campaign)
    pub index: usize,
    /// [m/s]
    pub velocity_m_s: f64,
    /// strength seed of the shot (`failure.seed` of its case)
    pub seed: u64,
    /// the outcome: a complete penetration
    pub perforated: bool,
    /// [m/s]
    pub residual_velocity_m_s: f64,
    /// why the run stopped: perforated, rebounded or stopped (partials), or end_time_s
    pub stopped_by: String,
    /// steps taken
    pub steps: u64,
    /// wall time of the shot [s]
    pub wall_s: f64,
    /// ranks it ran on
    pub ranks: usize,
    /// largest contact force on the projectile [N]
    pub max_projectile_force_n: f64,
    /// where the shot aimed: the case's `offset_m` plus its drawn shift (x, y) [m]
    #[serde(default)]
    pub aim_offset_m: [f64; 2],
    /// yaw fired with: the case's plus the drawn deviation [deg]
    #[serde(default)]
    pub yaw_deg: f64,
    /// obliquity fired with: the case's plus the drawn deviation [deg]
    #[serde(default)]
    pub obliquity_deg: f64,
    /// how the fibre–projectile friction spring kept its stretch, "rotating" or "anchored"
    /// (`contact.projectile_friction_spring`); a record written before the spring was named
    /// was fired with the seed's anchored one, the only one there was
    #[serde(default = "seeds_friction_spring")]
    pub projectile_friction_spring: String,
    /// how the fibre–fibre friction spring kept its stretch, "anchored" or "projected"
    /// (`contact.fibre_friction_spring`); a record written before the spring was named was
    /// fired with the seed's anchored one, the only one there was
    #[serde(default = "seeds_friction_spring")]
    pub fibre_friction_spring: String,
    /// when its broken elements stopped acting, "at_break" or "next_step" (`failure.unload`);
    /// a record written before the choice was named was fired with "next_step", the only
    /// order there was
    #[serde(default = "unload_before_it_was_named")]
    pub unload: String,
    /// how the failure criterion measured tension, "gauge" or "element"
    /// (`failure.tension_measure`); a record written before the measure was named was fired
    /// with what its case named, else "element", the default of that time
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tension_measure: Option<String>,
    /// what a spring bent at rest stored below its rest angle, "smooth" or "cone"
    /// (`target.rest_angle_law`), on a panel whose springs rest bent; a record written before
    /// the law was named was fired with what its case named, else "cone", the default of
    /// that time
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_angle_law: Option<String>,
    /// the run's energy balance at its end, `|E − E0| / E0` of its initial energy [-]
    /// (docs/theory.md I11b: above [`crate::run::ENERGY_BUDGET`] the step is suspect); a
    /// record written before it was kept has none
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy_balance_error: Option<f64>,
}

fn unload_before_it_was_named() -> String {
    Unload::NextStep.name().to_string()
}

/// A model choice a shot is fired with, by name, which every shot of a campaign must share:
/// (what it is, the case field, the value a case without it gets, the value of a record
/// without it, the name on record, the name the campaign asks for now).
type Choice<'a> = (&'a str, &'a str, &'a str, &'a str, &'a str, &'static str);

/// The tension measure and rest-angle law a shot `record` was fired with: its own names, or,
/// on a record written before they were named, those of its case as fired (`shot`, the
/// campaign's case as it stands, which names the choices it has kept since) with the
/// defaults of that time where it left them unsaid (`Case::with_earlier_defaults_named`).
pub(crate) fn fired_measures(record: &ShotRecord, shot: &Case) -> (String, Option<String>) {
    let earlier = shot.with_earlier_defaults_named();
    let tension = record.tension_measure.clone().or_else(|| earlier.failure.tension_measure.clone());
    let law = record.rest_angle_law.clone().or_else(|| earlier.named_rest_angle_law().map(str::to_string));
    (tension.unwrap_or_default(), law)
}

/// The choices of a shot `record` against those `shot` asks for: the first that differs is
/// an error, since shots fired with two choices must not be pooled in one V50.
fn check_choices(out: &Path, id: &str, record: &ShotRecord, shot: &Case) -> Result<(), CampaignError> {
    let anchored = FrictionSpring::Anchored.name();
    let (fired_tension, fired_law) = fired_measures(record, shot);
    let named = shot.with_named_choices();
    let (asked_tension, asked_law) =
        (named.failure.tension_measure.clone().unwrap_or_default(), named.named_rest_angle_law().map(str::to_string));
    let measures = [
        ("tension measure", "failure.tension_measure", "gauge", "element", fired_tension, Some(asked_tension)),
        ("rest-angle law", "target.rest_angle_law", "smooth", "cone", fired_law.unwrap_or_default(), asked_law),
    ];
    for (what, field, default, before, fired, asked) in measures {
        let Some(asked) = asked else { continue };
        if fired != asked {
            return Err(CampaignError::Output(format!(
                "{}: shot {id} on record was fired with the {what} \"{fired}\", but the campaign now asks for \"{asked}\" ({field}, \"{default}\" unless the case names another; a case that left it unsaid before 2026-12-03 was fired with \"{before}\"): its shots must not be mixed; give it another --out, or set {field} to \"{fired}\"",
                out.display(),
            )));
        }
    }
    let choices: [Choice; 3] = [
        (
            "fibre–projectile friction spring",
            "contact.projectile_friction_spring",
            FrictionSpring::Rotating.name(),
            anchored,
            &record.projectile_friction_spring,
            friction_spring_of(shot)?,
        ),
        (
            "fibre–fibre friction spring",
            "contact.fibre_friction_spring",
            FibreFrictionSpring::Anchored.name(),
            anchored,
            &record.fibre_friction_spring,
            fibre_friction_spring_of(shot)?,
        ),
        (
            "unloading of broken elements",
            "failure.unload",
            Unload::AtBreak.name(),
            Unload::NextStep.name(),
            &record.unload,
            unload_of(shot)?,
        ),
    ];
    for (what, field, default, before, fired, asked) in choices {
        if fired != asked {
            return Err(CampaignError::Output(format!(
                "{}: shot {id} on record was fired with the {what} \"{fired}\", but the campaign now asks for \"{asked}\" ({field}, \"{default}\" unless the case names another; records without it were fired with \"{before}\"): its shots must not be mixed; give it another --out, or set {field} to what the records were fired with",
                out.display(),
            )));
        }
    }
    Ok(())
}

fn seeds_friction_spring() -> String {
    FrictionSpring::Anchored.name().to_string()
}

/// The fibre–projectile friction spring a shot's case asks for, by name.
fn friction_spring_of(case: &Case) -> Result<&'static str, CampaignError> {
    case.projectile_friction_spring().map(FrictionSpring::name).map_err(|e| CampaignError::Output(e.to_string()))
}

/// When a shot's broken elements stop acting, by name.
fn unload_of(case: &Case) -> Result<&'static str, CampaignError> {
    case.unload().map(Unload::name).map_err(|e| CampaignError::Output(e.to_string()))
}

/// The fibre–fibre friction spring a shot's case asks for, by name.
fn fibre_friction_spring_of(case: &Case) -> Result<&'static str, CampaignError> {
    case.fibre_friction_spring().map(FibreFrictionSpring::name).map_err(|e| CampaignError::Output(e.to_string()))
}

impl ShotRecord {
    fn shot(&self) -> Shot {
        Shot {
            velocity: self.velocity_m_s,
            perforated: self.perforated,
            residual_velocity: if self.perforated { self.residual_velocity_m_s.max(0.0) } else { 0.0 },
        }
    }
}

/// This rank's group: `index` of `count`, each with its own communicator.
#[derive(Clone, Copy, Debug)]
pub struct Group {
    /// this group's index
    pub index: usize,
    /// groups the ranks are split into
    pub count: usize,
}

fn shots_directory(out: &Path) -> PathBuf {
    out.join("shots")
}

fn shot_id(replicate: usize, index: usize) -> String {
    format!("r{replicate:03}-{index:05}")
}

fn record_path(out: &Path, id: &str) -> PathBuf {
    shots_directory(out).join(format!("{id}.json"))
}

/// The record of a finished shot, if there is one.
fn finished(out: &Path, id: &str) -> Option<ShotRecord> {
    let text = std::fs::read_to_string(record_path(out, id)).ok()?;
    serde_json::from_str(&text).ok()
}

/// The case of one shot: the campaign's case at `velocity` with strength seed `seed`, its
/// aim, yaw and obliquity moved by `draws`; it stops as soon as its outcome is decided.
pub fn shot_case(case: &Case, campaign: &str, id: &str, velocity: f64, seed: u64, draws: &Draws) -> Case {
    let mut shot = case.clone();
    shot.name = format!("{campaign}-{id}");
    shot.projectile.velocity_m_s = velocity;
    shot.failure.seed = seed;
    for (offset, shift) in shot.projectile.offset_m.iter_mut().zip(draws.aim_shift_m) {
        *offset += shift;
    }
    shot.projectile.yaw_deg += draws.yaw_deg;
    shot.projectile.obliquity_deg += draws.obliquity_deg;
    shot.run.stop_on_perforation = true;
    shot
}

/// The size of the unit cell a scattered aim falls within [m].
fn aim_cell(case: &Case) -> Result<[f64; 2], CampaignError> {
    let cell =
        crate::setup::aim_cell(case).map_err(|error| CampaignError::Setup { id: "(unit cell)".into(), error })?;
    cell.ok_or_else(|| {
        CampaignError::Scatter(
            "scatter.aim: the target is straight fibres or yarns, without a weave unit cell to aim within; give \"aim\": \"fixed\"".into(),
        )
    })
}

/// A shot already on record, checked against what the campaign asks of it now: a record of
/// another velocity, seed, aim, yaw or obliquity means the campaign changed since it was
/// fired, and its directory must not mix the two.
fn on_record(out: &Path, id: &str, shot: &Case) -> Result<Option<ShotRecord>, CampaignError> {
    let Some(record) = finished(out, id) else { return Ok(None) };
    let p = &shot.projectile;
    let asked = (p.velocity_m_s, shot.failure.seed, p.offset_m, p.yaw_deg, p.obliquity_deg);
    let fired = (record.velocity_m_s, record.seed, record.aim_offset_m, record.yaw_deg, record.obliquity_deg);
    let bits = |(v, s, [x, y], yaw, obliquity): (f64, u64, [f64; 2], f64, f64)| {
        (v.to_bits(), s, x.to_bits(), y.to_bits(), yaw.to_bits(), obliquity.to_bits())
    };
    check_choices(out, id, &record, shot)?;
    if bits(asked) != bits(fired) {
        return Err(CampaignError::Output(format!(
            "{}: shot {id} on record was fired at {} m/s, seed {}, aim {:?} m, yaw {} deg, obliquity {} deg, but the campaign now asks for {} m/s, seed {}, aim {:?} m, yaw {} deg, obliquity {} deg: the campaign changed since; give it another --out",
            out.display(), fired.0, fired.1, fired.2, fired.3, fired.4, asked.0, asked.1, asked.2, asked.3, asked.4
        )));
    }
    Ok(Some(record))
}

/// Runs one shot on the group (from its checkpoint when an earlier attempt left one) and
/// gives back the communicator and, on every rank of the group, the record.
fn fire<C: Comm>(
    comm: C,
    case: &Case,
    out: &Path,
    id: &str,
    (replicate, index): (usize, usize),
    stop_signal: Option<Arc<AtomicBool>>,
) -> Result<(C, ShotRecord), CampaignError> {
    let directory = shots_directory(out).join(id);
    let checkpoint = directory.join("checkpoint");
    let setup = |error| CampaignError::Setup { id: id.to_string(), error };
    let (case, mut state, resume) = if manifest_path(&checkpoint).exists() {
        let restored = restore(&checkpoint, comm, Method::KWay).map_err(setup)?;
        let (stepped, asked) = (unload_of(&restored.case)?, unload_of(case)?);
        if stepped != asked {
            return Err(CampaignError::Output(format!(
                "{}: the checkpoint of shot {id} was stepped with failure.unload \"{stepped}\" (a checkpoint that does not name it was written before the choice existed, with \"next_step\"), but the campaign asks for \"{asked}\": remove the checkpoint to fire the shot afresh, or set failure.unload to \"{stepped}\"",
                checkpoint.display()
            )));
        }
        // the checkpoint continues under the campaign's end time and checkpoint intervals (a
        // shot undecided at an earlier end time runs on to the later one), nothing else
        let continued = restored.case.continued_by(case).map_err(|field| {
            CampaignError::Output(format!(
                "{}: the checkpoint of shot {id} was stepped with another {field} than the campaign asks for now: remove the checkpoint to fire the shot afresh, or give the campaign another --out",
                checkpoint.display()
            ))
        })?;
        let resume = Resume::from_checkpoint(&restored.global);
        (continued, restored.run, resume)
    } else {
        (case.clone(), build(case, comm, Method::KWay, None).map_err(setup)?, None)
    };
    let json = serde_json::to_string(&case).expect("case serialises");
    let mut options = RunOptions::for_case(&case, &json, &directory, &state, stop_signal, resume);
    // a shot undecided at the end time can be resumed under a later one (v50's warning)
    options.checkpoints.at_end = true;
    let summary = run(&mut state, &options).map_err(|error| CampaignError::Run { id: id.to_string(), error })?;
    // the group's rank 0 has the summary; every rank needs the outcome for the next velocity
    let outcome = state.from_rank0(summary.as_ref().map_or([0.0; 5], |s| {
        [s.perforated as u8 as f64, s.residual_velocity_m_s, s.steps as f64, s.wall_s, s.energy_balance_error]
    }));
    let record = ShotRecord {
        id: id.to_string(),
        replicate,
        index,
        velocity_m_s: case.projectile.velocity_m_s,
        seed: case.failure.seed,
        perforated: outcome[0] == 1.0,
        residual_velocity_m_s: outcome[1],
        stopped_by: summary.as_ref().map_or_else(String::new, |s| s.stopped_by.clone()),
        steps: outcome[2] as u64,
        wall_s: outcome[3],
        ranks: state.comm.size(),
        max_projectile_force_n: summary.as_ref().map_or(0.0, |s| s.max_projectile_force_n),
        aim_offset_m: case.projectile.offset_m,
        yaw_deg: case.projectile.yaw_deg,
        obliquity_deg: case.projectile.obliquity_deg,
        projectile_friction_spring: friction_spring_of(&case)?.to_string(),
        fibre_friction_spring: fibre_friction_spring_of(&case)?.to_string(),
        unload: unload_of(&case)?.to_string(),
        tension_measure: case.with_named_choices().failure.tension_measure,
        rest_angle_law: case.with_named_choices().named_rest_angle_law().map(str::to_string),
        energy_balance_error: Some(outcome[4]),
    };
    if state.comm.rank() == Rank(0) {
        if let Some(warning) = crate::run::energy_budget_warning(outcome[4]) {
            tracing::warn!("shot {id}: {warning}");
        }
        // written whole, then renamed: a record on disk is a finished shot
        let path = record_path(out, id);
        let partial = path.with_extension("json.partial");
        let text = serde_json::to_string_pretty(&record).expect("record serialises");
        std::fs::write(&partial, text)
            .and_then(|()| std::fs::rename(&partial, &path))
            .map_err(|e| CampaignError::Output(format!("{}: {e}", path.display())))?;
    }
    Ok((state.comm, record))
}

/// How far a group got.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// every shot of the group's share is on record
    Complete,
    /// the group fired its `max_shots` and stopped; a later run continues
    Paused,
}

/// Fires this group's shots of the campaign: Monte Carlo shots `group.index`,
/// `group.index + group.count`, …; the sequences (replicates) of a sequential design
/// likewise. A shot with a record is not fired again; at most `max_shots` are fired (a job's
/// share of a campaign spread over several jobs).
pub fn run_group<C: Comm>(
    campaign: &Campaign,
    case: &Case,
    comm: C,
    group: Group,
    out: &Path,
    max_shots: Option<usize>,
    stop_signal: Option<Arc<AtomicBool>>,
) -> Result<Progress, CampaignError> {
    std::fs::create_dir_all(shots_directory(out))
        .map_err(|e| CampaignError::Output(format!("{}: {e}", out.display())))?;
    let base_seed = case.failure.seed;
    let mut comm = comm;
    let mut budget = max_shots.unwrap_or(usize::MAX);
    let design = &campaign.design;
    let scatter = campaign.scatter();
    let cell = if scatter.aim == Aim::UnitCell { Some(aim_cell(case)?) } else { None };
    if design.independent() {
        let mut index = group.index;
        while let Some(velocity) = design.planned(index, base_seed) {
            let id = shot_id(0, index);
            let draws = scatter.draw(base_seed, 0, index, cell);
            let shot = shot_case(case, &campaign.name, &id, velocity, base_seed.wrapping_add(index as u64), &draws);
            if on_record(out, &id, &shot)?.is_none() {
                if budget == 0 {
                    return Ok(Progress::Paused);
                }
                budget -= 1;
                comm = fire(comm, &shot, out, &id, (0, index), stop_signal.clone())?.0;
            }
            index += group.count;
        }
        return Ok(Progress::Complete);
    }
    for replicate in (group.index..campaign.replicates).step_by(group.count) {
        let seed = base_seed.wrapping_add(replicate as u64);
        let mut history: Vec<Shot> = Vec::new();
        while let Some(velocity) = design.next(&history, seed) {
            let index = history.len();
            let id = shot_id(replicate, index);
            let draws = scatter.draw(base_seed, replicate, index, cell);
            let shot = shot_case(case, &campaign.name, &id, velocity, seed, &draws);
            let record = match on_record(out, &id, &shot)? {
                Some(record) => record,
                None => {
                    if budget == 0 {
                        return Ok(Progress::Paused);
                    }
                    budget -= 1;
                    let (back, record) = fire(comm, &shot, out, &id, (replicate, index), stop_signal.clone())?;
                    comm = back;
                    record
                }
            };
            history.push(record.shot());
        }
    }
    Ok(Progress::Complete)
}

/// The estimates from every shot on record.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignReport {
    /// the campaign file's name
    pub campaign: String,
    /// every shot on record, in firing order
    pub shots: Vec<ShotRecord>,
    /// partial penetrations among them
    pub partials: usize,
    /// complete penetrations among them
    pub completes: usize,
    /// partials that were still undecided at the case's end time (see docs/theory.md V1)
    pub held_at_end: usize,
    /// each estimate, or why it cannot be made
    pub logistic: Result<Fit, String>,
    /// (the probit fit)
    pub probit: Result<Fit, String>,
    /// (the logistic fit by Firth's penalised likelihood, finite where the outcomes separate
    /// by velocity and the two above have none; docs/theory.md V11)
    pub firth_logistic: Result<Fit, String>,
    /// (MIL-STD-662F's V50)
    pub mil_std_662f: Result<MilStdEstimate, String>,
    /// (the Lambert–Jonas fit of the residual velocities)
    pub lambert_jonas: Result<LambertJonas, String>,
    /// a bisection's final bracket per replicate: (highest partial, lowest complete) [m/s]
    pub bisection_brackets: Vec<(f64, f64)>,
}

/// Every shot record in the campaign directory `out`, in firing order (by id).
pub fn records(out: &Path) -> Result<Vec<ShotRecord>, CampaignError> {
    let directory = shots_directory(out);
    let mut shots: Vec<ShotRecord> = Vec::new();
    let entries =
        std::fs::read_dir(&directory).map_err(|e| CampaignError::Output(format!("{}: {e}", directory.display())))?;
    for entry in entries.flatten() {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "json") {
            let text = std::fs::read_to_string(&path)
                .map_err(|e| CampaignError::Output(format!("{}: {e}", path.display())))?;
            shots.push(
                serde_json::from_str(&text).map_err(|e| CampaignError::Output(format!("{}: {e}", path.display())))?,
            );
        }
    }
    shots.sort_by(|a, b| a.id.cmp(&b.id));
    Ok(shots)
}

/// Reads every shot record of the campaign in `out` and estimates the ballistic limit.
pub fn report(campaign: &Campaign, out: &Path) -> Result<CampaignReport, CampaignError> {
    let shots = records(out)?;
    let bisection_brackets = match campaign.design {
        Design::Bisection { low_m_s, high_m_s, resolution_m_s } => (0..campaign.replicates)
            .map(|r| {
                let replicate: Vec<Shot> = shots.iter().filter(|s| s.replicate == r).map(ShotRecord::shot).collect();
                let (low, high) = bisection_bounds(low_m_s, high_m_s, resolution_m_s, &replicate);
                bracket(low, high, &replicate)
            })
            .collect(),
        _ => Vec::new(),
    };
    Ok(estimate(campaign.name.clone(), shots, &campaign.mil_std_662f, bisection_brackets))
}

/// The estimates from `shots` (in firing order), named `name`.
pub fn estimate(
    name: String,
    shots: Vec<ShotRecord>,
    mil_std: &MilStdSpec,
    bisection_brackets: Vec<(f64, f64)>,
) -> CampaignReport {
    let outcomes: Vec<Shot> = shots.iter().map(ShotRecord::shot).collect();
    let text = |e: dea_ballistic::EstimateError| e.to_string();
    CampaignReport {
        campaign: name,
        partials: outcomes.iter().filter(|s| !s.perforated).count(),
        held_at_end: shots.iter().filter(|s| s.stopped_by == "end_time_s").count(),
        completes: outcomes.iter().filter(|s| s.perforated).count(),
        logistic: fit(&outcomes, Link::Logistic).map_err(text),
        probit: fit(&outcomes, Link::Probit).map_err(text),
        firth_logistic: firth_logistic(&outcomes).map_err(text),
        mil_std_662f: mil_std_662f(&outcomes, mil_std.count, mil_std.spread_m_s).map_err(text),
        lambert_jonas: lambert_jonas(&outcomes).map_err(text),
        bisection_brackets,
        shots,
    }
}

pub use crate::provenance::GIT_COMMIT;

/// Writes `v50.json` and `provenance.json` (the campaign and case as loaded, the commit, and
/// every shot's velocity, seed and outcome).
pub fn write_report(
    report: &CampaignReport,
    campaign: &Campaign,
    case: &Case,
    campaign_text: &str,
    out: &Path,
) -> Result<(), CampaignError> {
    let failed = |e: std::io::Error| CampaignError::Output(format!("{}: {e}", out.display()));
    std::fs::write(out.join("v50.json"), serde_json::to_string_pretty(report).expect("report serialises"))
        .map_err(failed)?;
    let provenance = serde_json::json!({
        "git_commit": GIT_COMMIT,
        "campaign_file": campaign_text,
        "campaign": campaign,
        // the choices whose defaults changed named, so that a later binary reads what was fired
        "case": case.with_named_choices(),
        "shots": report.shots.iter().map(|s| serde_json::json!({ "id": s.id, "velocity_m_s": s.velocity_m_s, "seed": s.seed, "perforated": s.perforated, "residual_velocity_m_s": s.residual_velocity_m_s, "run": format!("shots/{}", s.id) })).collect::<Vec<_>>(),
    });
    std::fs::write(
        out.join("provenance.json"),
        serde_json::to_string_pretty(&provenance).expect("provenance serialises"),
    )
    .map_err(failed)
}
