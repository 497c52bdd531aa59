//! What a running job tells its user (rank 0): a progress bar with ETA on a terminal (also
//! under mpirun when mpirun itself writes to one, or when asked with `--progress bar`); in a
//! batch log a plain line every 30 s; `progress.json` beside the results, rewritten as often.
//! Besides the time to the end time, it estimates when the shot will be decided (the
//! projectile stops or its top passes the back face), at the deceleration seen lately.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;

/// Wall seconds of stepping before the first estimate of the time left.
const FIRST_ESTIMATE_AFTER_S: f64 = 5.0;
/// Seconds between two plain lines and two `progress.json` updates.
const REPORT_EVERY: Duration = Duration::from_secs(30);
/// Time between two redraws of the bar (its message is formatted only then).
const BAR_EVERY: Duration = Duration::from_millis(200);

/// How rank 0 shows progress (`run --progress`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ProgressMode {
    /// a bar when stderr is a terminal, or when the job runs under mpirun whose own stderr
    /// is one (rank 0 on mpirun's host); plain lines otherwise
    #[default]
    Auto,
    /// a bar whatever stderr is (e.g. under mpirun on another host, or a terminal the
    /// check cannot see)
    Bar,
    /// a plain line every 30 s
    Lines,
}

impl ProgressMode {
    /// Whether this process draws a bar.
    pub fn draws_bar(self) -> bool {
        match self {
            Self::Bar => true,
            Self::Lines => false,
            Self::Auto => std::io::stderr().is_terminal() || launcher_writes_to_a_terminal(),
        }
    }
}

/// Whether this process runs under mpirun (Open MPI names the job's size) and its parent,
/// mpirun on its own host, writes its stderr to a terminal: then what rank 0 writes reaches
/// that terminal through mpirun's pipes, and a bar draws there.
fn launcher_writes_to_a_terminal() -> bool {
    if std::env::var_os("OMPI_COMM_WORLD_SIZE").is_none() {
        return false;
    }
    let parent = std::os::unix::process::parent_id();
    std::fs::read_link(format!("/proc/{parent}/fd/2"))
        .is_ok_and(|target| target.starts_with("/dev/pts") || target.starts_with("/dev/tty"))
}

/// Simulated time until the shot is decided [s], if the projectile keeps its deceleration
/// `deceleration` [m/s^2] (not positive: none, it keeps its speed): it stops (its forward
/// speed `forward` [m/s] reaches zero) or its top passes the back face `to_exit` [m]
/// further on, whichever comes first. Zero once it moves back. Once its top is through the
/// back face while it still moves on, the fabric holds it (the judge waits for it to let
/// go, which cannot be foreseen from the flight): then the time to the stop, or not a
/// number while it does not decelerate.
pub fn time_to_decision(forward: f64, deceleration: f64, to_exit: f64) -> f64 {
    if forward <= 0.0 {
        return 0.0;
    }
    if to_exit <= 0.0 {
        return if deceleration > 0.0 { forward / deceleration } else { f64::NAN };
    }
    if deceleration <= 0.0 {
        return to_exit / forward;
    }
    let stopping_distance = forward * forward / (2.0 * deceleration);
    if stopping_distance <= to_exit {
        forward / deceleration
    } else {
        // the root of to_exit = u t - a t^2 / 2 before the stop, in the form that does not
        // cancel when a is small
        2.0 * to_exit / (forward + (forward * forward - 2.0 * deceleration * to_exit).sqrt())
    }
}

/// The projectile's speed as the progress line gives it: `speed` [m/s], and beside it its
/// part `forward` [m/s] along the panel's inward normal when that differs from the speed by
/// more than a tenth. Near a stop the FSP drifts sideways at several m/s (a 12-layer shot
/// turning back read "projectile 9.3 m/s" with under 1 m/s left along the shot line), while the
/// decision and its time go by the forward part alone.
fn speed_words(speed: f64, forward: f64) -> String {
    if (speed - forward.abs()).abs() > 0.1 * speed {
        format!("{speed:.1} m/s ({forward:.1} m/s along the shot line)")
    } else {
        format!("{speed:.1} m/s")
    }
}

/// Wall time to the end time [s] at the rate so far, `elapsed` seconds into the job with
/// `fraction` of its simulated time done; none in the first seconds of stepping (a rate from
/// the first steps alone, set-up caches and the first list build, is no rate).
fn to_end_time(elapsed: f64, fraction: f64) -> Option<f64> {
    (fraction > 0.0 && elapsed >= FIRST_ESTIMATE_AFTER_S).then(|| elapsed * (1.0 - fraction) / fraction)
}

/// Where the projectile stands with respect to the decision, at one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Flight {
    /// its speed along the panel's inward normal [m/s]
    pub forward: f64,
    /// how far its top still is from passing the back face (with the contact margin) [m]
    pub to_exit: f64,
}

/// The content of `progress.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ProgressReport {
    /// steps taken
    pub step: u64,
    /// [s]
    pub simulated_time_s: f64,
    /// [s]
    pub end_time_s: f64,
    /// of the end time, simulated [%]
    pub percent: f64,
    /// wall time since this job began stepping [s]
    pub elapsed_s: f64,
    /// to the end time, by the simulated-time rate since the start of this job
    pub eta_s: f64,
    /// to the decision (stopped or through the back face) at the projectile's deceleration
    /// since the last report and the same rate; 0 once finished; not a number (null) while
    /// it cannot be foreseen (through the back face, held, not decelerating)
    pub decision_eta_s: f64,
    /// [m/s]
    pub projectile_speed_m_s: f64,
    /// |E - E0| / E0 at the last history sample [-]
    pub energy_balance_error: f64,
    /// the simulated time of the checkpoint a rerun would go on from: the last one this job
    /// wrote, or the one it was restarted from; absent (null) while there is none [s]
    pub checkpoint_time_s: Option<f64>,
    /// `running`; `finished` once the run has taken its last step; `interrupted` once a
    /// signal stopped it at the checkpoint `checkpoint_time_s` names (a rerun goes on from
    /// it), so that a reader need not guess from the file's age whether it still steps
    pub state: &'static str,
    /// when finished: the outcome (`perforated`, `stopped`, `rebounded`, `undecided`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outcome: Option<String>,
}

/// Where a run stands, as `progress.json`'s `state` names it.
#[derive(Clone, Debug, PartialEq)]
enum RunState {
    /// stepping
    Running,
    /// a signal stopped it after a checkpoint, which a rerun goes on from
    Interrupted,
    /// it took its last step, with this outcome
    Finished(String),
}

impl RunState {
    fn name(&self) -> &'static str {
        match self {
            RunState::Running => "running",
            RunState::Interrupted => "interrupted",
            RunState::Finished(_) => "finished",
        }
    }
}

/// Rank 0's progress display.
pub struct Progress {
    start: Instant,
    start_time: f64,
    end_time: f64,
    last_report: Option<Instant>,
    last_bar: Option<Instant>,
    bar: Option<ProgressBar>,
    path: PathBuf,
    /// stepping, stopped by a signal at a checkpoint ([`Self::interrupted`]) or finished
    /// with its outcome ([`Self::finish`])
    state: RunState,
    /// simulated time and forward speed at the last report (for the deceleration)
    last_flight: Option<(f64, f64)>,
    /// the latest estimate of the wall time to the decision [s]
    decision_eta: f64,
    /// the simulated time of the checkpoint to go on from, if any [s]
    checkpoint_time: Option<f64>,
}

impl Progress {
    /// `start_time` is the simulated time this job begins at (after a restart, not zero);
    /// `restarted` says it goes on from a checkpoint, which stays the one to go on from until
    /// [`Self::checkpointed`] names a newer one.
    pub fn new(out: &std::path::Path, start_time: f64, end_time: f64, restarted: bool, mode: ProgressMode) -> Self {
        let bar = mode.draws_bar().then(|| {
            // drawn on stderr whatever it is (indicatif's own stderr target hides itself
            // when stderr is not a terminal, as under mpirun)
            let target = ProgressDrawTarget::term_like_with_hz(Box::new(console::Term::stderr()), 5);
            let bar = ProgressBar::with_draw_target(Some(1000), target);
            bar.set_style(ProgressStyle::with_template("{bar:12} {percent:>3}% {msg}").expect("a valid template"));
            bar
        });
        Self {
            start: Instant::now(),
            start_time,
            end_time,
            last_report: None,
            last_bar: None,
            bar,
            path: out.join("progress.json"),
            state: RunState::Running,
            last_flight: None,
            decision_eta: f64::NAN,
            checkpoint_time: restarted.then_some(start_time),
        }
    }

    /// Records that a checkpoint of simulated time `time` [s] is complete on disk, so that
    /// `progress.json` says where a rerun goes on from rather than only where the run was.
    pub fn checkpointed(&mut self, time: f64) {
        self.checkpoint_time = Some(time);
        // the next update writes it, however soon
        self.last_report = None;
    }

    /// Reports the state after a step; cheap unless a report is due.
    pub fn update(&mut self, step: u64, time: f64, projectile_speed: f64, energy_balance_error: f64, flight: Flight) {
        let fraction = ((time - self.start_time) / (self.end_time - self.start_time)).clamp(0.0, 1.0);
        if let Some(bar) = self.bar.as_ref().filter(|_| self.last_bar.is_none_or(|last| last.elapsed() >= BAR_EVERY)) {
            self.last_bar = Some(Instant::now());
            bar.set_position((1000.0 * (time / self.end_time).clamp(0.0, 1.0)) as u64);
            // within 80 columns: mpirun's terminal may be narrow, and its width is unknown here
            let eta = if let Some(to_end) = to_end_time(self.start.elapsed().as_secs_f64(), fraction) {
                let decision = if self.decision_eta.is_finite() {
                    format!(" (decided ~{:.0} s)", self.decision_eta.min(to_end))
                } else {
                    String::new()
                };
                format!(", end in {to_end:.0} s{decision}")
            } else {
                String::new()
            };
            bar.set_message(format!(
                "{time:.2e} s, {projectile_speed:.0} m/s, balance {:.2}%{eta}",
                100.0 * energy_balance_error
            ));
        }
        if self.last_report.is_some_and(|last| last.elapsed() < REPORT_EVERY) {
            return;
        }
        self.last_report = Some(Instant::now());
        let elapsed = self.start.elapsed().as_secs_f64();
        let to_end = to_end_time(elapsed, fraction);
        // the deceleration since the last report, and the wall time per simulated second
        let deceleration = self
            .last_flight
            .filter(|&(then, _)| time > then)
            .map_or(0.0, |(then, forward)| (forward - flight.forward) / (time - then));
        self.last_flight = Some((time, flight.forward));
        let wall_per_simulated = elapsed / (time - self.start_time);
        // nothing left to wait for once finished; nothing to foresee once interrupted
        self.decision_eta = match self.state {
            RunState::Finished(_) => 0.0,
            RunState::Running if to_end.is_some() => {
                time_to_decision(flight.forward, deceleration, flight.to_exit) * wall_per_simulated
            }
            _ => f64::NAN,
        };
        let report = ProgressReport {
            step,
            simulated_time_s: time,
            end_time_s: self.end_time,
            percent: 100.0 * time / self.end_time,
            elapsed_s: elapsed,
            eta_s: match self.state {
                RunState::Finished(_) => 0.0,
                RunState::Running => to_end.unwrap_or(f64::NAN),
                RunState::Interrupted => f64::NAN,
            },
            decision_eta_s: self.decision_eta,
            projectile_speed_m_s: projectile_speed,
            energy_balance_error,
            checkpoint_time_s: self.checkpoint_time,
            state: self.state.name(),
            outcome: match &self.state {
                RunState::Finished(outcome) => Some(outcome.clone()),
                _ => None,
            },
        };
        if self.bar.is_none() && self.state == RunState::Running {
            let eta = if report.eta_s.is_finite() && report.decision_eta_s.is_finite() {
                format!(
                    "{:.0} s to the end time, about {:.0} s to the decision at the present deceleration",
                    report.eta_s,
                    report.decision_eta_s.min(report.eta_s)
                )
            } else if report.eta_s.is_finite() {
                format!(
                    "{:.0} s to the end time, the decision waits on the fabric letting the projectile go",
                    report.eta_s
                )
            } else {
                "not yet known".into()
            };
            tracing::info!(
                "step {} t = {:.3e} s ({:.1}%), elapsed {:.0} s, ETA {eta}, projectile {}, energy balance {:.2}%",
                report.step,
                report.simulated_time_s,
                report.percent,
                report.elapsed_s,
                speed_words(report.projectile_speed_m_s, flight.forward),
                100.0 * report.energy_balance_error
            );
        }
        if let Ok(text) = serde_json::to_string_pretty(&report) {
            let temporary = self.path.with_extension("json.writing");
            if std::fs::write(&temporary, text + "\n").is_ok() {
                let _ = std::fs::rename(&temporary, &self.path);
            }
        }
    }

    /// Clears the bar and writes `progress.json` for a run a signal stopped after its
    /// checkpoint at `time` [s] ([`Self::checkpointed`] first): interrupted, nothing to
    /// foresee until a rerun goes on.
    pub fn interrupted(
        &mut self,
        step: u64,
        time: f64,
        projectile_speed: f64,
        energy_balance_error: f64,
        flight: Flight,
    ) {
        self.state = RunState::Interrupted;
        self.last_report = None;
        self.last_bar = None;
        self.update(step, time, projectile_speed, energy_balance_error, flight);
        if let Some(bar) = self.bar.take() {
            bar.abandon();
        }
    }

    /// Clears the bar and writes the final `progress.json`: finished, with the run's
    /// `outcome`, nothing left to wait for.
    pub fn finish(&mut self, step: u64, time: f64, projectile_speed: f64, energy_balance_error: f64, outcome: &str) {
        self.state = RunState::Finished(outcome.to_string());
        self.last_report = None;
        self.last_bar = None;
        self.update(step, time, projectile_speed, energy_balance_error, Flight::default());
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

/// How much more (positive) or less (negative) than usual the logs say on stderr: `-v`
/// and `-q` counted ([`set_verbosity`]).
static VERBOSITY: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);

/// The filter RUST_LOG asks for, if it is set; an error naming it when it cannot be read.
pub fn log_filter() -> Result<Option<tracing_subscriber::EnvFilter>, String> {
    match std::env::var("RUST_LOG") {
        Ok(spec) if !spec.trim().is_empty() => tracing_subscriber::EnvFilter::try_new(&spec)
            .map(Some)
            .map_err(|e| format!("RUST_LOG={spec:?}: {e} (e.g. RUST_LOG=debug, RUST_LOG=dea_fabric=debug)")),
        _ => Ok(None),
    }
}

/// Sets the verbosity [`init_logging`] gives stderr: +1 per `-v`, -1 per `-q`.
pub fn set_verbosity(verbosity: i32) {
    VERBOSITY.store(verbosity, std::sync::atomic::Ordering::Relaxed);
}

/// Sets up rank-tagged logging: rank 0 logs to stderr; with `log_directory`, every rank also
/// writes its own `rank-NNNNN.log` there. Returns the span to hold for the job's duration.
pub fn init_logging(rank: u32, log_directory: Option<&std::path::Path>) -> Result<tracing::span::EnteredSpan, String> {
    use tracing::level_filters::LevelFilter;
    use tracing_subscriber::prelude::*;
    // rank 0 tells the user how the run goes, the others only what goes wrong; -v and -q
    // move both by a level, and RUST_LOG, when set, decides instead (every rank alike)
    let levels = [
        LevelFilter::OFF,
        LevelFilter::ERROR,
        LevelFilter::WARN,
        LevelFilter::INFO,
        LevelFilter::DEBUG,
        LevelFilter::TRACE,
    ];
    let base = if rank == 0 { 3 } else { 2 };
    let level = levels[(base + VERBOSITY.load(std::sync::atomic::Ordering::Relaxed)).clamp(1, 5) as usize];
    let filter = match log_filter()? {
        Some(filter) => filter,
        None => tracing_subscriber::EnvFilter::default().add_directive(level.into()),
    };
    let stderr = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .without_time()
        .with_filter(filter);
    // a field formatter of its own type, so the file never reuses the terminal's colours
    let plain_fields = tracing_subscriber::fmt::format::debug_fn(|writer, field, value| {
        if field.name() == "message" {
            write!(writer, "{value:?}")
        } else {
            write!(writer, "{field}={value:?}")
        }
    });
    let file = match log_directory {
        Some(directory) => {
            std::fs::create_dir_all(directory).map_err(|e| format!("{}: {e}", directory.display()))?;
            let path = directory.join(format!("rank-{rank:05}.log"));
            let file = std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            Some(
                tracing_subscriber::fmt::layer()
                    .fmt_fields(plain_fields)
                    .with_writer(std::sync::Mutex::new(file))
                    .with_target(false)
                    .with_ansi(false)
                    .with_filter(tracing::level_filters::LevelFilter::INFO),
            )
        }
        None => None,
    };
    tracing_subscriber::registry().with(stderr).with(file).try_init().map_err(|e| e.to_string())?;
    Ok(tracing::info_span!("rank", r = rank).entered())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_to_the_decision_follows_constant_deceleration() {
        // stops before the back face: t = u / a, where it has gone u^2 / 2a
        assert_eq!(time_to_decision(100.0, 1e7, 1.0), 1e-5);
        // passes it: the earlier root of d = u t - a t^2 / 2
        let (u, a, d) = (300.0, 1e7, 2e-3);
        let t = time_to_decision(u, a, d);
        assert!((u * t - 0.5 * a * t * t - d).abs() < 1e-15, "{t}");
        assert!(t > d / u && t < u / a);
        // a tiny deceleration does not cancel the root away
        let t = time_to_decision(300.0, 1e-6, 3e-3);
        assert!((t - 1e-5).abs() < 1e-15, "{t}");
        // no deceleration: at the present speed; decided already: now
        assert_eq!(time_to_decision(200.0, 0.0, 1e-3), 5e-6);
        assert_eq!(time_to_decision(200.0, -5e6, 1e-3), 5e-6);
        assert_eq!(time_to_decision(-1.0, 1e7, 1e-3), 0.0);
        // through the back face and still held: to the stop, unknown while not decelerating
        // (a restarted 8-layer shot at 127 m/s, 49 us in, said "about 0 s")
        assert_eq!(time_to_decision(200.0, 1e7, -1e-4), 2e-5);
        assert!(time_to_decision(200.0, 0.0, -1e-4).is_nan());
        assert!(time_to_decision(200.0, -5e6, -1e-4).is_nan());
    }

    #[test]
    fn the_speed_along_the_shot_line_is_shown_when_it_differs() {
        // in flight: the speed is the forward part, nothing beside it
        assert_eq!(speed_words(375.0, 374.9), "375.0 m/s");
        assert_eq!(speed_words(0.0, 0.0), "0.0 m/s");
        // near the stop of a 12-layer shot: mostly sideways
        assert_eq!(speed_words(9.3, 0.4), "9.3 m/s (0.4 m/s along the shot line)");
        // turned back
        assert_eq!(speed_words(9.3, -2.0), "9.3 m/s (-2.0 m/s along the shot line)");
    }

    #[test]
    fn progress_names_the_checkpoint_a_rerun_goes_on_from() {
        let dir = std::env::temp_dir().join(format!("dea-progress-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let read = || -> serde_json::Value {
            serde_json::from_str(&std::fs::read_to_string(dir.join("progress.json")).unwrap()).unwrap()
        };
        // a fresh run: nothing to go on from until its first checkpoint
        let mut fresh = Progress::new(&dir, 0.0, 1e-4, false, ProgressMode::Lines);
        fresh.update(10, 1e-6, 300.0, 0.0, Flight::default());
        assert!(read()["checkpoint_time_s"].is_null(), "{}", read());
        // a checkpoint is written into progress.json at the next update, however soon
        fresh.checkpointed(2e-6);
        fresh.update(20, 2e-6, 299.0, 0.0, Flight::default());
        assert_eq!(read()["checkpoint_time_s"].as_f64(), Some(2e-6));
        // later reports keep it while the run goes past it (an 8-layer shot said "at 28.4 us,
        // goes on from its checkpoint", which was at 19.8 us)
        fresh.checkpointed(2e-6);
        fresh.update(30, 3e-6, 298.0, 0.0, Flight::default());
        fresh.finish(40, 4e-6, 297.0, 0.0, "perforated");
        assert_eq!(
            (read()["simulated_time_s"].as_f64(), read()["checkpoint_time_s"].as_f64()),
            (Some(4e-6), Some(2e-6))
        );
        // a restarted run goes on from the checkpoint it began at
        let mut restarted = Progress::new(&dir, 5e-6, 1e-4, true, ProgressMode::Lines);
        restarted.update(60, 6e-6, 290.0, 0.0, Flight::default());
        assert_eq!(
            (read()["simulated_time_s"].as_f64(), read()["checkpoint_time_s"].as_f64()),
            (Some(6e-6), Some(5e-6))
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn lines_or_bar_as_asked() {
        assert!(ProgressMode::Bar.draws_bar());
        assert!(!ProgressMode::Lines.draws_bar());
    }
}
