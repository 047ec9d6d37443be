//! Pre-solve consistency checks of the paired poses: facts every correct data set satisfies
//! whatever `X` is, so a failure names a mistake in the input rather than a bad solution.
//!
//! `A X = X B` makes every robot motion `A` a conjugate of its camera motion `B`; conjugation
//! by a rigid transform preserves
//!
//! * the rotation angle of each motion (`θ_A = θ_B`),
//! * the rotation axes up to one common rotation (`axis_A = R_X axis_B`): after the best such
//!   rotation (orthogonal Procrustes, a lower bound over every `X`) only noise is left,
//! * the screw invariants with a length: the scalar part of the dual quaternion
//!   (`−½ sin(θ/2) · (axis · t)`) and the dual part of the inner product of two motions' screw
//!   axes (`v_k·d_l + d_k·v_l` with `q = v + ε d` the vector parts). Their ratio robot : camera is
//!   the ratio of the length units.
//!
//! Inverting one side (robot poses given as `gripper_from_base`, eye-to-hand data solved as
//! eye-in-hand or the reverse, camera poses given as `board_from_camera`) keeps the angles but
//! rotates each motion's axis by a different station orientation and mirrors it (`α' = −R_j α`);
//! reading roll-pitch-yaw degrees as axis-angle radians changes the angles themselves. A camera
//! pose `camera_from_board` must also put the board in front of the camera (`t_z > 0`).

use glam::{DMat3, DVec3};
use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::linear::dual_quat;
use crate::motion::{Motion, PairSelection, Setup, check_stations, motions_from_internal, robot_side};
use crate::quality::median;
use crate::{HandEyeError, Result};
use parallax_least_squares::nearest_rotation;

/// Thresholds and overrides of the consistency checks (all unit-free).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ConsistencyConfig {
    /// Largest median over the motions of `|θ_A − θ_B|`, degrees. Pose noise of 0.1° gives
    /// about 0.1°; a wrong rotation convention gives tens of degrees.
    pub max_angle_mismatch_deg: f64,
    /// Largest median angle between the robot motions' rotation axes and the camera motions'
    /// axes under the best common rotation, degrees (noise of 0.1° gives well under 1°).
    pub max_axis_mismatch_deg: f64,
    /// Motions rotating by less than this (or more than 180° minus this) on either side are left
    /// out of the axis test (their axes are noisy or sign-ambiguous), degrees.
    pub min_axis_rotation_deg: f64,
    /// Largest accepted ratio (either way) of the robot's to the camera's length invariants.
    pub max_scale_ratio: f64,
    /// Above this ratio (either way, and up to `max_scale_ratio`) the solution carries a
    /// [`crate::HandEyeWarning::ScaleDisagreement`]: a wrong square size or focal length, whose
    /// error the translation of `X` absorbs. Noise of 0.3° / 3 mm gives at most ×1.07 over 400
    /// synthetic sets.
    pub warn_scale_ratio: f64,
    /// The length invariants decide the scale only when robot and camera invariants correlate
    /// at least this much; below, the motions carry too little translation signal (rotations
    /// about one point) and the scale is reported unchecked (a warning).
    pub min_scale_correlation: f64,
    /// A unit mismatch is refused only when the ratio is beyond `max_scale_ratio` by this many
    /// standard deviations of its own uncertainty (from the pose noise the data show, see
    /// [`ConsistencyReport::scale_sigma`]); closer, the geometry cannot tell, and the solution
    /// carries a [`crate::HandEyeWarning::ScaleUncertain`].
    pub scale_sigmas: f64,
    /// A station whose motions have a median `|θ_A − θ_B|` above this factor times the median
    /// over all motions (and above `min_station_mismatch_deg`) does not fit the others: swapped
    /// or mis-paired poses, refused before solving, naming it. 4000 correct synthetic sets
    /// (4–15 stations, 0.3° and 0.5° pose noise on both lists) measured at most 5.8× and 10.9×
    /// (99.9 % under 5.5×); 27 of the 28 swapped pairs of a real 8-station session 10.8–182×.
    /// The solution's own per-station check ([`crate::ObservabilityConfig::station_factor`])
    /// catches the last (two nearly equal poses, 4.0× here).
    pub station_factor: f64,
    /// No station is named below this figure, degrees (here and in the solution's per-station
    /// check): a real session's stations measured at most 0.62° here over every subset of four
    /// or more of its stations.
    pub min_station_mismatch_deg: f64,
    /// Skip the rotation checks (angles, axes, handedness) — CLI `--allow-rotation-mismatch`.
    pub allow_rotation_mismatch: bool,
    /// Skip the length-unit check — CLI `--allow-scale-mismatch`.
    pub allow_scale_mismatch: bool,
    /// Accept camera poses with the board behind the camera — CLI `--allow-board-behind-camera`.
    pub allow_board_behind_camera: bool,
}

impl Default for ConsistencyConfig {
    fn default() -> Self {
        Self {
            max_angle_mismatch_deg: 2.0,
            max_axis_mismatch_deg: 5.0,
            min_axis_rotation_deg: 10.0,
            max_scale_ratio: 1.2,
            warn_scale_ratio: 1.1,
            min_scale_correlation: 0.95,
            scale_sigmas: 3.0,
            station_factor: 10.0,
            min_station_mismatch_deg: 1.0,
            allow_rotation_mismatch: false,
            allow_scale_mismatch: false,
            allow_board_behind_camera: false,
        }
    }
}

impl ConsistencyConfig {
    fn validate(&self) -> Result<()> {
        let ok = self.max_angle_mismatch_deg >= 0.0
            && self.max_axis_mismatch_deg >= 0.0
            && (0.0..90.0).contains(&self.min_axis_rotation_deg)
            && self.max_scale_ratio >= 1.0
            && self.warn_scale_ratio >= 1.0
            && (0.0..=1.0).contains(&self.min_scale_correlation)
            && (0.0..=10.0).contains(&self.scale_sigmas)
            && self.station_factor >= 1.0
            && self.min_station_mismatch_deg >= 0.0;
        if !ok {
            return Err(HandEyeError::InvalidConfig(format!("consistency thresholds out of range: {self:?}")));
        }
        Ok(())
    }
}

/// The kind of mistake a consistency check found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Inconsistency {
    /// A camera pose puts the board behind the camera: inverted camera poses or a
    /// non-OpenCV camera frame.
    BoardBehindCamera,
    /// The motions agree only with one side inverted: robot poses inverted, the wrong
    /// eye-in-hand / eye-to-hand mode, or camera poses inverted.
    InvertedPoses,
    /// Robot and camera rotations disagree outright: a wrong rotation format (roll-pitch-yaw
    /// degrees read as axis-angle, degrees for radians), or stations out of order.
    RotationMismatch,
    /// The robot and camera translations are in different length units.
    UnitMismatch,
    /// Some stations do not fit the others (their robot and camera poses are swapped with
    /// another station's, or mis-paired); the message names them. Found before solving (their
    /// motions' angles) or in a solution (the board frame each station implies).
    MismatchedStations,
}

/// Figures of the consistency checks (all unit-free).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct ConsistencyReport {
    /// Median over the motions of `|θ_A − θ_B|`, degrees.
    pub angle_mismatch_deg: f64,
    /// Median angle between the robot axes and the best common rotation of the camera axes,
    /// degrees (`None` with fewer than two motions usable for axes).
    pub axis_mismatch_deg: Option<f64>,
    /// Robot : camera ratio of the length invariants (`None` without translation signal).
    pub scale_ratio: Option<f64>,
    /// Correlation of the robot and camera length invariants (1 when they agree up to scale).
    pub scale_correlation: Option<f64>,
    /// Relative standard deviation of `scale_ratio` (of its logarithm) under the pose noise the
    /// data show: the camera poses perturbed 64 times (a fixed seed) by the rotation noise the
    /// median `|θ_A − θ_B|` implies (at least 0.1°) and by that angle times each camera's
    /// distance from the board in translation, the ratio recomputed each time.
    pub scale_sigma: Option<f64>,
    /// The median `|θ_A − θ_B|` over all motions, degrees (what a station's is compared with).
    pub motion_mismatch_deg: Option<f64>,
}

/// The axis mismatch as given above which a reading with one side inverted may win: pose noise
/// of 0.1° gives well under this, degrees.
const INVERSION_NOISE_DEG: f64 = 1.0;
/// How many times smaller the inverted reading's axis mismatch must be to win over the data as
/// given (the wrong reading of correct data measured 17x the right one on the hand-eye fixture).
const INVERSION_ADVANTAGE: f64 = 3.0;

/// At most this many motions enter the pair and triple statistics (spread over the list).
const MAX_STAT_MOTIONS: usize = 30;

fn vec_angle_deg(u: DVec3, v: DVec3) -> f64 {
    u.cross(v).length().atan2(u.dot(v)).to_degrees()
}

/// Evenly spread subset of at most `MAX_STAT_MOTIONS` items.
fn spread<T: Copy>(items: &[T]) -> Vec<T> {
    let step = items.len().div_ceil(MAX_STAT_MOTIONS).max(1);
    items.iter().step_by(step).copied().collect()
}

#[derive(Debug, Clone, Copy)]
struct RotationStats {
    angle: f64,
    axis: Option<f64>,
}

impl RotationStats {
    fn consistent(&self, cfg: &ConsistencyConfig) -> bool {
        self.angle <= cfg.max_angle_mismatch_deg && self.axis.is_none_or(|a| a <= cfg.max_axis_mismatch_deg)
    }
}

/// Median `|θ_A − θ_B|`, and the median angle left between the robot axes and the camera axes
/// under the best common proper rotation (orthogonal Procrustes over the unit axes of the
/// motions that rotate by at least `min_axis_rotation_deg` on both sides). The second is a
/// lower bound over every `X`: no hand-eye solution can map the axes closer, so it does not
/// depend on a solver; with one side inverted the axes are rotated by each station's own
/// orientation and mirrored, which no single rotation undoes.
fn rotation_stats(motions: &[Motion], cfg: &ConsistencyConfig) -> RotationStats {
    let angle = median(motions.iter().map(|m| (m.a.angle() - m.b.angle()).abs().to_degrees()).collect()).unwrap_or(0.0);
    let usable = usable_axes(motions, cfg);
    let axis = if usable.len() < 2 {
        None
    } else {
        let mut m = DMat3::ZERO;
        for (a, b) in &usable {
            m += DMat3::from_cols(*a * b.x, *a * b.y, *a * b.z);
        }
        nearest_rotation(m).ok().and_then(|r| median(usable.iter().map(|(a, b)| vec_angle_deg(*a, r * *b)).collect()))
    };
    RotationStats { angle, axis }
}

/// Unit rotation axes of robot and camera for the motions that rotate by at least
/// `min_axis_rotation_deg` (and at most 180° minus it) on both sides.
fn usable_axes(motions: &[Motion], cfg: &ConsistencyConfig) -> Vec<(DVec3, DVec3)> {
    let lo = cfg.min_axis_rotation_deg.to_radians();
    let hi = std::f64::consts::PI - lo;
    motions
        .iter()
        .filter(|m| (lo..=hi).contains(&m.a.angle()) && (lo..=hi).contains(&m.b.angle()))
        .map(|m| (m.a.rvec().normalize(), m.b.rvec().normalize()))
        .collect()
}

/// Median angle between the robot axes and the camera axes turned by `rotation` (the rotation
/// of a solution `X`), degrees: for the solution what [`ConsistencyReport::axis_mismatch_deg`]
/// is for the best common rotation of the axes. `None` with fewer than two motions usable for
/// axes.
pub(crate) fn axis_misfit_deg(motions: &[Motion], rotation: DMat3, cfg: &ConsistencyConfig) -> Option<f64> {
    let usable = usable_axes(motions, cfg);
    if usable.len() < 2 {
        return None;
    }
    median(usable.iter().map(|(a, b)| vec_angle_deg(*a, rotation * *b)).collect())
}

/// Robot : camera ratio and correlation of the length invariants (dual-quaternion scalar parts
/// and pairwise dual inner products); `None` when either side has no translation signal.
fn scale_stats(motions: &[Motion]) -> Option<(f64, f64)> {
    let lim = 170f64.to_radians();
    let dq: Vec<((glam::DQuat, glam::DQuat), (glam::DQuat, glam::DQuat))> = motions
        .iter()
        .filter(|m| m.a.angle() <= lim && m.b.angle() <= lim)
        .map(|m| (dual_quat(&m.a), dual_quat(&m.b)))
        .collect();
    let dq = spread(&dq);
    let (mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0);
    let mut add = |a: f64, b: f64| {
        saa += a * a;
        sbb += b * b;
        sab += a * b;
    };
    for ((_, ad), (_, bd)) in &dq {
        add(ad.w, bd.w);
    }
    for k in 0..dq.len() {
        for l in k + 1..dq.len() {
            let inv = |(rk, dk): (glam::DQuat, glam::DQuat), (rl, dl): (glam::DQuat, glam::DQuat)| {
                rk.xyz().dot(dl.xyz()) + dk.xyz().dot(rl.xyz())
            };
            add(inv(dq[k].0, dq[l].0), inv(dq[k].1, dq[l].1));
        }
    }
    (saa > 0.0 && sbb > 0.0 && saa.is_finite() && sbb.is_finite())
        .then(|| ((saa / sbb).sqrt(), sab / (saa * sbb).sqrt()))
}

/// Draws of [`scale_sigma`].
const SCALE_DRAWS: usize = 64;
/// The least rotation noise [`scale_sigma`] assumes, degrees per axis: a median `|θ_A − θ_B|`
/// of a few motions can be far below the noise that made it.
const MIN_SCALE_NOISE_DEG: f64 = 0.1;

/// Relative standard deviation of the scale ratio under the pose noise the data show (a
/// parametric bootstrap: the camera poses perturbed by right-multiplied noise, `SCALE_DRAWS`
/// times with a fixed seed, and [`scale_stats`] recomputed). The rotation noise per axis is the
/// median `|θ_A − θ_B|` over 0.954 (the median of `|N(0, 2σ²)|` is 0.954σ), at least
/// `MIN_SCALE_NOISE_DEG`; the translation noise of a camera pose is that angle times its
/// distance from the board (a pose fitted to image points errs in position about as much as
/// its rotation moves the board). `None` when fewer than half the draws give a ratio.
fn scale_sigma(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    pairs: PairSelection,
    angle_deg: f64,
) -> Option<f64> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let sigma = (angle_deg / 0.954).max(MIN_SCALE_NOISE_DEG).to_radians();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5ca1e);
    let mut normal3 = |s: f64| {
        let mut v = [0.0; 3];
        for x in &mut v {
            let z: f64 = StandardNormal.sample(&mut rng);
            *x = z * s;
        }
        DVec3::from_array(v)
    };
    let mut logs = Vec::with_capacity(SCALE_DRAWS);
    for _ in 0..SCALE_DRAWS {
        let noisy: Vec<Isometry3> = camera_from_board
            .iter()
            .map(|c| {
                let d = c.translation.length();
                *c * Isometry3::from_rvec_tvec(normal3(sigma), normal3(sigma * d))
            })
            .collect();
        if let Some((r, _)) = scale_stats(&motions_from_internal(robot, &noisy, pairs)) {
            logs.push(r.ln());
        }
    }
    if logs.len() < SCALE_DRAWS / 2 {
        return None;
    }
    let n = logs.len() as f64;
    let mean = logs.iter().sum::<f64>() / n;
    Some((logs.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
}

/// Per station, the median `|θ_A − θ_B|` over the motions it is part of, degrees (`None` for a
/// station in no motion).
fn station_mismatch_deg(motions: &[Motion], stations: usize) -> Vec<Option<f64>> {
    let mut per: Vec<Vec<f64>> = vec![Vec::new(); stations];
    for m in motions {
        let e = (m.a.angle() - m.b.angle()).abs().to_degrees();
        per[m.i].push(e);
        per[m.j].push(e);
    }
    per.into_iter().map(median).collect()
}

/// The stations whose figure exceeds `factor` times `typical` and `floor` (with four stations
/// or more), with their figures.
pub(crate) fn out_of_line(per_station: &[Option<f64>], typical: f64, factor: f64, floor: f64) -> Vec<(usize, f64)> {
    if per_station.len() < 4 {
        return Vec::new();
    }
    let limit = floor.max(factor * typical);
    per_station.iter().enumerate().filter_map(|(k, v)| v.filter(|v| *v > limit).map(|v| (k, v))).collect()
}

/// `3 (1.20°), 5 (48.1°)`: stations counted from 0 with their figures.
pub(crate) fn name_stations(bad: &[(usize, f64)]) -> String {
    let named: Vec<String> = bad.iter().take(12).map(|(k, v)| format!("{k} ({v:.2}°)")).collect();
    format!("{}{}", named.join(", "), if bad.len() > 12 { ", …" } else { "" })
}

/// Known ratios between length units, with the reading of `robot = factor × camera`.
const UNIT_FACTORS: [(f64, &str); 9] = [
    (1000.0, "robot in millimetres and camera in metres"),
    (100.0, "robot in centimetres and camera in metres"),
    (10.0, "robot in millimetres and camera in centimetres"),
    (25.4, "robot in millimetres and camera in inches"),
    (2.54, "robot in centimetres and camera in inches"),
    (39.37, "robot in inches and camera in metres"),
    (304.8, "robot in millimetres and camera in feet"),
    (3.2808, "robot in feet and camera in metres"),
    (12.0, "robot in inches and camera in feet"),
];

/// The standard unit factor within 15 % of `ratio` (robot : camera), with its reading.
pub fn unit_factor_hint(ratio: f64) -> Option<(f64, String)> {
    let swap = |s: &str| {
        let (r, c) = s.split_once(" and camera in ").expect("fixed format");
        format!("camera in {} and robot in {}", r.trim_start_matches("robot in "), c)
    };
    UNIT_FACTORS.iter().find_map(|(f, what)| {
        if (ratio / f).ln().abs() < 0.15f64.ln_1p() {
            Some((*f, what.to_string()))
        } else if (ratio * f).ln().abs() < 0.15f64.ln_1p() {
            Some((1.0 / f, swap(what)))
        } else {
            None
        }
    })
}

fn inconsistent(kind: Inconsistency, message: String) -> HandEyeError {
    HandEyeError::Inconsistent { kind, message }
}

/// The refusal of stations that do not fit the others, `why` saying by which figure.
pub(crate) fn mismatched_stations(bad: &[(usize, f64)], stations: usize, why: &str) -> HandEyeError {
    inconsistent(
        Inconsistency::MismatchedStations,
        format!(
            "{} of {stations} stations do not fit the others: stations {} (counted from 0) have {why}. Likely \
             mistake: these stations' robot and camera poses are swapped with each other or mis-paired (a pose \
             file out of order, an image taken before the robot settled) — re-pair or remove them. Override: \
             consistency.allow_rotation_mismatch (--allow-rotation-mismatch)",
            bad.len(),
            name_stations(bad),
        ),
    )
}

fn list_stations(idx: &[usize]) -> String {
    let shown: Vec<String> = idx.iter().take(12).map(usize::to_string).collect();
    format!("{}{}", shown.join(", "), if idx.len() > 12 { ", …" } else { "" })
}

/// Checks the poses (already in the `G_i X C_i = W` form of `setup`) and their motions; returns
/// the figures or the first failed check as [`HandEyeError::Inconsistent`] with a hint.
pub(crate) fn check(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    motions: &[Motion],
    setup: Setup,
    pairs: PairSelection,
    cfg: &ConsistencyConfig,
) -> Result<ConsistencyReport> {
    cfg.validate()?;
    if !cfg.allow_board_behind_camera {
        let behind: Vec<usize> =
            camera_from_board.iter().enumerate().filter(|(_, c)| c.translation.z <= 0.0).map(|(k, _)| k).collect();
        if !behind.is_empty() {
            return Err(inconsistent(
                Inconsistency::BoardBehindCamera,
                format!(
                    "{} of {} camera poses put the board behind the camera (t_z ≤ 0; stations {}): a \
                     camera_from_board pose has the board in front (OpenCV camera frame, z forward). \
                     Likely mistake: the camera poses are inverted (board_from_camera) — invert them; or the \
                     camera frame is z-backward (OpenGL). Override: consistency.allow_board_behind_camera \
                     (--allow-board-behind-camera)",
                    behind.len(),
                    camera_from_board.len(),
                    list_stations(&behind)
                ),
            ));
        }
    }
    let rot = rotation_stats(motions, cfg);
    let mut report =
        ConsistencyReport { angle_mismatch_deg: rot.angle, axis_mismatch_deg: rot.axis, ..Default::default() };
    // Stations out of line with the others. A few (a third at most) are named before the
    // global checks, which they would otherwise fail without a name; more are left to those.
    report.motion_mismatch_deg =
        median(motions.iter().map(|m| (m.a.angle() - m.b.angle()).abs().to_degrees()).collect());
    let typical = report.motion_mismatch_deg.unwrap_or(0.0);
    let bad = out_of_line(
        &station_mismatch_deg(motions, robot.len()),
        typical,
        cfg.station_factor,
        cfg.min_station_mismatch_deg,
    );
    let stations_refusal = (!bad.is_empty()).then(|| {
        mismatched_stations(
            &bad,
            robot.len(),
            &format!(
                "a median |θ_robot − θ_camera| over their motions above {}× the median motion's {typical:.2}° (and \
                 above {}°)",
                cfg.station_factor, cfg.min_station_mismatch_deg,
            ),
        )
    });
    if !cfg.allow_rotation_mismatch
        && bad.len() * 3 <= robot.len()
        && let Some(refusal) = stations_refusal.clone()
    {
        return Err(refusal);
    }
    let inverted: Vec<Isometry3> = robot.iter().map(Isometry3::inverse).collect();
    let inv = rotation_stats(&motions_from_internal(&inverted, camera_from_board, pairs), cfg);
    // Within the limit as given, but far closer with one side inverted: the inverted reading is
    // the data's (the project's hand-eye fixture solved as eye-to-hand, or with its robot poses
    // inverted: 3.52° as given, under the 5° limit, 0.20° inverted; its correct reading the
    // other way round) — the solvers then returned `X` ~1.1 m off with exit 0.
    let inverted_fits_better = match (rot.axis, inv.axis) {
        (Some(a), Some(b)) => a > INVERSION_NOISE_DEG && b * INVERSION_ADVANTAGE < a && inv.consistent(cfg),
        _ => false,
    };
    if !cfg.allow_rotation_mismatch && (!rot.consistent(cfg) || inverted_fits_better) {
        let figures = format!(
            "median |θ_robot − θ_camera| {:.2}° (limit {}°), median axis mismatch under the best common rotation {}",
            rot.angle,
            cfg.max_angle_mismatch_deg,
            rot.axis.map_or("n/a".into(), |a| format!("{a:.2}° (limit {}°)", cfg.max_axis_mismatch_deg)),
        );
        if inv.consistent(cfg) {
            let (mode, other) = match setup {
                Setup::EyeInHand => ("eye-in-hand", "eye-to-hand (camera fixed, board on the gripper: --eye-to-hand)"),
                Setup::EyeToHand => ("eye-to-hand", "eye-in-hand (camera on the gripper: drop --eye-to-hand)"),
            };
            return Err(inconsistent(
                Inconsistency::InvertedPoses,
                format!(
                    "robot and camera motions disagree ({figures}) but agree with the robot poses inverted \
                     (median angle mismatch {:.2}°, axis mismatch {}). Likely mistake: the data is {other} \
                     while solving {mode}; or the robot poses are gripper_from_base instead of base_from_gripper \
                     (invert them); or the camera poses are board_from_camera instead of camera_from_board. \
                     Override: consistency.allow_rotation_mismatch (--allow-rotation-mismatch)",
                    inv.angle,
                    inv.axis.map_or("n/a".into(), |a| format!("{a:.2}°")),
                ),
            ));
        }
        return Err(inconsistent(
            Inconsistency::RotationMismatch,
            format!(
                "robot and camera rotations disagree ({figures}); equal motion angles are required by \
                 A X = X B whatever X is. Likely mistake: the robot rotation format — roll-pitch-yaw in \
                 degrees read as axis-angle radians (or the reverse, or degrees for radians, or another \
                 Euler order); or the robot and camera lists are not in the same station order. \
                 Override: consistency.allow_rotation_mismatch (--allow-rotation-mismatch)"
            ),
        ));
    }
    if let Some(refusal) = stations_refusal.filter(|_| !cfg.allow_rotation_mismatch) {
        return Err(refusal);
    }
    if let Some((ratio, corr)) = scale_stats(motions) {
        report.scale_ratio = Some(ratio);
        report.scale_correlation = Some(corr);
        let off = ratio.max(1.0 / ratio).ln();
        let limit = cfg.max_scale_ratio.ln();
        let sigma = if off > limit { scale_sigma(robot, camera_from_board, pairs, rot.angle) } else { None };
        report.scale_sigma = sigma;
        // Beyond the limit, but noise alone could have put it there: a warning, not a refusal.
        let decided = sigma.is_some_and(|s| off - cfg.scale_sigmas * s > limit);
        if !cfg.allow_scale_mismatch && corr >= cfg.min_scale_correlation && off > limit && decided {
            let hint = match unit_factor_hint(ratio) {
                Some((f, what)) => {
                    format!("factor ≈ {}: {what}", if f >= 1.0 { format!("{f}") } else { format!("1/{}", 1.0 / f) })
                }
                None => "not a standard unit factor: check the square size and the robot's length unit".into(),
            };
            return Err(inconsistent(
                Inconsistency::UnitMismatch,
                format!(
                    "the robot's translations are {ratio:.4}× the camera's (screw invariants of the paired motions, \
                     correlation {corr:.4}, ±{:.1} % from the pose noise; limit ×{} either way, by {} σ): {hint}. \
                     Give both in one unit (with images, --square in the robot poses' unit). Override: \
                     consistency.allow_scale_mismatch (--allow-scale-mismatch)",
                    100.0 * sigma.unwrap_or(0.0),
                    cfg.max_scale_ratio,
                    cfg.scale_sigmas,
                ),
            ));
        }
    }
    Ok(report)
}

/// The consistency checks on their own (as [`crate::calibrate`] runs them before solving).
pub fn check_consistency(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    setup: Setup,
    pairs: PairSelection,
    cfg: &ConsistencyConfig,
) -> Result<ConsistencyReport> {
    check_stations(base_from_gripper, camera_from_board, 3)?;
    let robot = robot_side(base_from_gripper, setup);
    let motions = motions_from_internal(&robot, camera_from_board, pairs);
    check(&robot, camera_from_board, &motions, setup, pairs, cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_factors_are_named_both_ways() {
        let (f, what) = unit_factor_hint(1003.0).unwrap();
        assert_eq!(f, 1000.0);
        assert!(what.contains("robot in millimetres and camera in metres"), "{what}");
        let (f, what) = unit_factor_hint(1.0 / 998.0).unwrap();
        assert!((f - 1e-3).abs() < 1e-15);
        assert!(what.contains("camera in millimetres and robot in metres"), "{what}");
        assert_eq!(unit_factor_hint(25.0).unwrap().0, 25.4);
        assert!(unit_factor_hint(1.5).is_none());
        assert!(unit_factor_hint(600.0).is_none());
    }

    #[test]
    fn median_of_even_and_odd_lists() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(median(vec![]), None);
    }
}
