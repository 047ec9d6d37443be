//! What a RON / JSON result file of the commands holds: a mono or stereo calibration with its
//! views and uncertainties ([`MonoOutput`], [`StereoOutput`]) and a hand-eye calibration with
//! every method's solution ([`HandEyeOutput`]). Matrices are row-major and poses are given in
//! every convention (`parallax_interop`'s records); the `calibration` / `result` field is what
//! every command reads back.

use parallax_hand_eye::{HandEyeSolution, Method};
use parallax_interop::{
    HandEyeCalibration, HandEyeRecord, MonoCalibration, MonoRecord, PoseRecord, StereoCalibration, StereoRecord,
};
use parallax_planar_calibration::{
    CalibrationResult, CalibrationWarning, IntrinsicStdDevs, RigStdDevs, StereoCalibrationResult,
};
use serde::Serialize;

use crate::Result;

/// A mono calibration's result file. `B` is the target: a `Chessboard` (the file form of the
/// chessboard commands) or any `TargetDescription`.
#[derive(Debug, Serialize)]
pub struct MonoOutput<'a, B> {
    /// The images with the target found, in the order of the views.
    pub images: Vec<String>,
    /// The target.
    pub board: B,
    /// The calibration (camera, RMS, per-view RMS).
    pub calibration: MonoRecord,
    /// Per-view `camera_from_board`.
    pub camera_from_board: Vec<PoseRecord>,
    /// Standard deviations of the intrinsics (`None` = held fixed).
    pub std_devs: &'a IntrinsicStdDevs,
    /// Estimated pixel noise per coordinate.
    pub sigma_px: f64,
    /// Degrees of freedom of the fit.
    pub dof: usize,
    /// Solver iterations.
    pub iterations: usize,
    /// Whether the solver converged.
    pub converged: bool,
    /// The calibration's warnings.
    pub warnings: &'a [CalibrationWarning],
}

/// The calibration of `r` as the interop model (what every format writes).
pub fn mono_calibration(r: &CalibrationResult) -> MonoCalibration {
    MonoCalibration { camera: r.camera, rms_px: Some(r.rms_px), per_view_rms_px: r.per_view_rms_px.clone() }
}

impl<'a, B> MonoOutput<'a, B> {
    /// The file of calibration `r` from the views `images` of `board`.
    pub fn new(images: Vec<String>, board: B, r: &'a CalibrationResult) -> Self {
        Self {
            images,
            board,
            calibration: MonoRecord::of(&mono_calibration(r)),
            camera_from_board: r.camera_from_board.iter().map(PoseRecord::of).collect(),
            std_devs: &r.std_devs,
            sigma_px: r.sigma_px,
            dof: r.dof,
            iterations: r.iterations,
            converged: r.converged,
            warnings: &r.warnings,
        }
    }
}

/// A stereo calibration's result file: `calibration` holds the rig, its OpenCV matrices
/// `M1 D1 M2 D2 R T E F` and the rectification `R1 R2 P1 P2 Q` that `rectify` computes by
/// default (alpha 0, zero disparity). `B` as in [`MonoOutput`].
#[derive(Debug, Serialize)]
pub struct StereoOutput<'a, B> {
    /// Left images of the pairs used.
    pub left_images: Vec<String>,
    /// Right images of the pairs used.
    pub right_images: Vec<String>,
    /// The target.
    pub board: B,
    /// The rig with its rectification.
    pub calibration: StereoRecord,
    /// RMS reprojection error of the left camera, pixels.
    pub left_rms_px: f64,
    /// RMS reprojection error of the right camera, pixels.
    pub right_rms_px: f64,
    /// Per-view left `camera_from_board`.
    pub left_camera_from_board: Vec<PoseRecord>,
    /// Standard deviations of the left intrinsics.
    pub left_std_devs: &'a IntrinsicStdDevs,
    /// Standard deviations of the right intrinsics.
    pub right_std_devs: &'a IntrinsicStdDevs,
    /// Standard deviations of `right_from_left` and the baseline.
    pub rig_std_devs: &'a RigStdDevs,
    /// Estimated pixel noise per coordinate.
    pub sigma_px: f64,
    /// Degrees of freedom of the fit.
    pub dof: usize,
    /// Solver iterations.
    pub iterations: usize,
    /// Whether the solver converged.
    pub converged: bool,
    /// The calibration's warnings.
    pub warnings: &'a [CalibrationWarning],
}

/// The stereo calibration of `r` as the interop model, with the rectification `rectify`
/// computes by default (so that `disparity --calib` on this file and on `rectify`'s output
/// agree). A rig with a wide lens that no pinhole pair can hold (image edges 90° or more from
/// the rectified axis) is written without one: `rectify` says why.
pub fn stereo_calibration(r: &StereoCalibrationResult) -> Result<StereoCalibration> {
    let rectification = match parallax_interop::rectify_default(&r.rig) {
        Ok(rect) => Some(rect),
        Err(_) if r.rig.has_wide_lens() => None,
        Err(e) => return Err(e.into()),
    };
    Ok(StereoCalibration {
        rig: r.rig,
        rectification,
        rms_px: Some(r.rms_px),
        per_view_rms_px: r.per_view_rms_px.clone(),
    })
}

impl<'a, B> StereoOutput<'a, B> {
    /// The file of stereo calibration `r` (as [`stereo_calibration`] gives it) from the pairs
    /// `left_images` / `right_images` of `board`.
    pub fn new(
        left_images: Vec<String>,
        right_images: Vec<String>,
        board: B,
        calibration: &StereoCalibration,
        r: &'a StereoCalibrationResult,
    ) -> Self {
        Self {
            left_images,
            right_images,
            board,
            calibration: StereoRecord::of(calibration),
            left_rms_px: r.left_rms_px,
            right_rms_px: r.right_rms_px,
            left_camera_from_board: r.camera_from_board.iter().map(PoseRecord::of).collect(),
            left_std_devs: &r.left_std_devs,
            right_std_devs: &r.right_std_devs,
            rig_std_devs: &r.rig_std_devs,
            sigma_px: r.sigma_px,
            dof: r.dof,
            iterations: r.iterations,
            converged: r.converged,
            warnings: &r.warnings,
        }
    }
}

/// A hand-eye result file: the chosen solution (the refined one, else the first that
/// succeeded) in every convention — what other commands read back — and every solution.
#[derive(Debug, Serialize)]
pub struct HandEyeOutput<'a> {
    /// The chosen solution.
    pub result: HandEyeRecord,
    /// Every method's solution.
    pub solutions: Vec<SolutionRecord<'a>>,
}

/// One method's solution: `X` in every convention, then everything the solver reports.
#[derive(Debug, Serialize)]
pub struct SolutionRecord<'a> {
    /// `X` in every convention.
    pub pose: PoseRecord,
    /// The solver's result.
    pub solution: &'a HandEyeSolution,
}

/// The solution a hand-eye run reports: the refined method's, else the first.
pub fn chosen_solution(solutions: &[HandEyeSolution]) -> Option<&HandEyeSolution> {
    solutions.iter().find(|s| s.method == Method::Refined).or(solutions.first())
}

/// The interop model of solution `s` (what every format writes).
pub fn hand_eye_calibration(s: &HandEyeSolution) -> HandEyeCalibration {
    HandEyeCalibration { setup: s.setup, transform: s.transform, method: Some(s.method.to_string()) }
}

impl<'a> HandEyeOutput<'a> {
    /// The file of `chosen` and every solution.
    pub fn new(chosen: &HandEyeCalibration, solutions: &'a [HandEyeSolution]) -> Self {
        Self {
            result: HandEyeRecord::of(chosen),
            solutions: solutions
                .iter()
                .map(|s| SolutionRecord { pose: PoseRecord::of(&s.transform), solution: s })
                .collect(),
        }
    }
}

/// A rig calibration's result file (RON / JSON): the frames (matched file names), each
/// camera's input, the target, and the whole result (cameras, `camI_from_cam0`,
/// `cam0_from_board` per frame, residuals, 1σ, the visibility, warnings).
#[derive(Debug, Serialize)]
pub struct RigOutput<'a, B> {
    /// The frames, by the file name the cameras' images share.
    pub frames: Vec<String>,
    /// Each camera's input (its `--camera` glob or corners file).
    pub camera_inputs: Vec<String>,
    /// The target.
    pub board: B,
    /// The calibration.
    pub result: &'a parallax_planar_calibration::RigCalibrationResult,
}
