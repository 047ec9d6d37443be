//! Result files of the commands: the format of every `--out` (its extension or `--format`), and
//! calibrations read in any format (`parallax_interop` detects which from the content).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail, ensure};
use parallax_camera_model::DisparityMap;
use parallax_interop::{Calibration, Format};
use serde::Serialize;

/// The format of `--out path` (and `--format`).
pub fn output_format(path: &Path, explicit: Option<&str>) -> anyhow::Result<Format> {
    Ok(Format::for_output(path, explicit)?)
}

/// Writes a result: `native` as RON or JSON, or `calibration` in a calibration format (OpenCV,
/// ROS, Kalibr); a result that is no calibration is refused in those. Returns the files written.
pub fn write_result<T: Serialize>(
    path: &Path,
    format: Format,
    native: &T,
    calibration: Option<&Calibration>,
) -> anyhow::Result<Vec<PathBuf>> {
    let files = match (format, calibration) {
        (Format::Ron | Format::Json, _) => vec![(path.to_path_buf(), parallax_interop::native_string(native, format)?)],
        (_, Some(c)) => parallax_interop::render(c, format, path)?,
        (_, None) => bail!("{}: this result is written as ron or json, not {}", path.display(), format.name()),
    };
    for (p, text) in &files {
        parallax_composition::io::write_atomic(p, text.as_bytes())?;
    }
    Ok(files.into_iter().map(|f| f.0).collect())
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

/// `disparity --calib`: the rectified rig's `Q` turns the map into points (rectified left frame,
/// the calibration's length unit); writes `points.ply` and prints the depth figures. The file
/// must hold the rectification the pair was rectified with (`rectify`'s output), and a native
/// `rectify` output must be for this map's size.
pub fn disparity_depth(calib: &[PathBuf], map: &DisparityMap, out: &Path) -> anyhow::Result<()> {
    let stereo = read_calibration(calib)?.into_stereo(&calib[0].display().to_string())?;
    let rect = stereo.rectification.with_context(|| {
        format!(
            "{}: no rectification (R1 R2 P1 P2 Q): give the file `rectify` wrote for this pair \
             (rectification.ron / .json / .yml in its --out folder)",
            calib[0].display()
        )
    })?;
    let (cx, cy) = (rect.p1.rows[0][2], rect.p1.rows[1][2]);
    let (w, h) = (map.width() as f64, map.height() as f64);
    ensure!(
        (0.0..w).contains(&cx) && (0.0..h).contains(&cy),
        "the rectified principal point ({cx:.1}, {cy:.1}) lies outside the {w}x{h} disparity map: this \
         rectification is not the one of these images"
    );
    let cloud = parallax_composition::point_cloud(map, rect.q, None)?;
    let mut depths: Vec<f64> = cloud.points.iter().map(|p| p.z).collect();
    ensure!(!depths.is_empty(), "no valid disparity gives a point in front of the rig");
    depths.sort_by(f64::total_cmp);
    let ply = out.join("points.ply");
    parallax_triangulation::write_ply(&ply, &cloud, parallax_triangulation::PlyFormat::BinaryLittleEndian)?;
    println!("wrote {}", ply.display());
    println!("points: {}", cloud.len());
    println!("depth_min: {:.6}", depths[0]);
    println!("depth_median: {:.6}", depths[depths.len() / 2]);
    println!("depth_max: {:.6}", depths[depths.len() - 1]);
    Ok(())
}
