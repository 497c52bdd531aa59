//! `dea-mpi`: the digital-element ballistic impact solver.

mod bench;
mod comm;
mod run;
mod setup;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use dea_io::case::{default_case, load_case, Case};

/// Exit codes (part of the interface: scripts rely on them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Exit {
    Usage = 2,
    BadCase = 3,
    File = 4,
    Numerical = 5,
}

#[derive(Parser)]
#[command(name = "dea-mpi", version, about = "Fibre-level ballistic impact solver (modified digital element approach)", long_about = None,
    after_help = "Examples:\n  dea-mpi run                       # built-in default case, results in ./out\n  mpirun -np 1 dea-mpi run case.json --out results/\n  dea-mpi check case.json           # validate and print the resolved case\n  dea-mpi bench --json              # node-step cost, one JSON object\n\nExit codes: 0 done (a perforation is a result), 2 usage, 3 bad case, 4 mesh/file error, 5 numerical failure.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case (no file: the built-in default case).
    #[command(after_help = "Examples:\n  dea-mpi run\n  dea-mpi run cases/single_fibre.json --out out/fibre")]
    Run {
        /// case file (JSON, SI units)
        case: Option<PathBuf>,
        /// output directory for results.h5 and summary.json
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Validate a case and print it resolved, without running.
    #[command(after_help = "Example:\n  dea-mpi check cases/default.json")]
    Check {
        /// case file (JSON, SI units)
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
        /// nodes per fibre segment (graph vertex); default: 64, fewer when that would give a
        /// rank less than 32 segments to balance with
        #[arg(long)]
        segment_nodes: Option<u32>,
        /// METIS algorithm
        #[arg(long, value_enum, default_value_t = PartitionMethod::Kway)]
        method: PartitionMethod,
        /// print one JSON object on stdout
        #[arg(long)]
        json: bool,
    },
    /// Benchmark the step on a dense 19-fibre yarn (>= 300,000 nodes by default).
    #[command(after_help = "Examples:\n  dea-mpi bench\n  dea-mpi bench --json --nodes 300000 --steps 2000")]
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

fn load(path: Option<&PathBuf>) -> Result<Case, ExitCode> {
    match path {
        None => Ok(default_case()),
        Some(path) if !path.exists() => Err(fail(Exit::File, format!("{}: no such file", path.display()))),
        Some(path) => load_case(path).map_err(|e| fail(Exit::BadCase, e)),
    }
}

/// Refuses more than one rank until the domain decomposition exists, on every rank alike.
fn single_rank(world: &comm::World) -> Result<(), ExitCode> {
    if world.size() > 1 {
        return Err(fail(Exit::Usage, format!("started on {} ranks, but this build runs one rank per job (domain decomposition is not implemented yet); use mpirun -np 1", world.size())));
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { case } => {
            let case = match load(Some(&case)) {
                Ok(case) => case,
                Err(code) => return code,
            };
            let domain = match setup::build_domain(&case) {
                Ok(domain) => domain,
                Err(e) => return fail(Exit::Numerical, e),
            };
            let projectile = case.projectile().expect("validated case");
            let resolved = serde_json::json!({
                "case": case,
                "resolved": {
                    "material": domain.material,
                    "sections": domain.sections,
                    "projectile": { "shape": projectile.shape, "mass_kg": projectile.mass, "speed_m_s": projectile.speed },
                    "nodes": domain.nodes.n_owned,
                    "time_step_s": domain.time_step,
                    "steps": (case.run.end_time_s / domain.time_step).ceil(),
                    "skin_m": domain.pairs.skin,
                }
            });
            println!("{}", serde_json::to_string_pretty(&resolved).expect("case serialises"));
            ExitCode::SUCCESS
        }
        Command::Run { case, out } => {
            let case = match load(case.as_ref()) {
                Ok(case) => case,
                Err(code) => return code,
            };
            let world = match comm::World::initialize() {
                Ok(world) => world,
                Err(e) => return fail(Exit::Usage, e),
            };
            if let Err(code) = single_rank(&world) {
                return code;
            }
            let domain = match setup::build_domain(&case) {
                Ok(domain) => domain,
                Err(e) => return fail(Exit::Numerical, e),
            };
            let json = serde_json::to_string(&case).expect("case serialises");
            eprintln!("dea-mpi: case {:?}, {} nodes, dt = {:.3e} s, end {:.3e} s, {} rank(s)", case.name, domain.nodes.n_owned, domain.time_step, case.run.end_time_s, world.size());
            match run::run(domain, &case.name, &json, case.run.end_time_s, case.run.history_interval_steps, case.run.stop_on_perforation, &out, world.size()) {
                Ok(summary) => {
                    println!(
                        "{}: {} steps, {:.3e} s simulated in {:.1} s; perforated: {}; residual velocity {:.2} m/s; peak force {:.1} N; broken elements {}; {:.3e} node-steps/s/core; results in {}",
                        summary.case,
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
                    ExitCode::SUCCESS
                }
                Err(e @ run::RunError::Numerical(_)) => fail(Exit::Numerical, e),
                Err(e @ run::RunError::Output(_)) => fail(Exit::File, e),
            }
        }
        Command::Partition { case, ranks, segment_nodes, method, json } => {
            if ranks == 0 {
                return fail(Exit::Usage, "--ranks must be at least 1");
            }
            let case = match load(case.as_ref()) {
                Ok(case) => case,
                Err(code) => return code,
            };
            let domain = match setup::build_domain(&case) {
                Ok(domain) => domain,
                Err(e) => return fail(Exit::Numerical, e),
            };
            let method = match method {
                PartitionMethod::Kway => dea_partition::Method::KWay,
                PartitionMethod::Recursive => dea_partition::Method::RecursiveBisection,
            };
            let segment_nodes = segment_nodes.unwrap_or_else(|| dea_partition::default_segment_nodes(domain.nodes.len(), ranks));
            let partition = match dea_partition::partition(&domain.nodes, &domain.pairs, ranks, segment_nodes, method) {
                Ok(partition) => partition,
                Err(e) => return fail(Exit::Usage, e),
            };
            let report = dea_partition::quality(&domain.nodes, &domain.pairs, &partition);
            if json {
                println!("{}", serde_json::to_string(&report).expect("report serialises"));
            } else {
                println!("{}: {} nodes on {} ranks; edge cut {}, load imbalance {:.3}, ghost fraction {:.3}, halo {} bytes/step", case.name, domain.nodes.len(), ranks, report.edge_cut, report.load_imbalance, report.ghost_fraction, report.halo_bytes_per_step);
                println!("{:>6} {:>12} {:>12} {:>14} {:>16}", "rank", "owned", "ghosts", "work", "halo bytes/step");
                for r in &report.ranks {
                    println!("{:>6} {:>12} {:>12} {:>14} {:>16}", r.rank, r.owned_nodes, r.ghost_nodes, r.work, r.halo_bytes_per_step);
                }
            }
            ExitCode::SUCCESS
        }
        Command::Bench { json, nodes, steps } => {
            let world = match comm::World::initialize() {
                Ok(world) => world,
                Err(e) => return fail(Exit::Usage, e),
            };
            if let Err(code) = single_rank(&world) {
                return code;
            }
            match bench::bench(nodes, steps, world.size()) {
                Ok(report) if json => {
                    println!("{}", serde_json::to_string(&report).expect("report serialises"));
                    ExitCode::SUCCESS
                }
                Ok(report) => {
                    println!("{}", serde_json::to_string_pretty(&report).expect("report serialises"));
                    ExitCode::SUCCESS
                }
                Err(e) => fail(Exit::Numerical, e),
            }
        }
    }
}
