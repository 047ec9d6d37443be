//! Hand-eye inputs on files: robot and camera pose files (one file holding a list, or a glob of
//! one-pose files such as ViSP's), the camera intrinsics from any calibration file or a ViSP
//! XML, and camera poses measured from target images ([`camera_poses_from_images`]).

use std::path::{Path, PathBuf};

use parallax_camera_model::{Camera, Isometry3, TargetDescription};
use parallax_hand_eye::Method;
use parallax_hand_eye::io::{PoseFileFormat, parse_pose_file};
use parallax_hand_eye::visp::VispCamera;
use parallax_interop::{Calibration, Format, Side};

use crate::{PipelineError, Result};

/// Reads the poses of one file in `format` (`None`: from the extension, see
/// [`PoseFileFormat::from_path`]).
pub fn read_pose_file(path: &Path, format: Option<PoseFileFormat>) -> Result<Vec<Isometry3>> {
    let text = parallax_interop::read_text_file(path).map_err(|source| PipelineError::Io {
        what: "reading",
        path: path.to_path_buf(),
        source,
    })?;
    let format = format.unwrap_or_else(|| PoseFileFormat::from_path(path));
    Ok(parse_pose_file(&text, format, &path.display().to_string())?)
}

/// Reads poses from one file, or from a glob of files concatenated in natural order (`img2`
/// before `img10`).
pub fn read_poses(spec: &str, format: Option<PoseFileFormat>) -> Result<Vec<Isometry3>> {
    let paths = if Path::new(spec).is_file() { vec![PathBuf::from(spec)] } else { crate::io::expand_glob(spec)? };
    let mut poses = Vec::new();
    for p in &paths {
        poses.extend(read_pose_file(p, format)?);
    }
    Ok(poses)
}

/// Parses a list of hand-eye methods: `all`, or names separated by commas (`tsai,park`).
pub fn parse_methods(spec: &str) -> Result<Vec<Method>> {
    if spec.trim().eq_ignore_ascii_case("all") {
        return Ok(Method::ALL.to_vec());
    }
    spec.split(',').map(|s| Ok(s.parse::<Method>()?)).collect()
}

/// Camera intrinsics read from a file.
#[derive(Debug, Clone)]
pub enum Intrinsics {
    /// A calibration in any format `parallax_interop` reads, and the chosen camera of it.
    Calibration {
        /// The calibration read.
        calibration: Box<Calibration>,
        /// The formats it was read in.
        formats: Vec<Format>,
        /// The chosen camera.
        camera: Camera,
    },
    /// A ViSP XML camera (its size comes from each image).
    Visp(VispCamera),
}

impl Intrinsics {
    /// The camera of an image of `width x height` pixels: a calibration's camera only at its own
    /// size (an image of another size put the board pose — and the hand-eye rotations — off,
    /// reported as a rotation-format mistake).
    pub fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        match self {
            Self::Calibration { camera, .. } if (camera.width, camera.height) != (width, height) => {
                Err(PipelineError::Input(format!(
                    "the image is {width}x{height} but the intrinsics are of a {}x{} camera: give the calibration \
                     of this resolution (or images of the calibrated size)",
                    camera.width, camera.height
                )))
            }
            Self::Calibration { camera, .. } => Ok(*camera),
            Self::Visp(v) => Ok(v.camera(width, height)?),
        }
    }
}

/// Reads camera intrinsics: any calibration file (mono or stereo, OpenCV YAML/XML, ROS,
/// Kalibr, a RON `Camera`; `side` chooses the camera of a stereo calibration) or a ViSP XML
/// (`perspectiveProjWithDistortion` when present, its `kud` as OpenCV's k1).
pub fn read_intrinsics(path: &Path, side: Side) -> Result<Intrinsics> {
    let what = path.display().to_string();
    let text = parallax_interop::read_text_file(path).map_err(|source| PipelineError::Io {
        what: "reading",
        path: path.to_path_buf(),
        source,
    })?;
    if text.trim_start().starts_with('<') && !parallax_interop::opencv::is_opencv_xml(&text) {
        return Ok(Intrinsics::Visp(parallax_hand_eye::visp::parse_camera_xml(&text, &what, None, None)?));
    }
    let (calibration, formats) = parallax_interop::read(&[path])?;
    let camera = calibration.camera(side, &what)?;
    Ok(Intrinsics::Calibration { calibration: Box::new(calibration), formats, camera })
}

/// One station of [`camera_poses_from_images`]: the image, and the number of target points
/// found and the pose's RMS reprojection error in pixels (`None`: target not found, station
/// skipped).
#[derive(Debug, Clone, PartialEq)]
pub struct StationImage<'a> {
    /// The image file.
    pub path: &'a Path,
    /// Points found and RMS reprojection error of the pose, pixels.
    pub found: Option<(usize, f64)>,
}

/// Camera poses `camera_from_target` measured in one image per robot pose: `target` found
/// ([`crate::detect_target`]) and its planar pose ([`crate::target_pose`]) with the
/// intrinsics. Images where the target is not found are dropped together with their robot pose
/// (`on_image` hears of each image). Returns the kept robot and camera poses; refuses a
/// target found in no image, naming it and the accepted target forms.
pub fn camera_poses_from_images(
    images: &[PathBuf],
    robot: Vec<Isometry3>,
    target: &TargetDescription,
    intrinsics: &Intrinsics,
    mut on_image: impl FnMut(&StationImage<'_>),
) -> Result<(Vec<Isometry3>, Vec<Isometry3>)> {
    if images.len() != robot.len() {
        return Err(PipelineError::Input(format!("{} images for {} robot poses", images.len(), robot.len())));
    }
    let (mut kept_robot, mut camera) = (Vec::new(), Vec::new());
    for (path, g) in images.iter().zip(robot) {
        let img = crate::io::load_gray(path)?;
        let name = path.display();
        let cam =
            intrinsics.camera(img.width(), img.height()).map_err(|e| PipelineError::Input(format!("{name}: {e}")))?;
        let context = |what: &str, e: PipelineError| PipelineError::Input(format!("{what} in {name}: {e}"));
        let found = crate::detect_target(&img, target).map_err(|e| context("target", e))?;
        let mut report = StationImage { path, found: None };
        if let Some(obs) = found {
            let (pose, rms) = crate::target_pose(&cam, target, &obs).map_err(|e| context("target pose", e))?;
            report.found = Some((obs.ids().len(), rms));
            kept_robot.push(g);
            camera.push(pose);
        }
        on_image(&report);
    }
    if camera.is_empty() {
        return Err(crate::session::target_absent(target, images.len()));
    }
    Ok((kept_robot, camera))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn pose_globs_are_read_in_natural_order_and_methods_parse() {
        let dir = crate::io::test_dir("glob");
        // One axis-angle pose per file: tx = the file number.
        for k in [1, 2, 10] {
            std::fs::write(dir.join(format!("pose{k}.txt")), format!("{k} 0 0 0 0 0.1\n")).unwrap();
        }
        let poses = read_poses(&dir.join("pose*.txt").to_string_lossy(), None).unwrap();
        let x: Vec<f64> = poses.iter().map(|p| p.translation.x).collect();
        assert_eq!(x, [1.0, 2.0, 10.0]);
        assert!((poses[0].rvec() - DVec3::new(0.0, 0.0, 0.1)).length() < 1e-12);
        let one = read_poses(&dir.join("pose2.txt").to_string_lossy(), Some(PoseFileFormat::AxisAngle)).unwrap();
        assert_eq!(one.len(), 1);
        assert!(read_poses(&dir.join("none*.txt").to_string_lossy(), None).is_err());
        assert_eq!(parse_methods("all").unwrap(), Method::ALL.to_vec());
        assert_eq!(parse_methods("tsai, park").unwrap(), [Method::Tsai, Method::Park]);
        assert!(parse_methods("tsai,nope").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
