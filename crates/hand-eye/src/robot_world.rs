//! Robot-world-hand-eye calibration `A_i X = Z B_i` from absolute poses.
//!
//! With `G_i X C_i = W` (eye-in-hand: `G = base_from_gripper`, `X = gripper_from_camera`,
//! `C = camera_from_board`, `W = base_from_board`), `A_i = G_i`, `B_i = C_i⁻¹`, `Z = W`.
//! Eye-to-hand uses `G_i⁻¹` instead (see [`crate::Setup`]), so `X = base_from_camera` and
//! `Z = gripper_from_board`.

use faer::{Col, Mat};
use glam::{DMat3, DVec3};
use parallax_camera_model::Isometry3;
use parallax_least_squares::{nearest_rotation, null_vector, solve_linear_least_squares};

use crate::{HandEyeError, Result};

/// Writes `I ⊗ R_a − R_bᵀ ⊗ I` (the column-major `vec` form of `R_a R_x − R_z R_b`, split into
/// its `X` and `Z` halves) into rows `row..row + 9`.
fn put_rotation_rows(m: &mut Mat<f64>, row: usize, ra: DMat3, rb: DMat3) {
    for c in 0..3 {
        for r in 0..3 {
            let i = row + 3 * c + r;
            for k in 0..3 {
                // (I ⊗ R_a)[(3c + r), (3c + k)] = R_a[r, k]
                m[(i, 3 * c + k)] = ra.col(k)[r];
                // −(R_bᵀ ⊗ I)[(3c + r), (3k + r)] = −R_b[k, c]
                m[(i, 9 + 3 * k + r)] = -rb.col(c)[k];
            }
        }
    }
}

fn mat3_from_vec(v: &[f64]) -> DMat3 {
    DMat3::from_cols(DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]), DVec3::new(v[6], v[7], v[8]))
}

/// Translations of `X` and `Z` by least squares given both rotations:
/// `R_a t_x − t_z = R_z t_b − t_a`.
fn solve_translations(a: &[Isometry3], b: &[Isometry3], r_z: DMat3, solver: &'static str) -> Result<(DVec3, DVec3)> {
    let n = a.len();
    let mut m = Mat::<f64>::zeros(3 * n, 6);
    let mut rhs = Col::<f64>::zeros(3 * n);
    for k in 0..n {
        let ra = a[k].rotation_matrix();
        let v = r_z * b[k].translation - a[k].translation;
        for r in 0..3 {
            for c in 0..3 {
                m[(3 * k + r, c)] = ra.col(c)[r];
            }
            m[(3 * k + r, 3 + r)] = -1.0;
            rhs[3 * k + r] = v[r];
        }
    }
    let t = solve_linear_least_squares(m.as_ref(), rhs.as_ref()).map_err(|e| HandEyeError::numerical(solver, e))?;
    Ok((DVec3::new(t[0], t[1], t[2]), DVec3::new(t[3], t[4], t[5])))
}

fn finish(
    solver: &'static str,
    rx: DMat3,
    rz: DMat3,
    a: &[Isometry3],
    b: &[Isometry3],
) -> Result<(Isometry3, Isometry3)> {
    let (tx, tz) = solve_translations(a, b, rz, solver)?;
    let x = Isometry3::from_rotation_translation(rx, tx).map_err(|e| HandEyeError::numerical(solver, e))?;
    let z = Isometry3::from_rotation_translation(rz, tz).map_err(|e| HandEyeError::numerical(solver, e))?;
    Ok((x, z))
}

fn scaled_rotations(solver: &'static str, vx: DMat3, vz: DMat3) -> Result<(DMat3, DMat3)> {
    let det = vx.determinant();
    if det.is_nan() || det.abs() <= 1e-12 {
        return Err(HandEyeError::numerical(solver, "rotation block of the solution is singular"));
    }
    let s = 1.0 / det.cbrt();
    let rx = nearest_rotation(vx * s).map_err(|e| HandEyeError::numerical(solver, e))?;
    let rz = nearest_rotation(vz * s).map_err(|e| HandEyeError::numerical(solver, e))?;
    Ok((rx, rz))
}

/// Shah (2013): the SVD null vector of the stacked `[I ⊗ R_a, −R_bᵀ ⊗ I]` (9N×18) holds
/// `vec(R_x)` and `vec(R_z)` with a common scale, fixed by `det R_x = 1`; both are projected on
/// the rotations and the translations solved by least squares. `a` and `b` are `A_i` and
/// `B_i` of `A_i X = Z B_i`; returns `(X, Z)`.
pub fn shah(a: &[Isometry3], b: &[Isometry3]) -> Result<(Isometry3, Isometry3)> {
    check_len(a, b)?;
    let n = a.len();
    let mut k = Mat::<f64>::zeros(9 * n, 18);
    for i in 0..n {
        put_rotation_rows(&mut k, 9 * i, a[i].rotation_matrix(), b[i].rotation_matrix());
    }
    let nv = null_vector(k.as_ref()).map_err(|e| HandEyeError::numerical("Shah", e))?;
    let v: Vec<f64> = nv.vector.iter().copied().collect();
    let (rx, rz) = scaled_rotations("Shah", mat3_from_vec(&v[..9]), mat3_from_vec(&v[9..]))?;
    finish("Shah", rx, rz, a, b)
}

/// Li, Wang and Wu (2010): rotations and translations in one linear least-squares system of
/// 24 unknowns (`vec R_x`, `vec R_z`, `t_x`, `t_z`), 12 equations per station; the rotation
/// blocks are projected on the rotations and — unlike OpenCV, whose joint translations are
/// 43 mm off on ViSP's data — the translations are re-solved with those rotations.
pub fn li(a: &[Isometry3], b: &[Isometry3]) -> Result<(Isometry3, Isometry3)> {
    check_len(a, b)?;
    let n = a.len();
    let mut m = Mat::<f64>::zeros(12 * n, 24);
    let mut rhs = Col::<f64>::zeros(12 * n);
    for i in 0..n {
        let ra = a[i].rotation_matrix();
        put_rotation_rows(&mut m, 12 * i, ra, b[i].rotation_matrix());
        // R_a t_x − t_z − (t_bᵀ ⊗ I) vec(R_z) = −t_a
        let tb = b[i].translation;
        for r in 0..3 {
            let row = 12 * i + 9 + r;
            for c in 0..3 {
                m[(row, 18 + c)] = ra.col(c)[r];
                m[(row, 9 + 3 * c + r)] = -tb[c];
            }
            m[(row, 21 + r)] = -1.0;
            rhs[row] = -a[i].translation[r];
        }
    }
    let x = solve_linear_least_squares(m.as_ref(), rhs.as_ref()).map_err(|e| HandEyeError::numerical("Li", e))?;
    let v: Vec<f64> = x.iter().copied().collect();
    let (rx, rz) = scaled_rotations("Li", mat3_from_vec(&v[..9]), mat3_from_vec(&v[9..18]))?;
    finish("Li", rx, rz, a, b)
}

fn check_len(a: &[Isometry3], b: &[Isometry3]) -> Result<()> {
    if a.len() != b.len() {
        return Err(HandEyeError::SizeMismatch(format!("{} A poses but {} B poses", a.len(), b.len())));
    }
    if a.len() < 3 {
        return Err(HandEyeError::NotEnoughData(format!(
            "{} stations, robot-world calibration needs at least 3",
            a.len()
        )));
    }
    Ok(())
}
