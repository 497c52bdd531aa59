//! Case files (JSON, SI units, validated with field paths), presets, and HDF5 results.

pub mod campaign;
pub mod case;
pub mod cell;
pub mod checkpoint;
pub mod results;
pub mod snapshot;

pub use case::{load_case, parse_case, Case, CaseError};
