//! Result files of the commands: the format of every `--out` (its extension or `--format`), and
//! calibrations read in any format (`parallax_interop` detects which from the content).

use std::path::{Path, PathBuf};

use anyhow::ensure;
use parallax_camera_model::TargetDescription;
use parallax_interop::{Calibration, Format};

/// The format of `--out path` (and `--format`).
pub fn output_format(path: &Path, explicit: Option<&str>) -> anyhow::Result<Format> {
    Ok(Format::for_output(path, explicit)?)
}

/// A baseline at or above this, in a file whose lengths are metres, is warned of: stereo rigs
/// are a few centimetres to a metre or two wide; a rig in millimetres is 20–500 wide.
pub const BASELINE_WARN_METRES: f64 = 10.0;

/// The name of the first format in `formats` whose lengths are metres (ROS, Kalibr).
fn formats_in_metres(formats: &[Format]) -> Option<&'static str> {
    formats.iter().find(|f| in_metres(**f)).map(|f| f.name())
}

/// Whether `format` gives lengths in metres whatever the calibration's unit: ROS `camera_info`
/// (the baseline in `P`) and Kalibr camchains (`T_cn_cnm1`). A result is written in its own unit,
/// the target's, so these need a target measured in metres.
pub fn in_metres(format: Format) -> bool {
    matches!(format, Format::Ros | Format::Kalibr)
}

/// The distance between a target's first two points (a chessboard's or ChArUco board's square,
/// a circle grid's spacing, an AprilGrid tag's side), in the unit of its lengths.
fn target_pitch(target: &TargetDescription) -> Option<f64> {
    Some((target.point(1)? - target.point(0)?).length())
}

/// A stereo result for a file in metres ([`in_metres`]) from a target whose points are a metre or
/// more apart: its lengths are in millimetres or centimetres, and the file would carry a
/// baseline 1000 or 100 times the rig's. Refused before any work, naming the fix.
pub fn refuse_unit_for_metres(format: Format, target: &TargetDescription) -> anyhow::Result<()> {
    let Some(pitch) = target_pitch(target).filter(|_| in_metres(format)) else { return Ok(()) };
    ensure!(
        pitch < 1.0,
        "--format {} gives lengths in metres (the stereo baseline), and the result's lengths are in the target's \
         unit, whose points are {pitch} apart here: a {pitch} m square is no calibration target. Give the target \
         in metres (--square 0.025 for 25 mm squares; a target file's or description's lengths likewise)",
        format.name()
    );
    Ok(())
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

/// The calibration in `paths` (one file, or two read together), in any format. A command that
/// holds the calibrated images gives their `image_size`: a file without one takes theirs, and the
/// command says so.
pub fn read_calibration(paths: &[PathBuf], image_size: Option<(u32, u32)>) -> anyhow::Result<Calibration> {
    ensure!(!paths.is_empty(), "--calib: give a calibration file");
    let (c, formats, sized) = match image_size {
        Some(size) => parallax_interop::read_with_image_size(paths, size)?,
        None => {
            let (c, f) = parallax_interop::read(paths).map_err(|e| {
                let hint = e.to_string().contains("no image size");
                let e = anyhow::Error::from(e);
                if hint {
                    e.context("give the calibrated images (measure: --left / --right) to take their size")
                } else {
                    e
                }
            })?;
            (c, f, false)
        }
    };
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let names_of: Vec<&str> = formats.iter().map(|f| f.name()).collect();
    println!("calibration: {} ({}, {})", names.join(" + "), names_of.join(" + "), c.kind());
    if let (true, Some((w, h))) = (sized, image_size) {
        println!("  image size: none in the file; the images' {w}x{h}");
    }
    // ROS and Kalibr files are in metres: a baseline of 10 or more is a file written in
    // millimetres or centimetres (the writers warn of it; so does the reader)
    if let (Some(f), Calibration::Stereo(st)) = (formats_in_metres(&formats), &c)
        && st.rig.baseline() >= BASELINE_WARN_METRES
    {
        eprintln!(
            "warning: {} files are in metres, and this rig's baseline is {:.4}: a rig {:.4} m wide is unlikely; if \
             the file was written in millimetres or centimetres, every length computed with it is in that unit",
            f,
            st.rig.baseline(),
            st.rig.baseline()
        );
    }
    Ok(c)
}
