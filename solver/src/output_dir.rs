//! An output directory belongs to one run (issue 34): a fresh run refuses a directory that
//! holds another run's outputs unless asked to clear it (`--overwrite`), and every run holds
//! a lock on its directory while it writes, so two runs cannot mix their files.

use std::fs::File;
use std::path::{Path, PathBuf};

/// What a run writes into its output directory (docs/output.md), the lock aside.
pub const RUN_OUTPUTS: [&str; 11] = [
    "results.h5",
    "provenance.json",
    "README.txt",
    "history.csv",
    "summary.json",
    "progress.json",
    "fields.xdmf",
    "broken-elements.xdmf",
    "projectile.xdmf",
    "fields",
    "checkpoint",
];

/// The lock file a run holds in its output directory.
pub const LOCK_FILE: &str = ".dea-mpi.lock";

/// How a run means to use its output directory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Intent {
    /// a new run: the directory must hold no other run's outputs, or `overwrite` clears them
    Fresh {
        /// clear another run's outputs first
        overwrite: bool,
    },
    /// a restart, which continues the outputs already there
    Continue,
}

/// Why a directory cannot be had.
#[derive(Debug, thiserror::Error)]
pub enum ClaimError {
    /// another run holds the lock
    #[error("{}: another run is writing into this directory (it holds {LOCK_FILE}); wait for it, or choose another --out", .0.display())]
    Busy(PathBuf),
    /// a fresh run found another run's outputs
    #[error("{}: holds the outputs of an earlier run ({}); choose another --out, or add --overwrite to delete them first", .directory.display(), .found.join(", "))]
    Occupied {
        /// the directory
        directory: PathBuf,
        /// the outputs found in it
        found: Vec<String>,
    },
    /// the file system refused
    #[error("{}: {message}", .path.display())]
    Io {
        /// the path it refused
        path: PathBuf,
        /// what it said
        message: String,
    },
}

/// A run's hold on its output directory: the lock is released when this is dropped or the
/// process ends, however it ends.
#[derive(Debug)]
pub struct OutputLock {
    _file: File,
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> ClaimError + '_ {
    move |e| ClaimError::Io { path: path.to_path_buf(), message: e.to_string() }
}

/// Creates `directory` if need be, locks it, and checks (or, asked to overwrite, clears) the
/// outputs an earlier run left in it. Rank 0 calls this once for the whole job.
pub fn claim(directory: &Path, intent: Intent) -> Result<OutputLock, ClaimError> {
    std::fs::create_dir_all(directory).map_err(io_error(directory))?;
    let lock_path = directory.join(LOCK_FILE);
    let file =
        File::options().create(true).truncate(false).write(true).open(&lock_path).map_err(io_error(&lock_path))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => return Err(ClaimError::Busy(directory.to_path_buf())),
        Err(std::fs::TryLockError::Error(e)) => return Err(io_error(&lock_path)(e)),
    }
    if let Intent::Fresh { overwrite } = intent {
        let found: Vec<&str> = RUN_OUTPUTS.iter().copied().filter(|name| directory.join(name).exists()).collect();
        if !found.is_empty() && !overwrite {
            return Err(ClaimError::Occupied {
                directory: directory.to_path_buf(),
                found: found.iter().map(|s| s.to_string()).collect(),
            });
        }
        for name in found {
            let path = directory.join(name);
            let removed = if path.is_dir() { std::fs::remove_dir_all(&path) } else { std::fs::remove_file(&path) };
            removed.map_err(io_error(&path))?;
        }
    }
    Ok(OutputLock { _file: file })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("dea-output-dir-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn a_fresh_run_refuses_another_runs_outputs_unless_it_overwrites_them() {
        let dir = scratch("fresh");
        drop(claim(&dir, Intent::Fresh { overwrite: false }).expect("a new directory"));
        drop(claim(&dir, Intent::Fresh { overwrite: false }).expect("an empty directory"));
        std::fs::write(dir.join("summary.json"), "{}").unwrap();
        std::fs::create_dir_all(dir.join("fields")).unwrap();
        std::fs::write(dir.join("fields/ranks-00003-part-00002.h5"), "stale").unwrap();
        std::fs::write(dir.join("notes.txt"), "the user's").unwrap();
        let refused = claim(&dir, Intent::Fresh { overwrite: false }).unwrap_err();
        assert!(
            matches!(&refused, ClaimError::Occupied { found, .. } if found == &["summary.json", "fields"]),
            "{refused}"
        );
        assert!(refused.to_string().contains("--overwrite"), "{refused}");
        drop(claim(&dir, Intent::Continue).expect("a restart continues what is there"));
        assert!(dir.join("summary.json").exists());
        drop(claim(&dir, Intent::Fresh { overwrite: true }).expect("overwrite clears"));
        assert!(!dir.join("summary.json").exists() && !dir.join("fields").exists());
        assert!(dir.join("notes.txt").exists(), "files that are not a run's outputs stay");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_directory_is_locked_while_a_run_holds_it() {
        let dir = scratch("lock");
        let held = claim(&dir, Intent::Fresh { overwrite: false }).unwrap();
        let refused = claim(&dir, Intent::Continue).unwrap_err();
        assert!(matches!(refused, ClaimError::Busy(_)), "{refused}");
        drop(held);
        drop(claim(&dir, Intent::Continue).expect("free again once the run ends"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
