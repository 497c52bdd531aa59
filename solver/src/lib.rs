//! `dea-mpi`: the digital-element ballistic impact solver. The library holds the
//! communication layer, the distributed step, set-up, the run loop and the benchmark; the
//! binary (`main.rs`) is the command line.

pub mod bench;
pub mod campaign;
pub mod comm;
pub mod deformable;
pub mod distributed;
pub mod fabric;
pub mod progress;
pub mod run;
pub mod setup;
pub mod step;
