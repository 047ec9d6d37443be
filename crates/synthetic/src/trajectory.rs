//! Robot trajectories with a known hand-eye transform.

use glam::{DQuat, DVec3};
use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::error::{non_negative, positive};
use crate::noise::{bounded_rotation, perturb_pose, rng, uniform, uniform_rotation};

/// Generator of a hand-eye data set, following the synthetic protocol of
/// `../shared/reference/peer/handeye.py`.
///
/// Lengths are in one unit for the whole configuration (metres by default; the built-in scene
/// uses millimetres and scales every length field).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrajectoryConfig {
    /// Number of robot stations (at least 3 for a well-posed AX = XB). Default 10.
    pub stations: usize,
    /// True: camera on the gripper (solve `gripper_from_camera`); false: camera fixed in the
    /// robot base, board held by the gripper (solve `base_from_camera`). Default true.
    pub eye_in_hand: bool,
    /// Smallest depth of the board point `board_centre` in the camera frame. Default 0.4.
    pub min_distance: f64,
    /// Largest depth of `board_centre` in the camera frame. Default 0.7.
    pub max_distance: f64,
    /// Largest angle between each view and the nominal view (board facing the camera, with a
    /// random roll drawn once), degrees. Default 45.
    pub max_view_angle_deg: f64,
    /// Rotation noise σ per axis, radians, right-multiplied on every `base_from_gripper` and
    /// every `camera_from_board`. Default 0.1° (as handeye.py).
    pub rot_noise_rad: f64,
    /// Translation noise σ per axis, length unit, right-multiplied likewise. Default 0.001.
    pub trans_noise: f64,
    /// Lateral position of `board_centre` in the camera frame: `x, y ~ U(−r, r)`. Default 0.1.
    pub lateral_range: f64,
    /// Translation of the hand-eye transform (`gripper_from_camera` or `gripper_from_board`):
    /// each axis `~ U(−r, r)`. Default 0.1.
    pub hand_eye_offset: f64,
    /// Mean distance of the fixed frame (`base_from_board` eye-in-hand, `base_from_camera`
    /// eye-to-hand) from the robot base along base `x`; each axis adds `U(−hand_eye_offset,
    /// hand_eye_offset)`. Default 0.6.
    pub base_distance: f64,
    /// The point of the board frame placed at the sampled position (e.g. the board's centre,
    /// `((cols−1)·s/2, (rows−1)·s/2, 0)`); default the origin, as handeye.py.
    pub board_centre: DVec3,
    /// Seed of the generator. Default 42.
    pub seed: u64,
}

impl Default for TrajectoryConfig {
    fn default() -> Self {
        Self {
            stations: 10,
            eye_in_hand: true,
            min_distance: 0.4,
            max_distance: 0.7,
            max_view_angle_deg: 45.0,
            rot_noise_rad: 0.1f64.to_radians(),
            trans_noise: 0.001,
            lateral_range: 0.1,
            hand_eye_offset: 0.1,
            base_distance: 0.6,
            board_centre: DVec3::ZERO,
            seed: 42,
        }
    }
}

impl TrajectoryConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        if self.stations < 2 {
            return Err(SyntheticError::config("stations", format!("needs at least 2, got {}", self.stations)));
        }
        positive("min_distance", self.min_distance)?;
        positive("max_distance", self.max_distance)?;
        if self.min_distance > self.max_distance {
            return Err(SyntheticError::config(
                "min_distance",
                format!("{} is larger than max_distance {}", self.min_distance, self.max_distance),
            ));
        }
        non_negative("max_view_angle_deg", self.max_view_angle_deg)?;
        if self.max_view_angle_deg > 80.0 {
            return Err(SyntheticError::config("max_view_angle_deg", "must be at most 80 (board seen edge-on)"));
        }
        non_negative("rot_noise_rad", self.rot_noise_rad)?;
        non_negative("trans_noise", self.trans_noise)?;
        non_negative("lateral_range", self.lateral_range)?;
        non_negative("hand_eye_offset", self.hand_eye_offset)?;
        if !self.base_distance.is_finite() {
            return Err(SyntheticError::config("base_distance", "must be finite"));
        }
        if !self.board_centre.is_finite() {
            return Err(SyntheticError::config("board_centre", "must be finite"));
        }
        Ok(())
    }
}

/// The true transforms of a hand-eye data set. Eye-in-hand uses `gripper_from_camera` (X)
/// and `base_from_board`; eye-to-hand uses `base_from_camera` and `gripper_from_board`. The
/// pair the mode does not use is filled with its value at station 0 (it is not constant over
/// the stations), so the four always satisfy
/// `base_from_gripper[0] * gripper_from_camera == base_from_camera` and
/// `gripper_from_camera * camera_from_board[0] == gripper_from_board` (noise-free).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandEyeTruth {
    /// Camera pose on the gripper (eye-in-hand unknown `X`).
    pub gripper_from_camera: Isometry3,
    /// Board pose in the robot base (eye-in-hand, constant).
    pub base_from_board: Isometry3,
    /// Camera pose in the robot base (eye-to-hand unknown).
    pub base_from_camera: Isometry3,
    /// Board pose on the gripper (eye-to-hand, constant).
    pub gripper_from_board: Isometry3,
}

/// A hand-eye data set: per-station robot poses and board poses (noisy if the configuration
/// asks for noise) and the noise-free truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Robot forward kinematics per station (noisy).
    pub base_from_gripper: Vec<Isometry3>,
    /// Board pose in the camera per station, as calibration extrinsics would give (noisy).
    pub camera_from_board: Vec<Isometry3>,
    /// The true transforms.
    pub truth: HandEyeTruth,
    /// Which configuration was generated.
    pub eye_in_hand: bool,
}

/// Generates a hand-eye data set as handeye.py's synthetic test: true `X` with a uniform random
/// rotation and translation `~ U(−r, r)³`; the fixed frame at `(base_distance, 0, 0) + U(−r, r)³`
/// with a uniform rotation; per station the board centre at depth `U(min, max)` and lateral
/// offset `U(−lateral_range, lateral_range)` in the camera, oriented within
/// `max_view_angle_deg` of a nominal view; robot poses from the chain
/// (`G = W C⁻¹ X⁻¹` eye-in-hand, `G = Y C Z⁻¹` eye-to-hand); then noise right-multiplied on
/// every robot pose and every camera pose ([`perturb_pose`]).
///
/// Unlike handeye.py, whose nominal orientation is a uniform random rotation (the board may
/// face away from the camera), the nominal view here faces the board with a random roll, so
/// the poses can also be rendered; the distribution of relative motions is the same.
pub fn hand_eye_trajectory(cfg: &TrajectoryConfig) -> Result<Trajectory, SyntheticError> {
    cfg.validate()?;
    let mut rng = rng(cfg.seed);
    let r = cfg.hand_eye_offset;
    let rand_t =
        |rng: &mut rand_chacha::ChaCha8Rng| DVec3::new(uniform(rng, -r, r), uniform(rng, -r, r), uniform(rng, -r, r));
    // The hand-eye transform (X, or Z eye-to-hand) and the fixed frame (W, or Y eye-to-hand).
    let hand_q = uniform_rotation(&mut rng);
    let hand_t = rand_t(&mut rng);
    let hand = Isometry3::from_quat_translation(hand_q, hand_t);
    let fixed_q = uniform_rotation(&mut rng);
    let fixed_t = DVec3::new(cfg.base_distance, 0.0, 0.0) + rand_t(&mut rng);
    let fixed = Isometry3::from_quat_translation(fixed_q, fixed_t);
    let nominal = DQuat::from_rotation_z(uniform(&mut rng, 0.0, std::f64::consts::TAU));
    let max_angle = cfg.max_view_angle_deg.to_radians();
    let l = cfg.lateral_range;
    let camera_from_board: Vec<Isometry3> = (0..cfg.stations)
        .map(|_| {
            let q = (bounded_rotation(&mut rng, max_angle) * nominal).normalize();
            let p = DVec3::new(
                uniform(&mut rng, -l, l),
                uniform(&mut rng, -l, l),
                uniform(&mut rng, cfg.min_distance, cfg.max_distance),
            );
            Isometry3::from_quat_translation(q, p - q * cfg.board_centre)
        })
        .collect();
    let base_from_gripper: Vec<Isometry3> = camera_from_board
        .iter()
        .map(|c| if cfg.eye_in_hand { fixed * c.inverse() * hand.inverse() } else { fixed * *c * hand.inverse() })
        .collect();
    let truth = if cfg.eye_in_hand {
        HandEyeTruth {
            gripper_from_camera: hand,
            base_from_board: fixed,
            base_from_camera: base_from_gripper[0] * hand,
            gripper_from_board: hand * camera_from_board[0],
        }
    } else {
        HandEyeTruth {
            gripper_from_camera: base_from_gripper[0].inverse() * fixed,
            base_from_board: fixed * camera_from_board[0],
            base_from_camera: fixed,
            gripper_from_board: hand,
        }
    };
    let base_from_gripper =
        base_from_gripper.iter().map(|g| perturb_pose(g, cfg.rot_noise_rad, cfg.trans_noise, &mut rng)).collect();
    let camera_from_board =
        camera_from_board.iter().map(|c| perturb_pose(c, cfg.rot_noise_rad, cfg.trans_noise, &mut rng)).collect();
    Ok(Trajectory { base_from_gripper, camera_from_board, truth, eye_in_hand: cfg.eye_in_hand })
}
