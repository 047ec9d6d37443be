//! The wide-lens part of [`crate::calibrate_camera`] and [`crate::calibrate_stereo`] (a
//! [`Camera`] with a Kannala–Brandt or double sphere lens), mono and stereo, from planar targets: an initialisation that needs no focal-length guess,
//! then the same maximum-likelihood refinement as the pinhole path (Levenberg–Marquardt over
//! intrinsics, lens parameters and every view pose, block-accumulated normal equations,
//! covariance `σ² (JᵀJ)⁻¹`), standard deviations, per-view errors and warnings.
//!
//! Initialisation (no guess needed): with the principal point at the image centre and the
//! lens at its neutral shape (Kannala–Brandt: equidistant `θ_d = θ`; double sphere: `ξ = 0,
//! α = ½`, the stereographic projection), every candidate focal length `f` turns the corners
//! into rays; each view's pose follows linearly from the plane ↔ ray homography (DLT on
//! `d × H q = 0`, valid for rays beyond 90°), and `f` minimises the total reprojection error
//! (a scan over 48 log-spaced values from 0.05 to 2 image sizes, then golden-section search).
//! A double sphere calibration starts from the double sphere closest to a Kannala–Brandt
//! calibration of the same corners (grid over `ξ, α`, focal scale in closed form), falling back
//! to the neutral scan if that fails.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, CameraModelError, DoubleSphere, Intrinsics, Isometry3, Lens, LensModel};
use parallax_least_squares::{
    EvaluationError, LmConfig, LmReport, Problem, levenberg_marquardt, nearest_rotation, null_vector,
};

use crate::bundle::{Bundle, CameraSlots, Slot, ViewObs, pose_at, store_pose};
use crate::calibrate::{
    CalibrationConfig, CalibrationResult, CalibrationWarning, IntrinsicStdDevs, mono_solution, outlier_views,
    refine_mono, view_spread_deg,
};
use crate::{CalibrationError, Result};

/// Length of the full per-camera parameter vector `(fx, fy, cx, cy, skew, l0, l1, l2, l3)`
/// (`l` = lens parameters in the model's order; double sphere uses `l0 = ξ`, `l1 = α`).
const N_FULL: usize = 9;

/// The parametrisation of one camera.
#[derive(Debug, Clone)]
pub(crate) struct Slots {
    slots: [Slot; N_FULL],
    num_free: usize,
    template: Camera,
}

fn full_of(c: &Camera) -> [f64; N_FULL] {
    let k = c.intrinsics();
    let l = c.lens().parameters();
    let mut t = [k.fx, k.fy, k.cx, k.cy, k.skew, 0.0, 0.0, 0.0, 0.0];
    t[5..5 + l.len()].copy_from_slice(&l);
    t
}

impl Slots {
    pub(crate) fn new(cfg: &CalibrationConfig, init: &Camera, all_fixed: bool) -> Self {
        let theta = full_of(init);
        let mut slots: [Slot; N_FULL] = std::array::from_fn(|i| Slot::Fixed(theta[i]));
        if all_fixed {
            return Self { slots, num_free: 0, template: *init };
        }
        let mut n = 0;
        let mut free = |slots: &mut [Slot; N_FULL], i: usize| {
            slots[i] = Slot::Free { index: n, scale: 1.0 };
            n += 1;
        };
        free(&mut slots, 1);
        if cfg.fix_aspect_ratio {
            slots[0] = Slot::Free { index: 0, scale: theta[0] / theta[1] };
        } else {
            free(&mut slots, 0);
        }
        if !cfg.fix_principal_point {
            free(&mut slots, 2);
            free(&mut slots, 3);
        }
        if cfg.estimate_skew {
            free(&mut slots, 4);
        }
        let fix_lens = fix_lens(cfg);
        for i in 0..init.lens().num_parameters() {
            if !fix_lens[i] {
                free(&mut slots, 5 + i);
            }
        }
        Self { slots, num_free: n, template: *init }
    }

    fn full(&self, free: &[f64]) -> [f64; N_FULL] {
        std::array::from_fn(|i| match self.slots[i] {
            Slot::Fixed(v) => v,
            Slot::Free { index, scale } => scale * free[index],
        })
    }

    fn camera(&self, free: &[f64]) -> std::result::Result<Camera, CameraModelError> {
        let t = self.full(free);
        let nl = self.template.lens().num_parameters();
        let lens = self.template.lens().with_parameters(&t[5..5 + nl])?;
        Camera::new(
            Intrinsics { fx: t[0], fy: t[1], cx: t[2], cy: t[3], skew: t[4] },
            lens,
            self.template.width(),
            self.template.height(),
        )
    }

    fn free_values(&self, c: &Camera) -> Vec<f64> {
        let theta = full_of(c);
        let mut out = vec![0.0; self.num_free];
        for (i, s) in self.slots.iter().enumerate() {
            if let Slot::Free { index, scale } = *s {
                out[index] = theta[i] / scale;
            }
        }
        out
    }

    pub(crate) fn std_devs(&self, offset: usize, cov: Option<&faer::Mat<f64>>) -> IntrinsicStdDevs {
        let a: [Option<f64>; N_FULL] = std::array::from_fn(|i| match self.slots[i] {
            Slot::Fixed(_) => None,
            Slot::Free { index, scale } => {
                Some(cov.map_or(f64::NAN, |c| scale.abs() * c[(offset + index, offset + index)].max(0.0).sqrt()))
            }
        });
        let k = IntrinsicStdDevs { fx: a[0], fy: a[1], cx: a[2], cy: a[3], skew: a[4], ..Default::default() };
        match self.template.lens_model() {
            LensModel::DoubleSphere => IntrinsicStdDevs { xi: a[5], alpha: a[6], ..k },
            _ => IntrinsicStdDevs { k1: a[5], k2: a[6], k3: a[7], k4: a[8], ..k },
        }
    }
}

impl CameraSlots for Slots {
    type Camera = Camera;
    fn slots(&self) -> &[Slot] {
        &self.slots
    }
    fn num_free(&self) -> usize {
        self.num_free
    }
    fn camera(&self, free: &[f64]) -> std::result::Result<Camera, EvaluationError> {
        Slots::camera(self, free).map_err(|e| EvaluationError(e.to_string()))
    }
    fn free_values(&self, camera: &Camera) -> Vec<f64> {
        Slots::free_values(self, camera)
    }
    fn project(
        camera: &Camera,
        pose: &Isometry3,
        x: DVec3,
    ) -> parallax_camera_model::Result<parallax_camera_model::ProjectionJacobians> {
        camera.project_with_jacobians(pose, x)
    }
}

/// The pose of a plane seen along unit rays: DLT of `d × (H q) = 0` (all three rows, so rays
/// at or beyond 90° from the axis are fine) on similarity-normalised plane points, then
/// `H = λ [r1 r2 t]` with the sign that puts the points in front along their rays and the
/// rotation projected onto SO(3).
pub(crate) fn pose_from_rays(plane: &[DVec2], rays: &[DVec3]) -> Result<Isometry3> {
    let n = plane.len() as f64;
    let c = plane.iter().copied().sum::<DVec2>() / n;
    let spread = plane.iter().map(|p| (*p - c).length()).sum::<f64>() / n;
    if spread.is_nan() || spread <= 0.0 {
        return Err(CalibrationError::Degenerate("all plane points coincide".into()));
    }
    let s = std::f64::consts::SQRT_2 / spread;
    let mut a = faer::Mat::<f64>::zeros(3 * plane.len(), 9);
    for (i, (p, d)) in plane.iter().zip(rays).enumerate() {
        let q = [(p.x - c.x) * s, (p.y - c.y) * s, 1.0];
        // d × (H q): rows of H are h0, h1, h2; (H q)_k = h_k · q.
        // x: d_y (h2·q) − d_z (h1·q); y: d_z (h0·q) − d_x (h2·q); z: d_x (h1·q) − d_y (h0·q)
        for k in 0..3 {
            a[(3 * i, 6 + k)] = d.y * q[k];
            a[(3 * i, 3 + k)] = -d.z * q[k];
            a[(3 * i + 1, k)] = d.z * q[k];
            a[(3 * i + 1, 6 + k)] = -d.x * q[k];
            a[(3 * i + 2, 3 + k)] = d.x * q[k];
            a[(3 * i + 2, k)] = -d.y * q[k];
        }
    }
    let nv = null_vector(a.as_ref())?;
    let h = &nv.vector;
    let hn = DMat3::from_cols(DVec3::new(h[0], h[3], h[6]), DVec3::new(h[1], h[4], h[7]), DVec3::new(h[2], h[5], h[8]));
    let t = DMat3::from_cols(DVec3::new(s, 0.0, 0.0), DVec3::new(0.0, s, 0.0), DVec3::new(-s * c.x, -s * c.y, 1.0));
    let m = hn * t;
    let (c0, c1, c2) = (m.col(0), m.col(1), m.col(2));
    let scale = 0.5 * (c0.length() + c1.length());
    if !(scale.is_finite() && scale > 0.0) {
        return Err(CalibrationError::Degenerate("plane ↔ ray homography is degenerate".into()));
    }
    let front: f64 = plane.iter().zip(rays).map(|(p, d)| d.dot(m * p.extend(1.0))).sum();
    let lambda = if front < 0.0 { -1.0 / scale } else { 1.0 / scale };
    let (r1, r2, tr) = (c0 * lambda, c1 * lambda, c2 * lambda);
    let r = nearest_rotation(DMat3::from_cols(r1, r2, r1.cross(r2)))?;
    Ok(Isometry3::from_rotation_translation(r, tr)?)
}

/// The held lens parameters of `cfg`, in the lens model's order (`k1..k4`, or `ξ, α`).
fn fix_lens(cfg: &CalibrationConfig) -> [bool; 4] {
    match cfg.lens {
        LensModel::DoubleSphere => [cfg.fix_xi, cfg.fix_alpha, false, false],
        _ => [cfg.fix_k1, cfg.fix_k2, cfg.fix_k3, cfg.fix_k4],
    }
}

/// [`crate::solve_pnp_planar_points`] for a wide lens: the pose from the plane ↔ ray DLT of the
/// unprojected corners ([`pose_from_rays`], valid beyond 90° from the axis), refined by
/// Levenberg–Marquardt on the reprojection error with the camera held; returns the pose and the
/// RMS error in pixels.
pub(crate) fn solve_pnp_wide(camera: &Camera, object: &[DVec3], image: &[DVec2]) -> Result<(Isometry3, f64)> {
    let rays = image
        .iter()
        .enumerate()
        .map(|(i, q)| {
            camera.unproject(*q).map_err(|e| {
                CalibrationError::EstimationFailed(format!("pose: corner {i} at ({}, {}) has no ray: {e}", q.x, q.y))
            })
        })
        .collect::<Result<Vec<DVec3>>>()?;
    let plane: Vec<DVec2> = object.iter().map(|p| p.truncate()).collect();
    let init = pose_from_rays(&plane, &rays)?;
    let held = CalibrationConfig { lens: camera.lens_model(), ..CalibrationConfig::default() };
    let bundle = Bundle::new(vec![Slots::new(&held, camera, true)], vec![ViewObs::mono(object, image)]);
    let mut x0 = vec![0.0; 6];
    store_pose(&init, &mut x0);
    let cfg = LmConfig { max_iterations: 50, covariance: false, cost_tolerance: 1e-14, ..LmConfig::default() };
    let report = levenberg_marquardt(&bundle, &x0, &cfg)?;
    let residuals = bundle.residuals_by_view(&report.params).map_err(|e| CalibrationError::EstimationFailed(e.0))?;
    Ok((pose_at(&report.params), crate::calibrate::rms_of(&residuals[0][0])))
}

/// Poses of every view for a given camera (rays from unprojecting the corners), or `None`
/// when a corner cannot be unprojected.
fn poses_for(camera: &Camera, object: &[Vec<DVec3>], image: &[Vec<DVec2>]) -> Option<Vec<Isometry3>> {
    object
        .iter()
        .zip(image)
        .map(|(o, i)| {
            let rays: Option<Vec<DVec3>> = i.iter().map(|q| camera.unproject(*q).ok()).collect();
            let plane: Vec<DVec2> = o.iter().map(|p| p.truncate()).collect();
            pose_from_rays(&plane, &rays?).ok()
        })
        .collect()
}

/// Sum of squared reprojection errors (a corner that cannot be projected costs `penalty`).
fn sse(camera: &Camera, poses: &[Isometry3], object: &[Vec<DVec3>], image: &[Vec<DVec2>], penalty: f64) -> f64 {
    let mut s = 0.0;
    for ((p, o), i) in poses.iter().zip(object).zip(image) {
        for (x, q) in o.iter().zip(i) {
            s += camera.project_from(p, *x).map_or(penalty, |u| (u - *q).length_squared().min(penalty));
        }
    }
    s
}

/// The initial cameras and poses to refine (the refinement keeps the lowest cost): the guess,
/// or the focal scan (see the module docs); for double sphere, one start per band of `ξ` fitted
/// to a Kannala–Brandt calibration.
fn initial_estimates(
    (object, image): (&[Vec<DVec3>], &[Vec<DVec2>]),
    (width, height): (u32, u32),
    cfg: &CalibrationConfig,
) -> Result<Vec<(Camera, Vec<Isometry3>)>> {
    if let Some(guess) = &cfg.intrinsic_guess {
        let poses = poses_for(guess, object, image).ok_or_else(|| {
            CalibrationError::EstimationFailed(
                "a corner lies outside the intrinsic guess's valid region (its ray cannot be found)".into(),
            )
        })?;
        return Ok(vec![(*guess, poses)]);
    }
    if cfg.lens == LensModel::DoubleSphere {
        let kb_cfg = CalibrationConfig {
            lens: LensModel::KannalaBrandt,
            fix_k1: false,
            fix_k2: false,
            fix_k3: false,
            fix_k4: false,
            fix_xi: false,
            fix_alpha: false,
            estimate_skew: false,
            ..cfg.clone()
        };
        if let Ok(kb) = calibrate_wide((object, image), (width, height), &kb_cfg) {
            let starts = double_sphere_from_kannala_brandt(&kb.camera, &kb.camera_from_board, object);
            if !starts.is_empty() {
                return Ok(starts.into_iter().map(|c| (c, kb.camera_from_board.clone())).collect());
            }
        }
    }
    let centre = (0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
    let lens = cfg.lens.neutral();
    let size = width.max(height) as f64;
    let penalty = size * size;
    let eval = |f: f64| -> (f64, Option<(Camera, Vec<Isometry3>)>) {
        let Ok(cam) = Camera::new(Intrinsics::new(f, f, centre.0, centre.1), lens, width, height) else {
            return (f64::INFINITY, None);
        };
        match poses_for(&cam, object, image) {
            Some(poses) => (sse(&cam, &poses, object, image, penalty), Some((cam, poses))),
            None => (f64::INFINITY, None),
        }
    };
    const SCAN: usize = 48;
    let (lo, hi) = ((0.05 * size).ln(), (2.0 * size).ln());
    let grid: Vec<f64> = (0..SCAN).map(|i| (lo + (hi - lo) * i as f64 / (SCAN - 1) as f64).exp()).collect();
    let costs: Vec<f64> = grid.iter().map(|&f| eval(f).0).collect();
    let best = (0..SCAN).min_by(|&a, &b| costs[a].total_cmp(&costs[b])).expect("non-empty scan");
    if !costs[best].is_finite() {
        return Err(CalibrationError::EstimationFailed(format!(
            "no focal length between {:.0} and {:.0} px turns the corners into rays of a {:?} lens; check the \
             image size and the corner coordinates",
            grid[0],
            grid[SCAN - 1],
            cfg.lens
        )));
    }
    // Golden-section search on ln f between the neighbours of the best grid value.
    let (mut a, mut b) = (grid[best.saturating_sub(1)].ln(), grid[(best + 1).min(SCAN - 1)].ln());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (eval(x1.exp()).0, eval(x2.exp()).0);
    for _ in 0..40 {
        if f1 < f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - g * (b - a);
            f1 = eval(x1.exp()).0;
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + g * (b - a);
            f2 = eval(x2.exp()).0;
        }
    }
    let f = if f1.min(f2) < costs[best] { (0.5 * (a + b)).exp() } else { grid[best] };
    let (_, init) = eval(f);
    let (mut camera, poses) = match init {
        Some(x) => x,
        None => eval(grid[best]).1.expect("the best grid value evaluated"),
    };
    if cfg.fix_aspect_ratio {
        camera = camera.with_intrinsics(Intrinsics { fx: camera.intrinsics().fy, ..camera.intrinsics() })?;
    }
    Ok(vec![(camera, poses)])
}

/// The closed-form start of one wide camera from its views (the start of
/// [`initial_estimates`] with the lowest reprojection error), for a rig calibration.
pub(crate) fn initial_camera(
    views: (&[Vec<DVec3>], &[Vec<DVec2>]),
    (width, height): (u32, u32),
    cfg: &CalibrationConfig,
) -> Result<(Camera, Vec<Isometry3>)> {
    let size = width.max(height) as f64;
    let starts = initial_estimates(views, (width, height), cfg)?;
    let cost = |(c, p): &(Camera, Vec<Isometry3>)| sse(c, p, views.0, views.1, size * size);
    starts
        .into_iter()
        .min_by(|a, b| cost(a).total_cmp(&cost(b)))
        .ok_or_else(|| CalibrationError::EstimationFailed("no initial estimate".into()))
}

/// The double sphere cameras closest to a calibrated Kannala–Brandt one over the field angles
/// the corners reach: `(ξ, α)` on a grid (ξ ∈ [−0.9, 0.9] by 0.025, α ∈ [0.025, 0.975] by
/// 0.025), the focal scale in closed form (least squares of `s·r_DS(θ) = r_KB(θ)` over 200
/// angles); the best fit in each of the three bands ξ < −0.3, −0.3 ≤ ξ < 0.3, ξ ≥ 0.3 is kept.
/// These are the double sphere starts: `fx` and `ξ` are nearly interchangeable (near the axis
/// only `fx/(1 + ξ)` is seen), the cost has several valleys, and a single start (the neutral
/// `ξ = 0, α = ½`, or the single best fit) lands in a wrong one for some view sets (1 in 100
/// in the seeded trials); the refinement runs from each start and keeps the lowest cost.
fn double_sphere_from_kannala_brandt(kb: &Camera, poses: &[Isometry3], object: &[Vec<DVec3>]) -> Vec<Camera> {
    let Lens::KannalaBrandt(model) = kb.lens() else { return Vec::new() };
    let theta_max = poses
        .iter()
        .zip(object)
        .flat_map(|(p, o)| o.iter().map(move |x| p.transform_point(*x)))
        .map(|q| (q.z / q.length()).clamp(-1.0, 1.0).acos())
        .fold(0.0, f64::max)
        .min(0.999 * model.max_theta());
    if theta_max.is_nan() || theta_max <= 0.0 {
        return Vec::new();
    }
    let thetas: Vec<f64> = (1..=200).map(|i| theta_max * i as f64 / 200.0).collect();
    let target: Vec<f64> = thetas.iter().map(|&t| model.distort_theta(t)).collect();
    let mut best: [Option<(f64, Lens, f64)>; 3] = [None; 3];
    for i in 0..=72 {
        let xi = -0.9 + 0.025 * i as f64;
        for j in 1..=39 {
            let alpha = 0.025 * j as f64;
            let Ok(ds) = DoubleSphere::new(xi, alpha) else { continue };
            let lens = Lens::DoubleSphere(ds);
            let g: Option<Vec<f64>> = thetas
                .iter()
                .map(|&t| lens.project_normalized(DVec3::new(t.sin(), 0.0, t.cos())).ok().map(|(m, _, _)| m.x))
                .collect();
            let Some(g) = g else { continue };
            let gg: f64 = g.iter().map(|v| v * v).sum();
            let scale = g.iter().zip(&target).map(|(a, b)| a * b).sum::<f64>() / gg;
            let err: f64 = g.iter().zip(&target).map(|(a, b)| (scale * a - b).powi(2)).sum();
            let band = if i < 24 {
                0
            } else if i < 48 {
                1
            } else {
                2
            };
            if scale > 0.0 && best[band].as_ref().is_none_or(|b| err < b.0) {
                best[band] = Some((err, lens, scale));
            }
        }
    }
    let k = kb.intrinsics();
    best.iter()
        .flatten()
        .filter_map(|&(_, lens, scale)| {
            Camera::new(
                Intrinsics { fx: k.fx * scale, fy: k.fy * scale, cx: k.cx, cy: k.cy, skew: 0.0 },
                lens,
                kb.width(),
                kb.height(),
            )
            .ok()
        })
        .collect()
}

/// Largest field angle (degrees) of the midpoints of the four image edges that unproject
/// (the image's horizontal or vertical half field of view; the image corners, rarely covered
/// by a board, are left out).
fn image_field_deg(camera: &Camera) -> f64 {
    let (w, h) = (camera.width() as f64 - 1.0, camera.height() as f64 - 1.0);
    [DVec2::new(0.5 * w, 0.0), DVec2::new(0.5 * w, h), DVec2::new(0.0, 0.5 * h), DVec2::new(w, 0.5 * h)]
        .iter()
        .filter_map(|p| camera.unproject(*p).ok())
        .map(|r| r.z.clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max)
}

pub(crate) fn lens_warnings(
    warnings: &mut Vec<CalibrationWarning>,
    camera: &Camera,
    index: usize,
    poses: &[Isometry3],
    object: &[Vec<DVec3>],
    cfg: &CalibrationConfig,
) {
    let k = camera.intrinsics();
    let corners = [
        DVec2::new(-0.5, -0.5),
        DVec2::new(camera.width() as f64 - 0.5, -0.5),
        DVec2::new(-0.5, camera.height() as f64 - 0.5),
        DVec2::new(camera.width() as f64 - 0.5, camera.height() as f64 - 0.5),
    ];
    let rho_max = corners.iter().map(|c| k.to_normalized(*c).length()).fold(0.0, f64::max);
    if let Lens::KannalaBrandt(kb) = camera.lens()
        && kb.max_theta() < std::f64::consts::PI
    {
        let fold = kb.distort_theta(kb.max_theta());
        if fold < rho_max {
            warnings.push(CalibrationWarning::LensFoldsInsideImage {
                camera: index,
                max_field_deg: kb.max_theta().to_degrees(),
                radius_px: fold * k.fx,
                image_radius_px: rho_max * k.fx,
            });
        }
    }
    let observed = poses
        .iter()
        .zip(object)
        .flat_map(|(p, o)| o.iter().map(move |x| p.transform_point(*x)))
        .map(|q| (q.z / q.length()).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max);
    let image = image_field_deg(camera);
    if observed < cfg.min_field_coverage * image {
        warnings.push(CalibrationWarning::ExtrapolatedPeriphery {
            camera: index,
            observed_deg: observed,
            image_deg: image,
        });
    }
}

fn common_warnings(
    warnings: &mut Vec<CalibrationWarning>,
    poses: &[Isometry3],
    cfg: &CalibrationConfig,
    report: &LmReport,
) {
    let recommended = if cfg.fix_principal_point { 2 } else { 3 };
    if poses.len() < recommended {
        warnings.push(CalibrationWarning::TooFewViews { views: poses.len(), recommended });
    }
    let spread = view_spread_deg(poses);
    if cfg.intrinsic_guess.is_none() && spread < cfg.min_view_spread_deg {
        warnings
            .push(CalibrationWarning::SimilarViews { max_angle_deg: spread, threshold_deg: cfg.min_view_spread_deg });
    }
    if !report.stop_reason.converged() {
        warnings.push(CalibrationWarning::NotConverged { iterations: report.iterations });
    }
}

/// [`crate::calibrate_camera`] for a wide lens: `object_points[v]` on the plane `z = 0`
/// (board units), `image_points[v]` the observed pixels in the same order; no focal-length
/// guess is needed (see the module docs). The inputs and the configuration are checked by the
/// caller.
pub(crate) fn calibrate_wide(
    (object_points, image_points): (&[Vec<DVec3>], &[Vec<DVec2>]),
    size: (u32, u32),
    config: &CalibrationConfig,
) -> Result<CalibrationResult> {
    let starts = initial_estimates((object_points, image_points), size, config)?;
    // (the refinement runs from each start and keeps the lowest cost; a start that fails is
    // passed over while another succeeds)
    let mut best: Option<(Slots, Bundle<Slots>, LmReport)> = None;
    let mut last_error = None;
    for (init_camera, init_poses) in &starts {
        let slots = Slots::new(config, init_camera, false);
        match refine_mono(&slots, (init_camera, init_poses), object_points, image_points, &config.lm) {
            Ok((bundle, report)) => {
                if best.as_ref().is_none_or(|(_, _, b)| report.cost < b.cost) {
                    best = Some((slots, bundle, report));
                }
            }
            Err(e @ CalibrationError::TooFewPoints { .. }) => return Err(e),
            Err(e) => last_error = Some(e),
        }
    }
    let (slots, bundle, report) = match (best, last_error) {
        (Some(b), _) => b,
        (None, Some(e)) => return Err(e),
        (None, None) => return Err(CalibrationError::EstimationFailed("no initial estimate".into())),
    };
    let n = bundle.num_params();
    let solution = mono_solution(&bundle, &report, config.intrinsic_guess.is_none() && !config.fix_principal_point)?;
    let camera = slots
        .camera(&report.params[..slots.num_free])
        .map_err(|e| CalibrationError::EstimationFailed(format!("refined camera is invalid: {e}")))?;
    if let Some(cov) = report.covariance.as_ref() {
        crate::calibrate::check_focal(&slots.slots, &camera, 0, cov, config)?;
    }
    let std_devs = slots.std_devs(0, report.covariance.as_ref());
    let mut warnings = outlier_views(&solution.per_view_rms_px, config.outlier_view_factor, 0);
    common_warnings(&mut warnings, &solution.poses, config, &report);
    lens_warnings(&mut warnings, &camera, 0, &solution.poses, object_points, config);
    Ok(solution.into_result(camera, std_devs, n, &report, warnings))
}

#[cfg(test)]
mod tests {
    use super::*;
    use parallax_camera_model::KannalaBrandt;

    /// The analytic Jacobian of a two-camera wide-lens bundle (through `retract`) matches central
    /// differences, and the block-accumulated normal equations equal `JᵀJ`, `Jᵀr`.
    #[test]
    fn bundle_jacobian_matches_finite_differences_and_normal_equations() {
        let kb = Camera::new(
            Intrinsics { fx: 300.0, fy: 298.0, cx: 512.0, cy: 384.0, skew: 0.2 },
            Lens::KannalaBrandt(KannalaBrandt::new(0.02, -0.004, 0.001, -0.0002).unwrap()),
            1024,
            768,
        )
        .unwrap();
        let ds = Camera::new(
            Intrinsics::new(330.0, 331.0, 510.0, 380.0),
            Lens::DoubleSphere(DoubleSphere::new(-0.15, 0.6).unwrap()),
            1024,
            768,
        )
        .unwrap();
        let object: Vec<DVec3> =
            (0..12).map(|i| DVec3::new((i % 4) as f64 * 30.0, (i / 4) as f64 * 30.0, 0.0)).collect();
        let image: Vec<DVec2> = (0..12).map(|i| DVec2::new(300.0 + i as f64, 200.0 - i as f64)).collect();
        let cfg = CalibrationConfig { lens: LensModel::KannalaBrandt, estimate_skew: true, ..Default::default() };
        let sight = Some(crate::bundle::Sight { object: &object, image: &image });
        let views = vec![ViewObs { sights: vec![sight, sight] }, ViewObs { sights: vec![sight, sight] }];
        let b = Bundle::new(vec![Slots::new(&cfg, &kb, false), Slots::new(&cfg, &ds, false)], views);
        let n = b.num_params();
        let mut x = vec![0.0; n];
        x[..9].copy_from_slice(&b.cams[0].free_values(&kb));
        let o1 = b.cam_offsets[1];
        x[o1..o1 + b.cams[1].num_free].copy_from_slice(&b.cams[1].free_values(&ds));
        let ro = b.rig_offsets[1].unwrap();
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.03), DVec3::new(-100.0, 2.0, 1.0)),
            &mut x[ro..ro + 6],
        );
        // The second view is 100° off axis: behind the image plane.
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(0.3, -0.2, 0.1), DVec3::new(-40.0, -30.0, 300.0)),
            &mut x[b.view_offset(0)..b.view_offset(0) + 6],
        );
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(0.1, 1.4, 0.0), DVec3::new(300.0, -20.0, -50.0)),
            &mut x[b.view_offset(1)..b.view_offset(1) + 6],
        );
        crate::bundle::check_derivatives(&b, &x, b.num_global, 0.1);
    }

    /// `pose_from_rays` recovers a pose exactly from noise-free rays, also when the board lies
    /// beside the camera (rays beyond 90° from the axis).
    #[test]
    fn pose_from_rays_is_exact_beyond_90_degrees() {
        let plane: Vec<DVec2> = (0..20).map(|i| DVec2::new((i % 5) as f64 * 25.0, (i / 5) as f64 * 25.0)).collect();
        for pose in [
            Isometry3::from_rvec_tvec(DVec3::new(0.2, -0.1, 0.3), DVec3::new(-50.0, -40.0, 400.0)),
            Isometry3::from_rvec_tvec(DVec3::new(0.1, 2.0, 0.0), DVec3::new(300.0, 0.0, -60.0)),
        ] {
            let rays: Vec<DVec3> = plane.iter().map(|p| pose.transform_point(p.extend(0.0)).normalize()).collect();
            assert!(rays.iter().any(|r| r.z < 0.0) || pose.translation.z > 0.0);
            let got = pose_from_rays(&plane, &rays).unwrap();
            let (angle, dist) = got.distance(&pose);
            assert!(angle < 1e-9 && dist < 1e-7, "angle {angle}, distance {dist}");
        }
    }
}
