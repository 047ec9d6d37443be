//! Calibration view sets for wide-angle cameras: the board is placed anywhere in the (possibly
//! more than 180°) field of view, facing the camera, so the periphery of a fisheye lens is
//! covered. Works for any [`CameraModel`]; rendering goes through [`crate::render_chessboard`],
//! which is generic too.

use glam::{DQuat, DVec2, DVec3};
use parallax_camera_model::{CameraModel, Chessboard, Isometry3};
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::error::positive;
use crate::noise::{rng, uniform};
use crate::views::ViewSetConfig;

/// How [`wide_angle_calibration_poses`] spreads the views. Lengths are in the board's unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct WideViewSetConfig {
    /// Number of views (at least 1).
    pub views: usize,
    /// Largest tilt of the board away from facing the camera (its normal along the line of
    /// sight), degrees, below 75. Default 45.
    pub max_tilt_deg: f64,
    /// Smallest camera-to-board-centre distance. Default 200.
    pub min_distance: f64,
    /// Largest camera-to-board-centre distance. Default 450.
    pub max_distance: f64,
    /// Largest rotation of the board about its normal, degrees. Default 180 (any roll).
    pub max_roll_deg: f64,
    /// Part of the board that must be visible around the inner corners, in squares. Default 1.5.
    pub border_squares: f64,
    /// Distance every visible point keeps from the image border, pixels. Default 4.
    pub margin_px: f64,
    /// Largest angle between the optical axis and any visible point (corners and border),
    /// degrees; the default 360 leaves only the lens's own limit. Set it below 90 to keep every
    /// point in front of the image plane (for tools that need `z > 0`, like OpenCV's `fisheye`).
    pub max_field_angle_deg: f64,
    /// Seed of the generator.
    pub seed: u64,
}

impl Default for WideViewSetConfig {
    fn default() -> Self {
        Self {
            views: 20,
            max_tilt_deg: 45.0,
            min_distance: 200.0,
            max_distance: 450.0,
            max_roll_deg: 180.0,
            border_squares: 1.5,
            margin_px: 4.0,
            max_field_angle_deg: 360.0,
            seed: 1,
        }
    }
}

impl WideViewSetConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        // the fields shared with the pinhole view sets, under a tighter tilt limit
        let shared = ViewSetConfig {
            views: self.views,
            max_tilt_deg: self.max_tilt_deg,
            min_distance: self.min_distance,
            max_distance: self.max_distance,
            allow_partial: false,
            max_roll_deg: self.max_roll_deg,
            border_squares: self.border_squares,
            margin_px: self.margin_px,
            seed: self.seed,
        };
        shared.check(75.0)?;
        positive("max_field_angle_deg", self.max_field_angle_deg)?;
        Ok(())
    }
}

const ATTEMPTS_PER_VIEW: usize = 4000;

/// `camera_from_board` poses for a mono session with a wide-angle camera: the board centre is
/// seen at a pixel drawn uniformly over the image (so views reach the periphery, beyond 90°
/// from the axis when the lens images it), at a distance in `[min_distance, max_distance]`,
/// facing the camera up to `max_tilt_deg`; every inner corner and the border
/// (`border_squares`) project inside the image by `margin_px`, inside the model's valid region,
/// and are seen from the front at less than 75° from the board normal. Seeded.
pub fn wide_angle_calibration_poses<C: CameraModel>(
    camera: &C,
    board: &Chessboard,
    cfg: &WideViewSetConfig,
) -> Result<Vec<Isometry3>, SyntheticError> {
    camera.validate().map_err(SyntheticError::model("camera"))?;
    generate(&[(camera, Isometry3::IDENTITY)], board, cfg)
}

/// Left `camera_from_board` poses for a stereo session of two wide-angle cameras
/// (`right_from_left` the rig's pose): the board fully visible in both.
pub fn wide_angle_stereo_calibration_poses<C: CameraModel>(
    left: &C,
    right: &C,
    right_from_left: &Isometry3,
    board: &Chessboard,
    cfg: &WideViewSetConfig,
) -> Result<Vec<Isometry3>, SyntheticError> {
    left.validate().map_err(SyntheticError::model("left camera"))?;
    right.validate().map_err(SyntheticError::model("right camera"))?;
    if !right_from_left.is_finite() {
        return Err(SyntheticError::config("right_from_left", "pose is not finite"));
    }
    generate(&[(left, Isometry3::IDENTITY), (right, *right_from_left)], board, cfg)
}

fn generate<C: CameraModel>(
    cameras: &[(&C, Isometry3)],
    board: &Chessboard,
    cfg: &WideViewSetConfig,
) -> Result<Vec<Isometry3>, SyntheticError> {
    board.validate().map_err(SyntheticError::model("board"))?;
    cfg.validate()?;
    let mut rng = rng(cfg.seed);
    let reference = cameras[0].0;
    let s = board.square_size;
    let centre = DVec3::new((board.cols - 1) as f64 * s * 0.5, (board.rows - 1) as f64 * s * 0.5, 0.0);
    let samples = crate::views::border_samples(board, cfg.border_squares);
    let mut points = board.object_points();
    points.extend(samples);
    let cos_max = if cfg.max_field_angle_deg >= 180.0 { -2.0 } else { cfg.max_field_angle_deg.to_radians().cos() };
    let mut poses = Vec::with_capacity(cfg.views);
    for view in 0..cfg.views {
        let mut found = None;
        for _ in 0..ATTEMPTS_PER_VIEW {
            let target = DVec2::new(
                uniform(&mut rng, 0.0, reference.width() as f64 - 1.0),
                uniform(&mut rng, 0.0, reference.height() as f64 - 1.0),
            );
            let tilt = uniform(&mut rng, 0.0, cfg.max_tilt_deg).to_radians();
            let tilt_axis = uniform(&mut rng, 0.0, std::f64::consts::TAU);
            let roll = uniform(&mut rng, -cfg.max_roll_deg, cfg.max_roll_deg).to_radians();
            let distance = uniform(&mut rng, cfg.min_distance, cfg.max_distance);
            let Ok(ray) = reference.unproject_ray(target) else { continue };
            let ray = ray.normalize();
            // Board z (its normal, pointing away from the viewer) along the line of sight, then
            // tilted about an in-plane axis and rolled about the normal.
            let facing = DQuat::from_rotation_arc(DVec3::Z, ray);
            let axis = DVec3::new(tilt_axis.cos(), tilt_axis.sin(), 0.0);
            let rotation = facing * DQuat::from_axis_angle(axis, tilt) * DQuat::from_rotation_z(roll);
            let pose = Isometry3::from_quat_translation(rotation, ray * distance - rotation * centre);
            if cameras.iter().all(|(c, c_from_ref)| visible(*c, &(*c_from_ref * pose), &points, cfg.margin_px, cos_max))
            {
                found = Some(pose);
                break;
            }
        }
        match found {
            Some(p) => poses.push(p),
            None => {
                return Err(SyntheticError::Infeasible {
                    what: format!("wide-angle view {view} of {}", cfg.views),
                    attempts: ATTEMPTS_PER_VIEW,
                    hint: format!(
                        "the board ({}x{} inner corners, square {}) does not fit the image(s) at distances {}..{}; \
                         check the units or increase the distances",
                        board.cols, board.rows, board.square_size, cfg.min_distance, cfg.max_distance
                    ),
                });
            }
        }
    }
    Ok(poses)
}

/// Every point seen from the front of the board (< 75° from its normal), within the field angle
/// (`cos θ > cos_max`), projected inside the image by `margin`, through the valid region, and
/// unprojecting back to its own direction.
fn visible<C: CameraModel>(
    camera: &C,
    camera_from_board: &Isometry3,
    points: &[DVec3],
    margin: f64,
    cos_max: f64,
) -> bool {
    let normal = camera_from_board.transform_vector(DVec3::Z);
    let (w, h) = (camera.width() as f64, camera.height() as f64);
    points.iter().all(|&p| {
        let pc = camera_from_board.transform_point(p);
        let cos = normal.dot(pc) / pc.length();
        if cos.is_nan() || cos <= 15f64.to_radians().sin() || pc.z <= cos_max * pc.length() {
            return false;
        }
        let Ok(px) = camera.project(pc) else { return false };
        if !(px.x >= margin && px.y >= margin && px.x <= w - 1.0 - margin && px.y <= h - 1.0 - margin) {
            return false;
        }
        camera.unproject_ray(px).is_ok_and(|r| (r.normalize() - pc.normalize()).length() < 1e-9)
    })
}

/// A closed, textured box room (axis-aligned in its own frame): every ray from a point inside
/// hits a wall, so cameras of any field of view see texture everywhere. Each of the six walls
/// carries its own smooth value-noise texture (two octaves, feature size `texture_scale`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TexturedRoom {
    /// The corner with the smallest coordinates.
    pub min: DVec3,
    /// The corner with the largest coordinates.
    pub max: DVec3,
    /// Size of the texture's coarse features, in the room's length unit.
    pub texture_scale: f64,
    /// Seed of the textures.
    pub seed: u64,
}

impl TexturedRoom {
    /// Checks that the room has positive extent and a positive texture scale.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        if !(self.min.is_finite() && self.max.is_finite()) || (self.max - self.min).min_element() <= 0.0 {
            return Err(SyntheticError::config(
                "room",
                format!("min {} must be below max {} on every axis", self.min, self.max),
            ));
        }
        positive("texture_scale", self.texture_scale)
    }

    /// The first wall point along `direction` from `origin` (inside the room), with the wall's
    /// grey level; `None` when the origin is outside or the direction is zero.
    pub fn hit(&self, origin: DVec3, direction: DVec3) -> Option<(DVec3, f64)> {
        if !(origin.cmpgt(self.min).all() && origin.cmplt(self.max).all()) || direction.length_squared() == 0.0 {
            return None;
        }
        let (mut t, mut axis) = (f64::INFINITY, 0);
        for a in 0..3 {
            let d = direction[a];
            let ta = if d > 0.0 {
                (self.max[a] - origin[a]) / d
            } else if d < 0.0 {
                (self.min[a] - origin[a]) / d
            } else {
                f64::INFINITY
            };
            if ta < t {
                t = ta;
                axis = a;
            }
        }
        let p = origin + direction * t;
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let wall = 2 * axis as u64 + u64::from(direction[axis] > 0.0);
        let seed = crate::stereo::splitmix(self.seed ^ wall);
        let (x, y) = (p[u] / self.texture_scale, p[v] / self.texture_scale);
        let n = 0.65 * crate::stereo::value_noise(x, y, seed)
            + 0.35 * crate::stereo::value_noise(4.0 * x, 4.0 * y, seed ^ 1);
        Some((p, 30.0 + 195.0 * n))
    }
}

/// Renders `room` through any camera model placed at `camera_from_room` (inside the room):
/// `samples_per_axis²` point samples per pixel, each unprojected through the model and cast to
/// the walls (area-averaged grey level, rounded to 8 bits). Pixels whose samples have no ray
/// (outside a fisheye's image circle) are 0. Rows in parallel.
pub fn render_room<C: CameraModel + Sync>(
    camera: &C,
    camera_from_room: &Isometry3,
    room: &TexturedRoom,
    samples_per_axis: u32,
) -> Result<image::GrayImage, SyntheticError> {
    use rayon::prelude::*;
    camera.validate().map_err(SyntheticError::model("camera"))?;
    room.validate()?;
    if !(1..=16).contains(&samples_per_axis) {
        return Err(SyntheticError::config("samples_per_axis", format!("must be in 1..=16, got {samples_per_axis}")));
    }
    let room_from_camera = camera_from_room.inverse();
    let origin = room_from_camera.translation;
    if room.hit(origin, DVec3::Z).is_none() {
        return Err(SyntheticError::config("camera_from_room", "the camera is not inside the room"));
    }
    let (w, h) = (camera.width() as usize, camera.height() as usize);
    let n = samples_per_axis as usize;
    let mut data = vec![0u8; w * h];
    data.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
        for (u, out) in row.iter_mut().enumerate() {
            let (mut sum, mut count) = (0.0, 0usize);
            for j in 0..n {
                for i in 0..n {
                    let px = DVec2::new(
                        u as f64 - 0.5 + (i as f64 + 0.5) / n as f64,
                        v as f64 - 0.5 + (j as f64 + 0.5) / n as f64,
                    );
                    if let Ok(ray) = camera.unproject_ray(px)
                        && let Some((_, g)) = room.hit(origin, room_from_camera.transform_vector(ray))
                    {
                        sum += g;
                        count += 1;
                    }
                }
            }
            *out = if count == n * n { (sum / count as f64).round().clamp(0.0, 255.0) as u8 } else { 0 };
        }
    });
    Ok(image::GrayImage::from_raw(w as u32, h as u32, data).expect("buffer of width x height"))
}
