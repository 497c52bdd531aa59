//! `dea-mpi bench`: the cost of each stage of the step on a dense yarn.

use std::process::ExitCode;

use dea_mpi::comm::mpi::MpiComm;

use super::{fail, fail_all, setup_exit, Exit};

pub const ABOUT: &str = "Benchmark the step on a dense 19-fibre yarn on the ranks of the job";
pub const LONG_ABOUT: &str =
    "Benchmark the step on a dense 19-fibre yarn (>= 300,000 nodes by default), on the ranks of
the job: ns per node-step, per contact pair, per node of rods and of a rebuild, and the time of each stage.";
pub const EXAMPLES: &str =
    "Examples:\n  dea-mpi bench\n  mpirun -np 2 dea-mpi bench --json --nodes 300000 --steps 2000";

#[derive(clap::Args)]
pub struct Args {
    /// print one JSON object on stdout
    #[arg(long)]
    pub json: bool,
    /// minimum number of nodes
    #[arg(long, default_value_t = 300_000, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub nodes: usize,
    /// steps to time
    #[arg(long, default_value_t = 2000, value_parser = clap::value_parser!(u64).range(1..))]
    pub steps: u64,
}

pub fn main(Args { json, nodes, steps }: Args) -> ExitCode {
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
