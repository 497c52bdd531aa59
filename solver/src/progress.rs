//! What a running job tells its user (rank 0): a progress bar with ETA on a terminal; in a
//! batch log a plain line every 30 s; `progress.json` beside the results, rewritten as often.

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

/// The content of `progress.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ProgressReport {
    pub step: u64,
    pub simulated_time_s: f64,
    pub end_time_s: f64,
    pub percent: f64,
    pub elapsed_s: f64,
    /// by the simulated-time rate since the start of this job
    pub eta_s: f64,
    pub projectile_speed_m_s: f64,
    /// |E - E0| / E0 at the last history sample [-]
    pub energy_balance_error: f64,
    /// `running`, or `finished` once the run has taken its last step
    pub state: &'static str,
    /// when finished: the outcome (`perforated`, `stopped`, `rebounded`, `undecided`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outcome: Option<String>,
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
    /// set by [`Self::finish`]: the run's outcome
    finished: Option<String>,
}

impl Progress {
    /// `start_time` is the simulated time this job begins at (after a restart, not zero).
    pub fn new(out: &std::path::Path, start_time: f64, end_time: f64) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {percent:>3}% {msg} [{elapsed_precise}, ETA {eta}]")
                    .expect("a valid template"),
            );
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
            finished: None,
        }
    }

    /// Reports the state after a step; cheap unless a report is due.
    pub fn update(&mut self, step: u64, time: f64, projectile_speed: f64, energy_balance_error: f64) {
        let fraction = ((time - self.start_time) / (self.end_time - self.start_time)).clamp(0.0, 1.0);
        if let Some(bar) = self.bar.as_ref().filter(|_| self.last_bar.is_none_or(|last| last.elapsed() >= BAR_EVERY)) {
            self.last_bar = Some(Instant::now());
            bar.set_position((1000.0 * (time / self.end_time).clamp(0.0, 1.0)) as u64);
            bar.set_message(format!(
                "step {step}, t = {time:.3e} s, projectile {projectile_speed:.1} m/s, energy balance {:.2}%",
                100.0 * energy_balance_error
            ));
        }
        if self.last_report.is_some_and(|last| last.elapsed() < REPORT_EVERY) {
            return;
        }
        self.last_report = Some(Instant::now());
        let elapsed = self.start.elapsed().as_secs_f64();
        let report = ProgressReport {
            step,
            simulated_time_s: time,
            end_time_s: self.end_time,
            percent: 100.0 * time / self.end_time,
            elapsed_s: elapsed,
            // a rate from the first steps alone (set-up caches, the first list build) is
            // no rate: no estimate before a few seconds of stepping
            eta_s: if self.finished.is_some() {
                0.0
            } else if fraction > 0.0 && elapsed >= FIRST_ESTIMATE_AFTER_S {
                elapsed * (1.0 - fraction) / fraction
            } else {
                f64::NAN
            },
            projectile_speed_m_s: projectile_speed,
            energy_balance_error,
            state: if self.finished.is_some() { "finished" } else { "running" },
            outcome: self.finished.clone(),
        };
        if self.bar.is_none() && self.finished.is_none() {
            let eta = if report.eta_s.is_finite() {
                format!("{:.0} s to the end time (a decided shot stops sooner)", report.eta_s)
            } else {
                "not yet known".into()
            };
            tracing::info!(
                "step {} t = {:.3e} s ({:.1}%), elapsed {:.0} s, ETA {eta}, projectile {:.1} m/s, energy balance {:.2}%",
                report.step,
                report.simulated_time_s,
                report.percent,
                report.elapsed_s,
                report.projectile_speed_m_s,
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

    /// Clears the bar and writes the final `progress.json`: finished, with the run's
    /// `outcome`, nothing left to wait for.
    pub fn finish(&mut self, step: u64, time: f64, projectile_speed: f64, energy_balance_error: f64, outcome: &str) {
        self.finished = Some(outcome.to_string());
        self.last_report = None;
        self.last_bar = None;
        self.update(step, time, projectile_speed, energy_balance_error);
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
