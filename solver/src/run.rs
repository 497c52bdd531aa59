//! The run: step loop, histories, perforation test, results and summary.

use std::path::Path;
use std::time::Instant;

use dea_core::domain::StageTimes;
use dea_core::nodes::FailureMode;
use dea_core::{Domain, DomainError, Vec3};
use dea_io::results::{write_results, FinalState, Histories};
use serde::Serialize;

use crate::setup::{projectile_bottom, projectile_top};

/// What a run reports in `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub case: String,
    pub ranks: i32,
    pub nodes: usize,
    pub steps: u64,
    pub time_step_s: f64,
    pub simulated_time_s: f64,
    pub wall_s: f64,
    /// the projectile passed the whole target and still moves on
    pub perforated: bool,
    /// velocity component along the initial flight direction at the end (negative: rebound) [m/s]
    pub residual_velocity_m_s: f64,
    /// largest contact force on the projectile [N]
    pub max_projectile_force_n: f64,
    pub broken_elements_tension: u64,
    pub broken_elements_shear: u64,
    pub broken_elements_combined: u64,
    /// |E(t) - E(0)| / E(0) at the end [-]
    pub energy_balance_error: f64,
    pub node_steps_per_s_per_core: f64,
    pub stage_seconds: StageSeconds,
    /// why the run stopped
    pub stopped_by: String,
}

/// Stage times of the step plus the time spent sampling and writing output [s].
#[derive(Clone, Debug, Serialize)]
pub struct StageSeconds {
    #[serde(flatten)]
    pub step: StageTimes,
    pub output: f64,
}

fn sample(domain: &Domain, histories: &mut Histories) {
    let projectile = domain.projectile.as_ref().expect("runs have a projectile");
    histories.time.push(domain.time);
    histories.projectile_position.push(projectile.position);
    histories.projectile_velocity.push(projectile.velocity);
    histories.projectile_force.push(projectile.force);
    histories.energy.push(domain.energies());
    histories.broken_tension.push(domain.broken.tension);
    histories.broken_shear.push(domain.broken.shear);
    histories.broken_combined.push(domain.broken.combined);
}

/// How the shot ends, judged from the projectile against the target's extent along z.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Outcome {
    Undecided,
    Perforated,
    Rebounded,
}

/// Decides a shot: perforated once the projectile has passed the target's initial back face,
/// still moves forward, and every fibre it touches is broken somewhere (what hangs on it
/// are loose fragments); rebounded once it moves back, clear of the target and of contact.
struct Judge {
    direction: Vec3,
    /// lowest fibre node at time zero [m]
    back_face: f64,
    /// largest contact diameter [m]
    margin: f64,
    /// scratch: which fibres have a broken element
    fibre_broken: Vec<bool>,
}

impl Judge {
    fn new(domain: &Domain, direction: Vec3) -> Self {
        let owned = &domain.nodes.position[..domain.nodes.n_owned];
        let fibres = domain.nodes.fibre.iter().map(|f| f.0 as usize + 1).max().unwrap_or(0);
        Self {
            direction,
            back_face: owned.iter().map(|p| p.z).fold(f64::INFINITY, f64::min),
            margin: domain.sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max),
            fibre_broken: vec![false; fibres],
        }
    }

    fn outcome(&mut self, domain: &Domain) -> Outcome {
        let projectile = domain.projectile.as_ref().expect("runs have a projectile");
        let forward = projectile.velocity.dot(&self.direction);
        let nodes = &domain.nodes;
        if forward > 0.0 && projectile_top(projectile) < self.back_face - self.margin {
            self.fibre_broken.fill(false);
            for i in 0..nodes.n_owned {
                if domain.elements.failure[i] != FailureMode::Intact {
                    self.fibre_broken[nodes.fibre[i].0 as usize] = true;
                }
            }
            let contacts = &domain.projectile_contacts;
            let held = contacts.candidates.iter().any(|&i| contacts.touching[i as usize] && !self.fibre_broken[nodes.fibre[i as usize].0 as usize]);
            if !held {
                return Outcome::Perforated;
            }
        }
        let high = nodes.position[..nodes.n_owned].iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
        if forward < 0.0 && projectile_bottom(projectile) > high + self.margin && projectile.force.norm() == 0.0 {
            Outcome::Rebounded
        } else {
            Outcome::Undecided
        }
    }
}

/// Runs a case to its end time (or until the outcome is decided) and writes the results.
pub fn run(mut domain: Domain, case_name: &str, case_json: &str, end_time: f64, history_interval: u64, stop_when_decided: bool, out: &Path, ranks: i32) -> Result<Summary, RunError> {
    let direction = domain.projectile.as_ref().map(|p| p.velocity.normalize()).unwrap_or(-Vec3::z());
    let initial_energy = domain.energies().total();
    let mut histories = Histories::default();
    let mut output_seconds = 0.0;
    let mut max_force: f64 = 0.0;
    let start = Instant::now();
    let mut last_report = Instant::now();
    sample(&domain, &mut histories);
    let mut stopped_by = "end_time_s".to_string();
    let mut decided = Outcome::Undecided;
    let mut judge = Judge::new(&domain, direction);
    while domain.time + 0.5 * domain.time_step < end_time {
        domain.step().map_err(RunError::Numerical)?;
        max_force = max_force.max(domain.projectile.as_ref().map_or(0.0, |p| p.force.norm()));
        if domain.step % history_interval == 0 {
            let clock = Instant::now();
            sample(&domain, &mut histories);
            decided = judge.outcome(&domain);
            output_seconds += clock.elapsed().as_secs_f64();
            if stop_when_decided && decided != Outcome::Undecided {
                stopped_by = format!("{decided:?}").to_lowercase();
                break;
            }
            if last_report.elapsed().as_secs_f64() > 30.0 {
                last_report = Instant::now();
                eprintln!("step {} t = {:.3e} s ({:.0}%), wall {:.0} s", domain.step, domain.time, 100.0 * domain.time / end_time, start.elapsed().as_secs_f64());
            }
        }
    }
    if domain.step % history_interval != 0 {
        sample(&domain, &mut histories);
        decided = judge.outcome(&domain);
    }
    let wall = start.elapsed().as_secs_f64();
    let clock = Instant::now();
    let n = domain.nodes.n_owned;
    let final_state = FinalState {
        gid: domain.nodes.gid[..n].iter().map(|g| g.0).collect(),
        position: domain.nodes.position[..n].to_vec(),
        velocity: domain.nodes.velocity[..n].to_vec(),
        element_failure: domain.elements.failure[..n].iter().map(|&m| m as u8).collect(),
    };
    std::fs::create_dir_all(out).map_err(|e| RunError::Output(format!("{}: {e}", out.display())))?;
    write_results(&out.join("results.h5"), case_json, &histories, &final_state).map_err(|e| RunError::Output(format!("{}: {e}", out.join("results.h5").display())))?;
    output_seconds += clock.elapsed().as_secs_f64();
    let projectile = domain.projectile.as_ref().expect("runs have a projectile");
    let final_energy = histories.energy.last().map_or(initial_energy, |e| e.total());
    let summary = Summary {
        case: case_name.to_string(),
        ranks,
        nodes: n,
        steps: domain.step,
        time_step_s: domain.time_step,
        simulated_time_s: domain.time,
        wall_s: wall,
        perforated: decided == Outcome::Perforated,
        residual_velocity_m_s: projectile.velocity.dot(&direction),
        max_projectile_force_n: max_force,
        broken_elements_tension: domain.broken.tension,
        broken_elements_shear: domain.broken.shear,
        broken_elements_combined: domain.broken.combined,
        energy_balance_error: (final_energy - initial_energy).abs() / initial_energy,
        node_steps_per_s_per_core: (n as f64 * domain.step as f64) / wall / ranks as f64,
        stage_seconds: StageSeconds { step: domain.times, output: output_seconds },
        stopped_by,
    };
    let text = serde_json::to_string_pretty(&summary).expect("summary serialises");
    std::fs::write(out.join("summary.json"), text + "\n").map_err(|e| RunError::Output(format!("{}: {e}", out.join("summary.json").display())))?;
    Ok(summary)
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("numerical failure: {0}")]
    Numerical(DomainError),
    #[error("cannot write results: {0}")]
    Output(String),
}
