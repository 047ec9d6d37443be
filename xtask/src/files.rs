//! Result files of the commands: the format of every `--out` (its extension or `--format`), and
//! calibrations read in any format (`parallax_interop` detects which from the content).

use std::path::{Path, PathBuf};

use anyhow::ensure;
use parallax_interop::{Calibration, Format};
use serde::Serialize;

/// The format of `--out path` (and `--format`).
pub fn output_format(path: &Path, explicit: Option<&str>) -> anyhow::Result<Format> {
    Ok(Format::for_output(path, explicit)?)
}

/// Every file a result written at `path` in `format` may occupy, for the overwrite check: the
/// path and, for ROS, the `<stem>_left` / `<stem>_right` pair a stereo result is written as.
pub fn written_paths(path: &Path, format: Format) -> Vec<PathBuf> {
    let mut v = vec![path.to_path_buf()];
    if format == Format::Ros {
        v.extend(parallax_interop::ros_pair_paths(path));
    }
    v
}

/// Writes a result (`parallax_composition::io::write_result`); returns the files written.
pub fn write_result<T: Serialize>(
    path: &Path,
    format: Format,
    native: &T,
    calibration: Option<&Calibration>,
) -> anyhow::Result<Vec<PathBuf>> {
    Ok(parallax_composition::io::write_result(path, format, native, calibration)?)
}

/// The calibration in `paths` (one file, or two read together), in any format.
pub fn read_calibration(paths: &[PathBuf]) -> anyhow::Result<Calibration> {
    ensure!(!paths.is_empty(), "--calib: give a calibration file");
    let (c, formats) = parallax_interop::read(paths)?;
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let formats: Vec<&str> = formats.iter().map(|f| f.name()).collect();
    println!("calibration: {} ({}, {})", names.join(" + "), formats.join(" + "), c.kind());
    Ok(c)
}
