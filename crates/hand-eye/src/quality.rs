//! Quality measures of a hand-eye solution.

use glam::DMat4;
use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::Result;
use crate::motion::Motion;
use crate::refine::mean_board;

/// Residual of `A X = X B` for one motion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotionResidual {
    /// First station.
    pub i: usize,
    /// Second station.
    pub j: usize,
    /// Rotation angle of `A X (X B)⁻¹`, degrees.
    pub rotation_deg: f64,
    /// `|t(A X) − t(X B)|`, scene length unit.
    pub translation: f64,
    /// The thesis's Table 4 error: Frobenius norm of the 4x4 difference `A X − X B`.
    pub matrix_error: f64,
}

/// Quality of a solution `X` over the stations and motions it was computed from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Quality {
    /// Per-motion residuals of `A X = X B`.
    pub motions: Vec<MotionResidual>,
    /// Mean rotation residual over the motions, degrees.
    pub mean_rotation_deg: f64,
    /// Mean translation residual over the motions, scene length unit.
    pub mean_translation: f64,
    /// Mean of the Table 4 error `‖A_i X − X B_i‖_F`.
    pub mean_matrix_error: f64,
    /// The fixed frame implied by each station, `G_i X C_i` (`base_from_board` eye-in-hand,
    /// `gripper_from_board` eye-to-hand).
    pub station_boards: Vec<Isometry3>,
    /// Chordal mean of `station_boards`.
    pub mean_board: Isometry3,
    /// ViSP's consistency measure: mean rotation angle of each station's board from the mean, degrees.
    pub board_spread_rotation_deg: f64,
    /// Mean distance of each station's board origin from the mean, scene length unit.
    pub board_spread_translation: f64,
    /// Per station, the median rotation angle between its board frame and the other stations'
    /// (degrees): a station far above the others' figures does not fit (swapped or mis-paired).
    #[serde(default)]
    pub station_rotation_deg: Vec<f64>,
    /// Per station, the median distance between its board origin and the other stations'
    /// (scene length unit).
    #[serde(default)]
    pub station_translation: Vec<f64>,
}

/// Median of `v` (the mean of the two middle values for an even count); `None` when empty.
pub(crate) fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) })
}

/// Residual of one motion (see [`MotionResidual`]).
pub fn motion_residual(m: &Motion, x: &Isometry3) -> MotionResidual {
    let ax = m.a * *x;
    let xb = *x * m.b;
    let (angle, dist) = ax.distance(&xb);
    let d: DMat4 = ax.to_mat4() - xb.to_mat4();
    let matrix_error = d.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt();
    MotionResidual { i: m.i, j: m.j, rotation_deg: angle.to_degrees(), translation: dist, matrix_error }
}

/// Every quality measure of `x` given the stations (robot poses already in the `G_i X C_i = W`
/// form) and the motions.
pub(crate) fn quality(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    motions: &[Motion],
    x: &Isometry3,
) -> Result<Quality> {
    let res: Vec<MotionResidual> = motions.iter().map(|m| motion_residual(m, x)).collect();
    let n = res.len().max(1) as f64;
    let boards: Vec<Isometry3> = robot.iter().zip(camera_from_board).map(|(g, c)| *g * *x * *c).collect();
    let mean = mean_board(robot, camera_from_board, x)?;
    let k = boards.len().max(1) as f64;
    let (mut sr, mut st) = (0.0, 0.0);
    for b in &boards {
        let (a, d) = mean.distance(b);
        sr += a.to_degrees();
        st += d;
    }
    let (mut station_rotation_deg, mut station_translation) = (Vec::new(), Vec::new());
    for (k, b) in boards.iter().enumerate() {
        let (rot, tr): (Vec<f64>, Vec<f64>) = boards
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != k)
            .map(|(_, o)| {
                let (a, d) = b.distance(o);
                (a.to_degrees(), d)
            })
            .unzip();
        station_rotation_deg.push(median(rot).unwrap_or(0.0));
        station_translation.push(median(tr).unwrap_or(0.0));
    }
    Ok(Quality {
        station_rotation_deg,
        station_translation,
        mean_rotation_deg: res.iter().map(|r| r.rotation_deg).sum::<f64>() / n,
        mean_translation: res.iter().map(|r| r.translation).sum::<f64>() / n,
        mean_matrix_error: res.iter().map(|r| r.matrix_error).sum::<f64>() / n,
        motions: res,
        station_boards: boards,
        mean_board: mean,
        board_spread_rotation_deg: sr / k,
        board_spread_translation: st / k,
    })
}
