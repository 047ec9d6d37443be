//! Readers for robot and camera pose lists in the common conventions.
//!
//! Parsed by hand: the formats are a few numbers each, and a YAML or XML crate would be the
//! largest dependency of the crate.

use glam::{DQuat, DVec3};
use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::{HandEyeError, Result};

/// How the rotation of a 6-number pose line `[tx, ty, tz, a, b, c]` is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum RotationFormat {
    /// Axis × angle in radians (OpenCV's `rvec`, ViSP's `θu`).
    #[default]
    AxisAngle,
    /// Roll, pitch, yaw in degrees, ZYX order: `R = Rz(yaw) · Ry(pitch) · Rx(roll)`
    /// (the thesis's robot file).
    RollPitchYawDeg,
}

/// A pose from translation and rotation in the given format.
pub fn pose_from_six(v: [f64; 6], format: RotationFormat) -> Isometry3 {
    let t = DVec3::new(v[0], v[1], v[2]);
    match format {
        RotationFormat::AxisAngle => Isometry3::from_rvec_tvec(DVec3::new(v[3], v[4], v[5]), t),
        RotationFormat::RollPitchYawDeg => {
            let q = DQuat::from_rotation_z(v[5].to_radians())
                * DQuat::from_rotation_y(v[4].to_radians())
                * DQuat::from_rotation_x(v[3].to_radians());
            Isometry3::from_quat_translation(q, t)
        }
    }
}

/// Largest translation component a pose file may hold (in any unit: 1e12 m is beyond the solar
/// system, 1e12 mm beyond the Moon): larger values are a wrong column or a corrupt file, and
/// would overflow the solvers' squares.
pub const MAX_TRANSLATION: f64 = 1e12;

fn parse_err(what: &str, message: String) -> HandEyeError {
    HandEyeError::Parse { what: what.to_string(), message }
}

/// Parses a text pose list: one pose per line, six numbers separated by spaces, tabs, commas or
/// semicolons; empty lines and lines starting with `#` or `//` are skipped. `what` names the
/// input in errors (e.g. the file name).
pub fn parse_pose_lines(text: &str, format: RotationFormat, what: &str) -> Result<Vec<Isometry3>> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("//") {
            continue;
        }
        let nums: std::result::Result<Vec<f64>, _> = line
            .split(|c: char| c.is_whitespace() || c == ',' || c == ';')
            .filter(|s| !s.is_empty())
            .map(str::parse::<f64>)
            .collect();
        let nums = nums.map_err(|e| parse_err(what, format!("line {}: {e} in {line:?}", n + 1)))?;
        if nums.len() != 6 {
            return Err(parse_err(what, format!("line {}: expected 6 numbers, found {}", n + 1, nums.len())));
        }
        if nums.iter().any(|v| !v.is_finite()) {
            return Err(parse_err(what, format!("line {}: non-finite number", n + 1)));
        }
        let bad = |m: String| parse_err(what, format!("line {}: {m}", n + 1));
        match format {
            RotationFormat::AxisAngle => {
                // A huge component (1e308) overflows the length to infinity: report the
                // component instead (and never build a NaN rotation from it).
                let length = (nums[3] * nums[3] + nums[4] * nums[4] + nums[5] * nums[5]).sqrt();
                let angle =
                    if length.is_finite() { length } else { nums[3..].iter().fold(0.0f64, |m, v| m.max(v.abs())) };
                if angle > std::f64::consts::TAU {
                    let shown = if angle < 1e6 { format!("{angle:.3}") } else { format!("{angle:.3e}") };
                    return Err(bad(format!(
                        "rotation vector of length {shown} > 2π is not an axis-angle in radians — are these \
                         roll-pitch-yaw angles in degrees (RotationFormat::RollPitchYawDeg, --robot-format rpy-deg)?"
                    )));
                }
            }
            RotationFormat::RollPitchYawDeg => {
                if let Some(v) = nums[3..].iter().find(|v| v.abs() > 360.0) {
                    return Err(bad(format!(
                        "roll-pitch-yaw angle {v} is beyond ±360°: not an angle in degrees (a rotation in \
                         radians would be axis-angle, --robot-format axis-angle)"
                    )));
                }
            }
        }
        if let Some(t) = nums[..3].iter().find(|v| v.abs() > MAX_TRANSLATION) {
            return Err(bad(format!(
                "translation component {t:e} is beyond ±{MAX_TRANSLATION:e}: not a length (a wrong column or unit?)"
            )));
        }
        out.push(pose_from_six(std::array::from_fn(|i| nums[i]), format));
    }
    if out.is_empty() {
        return Err(parse_err(what, "no pose found".into()));
    }
    Ok(out)
}

/// Parses ViSP's pose file: a 6x1 `vpPoseVector` YAML
///
/// ```text
/// rows: 6
/// cols: 1
/// data:
///   - [0.335091]
///   ...
/// ```
///
/// holding `[tx, ty, tz, θux, θuy, θuz]` (axis × angle radians), also inline
/// (`data: [a, b, c, d, e, f]`), or a 4x4 `vpHomogeneousMatrix` (see
/// [`crate::visp::parse_pose_yaml`]).
pub fn parse_visp_pose(text: &str, what: &str) -> Result<Isometry3> {
    crate::visp::parse_pose_yaml(text, what)
}

/// Format of one pose file (see [`parse_pose_file`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PoseFileFormat {
    /// RON list of [`Isometry3`].
    Ron,
    /// ViSP YAML, one pose per file (6x1 pose vector or 4x4 matrix).
    Visp,
    /// Text lines `tx ty tz rx ry rz`, axis-angle radians.
    AxisAngle,
    /// Text lines `x y z roll pitch yaw`, degrees, `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    RollPitchYawDeg,
}

impl PoseFileFormat {
    /// The format a file name suggests: `.ron` RON, `.yaml`/`.yml` ViSP, anything else
    /// axis-angle text lines.
    pub fn from_path(path: &std::path::Path) -> Self {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("ron") => PoseFileFormat::Ron,
            Some("yaml" | "yml") => PoseFileFormat::Visp,
            _ => PoseFileFormat::AxisAngle,
        }
    }
}

/// The poses of one file's text in the given format (`what` names it in errors). Reading a
/// glob of per-station files is the caller's: call this per file, in station order.
pub fn parse_pose_file(text: &str, format: PoseFileFormat, what: &str) -> Result<Vec<Isometry3>> {
    match format {
        PoseFileFormat::Ron => parse_pose_ron(text, what),
        PoseFileFormat::Visp => Ok(vec![parse_visp_pose(text, what)?]),
        PoseFileFormat::AxisAngle => parse_pose_lines(text, RotationFormat::AxisAngle, what),
        PoseFileFormat::RollPitchYawDeg => parse_pose_lines(text, RotationFormat::RollPitchYawDeg, what),
    }
}

/// Parses a RON list of poses (`[(rotation: (x, y, z, w), translation: (x, y, z)), …]`, the
/// serde form of [`Isometry3`]).
pub fn parse_pose_ron(text: &str, what: &str) -> Result<Vec<Isometry3>> {
    let poses: Vec<Isometry3> = ron::from_str(text).map_err(|e| parse_err(what, e.to_string()))?;
    if poses.is_empty() {
        return Err(parse_err(what, "empty pose list".into()));
    }
    for (k, p) in poses.iter().enumerate() {
        if !p.translation.is_finite() || p.translation.abs().max_element() > MAX_TRANSLATION {
            return Err(parse_err(
                what,
                format!("pose {k}: translation {:?} is not finite or beyond ±{MAX_TRANSLATION:e}", p.translation),
            ));
        }
        if !p.rotation().is_finite() || (p.rotation().length() - 1.0).abs() > 1e-6 {
            return Err(parse_err(what, format!("pose {k}: rotation is not a finite unit quaternion")));
        }
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visp_pose_file_is_read() {
        // The first pose of ViSP's Franka eye-in-hand data set.
        let text = "rows: 6\ncols: 1\ndata: \n  - [0.335091]\n  - [-0.0321497]\n  - [0.30857]\n  - [-3.01226]\n  - [0.0236777]\n  - [-0.451343]\n";
        let p = parse_visp_pose(text, "pose").unwrap();
        assert!((p.translation - DVec3::new(0.335091, -0.0321497, 0.30857)).length() < 1e-15);
        assert!((p.rvec() - DVec3::new(-3.01226, 0.0236777, -0.451343)).length() < 1e-12);
        let inline = parse_visp_pose("data: [0.1, 0.2, 0.3, 0.0, 0.0, 0.5]\n", "inline").unwrap();
        assert!((inline.angle() - 0.5).abs() < 1e-15);
        let short = parse_visp_pose("rows: 6\ncols: 1\ndata:\n  - [1]\n  - [2]\nfoo: 3\n", "short.yaml").unwrap_err();
        assert!(short.to_string().contains("short.yaml") && short.to_string().contains("2 numbers"), "{short}");
    }

    #[test]
    fn rpy_lines_follow_zyx_order() {
        let text = "# x y z roll pitch yaw\n100, 200, 300, 10, 20, 30\n\n1 2 3 0 0 90\n";
        let poses = parse_pose_lines(text, RotationFormat::RollPitchYawDeg, "robot.txt").unwrap();
        assert_eq!(poses.len(), 2);
        // Independent composition with axis-angle matrices: Rz(30°) Ry(20°) Rx(10°).
        let expect = glam::DMat3::from_axis_angle(DVec3::Z, 30f64.to_radians())
            * glam::DMat3::from_axis_angle(DVec3::Y, 20f64.to_radians())
            * glam::DMat3::from_axis_angle(DVec3::X, 10f64.to_radians());
        let m = poses[0].rotation_matrix();
        assert!((m - expect).abs().to_cols_array().iter().all(|v| *v < 1e-14));
        assert_eq!(poses[0].translation, DVec3::new(100.0, 200.0, 300.0));
        // yaw 90°: x axis → y axis.
        assert!((poses[1].transform_vector(DVec3::X) - DVec3::Y).length() < 1e-15);
        let bad = parse_pose_lines("1 2 3 4 5\n", RotationFormat::AxisAngle, "robot.txt").unwrap_err();
        assert!(bad.to_string().contains("line 1") && bad.to_string().contains("robot.txt"), "{bad}");
        assert!(parse_pose_lines("1 2 x 4 5 6\n", RotationFormat::AxisAngle, "r").is_err());
        assert!(parse_pose_lines("# nothing\n", RotationFormat::AxisAngle, "r").is_err());
        // Roll-pitch-yaw degrees given as axis-angle: refused with the hint.
        let rpy = parse_pose_lines("0.1 0.2 0.3 180 0 90\n", RotationFormat::AxisAngle, "robot.txt").unwrap_err();
        assert!(rpy.to_string().contains("roll-pitch-yaw") && rpy.to_string().contains("201.246"), "{rpy}");
        // parse_pose_file dispatches by format.
        let f = parse_pose_file("1 2 3 0 0 90\n", PoseFileFormat::RollPitchYawDeg, "r").unwrap();
        assert!((f[0].transform_vector(DVec3::X) - DVec3::Y).length() < 1e-15);
        assert_eq!(PoseFileFormat::from_path(std::path::Path::new("a/cPo_1.YAML")), PoseFileFormat::Visp);
    }

    #[test]
    fn huge_but_finite_values_are_refused_at_parse_time() {
        // Axis-angle: |rvec|² overflows; the component is named, no NaN rotation is built.
        let e = parse_pose_lines("0 0 0 1e308 0 0\n", RotationFormat::AxisAngle, "r.txt").unwrap_err().to_string();
        assert!(e.contains("r.txt") && e.contains("line 1") && e.contains("1.000e308"), "{e}");
        // Roll-pitch-yaw beyond ±360°, a translation beyond ±1e12.
        let e = parse_pose_lines("0 0 0 1e308 0 0\n", RotationFormat::RollPitchYawDeg, "r.txt").unwrap_err();
        assert!(e.to_string().contains("beyond ±360°"), "{e}");
        assert!(parse_pose_lines("0 0 0 0 0 360\n", RotationFormat::RollPitchYawDeg, "r").is_ok());
        let e = parse_pose_lines("1e300 0 0 0 0 0\n", RotationFormat::AxisAngle, "r").unwrap_err().to_string();
        assert!(e.contains("translation") && e.contains("1e300"), "{e}");
        // ViSP 6x1: θu longer than 2π, and a 1e308 component.
        for text in ["data: [0, 0, 0, 1e308, 0, 0]\n", "data: [0, 0, 0, 4, 4, 4]\n"] {
            let e = parse_visp_pose(text, "p.yaml").unwrap_err().to_string();
            assert!(e.contains("p.yaml") && e.contains("longer than 2π"), "{text}: {e}");
        }
        let e = parse_visp_pose("data: [1e308, 0, 0, 0, 0, 0]\n", "p.yaml").unwrap_err().to_string();
        assert!(e.contains("translation"), "{e}");
        // RON lists: a translation beyond the bound is named as the translation.
        let e = parse_pose_ron("[(rotation: (0.0, 0.0, 0.0, 1.0), translation: (1e300, 0.0, 0.0))]", "p.ron")
            .unwrap_err()
            .to_string();
        assert!(e.contains("translation") && !e.contains("quaternion"), "{e}");
    }

    #[test]
    fn ron_round_trip() {
        let poses =
            vec![Isometry3::from_rvec_tvec(DVec3::new(0.1, 0.2, 0.3), DVec3::new(1.0, 2.0, 3.0)), Isometry3::IDENTITY];
        let text = ron::to_string(&poses).unwrap();
        assert_eq!(parse_pose_ron(&text, "p.ron").unwrap(), poses);
        assert!(parse_pose_ron("[]", "p.ron").is_err());
        assert!(parse_pose_ron("[(rotation: (0.0, 0.0, 0.0, 2.0), translation: (0.0, 0.0, 0.0))]", "p.ron").is_err());
    }
}
