//! `dea-mpi`: the digital-element ballistic impact solver.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use dea_core::Rank;
use dea_io::campaign::{is_campaign, load_campaign, Campaign};
use dea_io::case::{default_case, load_case, Case};
use dea_mpi::campaign::{CampaignError, Group, Progress};
use dea_mpi::comm::mpi::{MpiComm, MpiSession};
use dea_mpi::comm::Comm;
use dea_mpi::run::{RunError, RunOptions};
use dea_mpi::setup::{self, SetupError};

/// One line on a cell's relaxation, which took `seconds` [s].
fn print_relaxation(r: &dea_fabric::relax::RelaxReport, seconds: f64) {
    println!(
        "relaxed in {} iterations ({seconds:.2} s): largest nodal force {:.3e} -> {:.3e} N, {} contacts, deepest {:.1} % of a contact diameter",
        r.iterations, r.initial_residual_n, r.final_residual_n, r.contacts, 100.0 * r.largest_overlap_ratio
    );
}

/// `RANK/RANKS` of `--share`, RANK below RANKS.
fn parse_share(text: &str) -> Result<(u32, usize), String> {
    let (rank, ranks) = text.split_once('/').ok_or_else(|| format!("expected RANK/RANKS, e.g. 0/64, got {text:?}"))?;
    let rank: u32 = rank.trim().parse().map_err(|e| format!("RANK {rank:?}: {e}"))?;
    let ranks: usize = ranks.trim().parse().map_err(|e| format!("RANKS {ranks:?}: {e}"))?;
    if ranks == 0 || rank as usize >= ranks {
        return Err(format!("RANK must be below RANKS (at least 1), got {rank}/{ranks}"));
    }
    Ok((rank, ranks))
}

/// Exit codes (part of the interface: scripts rely on them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Exit {
    Usage = 2,
    BadCase = 3,
    File = 4,
    Numerical = 5,
    /// stopped by SIGTERM/SIGUSR1 after writing a checkpoint (EX_TEMPFAIL: requeue me)
    Interrupted = 75,
}

#[derive(Parser)]
#[command(name = "dea-mpi", version, about = "Fibre-level ballistic impact solver (modified digital element approach)", long_about = None,
    after_help = "Examples:\n  dea-mpi run                       # built-in default case, results in ./out\n  mpirun -np 4 dea-mpi run case.json --out results/\n  dea-mpi check case.json           # validate and print the resolved case\n  dea-mpi fabric case.json          # relax a woven case's cell, report the fabric\n  mpirun -np 4 dea-mpi v50 campaign.json --ranks-per-shot 2   # a V50 campaign, two shots at a time\n  dea-mpi bench --json              # node-step cost, one JSON object\n  dea-mpi compare a/results.h5 b/results.h5   # bitwise identity of two runs\n\nExit codes: 0 done (a perforation is a result), 1 compare found differences, 2 usage, 3 bad case, 4 mesh/file error, 5 numerical failure, 75 stopped by a signal after writing a checkpoint.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case (no file: the built-in default case) on the ranks of the job. Checkpoints
    /// go to OUT/checkpoint (run.checkpoint_interval_*); SIGTERM or SIGUSR1 writes one and
    /// stops with exit code 75.
    #[command(after_help = "Examples:\n  dea-mpi run\n  mpirun -np 2 dea-mpi run cases/four_layer_panel.json --out out/panel\n  mpirun -np 4 dea-mpi run --restart out/panel/checkpoint --out out/panel")]
    Run {
        /// case file (JSON, SI units)
        case: Option<PathBuf>,
        /// output directory for results.h5 and summary.json
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// METIS algorithm for the partition over the job's ranks
        #[arg(long, value_enum, default_value_t = PartitionMethod::Kway)]
        method: PartitionMethod,
        /// continue from a checkpoint directory (OUT/checkpoint of an earlier run), on any
        /// number of ranks; the case comes from the checkpoint
        #[arg(long, conflicts_with = "case")]
        restart: Option<PathBuf>,
        /// also write every rank's log to DIR/rank-NNNNN.log
        #[arg(long)]
        log_dir: Option<PathBuf>,
        /// fault injection for the test suite: this rank panics after set-up, to show that
        /// the whole job then ends at once
        #[arg(long, hide = true)]
        panic_on_rank: Option<u32>,
    },
    /// Generate and relax a woven case's unit cell, build its panel over the job's ranks
    /// (each rank only its own part) and report the fabric: OUT/cell.h5 (reusable as
    /// target.cell_file), OUT/cell.xdmf (ParaView) and OUT/fabric.json.
    #[command(
        after_help = "Examples:\n  dea-mpi fabric\n  mpirun -np 4 dea-mpi fabric cases/km2_706_patch.json --out out/fabric\n  dea-mpi fabric jobs/cases/table_6_1_disc.json --share 0/64   # one rank's part of a 64-rank job"
    )]
    Fabric {
        /// case file with a woven_panel target; none: the built-in default case
        case: Option<PathBuf>,
        /// output directory
        #[arg(long, default_value = "out/fabric")]
        out: PathBuf,
        /// METIS algorithm for the partition over the job's ranks
        #[arg(long, value_enum, default_value_t = PartitionMethod::Kway)]
        method: PartitionMethod,
        /// build, in this one process, only what rank RANK of a RANKS-rank job would (its
        /// own nodes and their contact lists) and report it in OUT/share.json: a panel too
        /// large for this machine, one rank's share at a time
        #[arg(long, value_name = "RANK/RANKS", value_parser = parse_share)]
        share: Option<(u32, usize)>,
    },
    /// Run a V50 campaign: the shots its design asks for, on groups of --ranks-per-shot ranks
    /// firing concurrently; every shot's record is kept the moment it ends (OUT/shots/), so a
    /// rerun skips finished shots and resumes an interrupted one from its checkpoint. Writes
    /// OUT/v50.json (logistic and probit V10/V50/V90 with 95 % intervals, MIL-STD-662F,
    /// Lambert-Jonas, bisection brackets) and OUT/provenance.json. SIGTERM or SIGUSR1:
    /// every group checkpoints its shot and the job stops with exit code 75.
    #[command(after_help = "Examples:\n  mpirun -np 4 dea-mpi v50 campaign.json --out out/v50 --ranks-per-shot 2\n  dea-mpi v50 campaign.json --out out/v50          # again: only the missing shots run")]
    V50 {
        /// campaign file (JSON)
        campaign: PathBuf,
        /// output directory
        #[arg(long, default_value = "out/v50")]
        out: PathBuf,
        /// ranks per shot (divides the job's ranks); default: all of them, one shot at a time
        #[arg(long)]
        ranks_per_shot: Option<usize>,
        /// fire at most this many new shots per group, then stop (exit 0; the next run
        /// continues): a campaign spread over several jobs
        #[arg(long)]
        shots_per_group: Option<usize>,
    },
    /// Validate a case, or a V50 campaign and its shot's case, and print it resolved, without
    /// running.
    #[command(after_help = "Examples:\n  dea-mpi check cases/default.json\n  dea-mpi check cases/v50_tiny_bisection.json")]
    Check {
        /// case or campaign file (JSON, SI units)
        case: PathBuf,
    },
    /// Partition a case over N ranks with METIS and report its quality, without running.
    #[command(after_help = "Examples:\n  dea-mpi partition cases/seed_6_1_single_fibre.json --ranks 4\n  dea-mpi partition case.json --ranks 64 --json --method recursive")]
    Partition {
        /// case file (JSON, SI units); none: the built-in default case
        case: Option<PathBuf>,
        /// number of ranks
        #[arg(long)]
        ranks: usize,
        /// positions along the fibres per yarn segment (graph vertex); default: 64, fewer
        /// when that would give a rank less than 32 segments to balance with
        #[arg(long)]
        segment_nodes: Option<u32>,
        /// METIS algorithm
        #[arg(long, value_enum, default_value_t = PartitionMethod::Kway)]
        method: PartitionMethod,
        /// print one JSON object on stdout
        #[arg(long)]
        json: bool,
    },
    /// Compare two results files dataset by dataset, bit for bit (the partition group
    /// excepted), and the field snapshots beside them node by node; exit 0 when identical,
    /// 1 when they differ.
    #[command(after_help = "Example:\n  dea-mpi compare out/1-rank/results.h5 out/4-ranks/results.h5")]
    Compare {
        first: PathBuf,
        second: PathBuf,
    },
    /// Benchmark the step on a dense 19-fibre yarn (>= 300,000 nodes by default), on the
    /// ranks of the job.
    #[command(after_help = "Examples:\n  dea-mpi bench\n  mpirun -np 2 dea-mpi bench --json --nodes 300000 --steps 2000")]
    Bench {
        /// print one JSON object on stdout
        #[arg(long)]
        json: bool,
        /// minimum number of nodes
        #[arg(long, default_value_t = 300_000)]
        nodes: usize,
        /// steps to time
        #[arg(long, default_value_t = 2000)]
        steps: u64,
    },
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum PartitionMethod {
    Kway,
    Recursive,
}

fn fail(code: Exit, message: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(code as u8)
}

/// Reads and validates a case (no path: the default case) without MPI.
fn load(path: Option<&PathBuf>) -> Result<Case, (Exit, String)> {
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

/// A case file, or a campaign file (one naming its shot's `case` or `case_file`) with its
/// shot's case.
fn load_case_or_campaign(path: &PathBuf) -> Result<(Option<Campaign>, Case), (Exit, String)> {
    let text = std::fs::read_to_string(path).map_err(|e| (Exit::File, format!("{}: cannot read: {e}", path.display())))?;
    let campaign = serde_json::from_str::<serde_json::Value>(&text).is_ok_and(|document| is_campaign(&document));
    if campaign {
        load_campaign(path).map(|(campaign, case)| (Some(campaign), case)).map_err(|e| (Exit::BadCase, e.to_string()))
    } else {
        load(Some(path)).map(|case| (None, case))
    }
}

/// Rank 0 runs `load` and every rank gets its value, or the same error: a file missing on one
/// node's file system cannot split the job.
fn from_rank0<T: serde::Serialize + serde::de::DeserializeOwned>(comm: &impl Comm, load: impl FnOnce() -> Result<T, (Exit, String)>) -> Result<T, (Exit, String)> {
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
        3 => Err((Exit::BadCase, text)),
        _ => Err((Exit::File, text)),
    }
}

/// Rank 0 reads the case (no path: the default case); every rank gets it.
fn load_shared(comm: &impl Comm, path: Option<&PathBuf>) -> Result<Case, (Exit, String)> {
    from_rank0(comm, || load(path))
}

/// Rank 0 reads the campaign, its case and its text; every rank gets them.
fn load_campaign_shared(comm: &impl Comm, path: &Path) -> Result<(Campaign, Case, String), (Exit, String)> {
    from_rank0(comm, || {
        let text = std::fs::read_to_string(path).map_err(|e| (Exit::File, format!("{}: cannot read: {e}", path.display())))?;
        let (campaign, case) = load_campaign(path).map_err(|e| (Exit::BadCase, e.to_string()))?;
        Ok((campaign, case, text))
    })
}

/// Ends every rank of a collective error: rank 0 prints the message once, all ranks wait
/// for it, then exit with the same code.
fn fail_all(session: &MpiSession, code: Exit, message: impl std::fmt::Display) -> ExitCode {
    if session.rank() == Rank(0) {
        eprintln!("error: {message}");
    }
    session.barrier();
    ExitCode::from(code as u8)
}

fn method_of(method: PartitionMethod) -> dea_partition::Method {
    match method {
        PartitionMethod::Kway => dea_partition::Method::KWay,
        PartitionMethod::Recursive => dea_partition::Method::RecursiveBisection,
    }
}

fn setup_exit(error: &SetupError) -> Exit {
    match error {
        SetupError::Partition(_) => Exit::Usage,
        SetupError::Numerical(_) | SetupError::Relaxation(_) => Exit::Numerical,
        SetupError::Checkpoint(_) | SetupError::Mesh(_) => Exit::File,
        SetupError::Case(_) => Exit::BadCase,
    }
}

fn main() -> ExitCode {
    // a closed pipe (`dea-mpi check case.json | head`) ends the process quietly, as it does
    // any Unix tool, rather than with a panic at the next print
    // SAFETY: the action only calls emulate_default_handler, which is async-signal-safe
    let _ = unsafe {
        signal_hook::low_level::register(signal_hook::consts::SIGPIPE, || {
            let _ = signal_hook::low_level::emulate_default_handler(signal_hook::consts::SIGPIPE);
        })
    };
    let cli = Cli::parse();
    match cli.command {
        Command::Check { case: path } => {
            let (campaign, case) = match load_case_or_campaign(&path) {
                Ok(loaded) => loaded,
                Err((code, message)) => return fail(code, message),
            };
            if let dea_io::case::TargetSpec::ThreeDWeaveCell { weave, .. } = &case.target {
                // a cell for `dea-mpi fabric`: its initial layout, not relaxed
                let material = case.material().expect("validated case");
                let cell = match setup::laid_out_cell(&case, weave, &material) {
                    Ok(cell) => cell,
                    Err(e) => return fail(setup_exit(&e), e),
                };
                let resolved = serde_json::json!({
                    "case": case,
                    "resolved": { "material": material, "section": cell.section, "period_m": cell.period, "yarns": cell.yarns, "fibres": cell.fibres(), "nodes": cell.positions.len(), "initial": cell.statistics(&material) }
                });
                println!("{}", serde_json::to_string_pretty(&resolved).expect("case serialises"));
                return ExitCode::SUCCESS;
            }
            let problem = match setup::problem(&case) {
                Ok(problem) => problem,
                Err(e) => return fail(setup_exit(&e), e),
            };
            let projectile = &problem.projectile;
            let fibres = *problem.fabric.first_fibres().last().expect("a total") as u64;
            let mut resolved = serde_json::json!({
                "case": case,
                "resolved": {
                    "material": problem.material,
                    "sections": problem.fabric.sections(&problem.material),
                    "projectile": setup::describe_projectile(projectile, &case.projectile().expect("validated case").body, problem.deformable.as_ref()),
                    "yarns": problem.fabric.yarn_count(),
                    "relaxation": problem.relaxation,
                    "fibres": fibres,
                    "nodes": problem.fabric.node_count(),
                    "time_step_s": problem.time_step,
                    "steps": (case.run.end_time_s / problem.time_step).ceil(),
                    "skin_m": problem.contact.skin,
                    "hybrid": match &problem.fabric {
                        dea_fabric::Fabric::Woven(panel) if panel.coarse.is_some() => Some(serde_json::json!({
                            "fine_nodes": panel.fine_node_count(),
                            "fine_yarns_per_layer": panel.fine_yarns_per_layer(),
                            "ties": panel.ties().len(),
                            "transitions": panel.transition_quality(),
                        })),
                        _ => None,
                    },
                }
            });
            if let Some(campaign) = campaign {
                resolved["campaign"] = serde_json::json!(campaign);
            }
            println!("{}", serde_json::to_string_pretty(&resolved).expect("case serialises"));
            ExitCode::SUCCESS
        }
        Command::Run { case, out, method, restart, log_dir, panic_on_rank } => {
            let (session, comm) = match MpiComm::initialize() {
                Ok(mpi) => mpi,
                Err(e) => return fail(Exit::Usage, e),
            };
            let _logging = match dea_mpi::progress::init_logging(comm.rank().0, log_dir.as_deref()) {
                Ok(span) => span,
                Err(e) => return fail(Exit::File, format!("logging: {e}")),
            };
            let stop_signal = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGUSR1] {
                if let Err(e) = signal_hook::flag::register(signal, stop_signal.clone()) {
                    return fail(Exit::Usage, format!("cannot handle signal {signal}: {e}"));
                }
            }
            let ranks = comm.size();
            let (case, mut run, resume) = match restart {
                Some(directory) => match setup::restore(&directory, comm, method_of(method)) {
                    Ok(restored) => {
                        let resume = dea_mpi::run::Resume::from_checkpoint(&restored.global);
                        if resume.is_none() {
                            return fail_all(&session, Exit::File, format!("{}: run state of another version", directory.display()));
                        }
                        (restored.case, restored.run, resume)
                    }
                    Err(e) => return fail_all(&session, setup_exit(&e), e),
                },
                None => {
                    let case = match load_shared(&comm, case.as_ref()) {
                        Ok(case) => case,
                        Err((code, message)) => return fail_all(&session, code, message),
                    };
                    match setup::build(&case, comm, method_of(method), None) {
                        Ok(run) => (case, run, None),
                        Err(e) => return fail_all(&session, setup_exit(&e), e),
                    }
                }
            };
            let json = serde_json::to_string(&case).expect("case serialises");
            if panic_on_rank == Some(run.comm.rank().0) {
                panic!("fault injection: rank {} panics on request", run.comm.rank().0);
            }
            tracing::info!(
                "case {:?}: {} owned nodes and {} ghosts here, dt = {:.3e} s, end {:.3e} s, {} rank(s)",
                case.name,
                run.domain.nodes.n_owned,
                run.ghosts(),
                run.domain.time_step,
                case.run.end_time_s,
                ranks
            );
            let options = RunOptions::for_case(&case, &json, &out, &run, Some(stop_signal), resume);
            match dea_mpi::run::run(&mut run, &options) {
                Ok(Some(summary)) => {
                    println!(
                        "{}: {} nodes on {} rank(s), {} steps, {:.3e} s simulated in {:.1} s; perforated: {}; residual velocity {:.2} m/s; peak force {:.1} N; broken elements {}; {:.3e} node-steps/s/core; results in {}",
                        summary.case,
                        summary.nodes,
                        summary.ranks,
                        summary.steps,
                        summary.simulated_time_s,
                        summary.wall_s,
                        summary.perforated,
                        summary.residual_velocity_m_s,
                        summary.max_projectile_force_n,
                        summary.broken_elements_tension + summary.broken_elements_shear + summary.broken_elements_combined,
                        summary.node_steps_per_s_per_core,
                        out.display()
                    );
                    let stages: Vec<String> = dea_mpi::step::Stage::ALL
                        .iter()
                        .map(|&stage| (stage, summary.stage_seconds.get(stage)))
                        .filter(|&(_, seconds)| seconds >= 0.005)
                        .map(|(stage, seconds)| format!("{} {seconds:.2}", stage.name().replace('_', " ")))
                        .collect();
                    println!(
                        "stages (mean s per rank): {}; halo {:.0} bytes/step, ghost fraction {:.3}, load imbalance {:.3}",
                        stages.join(", "),
                        summary.halo_bytes_per_step,
                        summary.ghost_fraction,
                        summary.load_imbalance
                    );
                    ExitCode::SUCCESS
                }
                Ok(None) => ExitCode::SUCCESS,
                Err(e @ RunError::Numerical(_)) => fail_all(&session, Exit::Numerical, e),
                Err(e @ RunError::Output(_)) => fail_all(&session, Exit::File, e),
                Err(e @ RunError::Interrupted(_)) => fail_all(&session, Exit::Interrupted, e),
            }
        }
        Command::Partition { case, ranks, segment_nodes, method, json } => {
            if ranks == 0 {
                return fail(Exit::Usage, "--ranks must be at least 1");
            }
            let case = match load(case.as_ref()) {
                Ok(case) => case,
                Err((code, message)) => return fail(code, message),
            };
            let problem = match setup::problem(&case) {
                Ok(problem) => problem,
                Err(e) => return fail(setup_exit(&e), e),
            };
            let graph = setup::segment_graph(&problem, ranks, segment_nodes);
            let partition = match dea_partition::partition(&graph, ranks, method_of(method)) {
                Ok(partition) => partition,
                Err(e) => return fail(Exit::Usage, e),
            };
            let report = dea_partition::quality(&graph, &partition);
            if json {
                println!("{}", serde_json::to_string(&report).expect("report serialises"));
            } else {
                let nodes: u64 = report.ranks.iter().map(|r| r.owned_nodes).sum();
                println!(
                    "{}: {} nodes in {} yarn segments on {} ranks; edge cut {}, predicted load imbalance {:.3}, ghost fraction {:.3}, halo {} bytes/step",
                    case.name, nodes, report.segments, ranks, report.edge_cut, report.load_imbalance, report.ghost_fraction, report.halo_bytes_per_step
                );
                println!("{:>6} {:>12} {:>12} {:>14} {:>16}", "rank", "owned", "ghosts", "work", "halo bytes/step");
                for r in &report.ranks {
                    println!("{:>6} {:>12} {:>12} {:>14.0} {:>16}", r.rank, r.owned_nodes, r.ghost_nodes, r.work, r.halo_bytes_per_step);
                }
            }
            ExitCode::SUCCESS
        }
        Command::Compare { first, second } => {
            match dea_io::results::compare_results(&first, &second).and_then(|mut differences| {
                differences.extend(dea_io::snapshot::compare_snapshots(first.parent().unwrap_or(Path::new(".")), second.parent().unwrap_or(Path::new(".")))?);
                Ok(differences)
            }) {
                Ok(differences) if differences.is_empty() => {
                    println!("identical: every dataset of {} and {}, and every field snapshot beside them, has the same bits", first.display(), second.display());
                    ExitCode::SUCCESS
                }
                Ok(differences) => {
                    for d in &differences {
                        println!("{d}");
                    }
                    ExitCode::from(1)
                }
                Err(e) => fail(Exit::File, format!("{} / {}: {e}", first.display(), second.display())),
            }
        }
        Command::V50 { campaign, out, ranks_per_shot, shots_per_group } => {
            let (session, comm) = match MpiComm::initialize() {
                Ok(mpi) => mpi,
                Err(e) => return fail(Exit::Usage, e),
            };
            let ranks = comm.size();
            let per_shot = ranks_per_shot.unwrap_or(ranks);
            if per_shot == 0 || ranks % per_shot != 0 {
                return fail_all(&session, Exit::Usage, format!("--ranks-per-shot {per_shot} does not divide the job's {ranks} ranks"));
            }
            let (campaign_spec, case, text) = match load_campaign_shared(&comm, &campaign) {
                Ok(loaded) => loaded,
                Err((code, message)) => return fail_all(&session, code, message),
            };
            let stop_signal = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGUSR1] {
                if let Err(e) = signal_hook::flag::register(signal, stop_signal.clone()) {
                    return fail_all(&session, Exit::Usage, format!("cannot handle signal {signal}: {e}"));
                }
            }
            let _logging = match dea_mpi::progress::init_logging(comm.rank().0, None) {
                Ok(span) => span,
                Err(e) => return fail(Exit::File, format!("logging: {e}")),
            };
            let group = Group { index: comm.rank().0 as usize / per_shot, count: ranks / per_shot };
            let group_comm = comm.split(group.index as u32);
            let result = dea_mpi::campaign::run_group(&campaign_spec, &case, group_comm, group, &out, shots_per_group, Some(stop_signal));
            let code = match &result {
                Ok(_) => 0,
                Err(CampaignError::Setup { error, .. }) => setup_exit(error) as u8,
                Err(CampaignError::Run { error: RunError::Numerical(_), .. }) => Exit::Numerical as u8,
                Err(CampaignError::Run { error: RunError::Interrupted(_), .. }) => Exit::Interrupted as u8,
                Err(CampaignError::Run { error: RunError::Output(_), .. }) | Err(CampaignError::Output(_)) => Exit::File as u8,
            };
            if let Err(e) = &result {
                // the group's own error: its rank 0 says what it was
                if comm.rank().0 as usize == group.index * per_shot {
                    eprintln!("error: group {}: {e}", group.index);
                }
            }
            // the whole job ends with the most serious code of any group
            let mut worst = [code as f64];
            comm.max_f64(&mut worst);
            if worst[0] != 0.0 {
                session.barrier();
                return ExitCode::from(worst[0] as u8);
            }
            let mut paused = [matches!(result, Ok(Progress::Paused)) as u8 as f64];
            comm.max_f64(&mut paused);
            if comm.rank() != Rank(0) {
                return ExitCode::SUCCESS;
            }
            if paused[0] != 0.0 {
                println!("{}: paused after --shots-per-group {} new shots per group; run again to continue", campaign_spec.name, shots_per_group.unwrap_or(0));
            }
            let report = match dea_mpi::campaign::report(&campaign_spec, &out).and_then(|r| dea_mpi::campaign::write_report(&r, &campaign_spec, &case, &text, &out).map(|()| r)) {
                Ok(report) => report,
                Err(e) => return fail(Exit::File, e),
            };
            println!("{}: {} shots ({} partial, {} complete) on {} group(s) of {} rank(s); results in {}", report.campaign, report.shots.len(), report.partials, report.completes, group.count, per_shot, out.display());
            if report.held_at_end > 0 {
                println!("warning: {} partial(s) were still undecided at the case's end time; a longer run.end_time_s would decide them", report.held_at_end);
            }
            for (name, fit) in [("logistic", &report.logistic), ("probit", &report.probit)] {
                match fit {
                    Ok(f) => println!(
                        "{name:>9}: V50 {:.1} m/s (95 %: {:.1}..{:.1} delta method, {:.1}..{:.1} profile likelihood), V10 {:.1}, V90 {:.1}",
                        f.v50.velocity, f.v50.low, f.v50.high, f.v50.profile_low, f.v50.profile_high, f.v10.velocity, f.v90.velocity
                    ),
                    Err(e) => println!("{name:>9}: {e}"),
                }
            }
            match &report.mil_std_662f {
                Ok(m) => println!("MIL-STD-662F: V50 {:.1} m/s from {} + {} shots within {:.1} m/s", m.v50, m.count, m.count, m.spread),
                Err(e) => println!("MIL-STD-662F: {e}"),
            }
            match &report.lambert_jonas {
                Ok(l) => println!("Lambert-Jonas: v_bl {:.1} m/s (a {:.3}, p {:.2}, rms {:.1} m/s)", l.v_bl, l.a, l.p, l.rms_m_s),
                Err(e) => println!("Lambert-Jonas: {e}"),
            }
            for (r, (low, high)) in report.bisection_brackets.iter().enumerate() {
                println!("bisection {r}: between {low:.1} and {high:.1} m/s (V50 ~ {:.1})", 0.5 * (low + high));
            }
            ExitCode::SUCCESS
        }
        Command::Fabric { case, out, method, share: Some((rank, ranks)) } => {
            let case = match load(case.as_ref()) {
                Ok(case) => case,
                Err((code, message)) => return fail(code, message),
            };
            match dea_mpi::fabric::fabric_share(&case, method_of(method), Rank(rank), ranks, &out) {
                Ok(r) => {
                    let me = &r.partition.ranks[rank as usize];
                    println!(
                        "{}: {} nodes ({} fine, {} ties); rank {} of {} owns {} (predicted ghosts {}, halo {} bytes/step); partitioned in {:.1} s (imbalance {:.3}); built its nodes and {} contact entries in {:.1} s, {:.0} bytes per node, peak resident set {:.2} GB; results in {}",
                        r.case, r.panel_nodes, r.fine_nodes, r.ties, r.rank, r.ranks, r.owned_nodes, me.ghost_nodes, me.halo_bytes_per_step, r.partition_s, r.partition.load_imbalance,
                        r.contact_entries, r.build_s, r.bytes_per_node, 1e-9 * r.peak_resident_bytes, out.display()
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => fail(setup_exit(&e), e),
            }
        }
        Command::Fabric { case, out, method, share: None } => {
            let (session, comm) = match MpiComm::initialize() {
                Ok(mpi) => mpi,
                Err(e) => return fail(Exit::Usage, e),
            };
            let case = match load_shared(&comm, case.as_ref()) {
                Ok(case) => case,
                Err((code, message)) => return fail_all(&session, code, message),
            };
            if matches!(case.target, dea_io::case::TargetSpec::ThreeDWeaveCell { .. } | dea_io::case::TargetSpec::ThreeDWovenPanel { .. }) {
                return match dea_mpi::fabric::fabric_cell(&case, comm, &out) {
                    Ok(Some(report)) => {
                        let (r, c) = (&report.relaxation, &report.cell);
                        print_relaxation(r, report.relaxation_s);
                        let crimps: Vec<String> = report.crimp_by_role.iter().map(|(role, crimp)| format!("{role} {:.2} %", 100.0 * crimp)).collect();
                        println!(
                            "cell: {:.2} x {:.2} mm, {} yarns, {} fibres, {} nodes; thickness {:.1} -> {:.1} um ({:+.1} %), crimp {}, fibre volume fraction {:.3}, {:.1} g/m^2; results in {}",
                            1e3 * report.period_m[0], 1e3 * report.period_m[1], report.yarns.len(), report.fibres, report.nodes, 1e6 * r.before.thickness_m, 1e6 * c.thickness_m,
                            100.0 * report.thickness_change, crimps.join(", "), c.fibre_volume_fraction, 1e3 * c.areal_density_kg_m2, out.display()
                        );
                        ExitCode::SUCCESS
                    }
                    Ok(None) => ExitCode::SUCCESS,
                    Err(e) => fail_all(&session, setup_exit(&e), e),
                };
            }
            match dea_mpi::fabric::fabric(&case, comm, method_of(method), &out) {
                Ok(Some(report)) => {
                    let (c, p) = (&report.cell, &report.panel);
                    if let Some(r) = &report.relaxation {
                        print_relaxation(r, report.relaxation_s);
                    }
                    println!(
                        "cell: thickness {:.1} um, crimp {:.2} %, yarn {:.0} x {:.0} um, fibre volume fraction {:.3}, {:.1} g/m^2 ({:+.2} % from style 706's 180)",
                        1e6 * c.thickness_m, 100.0 * c.crimp, 1e6 * c.yarn_width_m, 1e6 * c.yarn_thickness_m, c.fibre_volume_fraction, 1e3 * c.areal_density_kg_m2, 100.0 * report.style_706_areal_density_deviation
                    );
                    println!(
                        "panel: {} x {} cells ({:.2} mm square), {} layers {:.1} um apart ({:.1} um thick), {} yarns, {} fibres, {} nodes; results in {}",
                        p.cells_per_side, p.cells_per_side, 1e3 * p.side_m, p.layers, 1e6 * p.layer_pitch_m, 1e6 * p.thickness_m, p.yarns, p.fibres, p.nodes, out.display()
                    );
                    if let Some(coarse) = &report.coarse_cell {
                        println!(
                            "hybrid: {} fine yarns each way per layer, {} of the nodes fine; coarse cell thickness {:.1} um, crimp {:.2} %; deepest contact as built {:.1} % of a contact distance; the fine region's layers start {:.1} um apart",
                            p.fine_yarns_per_layer, p.fine_nodes, 1e6 * coarse.thickness_m, 100.0 * coarse.crimp, 100.0 * p.largest_overlap_ratio, 1e6 * p.fine_layer_gap_m
                        );
                        if p.ties > 0 {
                            println!(
                                "transitions: {} ties; tied fine area differs from a coarse fibre's by up to {:.1} %, and centres up to {:.1} % of a coarse contact diameter off its axis",
                                p.ties,
                                100.0 * p.transitions.area_mismatch,
                                100.0 * p.transitions.eccentricity
                            );
                        }
                    }
                    for r in &report.ranks {
                        println!("rank {}: {} nodes + {} ghosts, built in {:.2} s, {:.0} bytes per node", r.rank, r.owned_nodes, r.ghost_nodes, r.build_s, r.bytes_per_node);
                    }
                    ExitCode::SUCCESS
                }
                Ok(None) => ExitCode::SUCCESS,
                Err(e) => fail_all(&session, setup_exit(&e), e),
            }
        }
        Command::Bench { json, nodes, steps } => {
            let (session, comm) = match MpiComm::initialize() {
                Ok(mpi) => mpi,
                Err(e) => return fail(Exit::Usage, e),
            };
            match dea_mpi::bench::bench(comm, nodes, steps) {
                Ok(Some(report)) => {
                    let text = if json { serde_json::to_string(&report) } else { serde_json::to_string_pretty(&report) };
                    println!("{}", text.expect("report serialises"));
                    ExitCode::SUCCESS
                }
                Ok(None) => ExitCode::SUCCESS,
                Err(e) => fail_all(&session, setup_exit(&e), e),
            }
        }
    }
}
