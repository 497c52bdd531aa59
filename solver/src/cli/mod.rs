//! The command line: one file per subcommand, each with its arguments, its help texts as
//! constants and its `main`; here the top-level parser, the exit codes and what the
//! subcommands share (loading a case on rank 0 for every rank, collective failure).

pub mod bench;
pub mod check;
pub mod compare;
pub mod fabric;
pub mod fit;
pub mod partition;
pub mod run;
pub mod v50;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use dea_core::Rank;
use dea_io::campaign::{is_campaign, load_campaign, Campaign};
use dea_io::case::{default_case, load_case, Case};
use dea_mpi::comm::mpi::MpiSession;
use dea_mpi::comm::Comm;
use dea_mpi::setup::SetupError;

/// Exit codes (part of the interface: scripts rely on them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    Usage = 2,
    BadCase = 3,
    File = 4,
    Numerical = 5,
    /// stopped by SIGTERM/SIGUSR1 after writing a checkpoint (EX_TEMPFAIL: requeue me)
    Interrupted = 75,
}

const ABOUT: &str = "Fibre-level ballistic impact solver (modified digital element approach)";
const EXAMPLES: &str = "Examples:
  dea-mpi run                       # built-in default case, results in ./out
  mpirun -np 4 dea-mpi run case.json --out results/
  dea-mpi check case.json           # validate and print the resolved case
  dea-mpi fabric case.json          # relax a woven case's cell, report the fabric
  mpirun -np 4 dea-mpi v50 campaign.json --ranks-per-shot 2   # a V50 campaign, two shots at a time
  dea-mpi fit out/v50 out/v50-finer # V50 from the shots of two campaigns of one target, pooled
  dea-mpi bench --json              # node-step cost, one JSON object
  dea-mpi compare a/results.h5 b/results.h5   # bitwise identity of two runs

Exit codes: 0 done (a perforation is a result), 1 compare found differences, 2 usage, 3 bad case, 4 mesh/file error,
5 numerical failure, 75 stopped by a signal after writing a checkpoint.";

#[derive(Parser)]
#[command(name = "dea-mpi", version, about = ABOUT, after_help = EXAMPLES)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// less on stderr: warnings and errors only (-q), errors only (-qq)
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub quiet: u8,
    /// more on stderr: debug messages (-v), trace (-vv); RUST_LOG, when set, decides instead
    /// (e.g. RUST_LOG=debug, RUST_LOG=dea_fabric=debug)
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
}

#[derive(Subcommand)]
pub enum Command {
    #[command(about = run::ABOUT, long_about = run::LONG_ABOUT, after_help = run::EXAMPLES)]
    Run(run::Args),
    #[command(about = fabric::ABOUT, long_about = fabric::LONG_ABOUT, after_help = fabric::EXAMPLES)]
    Fabric(fabric::Args),
    #[command(about = v50::ABOUT, long_about = v50::LONG_ABOUT, after_help = v50::EXAMPLES)]
    V50(v50::Args),
    #[command(about = fit::ABOUT, long_about = fit::LONG_ABOUT, after_help = fit::EXAMPLES)]
    Fit(fit::Args),
    #[command(about = check::ABOUT, long_about = check::LONG_ABOUT, after_help = check::EXAMPLES)]
    Check(check::Args),
    #[command(about = partition::ABOUT, long_about = partition::LONG_ABOUT, after_help = partition::EXAMPLES)]
    Partition(partition::Args),
    #[command(about = compare::ABOUT, long_about = compare::LONG_ABOUT, after_help = compare::EXAMPLES)]
    Compare(compare::Args),
    #[command(about = bench::ABOUT, long_about = bench::LONG_ABOUT, after_help = bench::EXAMPLES)]
    Bench(bench::Args),
}

impl Command {
    /// Runs the subcommand.
    pub fn main(self) -> ExitCode {
        match self {
            Command::Run(args) => run::main(args),
            Command::Fabric(args) => fabric::main(args),
            Command::V50(args) => v50::main(args),
            Command::Fit(args) => fit::main(args),
            Command::Check(args) => check::main(args),
            Command::Partition(args) => partition::main(args),
            Command::Compare(args) => compare::main(args),
            Command::Bench(args) => bench::main(args),
        }
    }
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum PartitionMethod {
    Kway,
    Recursive,
}

pub fn fail(code: Exit, message: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(code as u8)
}

/// Reads and validates a case (no path: the default case) without MPI.
pub fn load(path: Option<&PathBuf>) -> Result<Case, (Exit, String)> {
    match path {
        None => Ok(default_case()),
        Some(path) => {
            if let Err(e) = std::fs::metadata(path) {
                return Err((Exit::File, format!("{}: cannot read: {e}", path.display())));
            }
            load_case(path).map_err(|e| (Exit::BadCase, e.to_string()))
        }
    }
}

/// The text of an input file: a missing or unreadable file is a file error (4), a FIFO, a
/// device or an oversized file a refused case (3).
fn read_input(path: &Path) -> Result<String, (Exit, String)> {
    if let Err(e) = std::fs::metadata(path) {
        return Err((Exit::File, format!("{}: cannot read: {e}", path.display())));
    }
    dea_io::case::read_input(path).map_err(|e| (Exit::BadCase, e.to_string()))
}

/// A case file, or a campaign file (one naming its shot's `case` or `case_file`) with its
/// shot's case.
pub fn load_case_or_campaign(path: &PathBuf) -> Result<(Option<Campaign>, Case), (Exit, String)> {
    let text = read_input(path)?;
    let text =
        dea_io::case::json_document(&text, &path.display().to_string()).map_err(|e| (Exit::BadCase, e.to_string()))?;
    let campaign = serde_json::from_str::<serde_json::Value>(text).is_ok_and(|document| is_campaign(&document));
    if campaign {
        load_campaign(path).map(|(campaign, case)| (Some(campaign), case)).map_err(|e| (Exit::BadCase, e.to_string()))
    } else {
        load(Some(path)).map(|case| (None, case))
    }
}

/// Rank 0 runs `load` and every rank gets its value, or the same error: a file missing on one
/// node's file system cannot split the job.
pub fn from_rank0<T: serde::Serialize + serde::de::DeserializeOwned>(
    comm: &impl Comm,
    load: impl FnOnce() -> Result<T, (Exit, String)>,
) -> Result<T, (Exit, String)> {
    let mut message = Vec::new();
    if comm.rank() == Rank(0) {
        match load() {
            Ok(value) => {
                message.push(0);
                message.extend(serde_json::to_string(&value).expect("what rank 0 read serialises").bytes());
            }
            Err((code, text)) => {
                message.push(code as u8);
                message.extend(text.bytes());
            }
        }
    }
    comm.broadcast_bytes(&mut message);
    let (&code, payload) = message.split_first().expect("rank 0 always sends a code");
    let text = String::from_utf8_lossy(payload).into_owned();
    match code {
        0 => serde_json::from_str(&text).map_err(|e| (Exit::BadCase, format!("from rank 0: {e}"))),
        2 => Err((Exit::Usage, text)),
        3 => Err((Exit::BadCase, text)),
        _ => Err((Exit::File, text)),
    }
}

/// Rank 0 reads the case (no path: the default case); every rank gets it.
pub fn load_shared(comm: &impl Comm, path: Option<&PathBuf>) -> Result<Case, (Exit, String)> {
    from_rank0(comm, || load(path))
}

/// Rank 0 reads the campaign, its case and its text; every rank gets them.
pub fn load_campaign_shared(comm: &impl Comm, path: &Path) -> Result<(Campaign, Case, String), (Exit, String)> {
    from_rank0(comm, || {
        let text = read_input(path)?;
        let (campaign, case) = load_campaign(path).map_err(|e| (Exit::BadCase, e.to_string()))?;
        Ok((campaign, case, text))
    })
}

/// Ends every rank of a collective error: rank 0 prints the message once, all ranks wait
/// for it, then exit with the same code.
pub fn fail_all(session: &MpiSession, code: Exit, message: impl std::fmt::Display) -> ExitCode {
    if session.rank() == Rank(0) {
        // a stop that wrote its checkpoint is the way a time limit ends, not an error
        let prefix = if code == Exit::Interrupted { "stopped" } else { "error" };
        eprintln!("{prefix}: {message}");
    }
    session.barrier();
    ExitCode::from(code as u8)
}

pub fn method_of(method: PartitionMethod) -> dea_partition::Method {
    match method {
        PartitionMethod::Kway => dea_partition::Method::KWay,
        PartitionMethod::Recursive => dea_partition::Method::RecursiveBisection,
    }
}

/// A set-up error as the user reads it: one about the case names the case file it came from
/// (the resolver's own errors already do; those found while building do not know it).
pub fn in_file(error: &SetupError, path: Option<&PathBuf>) -> String {
    let message = error.to_string();
    match (error, path) {
        (SetupError::Case(_), Some(path)) if !message.contains(&path.display().to_string()) => {
            format!("{message} (in {})", path.display())
        }
        _ => message,
    }
}

pub fn setup_exit(error: &SetupError) -> Exit {
    match error {
        SetupError::Partition(_) => Exit::Usage,
        SetupError::Numerical(_) | SetupError::Relaxation(_) => Exit::Numerical,
        SetupError::Checkpoint(_) | SetupError::Mesh(_) => Exit::File,
        SetupError::Case(_) => Exit::BadCase,
    }
}
