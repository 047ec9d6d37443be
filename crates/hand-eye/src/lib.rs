//! # hand-eye — where the camera sits on (or beside) the robot
//!
//! Hand-eye calibration `A X = X B` from `N` stations of `base_from_gripper` (robot forward
//! kinematics) and `camera_from_board` (calibration extrinsics), eye-in-hand
//! (`X = gripper_from_camera`) or eye-to-hand (`X = base_from_camera`), with every classic
//! solver a user may compare against OpenCV:
//!
//! * closed form ([`linear`]): Tsai–Lenz, Park–Martin, Horaud–Dornaika, Andreff (Kronecker
//!   product), Daniilidis (dual quaternions) and the thesis's Rodrigues-axis method;
//! * robot-world-hand-eye `A X = Z B` ([`robot_world`]): Shah and Li;
//! * [`Method::Refined`]: maximum likelihood over the absolute poses (X and the board frame
//!   together, each station weighted by its first-order noise covariance), with covariance.
//!
//! Every solution carries its [`Quality`]: per-motion residuals of `A X = X B` (degrees and
//! length), the thesis's Table 4 error `‖A_i X − X B_i‖`, and ViSP's consistency measure (the
//! spread of `base_from_board` over the stations). Degenerate motion sets — fewer than two
//! informative motions with non-parallel axes — are errors naming the stations
//! ([`check_motions`]).
//!
//! **No length unit.** [`calibrate`] divides every translation by the scene scale `L` (the RMS
//! translation of the input poses, [`length_scale`]) before solving and multiplies the result
//! back, so every method — Daniilidis and Li included, whose systems mix rotations and lengths —
//! gives the same rotation and the same translation × 1000 for poses in millimetres as in metres.
//! The refinement estimates the translation noise from the data (variance components, see
//! [`RefineConfig`]) or takes it in the data's unit; it reports `converged`, the stop reason and
//! the iterations ([`Refinement`]), and an unconverged refinement is an error unless
//! `refine.allow_unconverged`.
//!
//! **Wrong inputs are refused before solving** ([`check_consistency`],
//! [`HandEyeError::Inconsistent`]): robot and camera motions must have equal rotation angles and
//! axes related by one rotation (else: roll-pitch-yaw read as axis-angle, or one side inverted —
//! robot poses `gripper_from_base`, eye-to-hand data solved as eye-in-hand or the reverse,
//! camera poses `board_from_camera`), equal screw invariants with a length (else: a unit
//! mismatch, with the factor named, decided only when the ratio's own uncertainty under the
//! data's pose noise allows), the board in front of every camera, and every station in line with
//! the others (swapped or mis-paired stations are named). Each message names the likely mistake
//! and the [`ConsistencyConfig`] override. **Each solution is checked** too
//! ([`HandEyeError::Implausible`]): a rotation that fits the motions' axes far worse than the
//! data's lower bound (a failed solver), translations that fit no transform, a station whose
//! implied board frame is out of line. **Weak geometry** is a warning with the figure
//! ([`HandEyeWarning`]): rotation axes spread less than 10° ([`axis_spread_deg`]), a refined σ
//! above the [`ObservabilityConfig`] thresholds, a length ratio the geometry cannot decide.
//!
//! [`io`] reads pose lists (RON, ViSP YAML, axis-angle or roll-pitch-yaw text); [`visp`] reads
//! ViSP's camera XML (both perspective models, `kud` converted exactly to OpenCV's `k1`) and
//! reads and writes ViSP's `cPo` / `ePc` / `eMc` YAML; [`PoseConventions`] gives a transform as
//! quaternion `(x, y, z, w)`, row-major matrix, rotation vector (radians) and ROS `tf` line.
//!
//! Conventions (OpenCV's): `G_i X C_i = W` is constant (`W = base_from_board`); for stations
//! `i < j`, `A = G_j⁻¹ G_i`, `B = C_j C_i⁻¹`. Lengths are in the unit of the input poses.
//!
//! ```
//! use parallax_camera_model::Isometry3;
//! use glam::DVec3;
//! use parallax_hand_eye::{calibrate, points_to_base, HandEyeConfig, Method};
//!
//! let x = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, 1.57), DVec3::new(0.058, -0.034, -0.042));
//! let w = Isometry3::from_rvec_tvec(DVec3::new(3.1, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0));
//! let c: Vec<Isometry3> = [[0.0, 0.0, 0.0], [0.3, 0.1, 0.0], [-0.2, 0.4, 0.1], [0.1, -0.3, 0.5]]
//!     .iter()
//!     .map(|r| Isometry3::from_rvec_tvec(DVec3::from_array(*r), DVec3::new(0.0, 0.0, 0.5)))
//!     .collect();
//! let g: Vec<Isometry3> = c.iter().map(|c| w * c.inverse() * x.inverse()).collect();
//! let sol = calibrate(&g, &c, Method::Refined, &HandEyeConfig::default())?;
//! assert!(sol.transform.distance(&x).1 < 1e-9);
//! assert!(sol.refinement.as_ref().is_some_and(|r| r.converged));
//! // The same stations in millimetres: the same rotation, 1000 × the translation.
//! let mm = |p: &Isometry3| p.with_translation(p.translation * 1000.0);
//! let (g_mm, c_mm): (Vec<_>, Vec<_>) = (g.iter().map(mm).collect(), c.iter().map(mm).collect());
//! let sol_mm = calibrate(&g_mm, &c_mm, Method::Refined, &HandEyeConfig::default())?;
//! assert!(sol_mm.transform.distance(&sol.transform).0 < 1e-9);
//! assert!((sol_mm.transform.translation - sol.transform.translation * 1000.0).length() < 1e-6);
//! // For a ROS static_transform_publisher: "x y z qx qy qz qw".
//! assert_eq!(sol.conventions().tf_line().split(' ').count(), 7);
//! // A point 0.5 m in front of the camera at station 0, in the robot base frame:
//! let p = points_to_base(&g[0], &sol.transform, &[DVec3::new(0.0, 0.0, 0.5)])[0];
//! assert!((p - (g[0] * x).transform_point(DVec3::new(0.0, 0.0, 0.5))).length() < 1e-9);
//! # Ok::<(), parallax_hand_eye::HandEyeError>(())
//! ```

mod calibrate;
mod consistency;
mod error;
pub mod io;
pub mod linear;
mod motion;
mod observability;
mod output;
mod quality;
mod refine;
pub mod robot_world;
pub mod visp;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use calibrate::{
    HandEyeConfig, HandEyeSolution, Method, calibrate, calibrate_all, evaluate, length_scale, points_to_base,
    points_to_gripper, solve_motions,
};
pub use consistency::{ConsistencyConfig, ConsistencyReport, Inconsistency, check_consistency, unit_factor_hint};
pub use error::HandEyeError;
pub use motion::{DegeneracyConfig, Motion, PairSelection, Setup, check_motions, relative_motions};
pub use observability::{HandEyeWarning, ObservabilityConfig, axis_spread_deg};
pub use output::PoseConventions;
pub use parallax_least_squares::StopReason;
pub use quality::{MotionResidual, Quality, motion_residual};
pub use refine::{RefineConfig, Refinement};

/// Result alias of this crate.
pub type Result<T, E = HandEyeError> = std::result::Result<T, E>;
