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

/// An OpenCV stereo calibration (`stereoCalibrate`'s YAML) of a 640x480 rig: both cameras f = 600,
/// centred, distortion `k1` alone, no rotation, baseline 60 along x.
#[allow(dead_code)] // (each test binary uses its own part of this module)
pub fn opencv_stereo_yaml(k1: &str) -> String {
    let m = "600., 0., 320., 0., 600., 240., 0., 0., 1.";
    format!(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nM1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {m} ]\nD1: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {k1}, 0., 0., 0., 0. ]\nM2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {m} ]\nD2: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {k1}, 0., 0., 0., 0. ]\nR: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\nT: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ -60., 0., 0. ]\n"
    )
}
