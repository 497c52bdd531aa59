//! `dea-mpi compare`: two results files and their field snapshots, bit for bit.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use super::{fail, Exit};

pub const ABOUT: &str = "Compare two runs' results and field snapshots bit for bit";
pub const LONG_ABOUT: &str = "Compare two results files dataset by dataset, bit for bit (the partition group excepted),
and the field snapshots beside them node by node; exit 0 when identical, 1 when they differ.
A run's output directory stands for its results.h5. Two relaxed cells (`dea-mpi fabric`'s
cell.h5) compare the same way; anything else (a checkpoint's manifest, a field part, one
file of each kind) is refused with exit 4.";
pub const EXAMPLES: &str =
    "Examples:\n  dea-mpi compare out/1-rank/results.h5 out/4-ranks/results.h5\n  dea-mpi compare out/1-rank out/4-ranks";

#[derive(clap::Args)]
pub struct Args {
    /// a results file (results.h5, or a relaxed cell.h5), or a run's output directory
    pub first: PathBuf,
    /// the other, of the same kind
    pub second: PathBuf,
}

/// The results file a path names: itself, or a run directory's results.h5 (HDF5 alone would
/// answer a directory with "unable to open file ... Is a directory").
fn results_file(path: PathBuf) -> Result<PathBuf, String> {
    if !path.is_dir() {
        return Ok(path);
    }
    let results = path.join("results.h5");
    if results.is_file() {
        Ok(results)
    } else {
        Err(format!(
            "{}: a directory without results.h5: give a run's output directory or a results file",
            path.display()
        ))
    }
}

pub fn main(Args { first, second }: Args) -> ExitCode {
    let (first, second) = match (results_file(first), results_file(second)) {
        (Ok(first), Ok(second)) => (first, second),
        (Err(e), _) | (_, Err(e)) => return fail(Exit::File, e),
    };
    // every error names the file it met (a results file, or a field part beside it)
    match dea_io::results::compare_results(&first, &second).and_then(|mut differences| {
        differences.extend(dea_io::snapshot::compare_snapshots(
            first.parent().unwrap_or(Path::new(".")),
            second.parent().unwrap_or(Path::new(".")),
        )?);
        Ok(differences)
    }) {
        Ok(differences) if differences.is_empty() => {
            println!(
                "identical: every dataset of {} and {}, and every field snapshot beside them, has the same bits",
                first.display(),
                second.display()
            );
            ExitCode::SUCCESS
        }
        Ok(differences) => {
            for d in &differences {
                println!("{d}");
            }
            ExitCode::from(1)
        }
        Err(e) => fail(Exit::File, e),
    }
}
