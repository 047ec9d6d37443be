//! Calibration view sets: seeded `camera_from_board` poses with the board visible.

use glam::{DQuat, DVec2, DVec3};
use parallax_camera_model::{Camera, CameraModel, Chessboard, Isometry3, StereoRig};
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::error::{non_negative, positive};
use crate::noise::{rng, uniform};

/// How [`calibration_poses`] and [`stereo_calibration_poses`] spread the views.
///
/// Lengths are in the board's unit (the unit of [`Chessboard::square_size`]); the defaults suit
/// a 9x6 board of 25 mm squares seen by a ~60° camera (distances in mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewSetConfig {
    /// Number of views (at least 1).
    pub views: usize,
    /// Largest tilt of the board plane away from fronto-parallel, degrees (tilts are drawn
    /// uniformly in `[0, max_tilt_deg]` about a random in-plane axis). Default 50.
    pub max_tilt_deg: f64,
    /// Smallest camera-to-board-centre distance, board units.
    pub min_distance: f64,
    /// Largest camera-to-board-centre distance, board units.
    pub max_distance: f64,
    /// When true every third view (index 2, 5, 8, …) shows the board only partly: between 30 %
    /// and 90 % of its inner corners inside the image. Default false (whole board visible).
    pub allow_partial: bool,
    /// Largest rotation of the board about its own normal, degrees. Default 20.
    pub max_roll_deg: f64,
    /// Part of the board that must be visible around the inner corners, in squares: 1.0 is the
    /// outer row of squares, the default 1.5 adds half a square of white margin.
    pub border_squares: f64,
    /// Distance every visible point must keep from the image border, pixels. Default 4.
    pub margin_px: f64,
    /// Seed of the generator.
    pub seed: u64,
}

impl Default for ViewSetConfig {
    fn default() -> Self {
        Self {
            views: 12,
            max_tilt_deg: 50.0,
            min_distance: 300.0,
            max_distance: 600.0,
            allow_partial: false,
            max_roll_deg: 20.0,
            border_squares: 1.5,
            margin_px: 4.0,
            seed: 1,
        }
    }
}

impl ViewSetConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        self.check(80.0)
    }

    /// Checks every field, the tilt against `tilt_limit` degrees (the wide-angle view sets
    /// share these fields with a tighter limit).
    pub(crate) fn check(&self, tilt_limit: f64) -> Result<(), SyntheticError> {
        if self.views == 0 {
            return Err(SyntheticError::config("views", "must be at least 1"));
        }
        non_negative("max_tilt_deg", self.max_tilt_deg)?;
        if self.max_tilt_deg >= tilt_limit {
            return Err(SyntheticError::config(
                "max_tilt_deg",
                format!("must be below {tilt_limit}, got {}", self.max_tilt_deg),
            ));
        }
        non_negative("max_roll_deg", self.max_roll_deg)?;
        positive("min_distance", self.min_distance)?;
        positive("max_distance", self.max_distance)?;
        if self.min_distance > self.max_distance {
            return Err(SyntheticError::config(
                "min_distance",
                format!("{} is larger than max_distance {}", self.min_distance, self.max_distance),
            ));
        }
        non_negative("border_squares", self.border_squares)?;
        non_negative("margin_px", self.margin_px)?;
        Ok(())
    }
}

/// The image positions of a board's inner corners (OpenCV's order) seen through
/// `camera_from_board`, projected with `camera-model` (distortion included).
///
/// Any [`CameraModel`] (pinhole or fisheye). Errors on an invalid camera or board, a non-finite
/// pose, or a corner outside the camera's valid region (behind a pinhole camera).
pub fn project_corners<C: CameraModel>(
    camera: &C,
    board: &Chessboard,
    camera_from_board: &Isometry3,
) -> Result<Vec<DVec2>, SyntheticError> {
    camera.validate().map_err(SyntheticError::model("camera"))?;
    board.validate().map_err(SyntheticError::model("board"))?;
    if !camera_from_board.is_finite() {
        return Err(SyntheticError::config("camera_from_board", "pose is not finite"));
    }
    board
        .object_points()
        .into_iter()
        .map(|p| camera.project_from(camera_from_board, p).map_err(SyntheticError::model("corner projection")))
        .collect()
}

/// `camera_from_board` poses for a mono calibration session: varied tilt (up to
/// `max_tilt_deg`), distance and position across the frame; every inner corner and the border
/// (`border_squares`) inside the image by `margin_px` (unless `allow_partial` marks the view
/// partial). Seeded and reproducible.
pub fn calibration_poses(
    camera: &Camera,
    board: &Chessboard,
    cfg: &ViewSetConfig,
) -> Result<Vec<Isometry3>, SyntheticError> {
    camera.validate().map_err(SyntheticError::model("camera"))?;
    generate(&[(*camera, Isometry3::IDENTITY)], board, cfg)
}

/// Left `camera_from_board` poses for a stereo session, with the board (and its border) fully
/// visible in BOTH cameras of the rig (the right pose is `rig.right_from_left * pose`).
pub fn stereo_calibration_poses(
    rig: &StereoRig,
    board: &Chessboard,
    cfg: &ViewSetConfig,
) -> Result<Vec<Isometry3>, SyntheticError> {
    rig.left.validate().map_err(SyntheticError::model("rig.left"))?;
    rig.right.validate().map_err(SyntheticError::model("rig.right"))?;
    if !rig.right_from_left.is_finite() {
        return Err(SyntheticError::config("rig.right_from_left", "pose is not finite"));
    }
    generate(&[(rig.left, Isometry3::IDENTITY), (rig.right, rig.right_from_left)], board, cfg)
}

const ATTEMPTS_PER_VIEW: usize = 4000;

/// Shared generator: each camera is `(camera, camera_from_reference)`; poses are
/// `reference_from_board`.
fn generate(
    cameras: &[(Camera, Isometry3)],
    board: &Chessboard,
    cfg: &ViewSetConfig,
) -> Result<Vec<Isometry3>, SyntheticError> {
    board.validate().map_err(SyntheticError::model("board"))?;
    cfg.validate()?;
    let mut rng = rng(cfg.seed);
    let reference = &cameras[0].0;
    let s = board.square_size;
    let centre = DVec3::new((board.cols - 1) as f64 * s * 0.5, (board.rows - 1) as f64 * s * 0.5, 0.0);
    let samples = border_samples(board, cfg.border_squares);
    let corners = board.object_points();
    let mut poses = Vec::with_capacity(cfg.views);
    for view in 0..cfg.views {
        let partial = cfg.allow_partial && view % 3 == 2;
        let mut found = None;
        for attempt in 0..ATTEMPTS_PER_VIEW {
            // The spread of the board centre over the frame shrinks as attempts fail, so a
            // large board still finds a central position.
            let spread = if partial { 1.1 } else { 1.0 - 0.9 * attempt as f64 / ATTEMPTS_PER_VIEW as f64 };
            let tilt = uniform(&mut rng, 0.0, cfg.max_tilt_deg).to_radians();
            let axis_angle = uniform(&mut rng, 0.0, std::f64::consts::TAU);
            let roll = uniform(&mut rng, -cfg.max_roll_deg, cfg.max_roll_deg).to_radians();
            let distance = uniform(&mut rng, cfg.min_distance, cfg.max_distance);
            let target = DVec2::new(
                (0.5 + 0.5 * spread * uniform(&mut rng, -1.0, 1.0)) * (reference.width as f64 - 1.0),
                (0.5 + 0.5 * spread * uniform(&mut rng, -1.0, 1.0)) * (reference.height as f64 - 1.0),
            );
            let axis = DVec3::new(axis_angle.cos(), axis_angle.sin(), 0.0);
            let rotation = DQuat::from_axis_angle(axis, tilt) * DQuat::from_rotation_z(roll);
            let Ok(ray) = reference.unproject(target) else { continue };
            let centre_in_camera = ray.normalize() * distance;
            let reference_from_board = Isometry3::from_quat_translation(rotation, centre_in_camera - rotation * centre);
            if accept(cameras, &reference_from_board, &samples, &corners, cfg.margin_px, partial) {
                found = Some(reference_from_board);
                break;
            }
        }
        match found {
            Some(p) => poses.push(p),
            None => {
                return Err(SyntheticError::Infeasible {
                    what: format!("view {view} of {}", cfg.views),
                    attempts: ATTEMPTS_PER_VIEW,
                    hint: format!(
                        "the board ({}x{} inner corners, square {}) does not fit the image(s) at distances {}..{} \
                         and tilts up to {} deg; check the units or increase the distances",
                        board.cols, board.rows, board.square_size, cfg.min_distance, cfg.max_distance, cfg.max_tilt_deg
                    ),
                });
            }
        }
    }
    Ok(poses)
}

/// Points along the border rectangle `border` squares outside the inner corners.
pub(crate) fn border_samples(board: &Chessboard, border: f64) -> Vec<DVec3> {
    let s = board.square_size;
    let (x0, y0) = (-border * s, -border * s);
    let (x1, y1) = ((board.cols - 1) as f64 * s + border * s, (board.rows - 1) as f64 * s + border * s);
    let n = 16;
    let mut out = Vec::with_capacity(4 * n);
    for k in 0..n {
        let t = k as f64 / n as f64;
        out.push(DVec3::new(x0 + t * (x1 - x0), y0, 0.0));
        out.push(DVec3::new(x1, y0 + t * (y1 - y0), 0.0));
        out.push(DVec3::new(x1 - t * (x1 - x0), y1, 0.0));
        out.push(DVec3::new(x0, y1 - t * (y1 - y0), 0.0));
    }
    out
}

/// True when a point projects inside the image by `margin` pixels, through an invertible part
/// of the lens model (unprojecting the pixel gives back the same ray).
pub(crate) fn visible(camera: &Camera, camera_from_board: &Isometry3, p: DVec3, margin: f64) -> bool {
    let pc = camera_from_board.transform_point(p);
    if pc.z <= 0.0 {
        return false;
    }
    let Ok(px) = camera.project(pc) else { return false };
    let inside = px.x >= margin
        && px.y >= margin
        && px.x <= camera.width as f64 - 1.0 - margin
        && px.y <= camera.height as f64 - 1.0 - margin;
    if !inside {
        return false;
    }
    match camera.unproject(px) {
        Ok(ray) => (ray.truncate() - DVec2::new(pc.x / pc.z, pc.y / pc.z)).length() < 1e-6,
        Err(_) => false,
    }
}

fn accept(
    cameras: &[(Camera, Isometry3)],
    reference_from_board: &Isometry3,
    border: &[DVec3],
    corners: &[DVec3],
    margin: f64,
    partial: bool,
) -> bool {
    let mut partial_ok = false;
    for (camera, camera_from_reference) in cameras {
        let camera_from_board = *camera_from_reference * *reference_from_board;
        // The camera must see the front of the board (board z points away from the viewer)
        // at less than 75 degrees from its normal.
        let to_camera = -camera_from_board.translation;
        let normal = camera_from_board.transform_vector(DVec3::Z);
        let cos = -normal.dot(to_camera) / to_camera.length();
        if cos.is_nan() || cos <= 15f64.to_radians().sin() {
            return false;
        }
        if partial {
            let inside = corners.iter().filter(|&&p| visible(camera, &camera_from_board, p, margin)).count();
            let fraction = inside as f64 / corners.len() as f64;
            // Every corner must still be in front of the camera (so it has a projection).
            if corners.iter().any(|&p| camera_from_board.transform_point(p).z <= 0.0) {
                return false;
            }
            if (0.3..0.9).contains(&fraction) {
                partial_ok = true;
            }
        } else if !corners.iter().chain(border).all(|&p| visible(camera, &camera_from_board, p, margin)) {
            return false;
        }
    }
    !partial || partial_ok
}
