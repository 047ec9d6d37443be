//! Stations, relative motions `A_i X = X B_i`, and the degeneracy check.

use glam::DVec3;
use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::{HandEyeError, Result};

/// Where the camera sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Setup {
    /// Camera on the gripper, board fixed in the world: solves `gripper_from_camera`
    /// (and `base_from_board`).
    #[default]
    EyeInHand,
    /// Camera fixed in the world, board on the gripper: solves `base_from_camera`
    /// (and `gripper_from_board`).
    EyeToHand,
}

/// Which station pairs become relative motions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum PairSelection {
    /// Every pair `i < j` (`N(N−1)/2` motions; what OpenCV's benchmark scripts use).
    #[default]
    All,
    /// Consecutive stations only (`N − 1` motions, each station used at most twice).
    Consecutive,
}

/// One relative motion between stations `i` and `j`: `A X = X B`.
///
/// Eye-in-hand: `A = G_j⁻¹ G_i` (gripper motion), `B = C_j C_i⁻¹` (camera motion), with
/// `G = base_from_gripper`, `C = camera_from_board`, `X = gripper_from_camera`.
/// Eye-to-hand: the same with `G` replaced by `G⁻¹ = gripper_from_base` and
/// `X = base_from_camera`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Motion {
    /// First station (index into the input lists).
    pub i: usize,
    /// Second station.
    pub j: usize,
    /// Robot-side motion `A`.
    pub a: Isometry3,
    /// Camera-side motion `B`.
    pub b: Isometry3,
}

/// Thresholds of [`check_motions`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DegeneracyConfig {
    /// A motion whose robot rotation is below this angle (degrees) is too small for the noise of
    /// a typical robot and camera pose (≈ 0.1°): it does not count as informative.
    pub min_rotation_deg: f64,
    /// Two informative motions must have rotation axes at least this far apart (degrees, as
    /// lines) for the rotation to be determined.
    pub min_axis_separation_deg: f64,
}

impl Default for DegeneracyConfig {
    fn default() -> Self {
        Self { min_rotation_deg: 1.0, min_axis_separation_deg: 2.0 }
    }
}

/// Checks the station lists: same length, at least `min` stations, all finite.
pub(crate) fn check_stations(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    min: usize,
) -> Result<()> {
    if base_from_gripper.len() != camera_from_board.len() {
        return Err(HandEyeError::SizeMismatch(format!(
            "{} robot poses (base_from_gripper) but {} camera poses (camera_from_board)",
            base_from_gripper.len(),
            camera_from_board.len()
        )));
    }
    if base_from_gripper.len() < min {
        return Err(HandEyeError::NotEnoughData(format!(
            "{} stations given, at least {min} needed (with fewer, the rotation is not determined)",
            base_from_gripper.len()
        )));
    }
    for (k, g) in base_from_gripper.iter().enumerate() {
        if !g.is_finite() {
            return Err(HandEyeError::NonFinite { what: "base_from_gripper", index: k });
        }
    }
    for (k, c) in camera_from_board.iter().enumerate() {
        if !c.is_finite() {
            return Err(HandEyeError::NonFinite { what: "camera_from_board", index: k });
        }
    }
    Ok(())
}

/// The robot poses in the form `G_i X C_i = const`: `base_from_gripper` for eye-in-hand,
/// their inverses (`gripper_from_base`) for eye-to-hand.
pub(crate) fn robot_side(base_from_gripper: &[Isometry3], setup: Setup) -> Vec<Isometry3> {
    match setup {
        Setup::EyeInHand => base_from_gripper.to_vec(),
        Setup::EyeToHand => base_from_gripper.iter().map(Isometry3::inverse).collect(),
    }
}

/// Relative motions from absolute station poses (see [`Motion`] for the formulas).
///
/// Errors when the lists differ in length, hold fewer than 3 stations, or contain a non-finite
/// pose. The degeneracy of the motions is checked separately by [`check_motions`].
pub fn relative_motions(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    setup: Setup,
    pairs: PairSelection,
) -> Result<Vec<Motion>> {
    check_stations(base_from_gripper, camera_from_board, 3)?;
    let g = robot_side(base_from_gripper, setup);
    Ok(motions_from_internal(&g, camera_from_board, pairs))
}

pub(crate) fn motions_from_internal(g: &[Isometry3], c: &[Isometry3], pairs: PairSelection) -> Vec<Motion> {
    let n = g.len();
    let mut out = Vec::new();
    let mut push = |i: usize, j: usize| {
        out.push(Motion { i, j, a: g[j].inverse() * g[i], b: c[j] * c[i].inverse() });
    };
    match pairs {
        PairSelection::All => {
            for i in 0..n {
                for j in i + 1..n {
                    push(i, j);
                }
            }
        }
        PairSelection::Consecutive => {
            for i in 0..n.saturating_sub(1) {
                push(i, i + 1);
            }
        }
    }
    out
}

/// Angle in degrees between two lines (directions up to sign), in `[0, 90]`.
fn line_angle_deg(u: DVec3, v: DVec3) -> f64 {
    let c = u.dot(v).abs().min(1.0);
    let s = u.cross(v).length();
    s.atan2(c).to_degrees()
}

/// Degeneracy check: at least two informative motions (robot rotation ≥
/// `min_rotation_deg`) whose rotation axes are at least `min_axis_separation_deg` apart.
///
/// With fewer, `A X = X B` leaves a rotation about the common axis (and a translation along
/// it) undetermined — a wrong answer rather than a noisy one — so this is an error that names
/// the stations.
pub fn check_motions(motions: &[Motion], cfg: &DegeneracyConfig) -> Result<()> {
    if !(cfg.min_rotation_deg >= 0.0 && cfg.min_axis_separation_deg >= 0.0) {
        return Err(HandEyeError::InvalidConfig(format!(
            "degeneracy thresholds must be non-negative, got {} and {}",
            cfg.min_rotation_deg, cfg.min_axis_separation_deg
        )));
    }
    if motions.len() < 2 {
        return Err(HandEyeError::NotEnoughData(format!(
            "{} relative motion(s); at least 2 with non-parallel rotation axes are needed (3 stations or more)",
            motions.len()
        )));
    }
    let informative: Vec<(&Motion, DVec3)> = motions
        .iter()
        .filter(|m| m.a.angle().to_degrees() >= cfg.min_rotation_deg)
        .map(|m| (m, m.a.rvec().normalize()))
        .collect();
    if informative.len() < 2 {
        let small: Vec<String> = motions
            .iter()
            .filter(|m| m.a.angle().to_degrees() < cfg.min_rotation_deg)
            .take(12)
            .map(|m| format!("{}–{} ({:.3}°)", m.i, m.j, m.a.angle().to_degrees()))
            .collect();
        return Err(HandEyeError::Degenerate(format!(
            "{} of {} motions rotate the robot by at least {}° (too small for the pose noise otherwise); \
             small motions between stations: {}",
            informative.len(),
            motions.len(),
            cfg.min_rotation_deg,
            small.join(", ")
        )));
    }
    let mut best = 0.0f64;
    for (k, (_, u)) in informative.iter().enumerate() {
        for (_, v) in &informative[k + 1..] {
            best = best.max(line_angle_deg(*u, *v));
            if best >= cfg.min_axis_separation_deg {
                return Ok(());
            }
        }
    }
    let (m0, axis) = informative[0];
    let names: Vec<String> = informative.iter().take(12).map(|(m, _)| format!("{}–{}", m.i, m.j)).collect();
    Err(HandEyeError::Degenerate(format!(
        "all {} informative motions rotate about the same axis (largest separation {best:.3}° < {}°, \
         axis ≈ [{:.3}, {:.3}, {:.3}] in the gripper frame of station {}); stations pairs: {}{}",
        informative.len(),
        cfg.min_axis_separation_deg,
        axis.x,
        axis.y,
        axis.z,
        m0.j,
        names.join(", "),
        if informative.len() > 12 { ", …" } else { "" }
    )))
}
