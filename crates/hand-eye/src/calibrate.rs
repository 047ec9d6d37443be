//! The entry point: every method on absolute station poses, with quality.

use std::fmt;
use std::str::FromStr;

use glam::DVec3;
use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::consistency::{self, ConsistencyConfig, ConsistencyReport};
use crate::motion::{
    DegeneracyConfig, Motion, PairSelection, Setup, check_motions, check_stations, motions_from_internal, robot_side,
};
use crate::observability::{HandEyeWarning, ObservabilityConfig, axis_spread_deg};
use crate::output::PoseConventions;
use crate::quality::{Quality, quality};
use crate::refine::{RefineConfig, Refinement, initial_cost, refine};
use crate::{HandEyeError, Result, linear, robot_world};

/// A hand-eye method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Method {
    /// Tsai–Lenz, modified Rodrigues vectors ([`linear::tsai`]).
    Tsai,
    /// Park–Martin, log map ([`linear::park`]).
    Park,
    /// Horaud–Dornaika, quaternions ([`linear::horaud`]).
    Horaud,
    /// Andreff, Kronecker product null vector ([`linear::andreff`]).
    Andreff,
    /// Daniilidis, dual quaternions ([`linear::daniilidis`]).
    Daniilidis,
    /// The thesis's Rodrigues-axis method ([`linear::rodrigues`]).
    Rodrigues,
    /// Nonlinear maximum-likelihood refinement from the best linear solution (see [`RefineConfig`]).
    Refined,
    /// Robot-world-hand-eye `A X = Z B`, Shah's Kronecker method ([`robot_world::shah`]).
    Shah,
    /// Robot-world-hand-eye `A X = Z B`, Li's joint linear method ([`robot_world::li`]).
    Li,
}

impl Method {
    /// Every method, linear `A X = X B` solvers first.
    pub const ALL: [Method; 9] = [
        Method::Tsai,
        Method::Park,
        Method::Horaud,
        Method::Andreff,
        Method::Daniilidis,
        Method::Rodrigues,
        Method::Refined,
        Method::Shah,
        Method::Li,
    ];
    /// The closed-form `A X = X B` solvers.
    pub const LINEAR: [Method; 6] =
        [Method::Tsai, Method::Park, Method::Horaud, Method::Andreff, Method::Daniilidis, Method::Rodrigues];

    /// Lower-case name (as accepted by [`FromStr`] and printed by `cargo xtask handeye`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Tsai => "tsai",
            Method::Park => "park",
            Method::Horaud => "horaud",
            Method::Andreff => "andreff",
            Method::Daniilidis => "daniilidis",
            Method::Rodrigues => "rodrigues",
            Method::Refined => "refined",
            Method::Shah => "shah",
            Method::Li => "li",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = HandEyeError;
    fn from_str(s: &str) -> Result<Self> {
        Method::ALL.into_iter().find(|m| m.name().eq_ignore_ascii_case(s.trim())).ok_or_else(|| {
            HandEyeError::InvalidConfig(format!(
                "unknown hand-eye method {s:?} (expected one of {})",
                Method::ALL.map(Method::name).join(", ")
            ))
        })
    }
}

/// Options of [`calibrate`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct HandEyeConfig {
    /// Eye-in-hand (default) or eye-to-hand.
    pub setup: Setup,
    /// Which station pairs form the relative motions (default: all pairs).
    pub pairs: PairSelection,
    /// Thresholds of the degeneracy check.
    pub degeneracy: DegeneracyConfig,
    /// Noise model and options of the refinement.
    pub refine: RefineConfig,
    /// Pre-solve consistency checks (thresholds and overrides).
    pub consistency: ConsistencyConfig,
    /// Weak-geometry warning thresholds.
    pub observability: ObservabilityConfig,
}

/// A hand-eye solution with its quality.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HandEyeSolution {
    /// The method that produced it.
    pub method: Method,
    /// Eye-in-hand or eye-to-hand.
    pub setup: Setup,
    /// `X`: `gripper_from_camera` (eye-in-hand) or `base_from_camera` (eye-to-hand).
    pub transform: Isometry3,
    /// The fixed frame: `base_from_board` (eye-in-hand) or `gripper_from_board` (eye-to-hand);
    /// estimated by the robot-world methods and the refinement, the stations' mean otherwise.
    pub board: Isometry3,
    /// Residuals and consistency measures.
    pub quality: Quality,
    /// For [`Method::Refined`]: the linear method it started from.
    pub start: Option<Method>,
    /// For [`Method::Refined`]: covariance, standard deviations, fit statistics and convergence.
    pub refinement: Option<Refinement>,
    /// The scene scale `L` (RMS translation of the input poses, data unit) the solvers worked
    /// in: translations were divided by it before solving and the result multiplied back, so no
    /// method depends on the length unit.
    pub length_scale: f64,
    /// Figures of the pre-solve consistency checks.
    pub consistency: ConsistencyReport,
    /// Spread of the motions' rotation axes, degrees (see [`crate::axis_spread_deg`]).
    pub axis_spread_deg: Option<f64>,
    /// Weak-geometry and unchecked-unit warnings (the solution is still returned).
    pub warnings: Vec<HandEyeWarning>,
}

impl HandEyeSolution {
    /// `X` in every common convention (quaternion, matrix, rotation vector, ROS tf order).
    pub fn conventions(&self) -> PoseConventions {
        PoseConventions::of(&self.transform)
    }
}

/// The scene scale of a set of stations: RMS of the translation lengths of both pose lists
/// (1 when they are all zero). Scaling every translation by `s` scales it by `s`.
pub fn length_scale(base_from_gripper: &[Isometry3], camera_from_board: &[Isometry3]) -> f64 {
    rms_length(base_from_gripper.iter().chain(camera_from_board).map(|p| p.translation))
}

fn rms_length(ts: impl Iterator<Item = DVec3>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for t in ts {
        sum += t.length_squared();
        n += 1;
    }
    let l = (sum / n.max(1) as f64).sqrt();
    if l.is_finite() && l > 0.0 { l } else { 1.0 }
}

/// `p` with its translation multiplied by `s`.
fn scaled(p: &Isometry3, s: f64) -> Isometry3 {
    p.with_translation(p.translation * s)
}

/// Solves `A X = X B` over the given motions with one closed-form method
/// ([`Method::LINEAR`]; other methods need absolute poses: use [`calibrate`]).
///
/// Scale-invariant: the translations are divided by three times their RMS length before solving
/// and the result's translation multiplied back (Daniilidis mixes rotations and lengths in one
/// system; every method then gives the same rotation whatever the length unit).
pub fn solve_motions(method: Method, motions: &[Motion]) -> Result<Isometry3> {
    if motions.len() < 2 {
        return Err(HandEyeError::NotEnoughData(format!("{} motion(s), at least 2 needed", motions.len())));
    }
    // Translations to an RMS of 1/3: only Daniilidis (one SVD over rotation and translation
    // equations) depends on the choice. Mean rotation error of Daniilidis on the peer protocol
    // (300 trials) with RMS 1/0.3, 1, 1/3, 1/10: 0.376°, 0.270°, 0.225°, 0.248°.
    let l = 3.0 * rms_length(motions.iter().flat_map(|m| [m.a.translation, m.b.translation]));
    let normalised: Vec<Motion> =
        motions.iter().map(|m| Motion { a: scaled(&m.a, 1.0 / l), b: scaled(&m.b, 1.0 / l), ..*m }).collect();
    let motions = &normalised;
    let x = match method {
        Method::Tsai => linear::tsai(motions),
        Method::Park => linear::park(motions),
        Method::Horaud => linear::horaud(motions),
        Method::Andreff => linear::andreff(motions),
        Method::Daniilidis => linear::daniilidis(motions),
        Method::Rodrigues => linear::rodrigues(motions),
        other => Err(HandEyeError::InvalidConfig(format!("{other} needs absolute poses: call calibrate()"))),
    }?;
    Ok(scaled(&x, l))
}

/// Hand-eye calibration from `N ≥ 3` stations: `base_from_gripper[i]` (robot forward
/// kinematics) and `camera_from_board[i]` (calibration extrinsics) taken at the same time.
///
/// Checks the inputs and the motions ([`check_motions`]) first: a degenerate set is an error
/// naming the stations, never a silently wrong answer.
///
/// ```
/// use parallax_camera_model::Isometry3;
/// use glam::DVec3;
/// use parallax_hand_eye::{calibrate, HandEyeConfig, Method};
///
/// let x = Isometry3::from_rvec_tvec(DVec3::new(0.1, -0.2, 1.5), DVec3::new(0.05, -0.03, 0.1));
/// let base_from_board = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, 0.3), DVec3::new(0.6, 0.0, 0.0));
/// let rvecs = [[0.0, 0.0, 0.0], [0.4, 0.0, 0.1], [0.0, 0.5, -0.2], [0.3, -0.3, 0.6]];
/// let camera_from_board: Vec<Isometry3> = rvecs
///     .iter()
///     .map(|r| Isometry3::from_rvec_tvec(DVec3::from_array(*r), DVec3::new(0.05, -0.02, 0.5)))
///     .collect();
/// // G_i X C_i = W  ⇒  G_i = W C_i⁻¹ X⁻¹
/// let base_from_gripper: Vec<Isometry3> =
///     camera_from_board.iter().map(|c| base_from_board * c.inverse() * x.inverse()).collect();
/// let sol = calibrate(&base_from_gripper, &camera_from_board, Method::Park, &HandEyeConfig::default())?;
/// let (angle, dist) = sol.transform.distance(&x);
/// assert!(angle < 1e-9 && dist < 1e-9);
/// assert!(sol.quality.mean_rotation_deg < 1e-6);
/// # Ok::<(), parallax_hand_eye::HandEyeError>(())
/// ```
pub fn calibrate(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    method: Method,
    config: &HandEyeConfig,
) -> Result<HandEyeSolution> {
    check_stations(base_from_gripper, camera_from_board, 3)?;
    // Unit-free from here on: every length divided by the scene scale, multiplied back at the end.
    let l = length_scale(base_from_gripper, camera_from_board);
    let g: Vec<Isometry3> = base_from_gripper.iter().map(|p| scaled(p, 1.0 / l)).collect();
    let c: Vec<Isometry3> = camera_from_board.iter().map(|p| scaled(p, 1.0 / l)).collect();
    let robot = robot_side(&g, config.setup);
    let motions = motions_from_internal(&robot, &c, config.pairs);
    check_motions(&motions, &config.degeneracy)?;
    let report = consistency::check(&robot, &c, &motions, config.setup, config.pairs, &config.consistency)?;
    let (transform, board, start, refinement) = match method {
        Method::Shah | Method::Li => {
            let b: Vec<Isometry3> = c.iter().map(Isometry3::inverse).collect();
            let (x, z) =
                if method == Method::Shah { robot_world::shah(&robot, &b)? } else { robot_world::li(&robot, &b)? };
            (x, Some(z), None, None)
        }
        Method::Refined => {
            let mut best: Option<(Method, Isometry3, f64)> = None;
            let mut last_err = None;
            for m in Method::LINEAR {
                match solve_motions(m, &motions) {
                    Ok(x) => {
                        let cost = initial_cost(&robot, &c, config.setup, &x, &config.refine, l)?;
                        if cost.is_finite() && best.as_ref().is_none_or(|b| cost < b.2) {
                            best = Some((m, x, cost));
                        }
                    }
                    Err(e) => last_err = Some(e),
                }
            }
            let (m, x0, _) = best.ok_or_else(|| last_err.expect("six solvers tried"))?;
            let r = refine(&robot, &c, &motions, config.setup, &x0, &config.refine, l)?.scaled(l);
            if !r.converged && !config.refine.allow_unconverged {
                return Err(HandEyeError::NotConverged(format!(
                    "{}; the result may not be a minimum. Hint: raise refine.lm.max_iterations or \
                     refine.max_passes, check the inputs, or accept it with refine.allow_unconverged (--allow-unconverged)",
                    r.convergence_summary()
                )));
            }
            (r.transform, Some(r.board), Some(m), Some(r))
        }
        linear => (solve_motions(linear, &motions)?, None, None, None),
    };
    let transform = if method == Method::Refined { transform } else { scaled(&transform, l) };
    let board = board.map(|b| if method == Method::Refined { b } else { scaled(&b, l) });
    // Quality on the data as given.
    let robot_orig = robot_side(base_from_gripper, config.setup);
    let motions_orig = motions_from_internal(&robot_orig, camera_from_board, config.pairs);
    let quality = quality(&robot_orig, camera_from_board, &motions_orig, &transform)?;
    let spread = axis_spread_deg(&motions, config.degeneracy.min_rotation_deg);
    let mut warnings = warnings(&report, spread, refinement.as_ref(), l, config);
    warnings.extend(check_fit(method, &motions, &transform, &report, &quality, l, config)?);
    Ok(HandEyeSolution {
        method,
        setup: config.setup,
        transform,
        board: board.unwrap_or(quality.mean_board),
        quality,
        start,
        refinement,
        length_scale: l,
        consistency: report,
        axis_spread_deg: spread,
        warnings,
    })
}

/// The plausibility checks of a solution (see [`ObservabilityConfig`]): its axis misfit against
/// the best common rotation's, each station's board frame against the others', and the motions'
/// translation residual against the scene scale. A failure is [`HandEyeError::Implausible`], or a warning with
/// `allow_poor_fit`; a translation fit between the warning and the refusal level is a warning.
fn check_fit(
    method: Method,
    motions: &[Motion],
    transform: &Isometry3,
    report: &ConsistencyReport,
    quality: &Quality,
    l: f64,
    config: &HandEyeConfig,
) -> Result<Vec<HandEyeWarning>> {
    let obs = &config.observability;
    let valid = obs.max_rotation_excess_deg >= 0.0
        && obs.warn_translation_fit_rel >= 0.0
        && obs.max_translation_fit_rel >= obs.warn_translation_fit_rel
        && obs.station_factor >= 1.0;
    if !valid {
        return Err(HandEyeError::InvalidConfig(format!("fit thresholds out of range: {obs:?}")));
    }
    let mut out = Vec::new();
    let refuse = |message: String| HandEyeError::Implausible { method: method.name(), message };
    let misfit = consistency::axis_misfit_deg(motions, transform.rotation_matrix(), &config.consistency);
    if let (Some(misfit_deg), Some(bound_deg)) = (misfit, report.axis_mismatch_deg)
        && misfit_deg > 3.0 * bound_deg + obs.max_rotation_excess_deg
    {
        if !obs.allow_poor_fit {
            return Err(refuse(format!(
                "its rotation leaves the robot and camera motion axes {misfit_deg:.2}° apart (median) where the \
                 best common rotation leaves {bound_deg:.2}° (limit 3× that + {}°): the solver failed on these \
                 data{}. Use another method (park or refined), or accept it with \
                 observability.allow_poor_fit (--allow-poor-fit)",
                obs.max_rotation_excess_deg,
                if matches!(method, Method::Daniilidis | Method::Li) {
                    " — it solves rotation and translation in one system, so noisy translations turn its rotation"
                } else {
                    ""
                },
            )));
        }
        out.push(HandEyeWarning::PoorRotationFit { misfit_deg, bound_deg });
    }
    let per: Vec<Option<f64>> = quality.station_rotation_deg.iter().map(|v| Some(*v)).collect();
    let typical = crate::quality::median(quality.station_rotation_deg.clone()).unwrap_or(0.0);
    let bad = consistency::out_of_line(&per, typical, obs.station_factor, config.consistency.min_station_mismatch_deg);
    if !bad.is_empty() && !config.consistency.allow_rotation_mismatch {
        return Err(consistency::mismatched_stations(
            &bad,
            per.len(),
            &format!(
                "board frames G·X·C turned from the other stations' by a median angle above {}× the median \
                 station's {typical:.2}° (and above {}°) in the {method} solution",
                obs.station_factor, config.consistency.min_station_mismatch_deg
            ),
        ));
    }
    // The quality was computed on the data as given: its lengths are in the data unit.
    let relative_residual = quality.mean_translation / l;
    if relative_residual > obs.max_translation_fit_rel && !obs.allow_poor_fit {
        return Err(refuse(format!(
            "the motions' translations fit it with a mean residual |t(AX) − t(XB)| of {:.6} (data unit), {:.1} % of \
             the scene scale {l:.6} (limit {:.0} %): the robot or camera positions are far noisier than a \
             calibration allows (a wrong length unit per station, poses from another session, or camera \
             positions from a failed pose fit), and the translation of X would be off by as much. Check the \
             translations, or accept it with observability.allow_poor_fit (--allow-poor-fit)",
            quality.mean_translation,
            100.0 * relative_residual,
            100.0 * obs.max_translation_fit_rel,
        )));
    }
    if relative_residual > obs.warn_translation_fit_rel {
        out.push(HandEyeWarning::PoorTranslationFit { relative_residual, residual: quality.mean_translation });
    }
    Ok(out)
}

fn warnings(
    report: &ConsistencyReport,
    spread: Option<f64>,
    refinement: Option<&Refinement>,
    l: f64,
    config: &HandEyeConfig,
) -> Vec<HandEyeWarning> {
    let obs = &config.observability;
    let mut out = Vec::new();
    if let Some(s) = spread.filter(|s| *s < obs.min_axis_spread_deg) {
        out.push(HandEyeWarning::WeakRotationAxes { spread_deg: s, threshold_deg: obs.min_axis_spread_deg });
    }
    if let Some(sd) = refinement.and_then(|r| r.std_devs) {
        let rot = sd[..3].iter().fold(0.0f64, |a, v| a.max(*v)).to_degrees();
        if rot > obs.max_rotation_sigma_deg {
            out.push(HandEyeWarning::LargeRotationSigma { sigma_deg: rot, threshold_deg: obs.max_rotation_sigma_deg });
        }
        let tr = sd[3..].iter().fold(0.0f64, |a, v| a.max(*v));
        let limit = obs.max_translation_sigma_rel * l;
        if tr > limit {
            out.push(HandEyeWarning::LargeTranslationSigma { sigma: tr, threshold: limit });
        }
    }
    if !config.consistency.allow_scale_mismatch {
        match report.scale_correlation {
            Some(c) if c < config.consistency.min_scale_correlation => {
                out.push(HandEyeWarning::ScaleUnchecked { correlation: c })
            }
            None => out.push(HandEyeWarning::ScaleUnchecked { correlation: 0.0 }),
            Some(c) => match (report.scale_ratio, report.scale_sigma) {
                (Some(ratio), Some(sigma)) if ratio.max(1.0 / ratio) > config.consistency.max_scale_ratio => {
                    out.push(HandEyeWarning::ScaleUncertain { ratio, sigma, limit: config.consistency.max_scale_ratio })
                }
                (Some(r), _) if r.max(1.0 / r) > config.consistency.warn_scale_ratio => {
                    out.push(HandEyeWarning::ScaleDisagreement { ratio: r, correlation: c })
                }
                _ => {}
            },
        }
    }
    out
}

/// The [`Quality`] of any transform `x` (for example another tool's result) on these stations:
/// residuals over the motions selected by `config.pairs` and the spread of the implied board.
pub fn evaluate(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    x: &Isometry3,
    config: &HandEyeConfig,
) -> Result<Quality> {
    check_stations(base_from_gripper, camera_from_board, 2)?;
    if !x.is_finite() {
        return Err(HandEyeError::NonFinite { what: "transform to evaluate", index: 0 });
    }
    let robot = robot_side(base_from_gripper, config.setup);
    let motions = motions_from_internal(&robot, camera_from_board, config.pairs);
    quality(&robot, camera_from_board, &motions, x)
}

/// Runs every method of `methods` on the same data; each result is independent (one failing
/// method does not hide the others).
pub fn calibrate_all(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    methods: &[Method],
    config: &HandEyeConfig,
) -> Vec<(Method, Result<HandEyeSolution>)> {
    methods.iter().map(|&m| (m, calibrate(base_from_gripper, camera_from_board, m, config))).collect()
}

/// Points measured in the camera frame, expressed in the gripper frame (eye-in-hand:
/// `p_g = gripper_from_camera · p_c`).
pub fn points_to_gripper(gripper_from_camera: &Isometry3, points_in_camera: &[DVec3]) -> Vec<DVec3> {
    points_in_camera.iter().map(|p| gripper_from_camera.transform_point(*p)).collect()
}

/// Points measured in the camera frame, expressed in the robot base frame at the station
/// where they were measured: `p_b = base_from_gripper · gripper_from_camera · p_c` (the
/// thesis's eq. 4.46). For eye-to-hand use `base_from_camera.transform_point` directly.
pub fn points_to_base(
    base_from_gripper: &Isometry3,
    gripper_from_camera: &Isometry3,
    points_in_camera: &[DVec3],
) -> Vec<DVec3> {
    let base_from_camera = *base_from_gripper * *gripper_from_camera;
    points_in_camera.iter().map(|p| base_from_camera.transform_point(*p)).collect()
}
