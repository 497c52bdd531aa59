//! `dea-mpi`: the digital-element ballistic impact solver. The library holds the
//! communication layer, the distributed step, set-up, the run loop and the benchmark; the
//! binary (`main.rs`) is the command line.

pub mod bench;
pub mod campaign;
pub mod checkpoint;
pub mod comm;
pub mod cost;
pub mod deflection;
pub mod deformable;
pub mod diagnostics;
pub mod distributed;
pub mod fabric;
pub mod output_dir;
pub mod pool;
pub mod progress;
pub mod provenance;
pub mod run;
pub mod settle;
pub mod setup;
pub mod snapshot;
pub mod step;
