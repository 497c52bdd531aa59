//! The run: step loop, histories, perforation test, results and summary, on every rank.

use dea_core::projectile::{RigidProjectile, RigidShape};
use dea_projectile::generate::Solid;
use std::path::Path;
use std::time::Instant;

use dea_core::{Rank, Vec3};
use dea_io::results::{write_histories_csv, write_results, Histories};
use serde::Serialize;

use crate::comm::Comm;
use crate::distributed::{Distributed, RunRequests};
use crate::progress::{Flight, Progress, ProgressMode};
use crate::setup::{projectile_bottom, projectile_top};
use crate::step::{Stage, StageSeconds};

/// What a run reports in `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// the case's name
    pub case: String,
    /// ranks of the job
    pub ranks: usize,
    /// fibre nodes of the whole problem
    pub nodes: u64,
    /// steps taken since the shot began
    pub steps: u64,
    /// [s]
    pub time_step_s: f64,
    /// simulated time at the end [s]
    pub simulated_time_s: f64,
    /// wall time of the whole run, every segment of a restarted one included (rank 0) [s]
    pub wall_s: f64,
    /// the projectile passed the whole target and still moves on
    pub perforated: bool,
    /// the shot's state at the end, judged along the panel's normal: `perforated`,
    /// `stopped` (moving back while still in or on the target: a partial), `rebounded`
    /// (moving back clear of it) or `undecided` (still in the target at the end time)
    pub outcome: String,
    /// the projectile's velocity at the end along the initial line of flight (negative:
    /// moving back), as chronographs on the line of fire measure it: the residual velocity
    /// when `outcome` is `perforated`, otherwise only the velocity at the end time [m/s]
    pub residual_velocity_m_s: f64,
    /// the projectile's velocity at the end along the panel's inward normal (-z), the
    /// direction the outcome is judged in; the same as the residual velocity for a normal shot [m/s]
    pub normal_velocity_m_s: f64,
    /// largest contact force on the projectile [N]
    pub max_projectile_force_n: f64,
    /// elements broken in tension (the shear term below 10 % of the criterion)
    pub broken_elements_tension: u64,
    /// elements broken in shear (the tension term below 10 % of the criterion)
    pub broken_elements_shear: u64,
    /// elements broken with both terms significant
    pub broken_elements_combined: u64,
    /// |E(t) - E(0)| / E(0) at the end [-]
    pub energy_balance_error: f64,
    /// node-steps per second of wall time per rank [1/s]
    pub node_steps_per_s_per_core: f64,
    /// mean over ranks of the wall time of each stage [s]
    pub stage_seconds: StageSeconds,
    /// forward-halo bytes received per step, summed over ranks
    pub halo_bytes_per_step: f64,
    /// ghost nodes / owned nodes, over every rank, at the end [-]
    pub ghost_fraction: f64,
    /// slowest rank's compute time (integration, forces, failure, rebuild) / the mean [-]
    pub load_imbalance: f64,
    /// ghost and list rebuilds of this run segment
    pub neighbour_rebuilds: u64,
    /// the share of the nodes held whose neighbour rows a rebuild searched afresh, over every
    /// rebuild of this run segment and every rank (1 where each rebuild relists everything;
    /// below it where one rank rebuilds only around the nodes that moved) [-]
    pub relisted_share: f64,
    /// energy each layer holds or has dissipated at the end (kinetic, strain, bending,
    /// contact, friction, plasticity, fracture), layer 0 struck first [J]
    pub energy_absorbed_by_layer_j: Vec<f64>,
    /// broken elements of each layer at the end
    pub broken_elements_by_layer: Vec<u64>,
    /// why the run stopped
    pub stopped_by: String,
    /// the settle before the shot, when the case asks for one (not known after a restart)
    pub settle: Option<crate::settle::SettleReport>,
}

/// Below this fraction of the peak contact force, what still touches a projectile past the
/// back face does not hold it (docs/theory.md V1).
pub const HELD_FRACTION: f64 = 0.01;

/// How the shot ends, judged from the projectile against the target's extent along z.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Outcome {
    Undecided = 0,
    Perforated = 1,
    Rebounded = 2,
    /// moving back along the normal while still in or on the target: the fabric stopped it
    Stopped = 3,
}

impl Outcome {
    /// The name `summary.json`, `progress.json` and the shot records use.
    fn name(self) -> &'static str {
        match self {
            Outcome::Undecided => "undecided",
            Outcome::Perforated => "perforated",
            Outcome::Rebounded => "rebounded",
            Outcome::Stopped => "stopped",
        }
    }
}

/// Decides a shot against the panel, along its inward normal (-z) whatever the obliquity:
/// perforated once the projectile has passed the target's initial back face, still moves
/// forward along the normal, and nothing holds it back: every fibre it touches is broken
/// somewhere (what hangs on it are loose fragments), or what still touches it resists with
/// less than [`HELD_FRACTION`] of the peak force so far (fibres pushed aside along its flank;
/// not on the single-yarn fixture, whose guided yarn cannot be pushed aside);
/// rebounded once it moves back along the normal, clear of the target and of contact;
/// stopped (a partial too) as soon as it moves back along the normal at all, still in or on
/// the target (docs/theory.md V1). Every rank takes part in the reductions; rank 0 decides and tells the others.
struct Judge {
    /// the panel's inward normal
    direction: Vec3,
    /// lowest fibre node at time zero [m]
    back_face: f64,
    /// largest contact diameter [m]
    margin: f64,
    fibres: usize,
    /// a projectile that unbroken fibres touch may still be through, pushed aside along its
    /// flank (false on the single-yarn fixture)
    aside_counts: bool,
}

impl Judge {
    /// `back_face`: the lowest fibre node at time zero, when already known (a restart).
    fn new<C: Comm>(run: &Distributed<C>, direction: Vec3, fibres: usize, back_face: Option<f64>) -> Self {
        let domain = &run.domain;
        let back_face = back_face.unwrap_or_else(|| run.z_range().0);
        Self {
            direction,
            back_face,
            margin: domain.sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max),
            fibres,
            aside_counts: domain.guides().is_none(),
        }
    }

    /// Where the projectile stands with respect to the decision (rank 0's progress).
    fn flight(&self, projectile: &RigidProjectile) -> Flight {
        Flight {
            forward: projectile.velocity.dot(&self.direction),
            to_exit: projectile_top(projectile) - (self.back_face - self.margin),
        }
    }

    fn outcome<C: Comm>(&self, run: &Distributed<C>, max_force: f64) -> Outcome {
        let broken = run.fibres_with_broken_elements(self.fibres);
        let domain = &run.domain;
        let contacts = &domain.projectile_contacts;
        let held_here = contacts.candidates.iter().map(|i| i.index()).any(|i| {
            let f = domain.nodes.fibre[i].0 as usize;
            contacts.touching[i] && broken[f / 64] & (1 << (f % 64)) == 0
        });
        let held = run.any(held_here);
        let (_, high) = run.z_range();
        let mut decision = Outcome::Undecided;
        if run.comm.rank() == Rank(0) {
            let projectile = domain.projectile.as_ref().expect("runs have a projectile");
            let forward = projectile.velocity.dot(&self.direction);
            let resisting = -projectile.force.dot(&self.direction);
            // on the single-yarn fixture no fibre can be pushed aside (the lateral hold), and
            // an uncut yarn drawn in over its sliding ends resists little while it carries the
            // projectile, or flies ahead of it after the blow: there only a yarn cut through,
            // every fibre broken, lets it through (theory V1, F13)
            let free = if self.aside_counts {
                !held || resisting <= HELD_FRACTION * max_force
            } else {
                (0..self.fibres).all(|f| broken[f / 64] & (1 << (f % 64)) != 0)
            };
            if forward > 0.0 && projectile_top(projectile) < self.back_face - self.margin && free {
                decision = Outcome::Perforated;
            } else if forward < 0.0
                && projectile_bottom(projectile) > high + self.margin
                && projectile.force.norm() == 0.0
            {
                decision = Outcome::Rebounded;
            } else if forward < 0.0 {
                // its motion along the normal reversed: the fabric has taken all it had, and
                // nothing behind the projectile can drive it forward again
                decision = Outcome::Stopped;
            }
        }
        match run.from_rank0([decision as u8 as f64])[0] as u8 {
            1 => Outcome::Perforated,
            2 => Outcome::Rebounded,
            3 => Outcome::Stopped,
            _ => Outcome::Undecided,
        }
    }
}

/// The run loop's own state at a checkpoint (rank 0's histories and scalars).
#[derive(Clone, Debug, Default)]
pub struct Resume {
    /// the histories sampled so far
    pub histories: Histories,
    /// largest contact force on the projectile so far [N]
    pub max_force: f64,
    /// total energy at time zero [J]
    pub initial_energy: f64,
    /// lowest fibre node at time zero [m]
    pub back_face: f64,
    /// wall time of the run's earlier segments, rank 0's clock [s]
    pub wall_s: f64,
}

impl Resume {
    /// The scalars in the order of a checkpoint's `run_scalars`.
    pub fn scalars(&self) -> Vec<f64> {
        vec![self.max_force, self.initial_energy, self.back_face, self.wall_s]
    }

    /// The state a checkpoint holds; one written before the wall time was kept (three
    /// scalars) resumes with its earlier wall time unknown, taken as 0.
    pub fn from_checkpoint(global: &dea_io::checkpoint::GlobalState) -> Option<Self> {
        let (max_force, initial_energy, back_face, wall_s) = match global.run_scalars[..] {
            [max_force, initial_energy, back_face] => (max_force, initial_energy, back_face, 0.0),
            [max_force, initial_energy, back_face, wall_s] => (max_force, initial_energy, back_face, wall_s),
            _ => return None,
        };
        Some(Self { histories: global.histories.clone(), max_force, initial_energy, back_face, wall_s })
    }
}

/// When to write checkpoints, and where.
pub struct CheckpointPolicy {
    /// every this many steps
    pub every_steps: Option<u64>,
    /// every this many seconds of wall time (rank 0's clock)
    pub every_seconds: f64,
    /// set by SIGTERM or SIGUSR1: checkpoint and stop
    pub stop_signal: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// also at the end time when the run reaches it (a shot still undecided there): a later
    /// end time then continues it from where it ended (a campaign's shots, docs/theory.md V1)
    pub at_end: bool,
}

/// What a run needs besides the rank's state.
pub struct RunOptions<'a> {
    /// the case's name, for the reports
    pub case_name: &'a str,
    /// the case as resolved, written beside the results
    pub case_json: &'a str,
    /// [s]
    pub end_time: f64,
    /// steps between history samples
    pub history_interval: u64,
    /// stop once the shot is decided (docs/theory.md V1)
    pub stop_when_decided: bool,
    /// the unit vector of the initial line of flight, along which the residual velocity is
    /// measured
    pub flight_direction: Vec3,
    /// the output directory
    pub out: &'a Path,
    /// fibres in the whole problem
    pub fibres: usize,
    /// layers of the target
    pub layers: usize,
    /// steps between field snapshots (none: no snapshots)
    pub snapshot_interval: Option<u64>,
    /// when to write checkpoints
    pub checkpoints: CheckpointPolicy,
    /// the run loop's state when restarting from a checkpoint
    pub resume: Option<Resume>,
    /// how rank 0 shows progress
    pub progress: ProgressMode,
}

impl<'a> RunOptions<'a> {
    /// The options a case asks for (`case_json`: the case as JSON, kept in the results), for
    /// the run `run` was built for.
    pub fn for_case<C: Comm>(
        case: &'a dea_io::case::Case,
        case_json: &'a str,
        out: &'a Path,
        run: &Distributed<C>,
        stop_signal: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
        resume: Option<Resume>,
    ) -> Self {
        Self {
            case_name: &case.name,
            case_json,
            end_time: case.run.end_time_s,
            history_interval: case.run.history_interval_steps,
            stop_when_decided: case.run.stop_on_perforation,
            flight_direction: crate::setup::flight_direction(case.projectile.obliquity_deg.to_radians()),
            out,
            fibres: run.fibres,
            layers: run.layer_of_yarn.iter().map(|&l| l as usize + 1).max().unwrap_or(1),
            snapshot_interval: case.run.snapshot_interval_steps,
            checkpoints: CheckpointPolicy {
                every_steps: case.run.checkpoint_interval_steps,
                every_seconds: 60.0 * case.run.checkpoint_interval_minutes,
                stop_signal,
                at_end: false,
            },
            resume,
            progress: ProgressMode::Auto,
        }
    }
}

/// Samples the histories: every rank joins the reductions, rank 0 records. Energies that are
/// not finite end the run on every rank alike (the reduction gives each rank the same sums).
fn sample<C: Comm>(run: &Distributed<C>, histories: &mut Histories, layers: usize) -> Result<(), RunError> {
    let energy = run.energies();
    // no allocation unless a value is wrong: this runs every history interval
    if !energy.values().iter().all(|value| value.is_finite()) {
        return Err(RunError::Numerical(dea_core::DomainError::NonFiniteEnergy {
            step: run.domain.step,
            kinds: energy.non_finite_kinds().join(", "),
        }));
    }
    let broken = run.broken();
    let by_layer = run.broken_by_layer(layers);
    let [largest, at_axis] = run.back_face_deflection();
    if run.comm.rank() == Rank(0) {
        let domain = &run.domain;
        let projectile = domain.projectile.as_ref().expect("runs have a projectile");
        histories.time.push(domain.time);
        histories.projectile_position.push(projectile.position);
        histories.projectile_velocity.push(projectile.velocity);
        histories.projectile_angular_velocity.push(projectile.angular_velocity());
        histories.projectile_force.push(projectile.force);
        histories.broken_by_layer.push(by_layer);
        histories.energy.push(energy);
        histories.broken_tension.push(broken.tension);
        histories.broken_shear.push(broken.shear);
        histories.broken_combined.push(broken.combined);
        histories.back_face_largest.push(largest);
        histories.back_face_at_axis.push(at_axis);
    }
    Ok(())
}

/// Runs to the end time (or until the outcome is decided) on every rank and writes the
/// results on rank 0, which returns the summary.
pub fn run<C: Comm>(run: &mut Distributed<C>, options: &RunOptions) -> Result<Option<Summary>, RunError> {
    let is_root = run.comm.rank() == Rank(0);
    // the stages of this run's steps, as its wall time counts them (not the set-up's build
    // or the settle's steps, which report their own time)
    run.timer.reset();
    // rank 0 records what made the outputs; every rank learns whether it could
    let restarted_at = options.resume.as_ref().map(|_| run.domain.step);
    rank0_writes(run, "record the provenance", || {
        crate::provenance::record(options.out, options.case_json, run.comm.size(), restarted_at)
            .map_err(|e| format!("{}: {e}", options.out.join(crate::provenance::PROVENANCE_FILE).display()))
    })?;
    let start = Instant::now();
    let mut last_checkpoint = Instant::now();
    // a resumed run's rates count the wall time of every segment, as its steps do
    let earlier_wall = options.resume.as_ref().map_or(0.0, |resume| resume.wall_s);
    let (mut histories, mut max_force, initial_energy, back_face) = match &options.resume {
        Some(resume) => (resume.histories.clone(), resume.max_force, resume.initial_energy, Some(resume.back_face)),
        None => {
            let mut histories = Histories::default();
            sample(run, &mut histories, options.layers)?;
            if options.snapshot_interval.is_some() {
                write_snapshot(run, options).map_err(RunError::Output)?;
            }
            (histories, 0.0, run.energies().total(), None)
        }
    };
    // the outcome is judged along the panel's normal; the residual velocity is measured along
    // the line of flight (from the case, so a restart agrees)
    let normal = -Vec3::z();
    let mut stopped_by = "end_time_s".to_string();
    let mut decided = Outcome::Undecided;
    let judge = Judge::new(run, normal, options.fibres, back_face);
    let mut progress = is_root.then(|| {
        Progress::new(options.out, run.domain.time, options.end_time, restarted_at.is_some(), options.progress)
    });
    let floor = energy_floor(run.domain.projectile.as_ref().map_or(0.0, |p| p.mass));
    let balance = |histories: &Histories| energy_balance_error(histories, initial_energy, floor);
    let speed = |run: &Distributed<C>| run.domain.projectile.as_ref().map_or(0.0, |p| p.velocity.norm());
    // under multi-rate stepping, checkpoints and the end fall on instants every section's
    // terms share: there each node's force is whole, and a restart computes it again
    let largest_rate = run.domain.rates().iter().copied().max().unwrap_or(1) as u64;
    let mut held = RunRequests::default();
    let mut checkpointed_at = None;
    // what a checkpoint keeps of the loop's own state
    let resume_at = |histories: &Histories, max_force: f64, back_face: f64| Resume {
        histories: histories.clone(),
        max_force,
        initial_energy,
        back_face,
        wall_s: earlier_wall + start.elapsed().as_secs_f64(),
    };
    while run.domain.time + 0.5 * run.domain.time_step < options.end_time
        || !run.domain.step.is_multiple_of(largest_rate)
    {
        let signalled =
            options.checkpoints.stop_signal.as_ref().is_some_and(|s| s.load(std::sync::atomic::Ordering::SeqCst));
        run.requests = RunRequests {
            stop: signalled,
            checkpoint: is_root && last_checkpoint.elapsed().as_secs_f64() >= options.checkpoints.every_seconds,
        };
        run.step().map_err(RunError::Numerical)?;
        max_force = max_force.max(run.domain.projectile.as_ref().map_or(0.0, |p| p.force.norm()));
        run.timer.start();
        if options.snapshot_interval.is_some_and(|n| run.domain.step.is_multiple_of(n)) {
            write_snapshot(run, options).map_err(RunError::Output)?;
        }
        if run.domain.step.is_multiple_of(options.history_interval) {
            sample(run, &mut histories, options.layers)?;
            decided = judge.outcome(run, max_force);
            run.timer.stamp(Stage::Output);
            if options.stop_when_decided && decided != Outcome::Undecided {
                stopped_by = decided.name().to_string();
                break;
            }
        }
        held.stop |= run.agreed.stop;
        held.checkpoint |= run.agreed.checkpoint;
        let RunRequests { stop, checkpoint: due_by_time } = held;
        let due_by_steps = options.checkpoints.every_steps.is_some_and(|n| run.domain.step.is_multiple_of(n));
        if (stop || due_by_time || due_by_steps) && run.domain.step.is_multiple_of(largest_rate) {
            held = RunRequests::default();
            let resume = resume_at(&histories, max_force, judge.back_face);
            let directory = write_checkpoint(run, options, &resume).map_err(RunError::Output)?;
            last_checkpoint = Instant::now();
            checkpointed_at = Some(run.domain.step);
            if let Some(progress) = &mut progress {
                progress.checkpointed(run.domain.time);
            }
            if stop {
                // the interrupted run's progress.json says so and names the checkpoint just
                // written, which a rerun goes on from
                if let Some(progress) = &mut progress {
                    let flight = run.domain.projectile.as_ref().map_or(Flight::default(), |p| judge.flight(p));
                    progress.interrupted(run.domain.step, run.domain.time, speed(run), balance(&histories), flight);
                }
                return Err(RunError::Interrupted(directory));
            }
        }
        if let Some(progress) = &mut progress {
            let flight = run.domain.projectile.as_ref().map_or(Flight::default(), |p| judge.flight(p));
            progress.update(run.domain.step, run.domain.time, speed(run), balance(&histories), flight);
        }
        run.timer.stamp(Stage::Output);
    }
    // before the closing sample below, which a run going on past this instant does not take
    if options.checkpoints.at_end && stopped_by == "end_time_s" && checkpointed_at != Some(run.domain.step) {
        run.timer.start();
        let resume = resume_at(&histories, max_force, judge.back_face);
        write_checkpoint(run, options, &resume).map_err(RunError::Output)?;
        if let Some(progress) = &mut progress {
            progress.checkpointed(run.domain.time);
        }
        run.timer.stamp(Stage::Output);
    }
    if !run.domain.step.is_multiple_of(options.history_interval) {
        sample(run, &mut histories, options.layers)?;
        decided = judge.outcome(run, max_force);
    }
    // the final state is the last snapshot, written by each rank for its own nodes
    if options.snapshot_interval.is_none_or(|n| !run.domain.step.is_multiple_of(n)) {
        write_snapshot(run, options).map_err(RunError::Output)?;
    }
    if let Some(progress) = &mut progress {
        progress.finish(run.domain.step, run.domain.time, speed(run), balance(&histories), decided.name());
    }
    let energy_by_layer = run.energy_by_layer(options.layers);
    let broken_by_layer = run.broken_by_layer(options.layers);
    let wall = earlier_wall + start.elapsed().as_secs_f64();
    run.timer.start();
    rank0_writes(run, "write the results", || {
        let path = options.out.join("results.h5");
        let csv = options.out.join("history.csv");
        std::fs::create_dir_all(options.out)
            .map_err(|e| format!("{}: {e}", options.out.display()))
            .and_then(|()| {
                write_results(&path, options.case_json, &histories).map_err(|e| format!("{}: {e}", path.display()))
            })
            .and_then(|()| write_histories_csv(&csv, &histories).map_err(|e| format!("{}: {e}", csv.display())))
    })?;
    run.timer.stamp(Stage::Output);
    let mut n = [run.domain.nodes.n_owned as i64, run.ghosts() as i64];
    run.comm.sum_i64(&mut n);
    let (nodes, ghosts) = (n[0] as u64, n[1] as u64);
    let pairs = &run.domain.pairs;
    let mut halo = [run.halo_bytes as i64, pairs.searched_nodes as i64, pairs.held_nodes as i64];
    run.comm.sum_i64(&mut halo);
    let broken = run.broken();
    let all_stages = run.comm.gather_f64(&run.timer.seconds.0);
    let Some(all_stages) = all_stages else { return Ok(None) };
    let ranks = run.comm.size();
    let mean = StageSeconds(std::array::from_fn(|k| all_stages.iter().map(|s| s[k]).sum::<f64>() / ranks as f64));
    let slowest =
        all_stages.iter().map(|s| StageSeconds(std::array::from_fn(|k| s[k])).computation()).fold(0.0, f64::max);
    let projectile = run.domain.projectile.as_ref().expect("runs have a projectile");
    let summary = Summary {
        case: options.case_name.to_string(),
        ranks,
        nodes,
        steps: run.domain.step,
        time_step_s: run.domain.time_step,
        simulated_time_s: run.domain.time,
        wall_s: wall,
        perforated: decided == Outcome::Perforated,
        outcome: decided.name().to_string(),
        residual_velocity_m_s: projectile.velocity.dot(&options.flight_direction),
        normal_velocity_m_s: projectile.velocity.dot(&normal),
        max_projectile_force_n: max_force,
        broken_elements_tension: broken.tension,
        broken_elements_shear: broken.shear,
        broken_elements_combined: broken.combined,
        energy_balance_error: energy_balance_error(&histories, initial_energy, floor),
        node_steps_per_s_per_core: (nodes as f64 * run.domain.step as f64) / wall / ranks as f64,
        stage_seconds: mean,
        halo_bytes_per_step: halo[0] as f64 / run.halo_steps.max(1) as f64,
        ghost_fraction: ghosts as f64 / nodes as f64,
        load_imbalance: if mean.computation() > 0.0 { slowest / mean.computation() } else { 1.0 },
        neighbour_rebuilds: run.rebuilds,
        relisted_share: if halo[2] > 0 { halo[1] as f64 / halo[2] as f64 } else { 0.0 },
        energy_absorbed_by_layer_j: energy_by_layer,
        broken_elements_by_layer: broken_by_layer,
        stopped_by,
        settle: run.settled,
    };
    let text = serde_json::to_string_pretty(&summary).expect("summary serialises");
    std::fs::write(options.out.join("summary.json"), text + "\n")
        .map_err(|e| RunError::Output(format!("{}: {e}", options.out.join("summary.json").display())))?;
    Ok(Some(summary))
}

/// Rank 0 runs `write` (files only it writes); every rank learns whether it succeeded and
/// returns the same error if not (`what`: what rank 0 could not do, for the other ranks).
fn rank0_writes<C: Comm>(
    run: &Distributed<C>,
    what: &str,
    write: impl FnOnce() -> Result<(), String>,
) -> Result<(), RunError> {
    let mut outcome = Ok(());
    if run.comm.rank() == Rank(0) {
        outcome = write();
    }
    if run.from_rank0([if outcome.is_ok() { 1.0 } else { 0.0 }])[0] == 0.0 {
        return Err(RunError::Output(outcome.err().unwrap_or_else(|| format!("rank 0 could not {what}"))));
    }
    Ok(())
}

/// Writes every rank's part of a field snapshot, then rank 0 rewrites the XDMF file that
/// joins all snapshots so far (collective).
fn write_snapshot<C: Comm>(run: &mut Distributed<C>, options: &RunOptions) -> Result<(), String> {
    let part = run.snapshot_part();
    let (ranks, rank, step, time) = (run.comm.size(), run.comm.rank().0, run.domain.step, run.domain.time);
    let written = dea_io::snapshot::write_part(options.out, ranks, rank, step, time, &part)
        .map_err(|e| format!("{}: {e}", dea_io::snapshot::fields_directory(options.out).display()));
    if run.any(written.is_err()) {
        return Err(written.err().unwrap_or_else(|| "another rank could not write its snapshot part".into()));
    }
    let mut joined = Ok(());
    if rank == 0 {
        joined = dea_io::snapshot::index(options.out, ranks, step)
            .map_err(|e| e.to_string())
            .and_then(|snapshots| dea_io::snapshot::write_xdmf(options.out, &snapshots).map_err(|e| e.to_string()))
            .map_err(|e| format!("{}: {e}", options.out.join("fields.xdmf").display()));
        if let (Ok(()), Some(projectile)) = (&joined, &run.domain.projectile) {
            let (vertices, triangles) = projectile_surface(projectile);
            let velocities = surface_velocities(projectile, run.deformable.as_ref(), &vertices);
            joined = dea_io::snapshot::write_projectile(options.out, step, time, &vertices, &velocities, &triangles)
                .and_then(|()| dea_io::snapshot::write_projectile_xdmf(options.out, step))
                .map_err(|e| format!("{}: {e}", options.out.join("projectile.xdmf").display()));
        }
    }
    if run.any(joined.is_err()) {
        return Err(joined.err().unwrap_or_else(|| "rank 0 could not write fields.xdmf".into()));
    }
    Ok(())
}

/// The projectile's surface in the world frame for display: a mesh's own triangles, or the
/// closed form tessellated (8 divisions).
fn projectile_surface(projectile: &RigidProjectile) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (vertices, triangles) = match &projectile.shape {
        RigidShape::Mesh(mesh) => (mesh.surface.vertices.clone(), mesh.surface.triangles.clone()),
        RigidShape::Sphere { radius } => Solid::Sphere { radius: *radius }.mesh(8).boundary(),
        RigidShape::Cylinder { radius, height, edge_radius } => {
            Solid::Cylinder { radius: *radius, height: *height, edge_radius: *edge_radius }.mesh(8).boundary()
        }
    };
    (vertices.iter().map(|v| projectile.position + projectile.orientation * v).collect(), triangles)
}

/// The velocity of each vertex of [`projectile_surface`] [m/s]: a deformable body's surface
/// nodes' own (its proxy's mesh lists them in the body's vertex order), or a rigid body's
/// `v + ω × (x − c)`.
fn surface_velocities(
    projectile: &RigidProjectile,
    deformable: Option<&crate::deformable::DeformableProjectile>,
    vertices: &[Vec3],
) -> Vec<Vec3> {
    match deformable {
        Some(body) if body.node_of_vertex.len() == vertices.len() => {
            body.node_of_vertex.iter().map(|&n| body.body.velocity[n as usize]).collect()
        }
        _ => {
            let spin = projectile.angular_velocity();
            vertices.iter().map(|x| projectile.velocity + spin.cross(&(x - projectile.position))).collect()
        }
    }
}

/// Writes a checkpoint of every rank into `OUT/checkpoint` (collective): parts and manifest
/// go to `OUT/checkpoint.writing`, which replaces the previous checkpoint only once complete.
pub fn write_checkpoint<C: Comm>(
    run: &Distributed<C>,
    options: &RunOptions,
    resume: &Resume,
) -> Result<std::path::PathBuf, String> {
    let target = options.out.join("checkpoint");
    let writing = options.out.join("checkpoint.writing");
    let is_root = run.comm.rank() == Rank(0);
    let mut prepared = Ok(());
    if is_root {
        let _ = std::fs::remove_dir_all(&writing);
        prepared = std::fs::create_dir_all(&writing).map_err(|e| format!("{}: {e}", writing.display()));
    }
    if run.any(prepared.is_err()) {
        return Err(prepared.err().unwrap_or_else(|| format!("{}: rank 0 could not create it", writing.display())));
    }
    let path = dea_io::checkpoint::part_path(&writing, run.comm.rank().0);
    let state = run.checkpoint_part();
    let part = dea_io::checkpoint::write_part(&path, &state).map_err(|e| format!("{}: {e}", path.display()));
    if run.any(part.is_err()) {
        return Err(part.err().unwrap_or_else(|| "another rank could not write its checkpoint part".into()));
    }
    // the manifest binds every part by its checksum (a u32 travels exactly in an f64)
    let part_checksums: Vec<u32> =
        run.comm.all_gather_f64(&[state.checksum() as f64]).into_iter().map(|c| c as u32).collect();
    let mut counts = [run.domain.nodes.n_owned as i64];
    run.comm.sum_i64(&mut counts);
    let broken = run.broken();
    let mut placed = Ok(());
    if is_root {
        let global = dea_io::checkpoint::GlobalState {
            case_json: naming_choices(options.case_json),
            parts: run.comm.size() as u32,
            nodes: counts[0] as u64,
            step: run.domain.step,
            time: run.domain.time,
            projectile: run.projectile_state(),
            broken: [broken.tension, broken.shear, broken.combined],
            rebuilds: run.rebuilds,
            list_builds: run.domain.pairs.builds,
            run_scalars: resume.scalars(),
            histories: resume.histories.clone(),
            part_checksums,
        };
        let manifest = dea_io::checkpoint::manifest_path(&writing);
        placed = dea_io::checkpoint::write_manifest(&manifest, &global)
            .map_err(|e| format!("{}: {e}", manifest.display()))
            .and_then(|()| {
                // the old checkpoint goes only once the new one is complete
                let old = options.out.join("checkpoint.old");
                let _ = std::fs::remove_dir_all(&old);
                if target.exists() {
                    std::fs::rename(&target, &old).map_err(|e| format!("{}: {e}", target.display()))?;
                }
                std::fs::rename(&writing, &target).map_err(|e| format!("{}: {e}", target.display()))?;
                let _ = std::fs::remove_dir_all(&old);
                Ok(())
            });
    }
    if run.any(placed.is_err()) {
        return Err(placed.err().unwrap_or_else(|| "rank 0 could not complete the checkpoint".into()));
    }
    if is_root {
        tracing::info!(
            "checkpoint written at step {}, t = {:.4e} s: {} (continue with --restart on any number of ranks)",
            run.domain.step,
            run.domain.time,
            target.display()
        );
    }
    Ok(target)
}

/// The energy balance error [-]: how far the total energy of the last history sample lies
/// from the initial energy, relative to it, or to `floor` [J] when that is larger: a run that
/// starts with (almost) no energy, as a projectile at rest does, would otherwise divide
/// rounding noise by rounding noise.
pub fn energy_balance_error(histories: &Histories, initial_energy: f64, floor: f64) -> f64 {
    let Some(last) = histories.energy.last() else { return 0.0 };
    let scale = if initial_energy.abs() >= floor { initial_energy.abs() } else { floor };
    if scale > 0.0 {
        (last.total() - initial_energy).abs() / scale
    } else {
        0.0
    }
}

/// The energy balance a run should keep: 1 % of its initial energy (docs/theory.md I7,
/// I11b). Beyond it the integration made or lost energy the forces do not account for, and a
/// run's closing lines and a campaign's shot say so.
pub const ENERGY_BUDGET: f64 = 0.01;

/// The warning for a run whose energy balance ended at `error` (|E − E0| / E0), or `None`
/// within [`ENERGY_BUDGET`].
pub fn energy_budget_warning(error: f64) -> Option<String> {
    (error > ENERGY_BUDGET).then(|| {
        format!(
            "the energy balance ended at {:.2} % of the initial energy, beyond the {:.0} % budget: the integration made or lost energy that no force accounts for, so the outcome is suspect; run it again with a shorter step (run.time_step_safety below its default 0.5) to see whether it depends on the step, and a woven target whose springs rest in its crimp with target.rest_angle_law \"smooth\" (docs/theory.md I11b, F4b)",
            100.0 * error,
            100.0 * ENERGY_BUDGET
        )
    })
}

/// The speed whose kinetic energy is the floor of the energy balance [m/s]: about a hundredth
/// of the slowest ballistic shot's, so a ten-thousandth of its energy.
const FLOOR_SPEED: f64 = 1.0;

/// The energy below which a run's energy balance is noise [J]: its projectile at
/// `FLOOR_SPEED`.
pub fn energy_floor(projectile_mass: f64) -> f64 {
    0.5 * projectile_mass * FLOOR_SPEED * FLOOR_SPEED
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A kernel found a numerical failure.
    #[error("numerical failure: {0}")]
    Numerical(dea_core::DomainError),
    /// Results could not be written.
    #[error("cannot write results: {0}")]
    Output(String),
    /// A signal stopped the run after its checkpoint.
    #[error("a signal asked the run to stop; the checkpoint {} holds it", .0.display())]
    Interrupted(std::path::PathBuf),
}

/// The case JSON a checkpoint stores: the choices whose defaults have changed named as the
/// run steps them (`Case::with_named_choices`: `failure.unload`, `failure.tension_measure`,
/// a crimped panel's `target.rest_angle_law`), so a checkpoint without a name is one written
/// before it was named (`setup::restore` gives it the default of that time). Only those
/// fields are added; the rest of the text is kept as given.
fn naming_choices(case_json: &str) -> String {
    let Ok(mut value) = serde_json::from_str::<serde_json::Value>(case_json) else { return case_json.to_string() };
    let Ok(case) = serde_json::from_value::<dea_io::case::Case>(value.clone()) else { return case_json.to_string() };
    let named = serde_json::to_value(case.with_named_choices()).expect("a case serialises");
    for (section, field) in [("failure", "unload"), ("failure", "tension_measure"), ("target", "rest_angle_law")] {
        if let (Some(object), Some(name)) =
            (value.get_mut(section).and_then(|s| s.as_object_mut()), named[section].get(field))
        {
            if !name.is_null() {
                object.insert(field.into(), name.clone());
            }
        }
    }
    value.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_checkpoints_case_names_the_choices_whose_defaults_changed_and_keeps_the_rest() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/km2_706_patch.json");
        let text = std::fs::read_to_string(&path).unwrap();
        let stored: serde_json::Value = serde_json::from_str(&naming_choices(&text)).unwrap();
        assert_eq!(stored["failure"]["unload"], "at_break");
        assert_eq!(stored["failure"]["tension_measure"], "gauge");
        assert_eq!(stored["target"]["rest_angle_law"], "smooth");
        // what the case names stays; nothing else is added
        let mut given: serde_json::Value = serde_json::from_str(&text).unwrap();
        given["failure"]["tension_measure"] = "element".into();
        given["target"]["rest_angle_law"] = "cone".into();
        let stored: serde_json::Value = serde_json::from_str(&naming_choices(&given.to_string())).unwrap();
        assert_eq!(stored["failure"]["tension_measure"], "element");
        assert_eq!(stored["target"]["rest_angle_law"], "cone");
        given["failure"]["unload"] = "at_break".into();
        assert_eq!(stored, given);
        // a crimp-free weave has no law to name
        let mut straight: serde_json::Value = serde_json::from_str(&text).unwrap();
        straight["target"]["weave"]["bending_at_rest"] = "straight".into();
        let stored: serde_json::Value = serde_json::from_str(&naming_choices(&straight.to_string())).unwrap();
        assert_eq!(stored["target"].get("rest_angle_law"), None);
    }

    #[test]
    fn a_balance_beyond_the_budget_is_named_with_its_size_and_one_within_is_not() {
        assert_eq!(energy_budget_warning(0.0), None);
        assert_eq!(energy_budget_warning(ENERGY_BUDGET), None);
        let warning = energy_budget_warning(0.0252).expect("beyond the budget");
        assert!(warning.contains("2.52 %") && warning.contains("1 % budget"), "{warning}");
        assert!(warning.contains("run.time_step_safety"), "says what to try: {warning}");
        assert!(warning.contains("target.rest_angle_law"), "and for a crimped weave: {warning}");
    }
}
