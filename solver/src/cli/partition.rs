//! `dea-mpi partition`: the METIS partition of a case over N ranks and its quality.

use std::path::PathBuf;
use std::process::ExitCode;

use dea_mpi::setup;

use super::{fail, in_file, load, method_of, setup_exit, Exit, PartitionMethod};

pub const ABOUT: &str = "Partition a case over N ranks with METIS and report its quality, without running";
pub const LONG_ABOUT: &str = "Partition a case over N ranks with METIS and report its quality (owned and ghost nodes,
work, halo bytes per rank, edge cut, the imbalance of work and of stored nodes, the largest
rank's memory), without running. METIS balances two constraints, work and stored nodes.";
pub const EXAMPLES: &str = "Examples:\n  dea-mpi partition cases/seed_6_1_single_fibre.json --ranks 4\n  dea-mpi partition case.json --ranks 64 --json --method recursive";

#[derive(clap::Args)]
pub struct Args {
    /// case file (JSON, SI units); none: the built-in default case
    pub case: Option<PathBuf>,
    /// number of ranks
    #[arg(long)]
    pub ranks: usize,
    /// positions along the fibres per yarn segment (graph vertex); default: 64, fewer
    /// when that would give a rank less than 32 segments to balance with
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub segment_nodes: Option<u32>,
    /// METIS algorithm
    #[arg(long, value_enum, default_value_t = PartitionMethod::Kway)]
    pub method: PartitionMethod,
    /// print one JSON object on stdout
    #[arg(long)]
    pub json: bool,
}

pub fn main(Args { case, ranks, segment_nodes, method, json }: Args) -> ExitCode {
    if ranks == 0 {
        return fail(Exit::Usage, "--ranks must be at least 1");
    }
    if segment_nodes == Some(0) {
        return fail(Exit::Usage, "--segment-nodes must be at least 1");
    }
    let case_path = case.clone();
    let case = match load(case.as_ref()) {
        Ok(case) => case,
        Err((code, message)) => return fail(code, message),
    };
    let problem = match setup::problem(&case) {
        Ok(problem) => problem,
        Err(e) => return fail(setup_exit(&e), in_file(&e, case_path.as_ref())),
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
            "{}: {} nodes in {} yarn segments on {} ranks; edge cut {}, predicted load imbalance {:.3} (work), memory imbalance {:.3} (owned and ghost nodes), ghost fraction {:.3}, halo {} bytes/step",
            case.name, nodes, report.segments, ranks, report.edge_cut, report.load_imbalance, report.memory_imbalance, report.ghost_fraction, report.halo_bytes_per_step
        );
        println!(
            "largest rank: {} nodes stored, about {:.2} GB at {} bytes per node (setup::BYTES_PER_NODE, measured)",
            report.largest_stored_nodes,
            report.largest_stored_nodes as f64 * setup::BYTES_PER_NODE / 1e9,
            setup::BYTES_PER_NODE
        );
        println!("{:>6} {:>12} {:>12} {:>14} {:>16}", "rank", "owned", "ghosts", "work", "halo bytes/step");
        for r in &report.ranks {
            println!(
                "{:>6} {:>12} {:>12} {:>14.0} {:>16}",
                r.rank, r.owned_nodes, r.ghost_nodes, r.work, r.halo_bytes_per_step
            );
        }
    }
    ExitCode::SUCCESS
}
