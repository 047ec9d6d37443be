//! Helpers shared by the integration tests that declare `mod common;`.

use std::path::{Path, PathBuf};

/// A fresh temporary folder for one test, removed when the test passes (kept when it fails,
/// to look at).
pub struct Temp(PathBuf);

impl Temp {
    /// `xtask-{prefix}-{name}-{pid}` in the system's temporary folder, emptied first.
    pub fn new(prefix: &str, name: &str) -> Temp {
        let d = std::env::temp_dir().join(format!("xtask-{prefix}-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Temp(d)
    }
}

impl std::ops::Deref for Temp {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<Path> for Temp {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}
