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
    Ok(Quality {
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
