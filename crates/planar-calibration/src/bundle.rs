//! The bundle problem shared by mono calibration, rig calibration (any number of cameras) and
//! pose-only solving: global parameters (the free intrinsics of every camera, then
//! `camI_from_cam0` for each camera `I ≥ 1`) followed by one 6-vector pose per view.
//! `normal_equations` accumulates `JᵀJ` block by block (camera blocks, extrinsic blocks,
//! per-view 6x6 blocks and their couplings) without forming `J`; the solver eliminates the
//! view blocks (`block_diagonal_tail`). One problem
//! for every camera model: a model enters through [`CameraSlots`] (pinhole with distortion
//! here, the fisheye models in `fisheye.rs`).

use faer::{Col, Mat, MatMut};
use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, ProjectionJacobians};
use parallax_least_squares::{EvaluationError, Problem};

/// Length of the full intrinsic vector `(fx, fy, cx, cy, skew, k1, k2, p1, p2, k3, k4, k5, k6)`.
pub(crate) const N_INTR: usize = 13;

/// How one full intrinsic parameter is obtained from the parameter vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Slot {
    /// Held at this value.
    Fixed(f64),
    /// `value = scale · params[camera offset + index]`.
    Free { index: usize, scale: f64 },
}

/// The parametrisation of one camera of a [`Bundle`]: which of its parameters are free (its
/// slots, in the order of [`ProjectionJacobians`]' intrinsics then distortion or lens
/// parameters) and the camera a free-parameter vector makes.
pub(crate) trait CameraSlots {
    /// The camera model.
    type Camera;
    /// One slot per parameter.
    fn slots(&self) -> &[Slot];
    /// How many slots are free.
    fn num_free(&self) -> usize;
    /// The camera of the free values `free`, or why there is none (a bundle step that leaves
    /// the model's domain).
    fn camera(&self, free: &[f64]) -> Result<Self::Camera, EvaluationError>;
    /// The free values of `camera` (the inverse of [`CameraSlots::camera`]).
    fn free_values(&self, camera: &Self::Camera) -> Vec<f64>;
    /// The pixel of `x` (object frame) seen from `pose`, with its derivatives.
    fn project(camera: &Self::Camera, pose: &Isometry3, x: DVec3)
    -> parallax_camera_model::Result<ProjectionJacobians>;
}

impl CameraSlots for CameraModelSlots {
    type Camera = Camera;
    fn slots(&self) -> &[Slot] {
        &self.slots
    }
    fn num_free(&self) -> usize {
        self.num_free
    }
    fn camera(&self, free: &[f64]) -> Result<Camera, EvaluationError> {
        let c = CameraModelSlots::camera(self, free);
        if !(c.intrinsics.fx > 0.0 && c.intrinsics.fy > 0.0) {
            return Err(EvaluationError("non-positive focal length".into()));
        }
        Ok(c)
    }
    fn free_values(&self, camera: &Camera) -> Vec<f64> {
        CameraModelSlots::free_values(self, camera)
    }
    fn project(camera: &Camera, pose: &Isometry3, x: DVec3) -> parallax_camera_model::Result<ProjectionJacobians> {
        camera.project_with_jacobians(pose, x)
    }
}

/// The parametrisation of one camera's intrinsics.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CameraModelSlots {
    pub slots: [Slot; N_INTR],
    pub num_free: usize,
    pub width: u32,
    pub height: u32,
}

impl CameraModelSlots {
    /// The free-parameter vector of `camera` under this parametrisation.
    pub fn free_values(&self, camera: &Camera) -> Vec<f64> {
        let theta = theta_of(camera);
        let mut out = vec![0.0; self.num_free];
        for (i, s) in self.slots.iter().enumerate() {
            if let Slot::Free { index, scale } = *s {
                out[index] = theta[i] / scale;
            }
        }
        out
    }

    pub fn camera(&self, free: &[f64]) -> Camera {
        let theta: [f64; N_INTR] = std::array::from_fn(|i| match self.slots[i] {
            Slot::Fixed(v) => v,
            Slot::Free { index, scale } => scale * free[index],
        });
        camera_of(&theta, self.width, self.height)
    }
}

pub(crate) fn theta_of(c: &Camera) -> [f64; N_INTR] {
    let k = &c.intrinsics;
    // (a Brown–Conrady camera: `calibrate_camera` refuses a wide-lens guess)
    let d = c.distortion().map_or([0.0; 8], |d| d.to_array());
    [k.fx, k.fy, k.cx, k.cy, k.skew, d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7]]
}

pub(crate) fn camera_of(t: &[f64; N_INTR], width: u32, height: u32) -> Camera {
    Camera {
        intrinsics: Intrinsics { fx: t[0], fy: t[1], cx: t[2], cy: t[3], skew: t[4] },
        lens: Distortion::from_array([t[5], t[6], t[7], t[8], t[9], t[10], t[11], t[12]]).into(),
        width,
        height,
    }
}

pub(crate) fn pose_at(p: &[f64]) -> Isometry3 {
    Isometry3::from_rvec_tvec(DVec3::new(p[0], p[1], p[2]), DVec3::new(p[3], p[4], p[5]))
}

pub(crate) fn store_pose(pose: &Isometry3, out: &mut [f64]) {
    let r = pose.rvec();
    out[..3].copy_from_slice(&r.to_array());
    out[3..6].copy_from_slice(&pose.translation.to_array());
}

/// What one camera saw of the target in one view: object points and their pixels, in the
/// same order.
#[derive(Clone, Copy)]
pub(crate) struct Sight<'a> {
    pub object: &'a [DVec3],
    pub image: &'a [DVec2],
}

/// One view (frame): per camera of the bundle, what it saw, if it saw the target.
pub(crate) struct ViewObs<'a> {
    pub sights: Vec<Option<Sight<'a>>>,
}

impl<'a> ViewObs<'a> {
    /// A view of a one-camera bundle.
    pub fn mono(object: &'a [DVec3], image: &'a [DVec2]) -> Self {
        Self { sights: vec![Some(Sight { object, image })] }
    }
}

/// The bundle of any number of cameras: their free intrinsics, then `camI_from_cam0` for every
/// camera `I ≥ 1`, then one `cam0_from_board` per view (camera `I` sees the view through
/// `camI_from_cam0 ∘ cam0_from_board`, whether or not camera 0 saw it).
pub(crate) struct Bundle<'a, S: CameraSlots> {
    pub cams: Vec<S>,
    pub cam_offsets: Vec<usize>,
    /// Offset of `camI_from_cam0` per camera (`None` for camera 0).
    pub rig_offsets: Vec<Option<usize>>,
    pub num_global: usize,
    pub views: Vec<ViewObs<'a>>,
    pub num_residuals: usize,
}

impl<'a, S: CameraSlots> Bundle<'a, S> {
    pub fn new(cams: Vec<S>, views: Vec<ViewObs<'a>>) -> Self {
        let mut cam_offsets = Vec::with_capacity(cams.len());
        let mut off = 0;
        for c in &cams {
            cam_offsets.push(off);
            off += c.num_free();
        }
        let mut rig_offsets = vec![None];
        for _ in 1..cams.len() {
            rig_offsets.push(Some(off));
            off += 6;
        }
        let num_residuals =
            views.iter().map(|v| v.sights.iter().flatten().map(|s| 2 * s.image.len()).sum::<usize>()).sum();
        Self { cams, cam_offsets, rig_offsets, num_global: off, views, num_residuals }
    }

    pub fn view_offset(&self, v: usize) -> usize {
        self.num_global + 6 * v
    }

    /// The cameras of `params`.
    pub fn cameras(&self, params: &[f64]) -> Result<Vec<S::Camera>, EvaluationError> {
        self.cams.iter().zip(&self.cam_offsets).map(|(c, &o)| c.camera(&params[o..o + c.num_free()])).collect()
    }

    /// `camI_from_cam0` of every camera at `params` (identity for camera 0).
    pub fn extrinsics(&self, params: &[f64]) -> Vec<Isometry3> {
        self.rig_offsets.iter().map(|o| o.map_or(Isometry3::IDENTITY, |o| pose_at(&params[o..o + 6]))).collect()
    }

    /// Visits every observation: `f(view, camera, residual, entries)` where `entries` lists
    /// `(parameter index, ∂r/∂p)` (the non-zero Jacobian columns of this 2-row block).
    fn for_each_observation(
        &self,
        params: &[f64],
        mut f: impl FnMut(usize, usize, DVec2, &[(usize, [f64; 2])]),
    ) -> Result<(), EvaluationError> {
        let cameras = self.cameras(params)?;
        let rigs = self.extrinsics(params);
        // Adjoint of each extrinsic for the left perturbation (ω, v): [[R, 0], [[t]× R, R]].
        let adjoints: Vec<[[f64; 6]; 6]> = rigs
            .iter()
            .map(|e| {
                let r = e.rotation_matrix();
                let tx = parallax_camera_model::skew_symmetric(e.translation) * r;
                let mut a = [[0.0; 6]; 6];
                for i in 0..3 {
                    for j in 0..3 {
                        a[i][j] = r.col(j)[i];
                        a[3 + i][3 + j] = r.col(j)[i];
                        a[3 + i][j] = tx.col(j)[i];
                    }
                }
                a
            })
            .collect();
        let mut entries: Vec<(usize, [f64; 2])> = Vec::with_capacity(32);
        for (v, view) in self.views.iter().enumerate() {
            let vo = self.view_offset(v);
            let reference = pose_at(&params[vo..vo + 6]);
            for (c, sight) in view.sights.iter().enumerate() {
                let Some(sight) = sight else { continue };
                let slots = &self.cams[c];
                let camera = &cameras[c];
                let pose = if c == 0 { reference } else { rigs[c] * reference };
                for (i, (x, q)) in sight.object.iter().zip(sight.image).enumerate() {
                    let pj = S::project(camera, &pose, *x)
                        .map_err(|e| EvaluationError(format!("view {v}, camera {c}, point {i}: {e}")))?;
                    let r = pj.pixel - *q;
                    entries.clear();
                    // Intrinsics.
                    let co = self.cam_offsets[c];
                    for k in 0..slots.num_free() {
                        entries.push((co + k, [0.0, 0.0]));
                    }
                    for (t, s) in slots.slots().iter().enumerate() {
                        if let Slot::Free { index, scale } = *s {
                            let (a, b) = if t < 5 {
                                (pj.d_intrinsics[0][t], pj.d_intrinsics[1][t])
                            } else {
                                (pj.d_distortion[0][t - 5], pj.d_distortion[1][t - 5])
                            };
                            let e = &mut entries[index].1;
                            e[0] += scale * a;
                            e[1] += scale * b;
                        }
                    }
                    match self.rig_offsets[c] {
                        None => {
                            for k in 0..6 {
                                entries.push((vo + k, [pj.d_pose[0][k], pj.d_pose[1][k]]));
                            }
                        }
                        Some(ro) => {
                            let a = &adjoints[c];
                            for k in 0..6 {
                                entries.push((ro + k, [pj.d_pose[0][k], pj.d_pose[1][k]]));
                            }
                            for k in 0..6 {
                                let mut d = [0.0; 2];
                                for l in 0..6 {
                                    d[0] += pj.d_pose[0][l] * a[l][k];
                                    d[1] += pj.d_pose[1][l] * a[l][k];
                                }
                                entries.push((vo + k, d));
                            }
                        }
                    }
                    f(v, c, r, &entries);
                }
            }
        }
        Ok(())
    }

    /// Per-view, per-camera residual vectors (projected − observed) at `params` (empty for a
    /// camera that did not see the view).
    pub fn residuals_by_view(&self, params: &[f64]) -> Result<Vec<Vec<Vec<DVec2>>>, EvaluationError> {
        let mut out: Vec<Vec<Vec<DVec2>>> = (0..self.views.len()).map(|_| vec![Vec::new(); self.cams.len()]).collect();
        self.for_each_observation(params, |v, c, r, _| out[v][c].push(r))?;
        Ok(out)
    }
}

impl<S: CameraSlots> Problem for Bundle<'_, S> {
    fn num_params(&self) -> usize {
        self.num_global + 6 * self.views.len()
    }
    fn num_residuals(&self) -> usize {
        self.num_residuals
    }
    fn evaluate(
        &self,
        params: &[f64],
        residuals: &mut [f64],
        mut jacobian: Option<MatMut<'_, f64>>,
    ) -> Result<(), EvaluationError> {
        if let Some(j) = jacobian.as_mut() {
            j.fill(0.0);
        }
        let mut row = 0;
        self.for_each_observation(params, |_, _, r, entries| {
            residuals[row] = r.x;
            residuals[row + 1] = r.y;
            if let Some(j) = jacobian.as_mut() {
                for &(col, d) in entries {
                    j[(row, col)] += d[0];
                    j[(row + 1, col)] += d[1];
                }
            }
            row += 2;
        })
    }

    fn retract(&self, params: &[f64], delta: &[f64], out: &mut [f64]) {
        for i in 0..self.num_params() {
            out[i] = params[i] + delta[i];
        }
        let pose_offsets = (0..self.views.len()).map(|v| self.view_offset(v));
        for o in pose_offsets.chain(self.rig_offsets.iter().flatten().copied()) {
            let d: [f64; 6] = std::array::from_fn(|k| delta[o + k]);
            let p = pose_at(&params[o..o + 6]).retract(&d);
            store_pose(&p, &mut out[o..o + 6]);
        }
    }

    fn normal_equations(
        &self,
        params: &[f64],
        jtj: &mut Mat<f64>,
        jtr: &mut Col<f64>,
        residuals: &mut [f64],
    ) -> Result<(), EvaluationError> {
        let n = self.num_params();
        if jtj.nrows() != n || jtj.ncols() != n {
            *jtj = Mat::zeros(n, n);
        } else {
            jtj.fill(0.0);
        }
        if jtr.nrows() != n {
            *jtr = Col::zeros(n);
        } else {
            jtr.fill(0.0);
        }
        let mut row = 0;
        self.for_each_observation(params, |_, _, r, entries| {
            residuals[row] = r.x;
            residuals[row + 1] = r.y;
            row += 2;
            for (a, &(ia, da)) in entries.iter().enumerate() {
                jtr[ia] += da[0] * r.x + da[1] * r.y;
                // Upper triangle (column ≥ row) only, mirrored below.
                for &(ib, db) in &entries[a..] {
                    let v = da[0] * db[0] + da[1] * db[1];
                    let (lo, hi) = if ia <= ib { (ia, ib) } else { (ib, ia) };
                    jtj[(lo, hi)] += v;
                }
            }
        })?;
        for j in 0..n {
            for i in (j + 1)..n {
                jtj[(i, j)] = jtj[(j, i)];
            }
        }
        Ok(())
    }

    fn block_diagonal_tail(&self) -> Option<(usize, usize)> {
        // No residual couples two view poses: eliminate them (Schur complement).
        Some((self.num_global, 6))
    }
}

/// Test support: the analytic Jacobian of `b` at `x` (through `retract`) matches central
/// differences (step `1e-6 · max(|x_k|, floor)` for the first `global` parameters, `1e-6` for
/// the pose perturbations), and the block-accumulated normal equations equal `JᵀJ`, `Jᵀr`.
#[cfg(test)]
pub(crate) fn check_derivatives<S: CameraSlots>(b: &Bundle<S>, x: &[f64], global: usize, floor: f64) {
    use faer::{Col, Mat};
    let (n, m) = (b.num_params(), b.num_residuals());
    let mut r = vec![0.0; m];
    let mut j = Mat::<f64>::zeros(m, n);
    b.evaluate(x, &mut r, Some(j.as_mut())).unwrap();
    let (mut xp, mut xm) = (vec![0.0; n], vec![0.0; n]);
    let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
    for k in 0..n {
        let h = if k < global { 1e-6 * x[k].abs().max(floor) } else { 1e-6 };
        let mut d = vec![0.0; n];
        d[k] = h;
        b.retract(x, &d, &mut xp);
        d[k] = -h;
        b.retract(x, &d, &mut xm);
        b.evaluate(&xp, &mut rp, None).unwrap();
        b.evaluate(&xm, &mut rm, None).unwrap();
        for i in 0..m {
            let fd = (rp[i] - rm[i]) / (2.0 * h);
            assert!(
                (fd - j[(i, k)]).abs() < 1e-4 * (1.0 + fd.abs()),
                "row {i} col {k}: fd {fd} analytic {}",
                j[(i, k)]
            );
        }
    }
    let mut jtj = Mat::<f64>::zeros(n, n);
    let mut jtr = Col::<f64>::zeros(n);
    let mut r2 = vec![0.0; m];
    b.normal_equations(x, &mut jtj, &mut jtr, &mut r2).unwrap();
    let dense = j.transpose() * &j;
    let g = j.transpose() * &Col::from_fn(m, |i| r[i]);
    for a in 0..n {
        assert!((jtr[a] - g[a]).abs() <= 1e-9 * (1.0 + g[a].abs()));
        for c in 0..n {
            assert!((jtj[(a, c)] - dense[(a, c)]).abs() <= 1e-9 * (1.0 + dense[(a, c)].abs()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parallax_least_squares::Problem;

    fn slots(cam: &Camera, free: &[usize]) -> CameraModelSlots {
        let theta = theta_of(cam);
        let mut s = [Slot::Fixed(0.0); N_INTR];
        for i in 0..N_INTR {
            s[i] = Slot::Fixed(theta[i]);
        }
        for (k, &i) in free.iter().enumerate() {
            s[i] = Slot::Free { index: k, scale: 1.0 };
        }
        CameraModelSlots { slots: s, num_free: free.len(), width: cam.width, height: cam.height }
    }

    /// The analytic Jacobian (through `retract`) matches central differences, and the
    /// block-accumulated normal equations equal `JᵀJ`, `Jᵀr` of the dense Jacobian.
    #[test]
    fn rig_jacobian_matches_finite_differences_and_normal_equations() {
        let cam = Camera::new(
            Intrinsics { fx: 520.0, fy: 515.0, cx: 320.0, cy: 240.0, skew: 0.3 },
            Distortion { k1: -0.2, k2: 0.05, p1: 0.001, p2: -0.002, k3: 0.01, k4: 0.02, k5: 0.0, k6: 0.0 },
            640,
            480,
        )
        .unwrap();
        let object: Vec<DVec3> =
            (0..12).map(|i| DVec3::new((i % 4) as f64 * 30.0, (i / 4) as f64 * 30.0, 0.0)).collect();
        let image: Vec<DVec2> = (0..12).map(|i| DVec2::new(300.0 + i as f64, 200.0 - i as f64)).collect();
        let all: Vec<usize> = (0..N_INTR).collect();
        let sight = Some(Sight { object: &object, image: &image });
        // Three cameras; camera 2 misses view 0, camera 0 misses view 1.
        let views = vec![ViewObs { sights: vec![sight, sight, None] }, ViewObs { sights: vec![None, sight, sight] }];
        let b = Bundle::new(vec![slots(&cam, &all), slots(&cam, &[0, 2, 5]), slots(&cam, &[1, 3])], views);
        let n = b.num_params();
        let mut x = vec![0.0; n];
        x[..N_INTR].copy_from_slice(&theta_of(&cam));
        x[N_INTR..N_INTR + 3].copy_from_slice(&[
            cam.intrinsics.fx,
            cam.intrinsics.cx,
            cam.distortion().copied().unwrap().k1,
        ]);
        let o2 = N_INTR + 3;
        x[o2..o2 + 2].copy_from_slice(&[cam.intrinsics.fy, cam.intrinsics.cy]);
        let ro = b.rig_offsets[1].unwrap();
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.03), DVec3::new(-100.0, 2.0, 1.0)),
            &mut x[ro..ro + 6],
        );
        let ro = b.rig_offsets[2].unwrap();
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(-0.03, 0.2, 0.01), DVec3::new(80.0, -20.0, 10.0)),
            &mut x[ro..ro + 6],
        );
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(0.3, -0.2, 0.1), DVec3::new(-40.0, -30.0, 500.0)),
            &mut x[b.view_offset(0)..b.view_offset(0) + 6],
        );
        store_pose(
            &Isometry3::from_rvec_tvec(DVec3::new(-0.2, 0.3, 0.0), DVec3::new(-20.0, -50.0, 600.0)),
            &mut x[b.view_offset(1)..b.view_offset(1) + 6],
        );
        check_derivatives(&b, &x, N_INTR + 5, 1e-3);
    }
}
