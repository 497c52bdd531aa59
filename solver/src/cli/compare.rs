//! `dea-mpi compare`: two results files and their field snapshots, bit for bit.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use super::{fail, Exit};

pub const ABOUT: &str = "Compare two runs' results and field snapshots bit for bit";
pub const LONG_ABOUT: &str = "Compare two results files dataset by dataset, bit for bit (the partition group excepted),
and the field snapshots beside them node by node; exit 0 when identical, 1 when they differ.
Two relaxed cells (`dea-mpi fabric`'s cell.h5) compare the same way; anything else (a
checkpoint's manifest, a field part, one file of each kind) is refused with exit 4.";
pub const EXAMPLES: &str = "Example:\n  dea-mpi compare out/1-rank/results.h5 out/4-ranks/results.h5";

#[derive(clap::Args)]
pub struct Args {
    pub first: PathBuf,
    pub second: PathBuf,
}

pub fn main(Args { first, second }: Args) -> ExitCode {
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
