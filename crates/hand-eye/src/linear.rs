//! Closed-form solvers of `A X = X B`.

use faer::{Col, Mat, Side};
use glam::{DMat3, DQuat, DVec3};
use parallax_camera_model::Isometry3;
use parallax_least_squares::{nearest_rotation, null_vector, solve_linear_least_squares};

use crate::motion::Motion;
use crate::{HandEyeError, Result};

/// The quaternion of a rotation with non-negative scalar part (the sign convention every
/// quaternion-based solver here relies on: `A` and `B` of one motion then agree in sign).
pub(crate) fn positive_quat(q: DQuat) -> DQuat {
    if q.w < 0.0 { -q } else { q }
}

/// `[v]×`, the cross-product matrix.
pub(crate) fn skew(v: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, v.z, -v.y), DVec3::new(-v.z, 0.0, v.x), DVec3::new(v.y, -v.x, 0.0))
}

fn rotation_to_isometry(solver: &'static str, r: DMat3, t: DVec3) -> Result<Isometry3> {
    Isometry3::from_rotation_translation(r, t).map_err(|e| HandEyeError::numerical(solver, e))
}

/// Translation of `X` by least squares over all motions, given its rotation:
/// `(R_a − I) t_x = R_x t_b − t_a` (Tsai–Lenz's second step, shared by most solvers).
pub fn solve_translation(motions: &[Motion], r_x: DMat3) -> Result<DVec3> {
    let n = motions.len();
    let mut a = Mat::<f64>::zeros(3 * n, 3);
    let mut b = Col::<f64>::zeros(3 * n);
    for (k, m) in motions.iter().enumerate() {
        let ra = m.a.rotation_matrix() - DMat3::IDENTITY;
        let rhs = r_x * m.b.translation - m.a.translation;
        for r in 0..3 {
            for c in 0..3 {
                a[(3 * k + r, c)] = ra.col(c)[r];
            }
            b[3 * k + r] = rhs[r];
        }
    }
    let t =
        solve_linear_least_squares(a.as_ref(), b.as_ref()).map_err(|e| HandEyeError::numerical("translation", e))?;
    Ok(DVec3::new(t[0], t[1], t[2]))
}

/// Tsai–Lenz (1989): modified Rodrigues vectors `P = 2 sin(θ/2) k` of both motions give
/// `[P_a + P_b]× P'_x = P_b − P_a` with `P'_x = tan(θ_x/2) k_x`; translation by
/// [`solve_translation`].
pub fn tsai(motions: &[Motion]) -> Result<Isometry3> {
    // tan(θ/2) is singular at θ = 180°: when the solution is beyond ~170° (or the system is
    // singular) the same least-squares problem is solved for X·R0ᵀ, with R0 a 90° rotation about x, y or z
    // (A X R0ᵀ = X R0ᵀ · R0 B R0ᵀ), and the better-conditioned answer is kept.
    let mut best: Option<(f64, DMat3)> = None;
    let mut last_err = None;
    let h = std::f64::consts::FRAC_PI_2;
    // A half-turn about n composed with a quarter-turn about a is a half-turn again iff n ⟂ a:
    // n cannot be perpendicular to all three axes.
    for r0 in [DMat3::IDENTITY, DMat3::from_rotation_x(h), DMat3::from_rotation_y(h), DMat3::from_rotation_z(h)] {
        let q0 = glam::DQuat::from_mat3(&r0);
        match tsai_modified_rodrigues(motions, q0) {
            Ok(p) => {
                let norm = p.length();
                let r = if norm == 0.0 { DMat3::IDENTITY } else { DMat3::from_axis_angle(p / norm, 2.0 * norm.atan()) };
                if best.as_ref().is_none_or(|b| norm < b.0) {
                    best = Some((norm, r * r0));
                }
                if norm < 10.0 {
                    break;
                }
            }
            Err(e) => last_err = Some(e),
        }
    }
    let (_, r_x) = best.ok_or_else(|| last_err.expect("tried"))?;
    let t = solve_translation(motions, r_x)?;
    rotation_to_isometry("Tsai", r_x, t)
}

/// Tsai–Lenz's rotation step for `X' = X R0ᵀ` (motions `B' = R0 B R0ᵀ`): `P'_x'`.
fn tsai_modified_rodrigues(motions: &[Motion], q0: DQuat) -> Result<DVec3> {
    let n = motions.len();
    let mut a = Mat::<f64>::zeros(3 * n, 3);
    let mut b = Col::<f64>::zeros(3 * n);
    for (k, m) in motions.iter().enumerate() {
        let pa = 2.0 * positive_quat(m.a.rotation()).xyz();
        let pb = 2.0 * positive_quat((q0 * m.b.rotation() * q0.conjugate()).normalize()).xyz();
        let s = skew(pa + pb);
        let rhs = pb - pa;
        for r in 0..3 {
            for c in 0..3 {
                a[(3 * k + r, c)] = s.col(c)[r];
            }
            b[3 * k + r] = rhs[r];
        }
    }
    let p = solve_linear_least_squares(a.as_ref(), b.as_ref()).map_err(|e| HandEyeError::numerical("Tsai", e))?;
    Ok(DVec3::new(p[0], p[1], p[2]))
}

/// Park–Martin (1994): with the log maps `α = log R_a`, `β = log R_b` (so `α = R_x β`), `R_x`
/// is the orthogonal polar factor of `Σ α βᵀ` (computed as the nearest rotation, which also
/// works with only two motions); translation by [`solve_translation`].
pub fn park(motions: &[Motion]) -> Result<Isometry3> {
    let mut m = DMat3::ZERO;
    for mo in motions {
        let alpha = mo.a.rvec();
        let beta = mo.b.rvec();
        m += DMat3::from_cols(alpha * beta.x, alpha * beta.y, alpha * beta.z);
    }
    let r_x = nearest_rotation(m).map_err(|e| HandEyeError::numerical("Park", e))?;
    let t = solve_translation(motions, r_x)?;
    rotation_to_isometry("Park", r_x, t)
}

/// Left and right quaternion multiplication matrices (`[w, x, y, z]` order):
/// `q p = L(q) p`, `p q = R(q) p`.
fn quat_lr(q: DQuat) -> ([[f64; 4]; 4], [[f64; 4]; 4]) {
    let (w, x, y, z) = (q.w, q.x, q.y, q.z);
    let l = [[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]];
    let r = [[w, -x, -y, -z], [x, w, z, -y], [y, -z, w, x], [z, y, -x, w]];
    (l, r)
}

/// Horaud–Dornaika (1995), linear quaternion form: `q_a q_x = q_x q_b`, i.e.
/// `(L(q_a) − R(q_b)) q_x = 0`; `q_x` is the eigenvector of the smallest eigenvalue of
/// `Σ (L − R)ᵀ (L − R)`. Translation by [`solve_translation`].
pub fn horaud(motions: &[Motion]) -> Result<Isometry3> {
    let mut s = Mat::<f64>::zeros(4, 4);
    for m in motions {
        let (l, _) = quat_lr(positive_quat(m.a.rotation()));
        let (_, r) = quat_lr(positive_quat(m.b.rotation()));
        let d: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| l[i][j] - r[i][j]));
        for i in 0..4 {
            for j in 0..4 {
                s[(i, j)] += (0..4).map(|k| d[k][i] * d[k][j]).sum::<f64>();
            }
        }
    }
    let evd = s.self_adjoint_eigen(Side::Lower).map_err(|e| HandEyeError::numerical("Horaud", format!("{e:?}")))?;
    let v = evd.U().col(0);
    let q = DQuat::from_xyzw(v[1], v[2], v[3], v[0]);
    if q.length().is_nan() || q.length() <= 0.5 {
        return Err(HandEyeError::numerical("Horaud", "no unit eigenvector"));
    }
    let r_x = DMat3::from_quat(q.normalize());
    let t = solve_translation(motions, r_x)?;
    rotation_to_isometry("Horaud", r_x, t)
}

/// Andreff et al. (2001), the Kronecker ("matrix direct product") form: `R_a R_x = R_x R_b`
/// becomes `(I ⊗ R_a − R_bᵀ ⊗ I) vec(R_x) = 0` (column-major `vec`); the SVD null vector of the
/// stacked 9N×9 matrix is `vec(R_x)` up to scale, fixed by `det = 1` and projected on the
/// rotations. Translation by [`solve_translation`] (least squares with the final rotation; the
/// joint 12-unknown system that OpenCV solves is 8 mm off on ViSP's data).
pub fn andreff(motions: &[Motion]) -> Result<Isometry3> {
    let n = motions.len();
    let mut k = Mat::<f64>::zeros(9 * n, 9);
    for (idx, m) in motions.iter().enumerate() {
        let ra = m.a.rotation_matrix();
        let rb = m.b.rotation_matrix();
        for c in 0..3 {
            for r in 0..3 {
                let row = 9 * idx + 3 * c + r;
                for cp in 0..3 {
                    for rp in 0..3 {
                        let col = 3 * cp + rp;
                        let mut v = 0.0;
                        if c == cp {
                            v += ra.col(rp)[r];
                        }
                        if r == rp {
                            v -= rb.col(c)[cp];
                        }
                        k[(row, col)] = v;
                    }
                }
            }
        }
    }
    let nv = null_vector(k.as_ref()).map_err(|e| HandEyeError::numerical("Andreff", e))?;
    let v = &nv.vector;
    let m = DMat3::from_cols(DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]), DVec3::new(v[6], v[7], v[8]));
    let det = m.determinant();
    if det.is_nan() || det.abs() <= 1e-12 {
        return Err(HandEyeError::numerical("Andreff", "null vector is not a scaled rotation (det ≈ 0)"));
    }
    let r_x = nearest_rotation(m * (1.0 / det.cbrt())).map_err(|e| HandEyeError::numerical("Andreff", e))?;
    let t = solve_translation(motions, r_x)?;
    rotation_to_isometry("Andreff", r_x, t)
}

/// Real and dual parts of the unit dual quaternion of a transform (`q_r` with `w ≥ 0`,
/// `q_d = ½ (0, t) q_r`).
pub(crate) fn dual_quat(t: &Isometry3) -> (DQuat, DQuat) {
    let qr = positive_quat(t.rotation());
    let tq = DQuat::from_xyzw(t.translation.x, t.translation.y, t.translation.z, 0.0);
    (qr, (tq * qr) * 0.5)
}

/// Smallest `|cos(θ/2)|` of a motion's rotations that [`daniilidis`] uses: nearer 180° the
/// sign of the scalar part, which pairs `q_A` with `q_B`, is decided by noise (measured on
/// realistic scenes with 0.2° / 2 mm noise: motions of ~180° roll flipped and gave rotation
/// errors up to 86° in 8 of 2000 trials, Park 0.27° on the same data).
const DANIILIDIS_MIN_HALF_COS: f64 = 0.05;

/// Daniilidis (1999), dual quaternions: every motion gives 6 linear equations in the 8
/// dual-quaternion coefficients of `X`; the two smallest right singular vectors of the stacked
/// matrix span the solutions, and the unit-norm and `q_r · q_d = 0` constraints pick the one.
/// Rotation and translation are solved together. Motions whose rotation is within ~6° of 180°
/// are left out (their quaternion signs cannot be paired reliably); fewer than two left is an
/// error.
pub fn daniilidis(motions: &[Motion]) -> Result<Isometry3> {
    let usable: Vec<((DQuat, DQuat), (DQuat, DQuat))> = motions
        .iter()
        .map(|m| (dual_quat(&m.a), dual_quat(&m.b)))
        .filter(|((ar, _), (br, _))| ar.w.abs().min(br.w.abs()) >= DANIILIDIS_MIN_HALF_COS)
        .collect();
    if usable.len() < 2 {
        return Err(HandEyeError::numerical(
            "Daniilidis",
            format!(
                "{} of {} motions rotate by less than ~174°: too few to solve (use another method)",
                usable.len(),
                motions.len()
            ),
        ));
    }
    let n = usable.len();
    let mut t = Mat::<f64>::zeros(6 * n, 8);
    for (k, &((ar, ad), (br, bd))) in usable.iter().enumerate() {
        let (a, a2, b, b2) = (ar.xyz(), ad.xyz(), br.xyz(), bd.xyz());
        let put = |t: &mut Mat<f64>, row: usize, col: usize, u: DVec3, s: DMat3| {
            for r in 0..3 {
                t[(row + r, col)] = u[r];
                for c in 0..3 {
                    t[(row + r, col + 1 + c)] = s.col(c)[r];
                }
            }
        };
        put(&mut t, 6 * k, 0, a - b, skew(a + b));
        put(&mut t, 6 * k + 3, 0, a2 - b2, skew(a2 + b2));
        put(&mut t, 6 * k + 3, 4, a - b, skew(a + b));
    }
    let svd = t.thin_svd().map_err(|e| HandEyeError::numerical("Daniilidis", format!("{e:?}")))?;
    let v = svd.V();
    let col = |j: usize| -> [f64; 8] { std::array::from_fn(|i| v[(i, j)]) };
    let (v1, v2) = (col(6), col(7));
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
    let (u1, w1, u2, w2) = (&v1[..4], &v1[4..], &v2[..4], &v2[4..]);
    // Constraint q_r · q_d = 0 as a quadratic form in λ = (λ1, λ2): λᵀ Q λ = 0.
    let (qa, qb, qc) = (dot(u1, w1), 0.5 * (dot(u1, w2) + dot(u2, w1)), dot(u2, w2));
    // Norm |q_r|² = λᵀ U λ.
    let (ua, ub, uc) = (dot(u1, u1), dot(u1, u2), dot(u2, u2));
    // Eigen-decompose the symmetric 2x2 Q: λ = √e2 w_min ± √(−e1) w_max solves λᵀQλ = 0.
    let mean = 0.5 * (qa + qc);
    let rad = (0.25 * (qa - qc).powi(2) + qb * qb).sqrt();
    let (e1, e2) = (mean - rad, mean + rad);
    let evec = |e: f64| -> (f64, f64) {
        let (x, y) = if (qa - e).abs() > (qc - e).abs() { (-qb, qa - e) } else { (qc - e, -qb) };
        let l = (x * x + y * y).sqrt();
        if l == 0.0 { (1.0, 0.0) } else { (x / l, y / l) }
    };
    let (wmin, wmax) = if rad == 0.0 { ((1.0, 0.0), (0.0, 1.0)) } else { (evec(e1), evec(e2)) };
    let (s_min, s_max) = (e2.max(0.0).sqrt(), (-e1).max(0.0).sqrt());
    let mut best: Option<(f64, f64, f64)> = None;
    for sign in [1.0, -1.0] {
        let l1 = s_min * wmin.0 + sign * s_max * wmax.0;
        let l2 = s_min * wmin.1 + sign * s_max * wmax.1;
        let norm2 = l1 * l1 * ua + 2.0 * l1 * l2 * ub + l2 * l2 * uc;
        if norm2 > 0.0 && best.is_none_or(|b| norm2 > b.2) {
            best = Some((l1, l2, norm2));
        }
    }
    let (l1, l2, norm2) = best.ok_or_else(|| HandEyeError::numerical("Daniilidis", "no real solution"))?;
    let s = 1.0 / norm2.sqrt();
    let q: [f64; 8] = std::array::from_fn(|i| s * (l1 * v1[i] + l2 * v2[i]));
    let qr = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
    let qd = DQuat::from_xyzw(q[5], q[6], q[7], q[4]);
    let r_x = DMat3::from_quat(qr.normalize());
    let tq = (qd * qr.conjugate()) * 2.0;
    rotation_to_isometry("Daniilidis", r_x, tq.xyz())
}

/// The thesis's Rodrigues-axis method. With `P = 2 sin(θ/2) k` for both motions, `P_a = R_x P_b`,
/// so every difference `P_a − P_b` is perpendicular to the axis `n` of `R_x`: `n` is the null
/// vector of the stacked differences. The angle follows from the components of `P_b` and `P_a`
/// perpendicular to `n`: `θ = atan2(Σ n·(P_b⊥ × P_a⊥), Σ P_b⊥·P_a⊥)`. Translation by
/// `(R_a − I) t_x = R_x t_b − t_a` ([`solve_translation`]).
pub fn rodrigues(motions: &[Motion]) -> Result<Isometry3> {
    let n = motions.len();
    let pairs: Vec<(DVec3, DVec3)> = motions
        .iter()
        .map(|m| (2.0 * positive_quat(m.a.rotation()).xyz(), 2.0 * positive_quat(m.b.rotation()).xyz()))
        .collect();
    let scale = pairs.iter().map(|(a, b)| a.length().max(b.length())).fold(0.0, f64::max);
    let max_diff = pairs.iter().map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    let r_x = if max_diff <= 1e-14 * scale.max(f64::MIN_POSITIVE) {
        // Every axis maps to itself: R_x = I (the difference equations are all zero).
        DMat3::IDENTITY
    } else {
        let d = Mat::from_fn(n.max(3), 3, |i, j| if i < n { (pairs[i].0 - pairs[i].1)[j] } else { 0.0 });
        let nv = null_vector(d.as_ref()).map_err(|e| HandEyeError::numerical("Rodrigues", e))?;
        let axis = DVec3::new(nv.vector[0], nv.vector[1], nv.vector[2]).normalize();
        let (mut s, mut c) = (0.0, 0.0);
        for (pa, pb) in &pairs {
            let a = *pa - axis * pa.dot(axis);
            let b = *pb - axis * pb.dot(axis);
            s += axis.dot(b.cross(a));
            c += b.dot(a);
        }
        DMat3::from_axis_angle(axis, s.atan2(c))
    };
    let t = solve_translation(motions, r_x)?;
    rotation_to_isometry("Rodrigues", r_x, t)
}
