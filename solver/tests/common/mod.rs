//! What several test files share.

use std::path::{Path, PathBuf};

/// A test's scratch directory under the system's temporary directory, removed when the
/// test ends well and kept when it fails (a panic unwinding through the drop), so that a
/// failure can be looked at and a passing run leaves nothing behind.
pub struct Scratch(PathBuf);

impl Scratch {
    /// `<temp>/<name>`, emptied if an earlier run left it; created when `create` is set.
    pub fn new(name: String, create: bool) -> Self {
        let dir = std::env::temp_dir().join(name);
        let _ = std::fs::remove_dir_all(&dir);
        if create {
            std::fs::create_dir_all(&dir).unwrap();
        }
        Self(dir)
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}
