//! Synthetic hand-eye trajectories following `../shared/reference/peer/handeye.py`
//! (10 stations, camera 0.4–0.7 m from the board within 45° of a nominal view, right-multiplied
//! pose noise), generated here so the tests need neither the synthetic crate nor ../shared.
#![allow(dead_code)]

use glam::{DQuat, DVec3};
use parallax_camera_model::Isometry3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn normal(rng: &mut impl Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Uniform random rotation (normalised Gaussian quaternion), or one about a random axis by
/// `U(0, max_deg)`.
pub fn rand_rot(rng: &mut impl Rng, max_deg: Option<f64>) -> DQuat {
    match max_deg {
        None => {
            let q = DQuat::from_xyzw(normal(rng), normal(rng), normal(rng), normal(rng));
            q.normalize()
        }
        Some(m) => {
            let axis = DVec3::new(normal(rng), normal(rng), normal(rng)).normalize();
            DQuat::from_axis_angle(axis, rng.random_range(0.0..m).to_radians())
        }
    }
}

/// `T · (R(ω), v)` with `ω ~ N(0, σ_r²)`, `v ~ N(0, σ_t²)` per axis.
pub fn noisy(t: &Isometry3, sigma_rad: f64, sigma_t: f64, rng: &mut impl Rng) -> Isometry3 {
    let w = DVec3::new(normal(rng), normal(rng), normal(rng)) * sigma_rad;
    let v = DVec3::new(normal(rng), normal(rng), normal(rng)) * sigma_t;
    *t * Isometry3::from_rvec_tvec(w, v)
}

pub struct Scene {
    /// base_from_gripper
    pub g: Vec<Isometry3>,
    /// camera_from_board
    pub c: Vec<Isometry3>,
    /// true gripper_from_camera
    pub x: Isometry3,
    /// true base_from_board
    pub w: Isometry3,
}

/// One trial of the peer protocol (noise-free); metres.
pub fn scene(rng: &mut impl Rng, stations: usize) -> Scene {
    let u = |rng: &mut dyn FnMut() -> f64| rng();
    let _ = u;
    let x = Isometry3::from_quat_translation(
        rand_rot(rng, None),
        DVec3::new(rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1)),
    );
    let w = Isometry3::from_quat_translation(
        rand_rot(rng, None),
        DVec3::new(0.6, 0.0, 0.0)
            + DVec3::new(rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1)),
    );
    let r0 = rand_rot(rng, None);
    let c: Vec<Isometry3> = (0..stations)
        .map(|_| {
            let r = rand_rot(rng, Some(45.0)) * r0;
            let t = DVec3::new(rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1), rng.random_range(0.4..0.7));
            Isometry3::from_quat_translation(r, t)
        })
        .collect();
    let g = c.iter().map(|ci| w * ci.inverse() * x.inverse()).collect();
    Scene { g, c, x, w }
}

/// The same scene with the peer protocol's noise on both pose lists.
pub fn noisy_scene(rng: &mut impl Rng, stations: usize, sigma_deg: f64, sigma_t: f64) -> Scene {
    let s = scene(rng, stations);
    let g = s.g.iter().map(|p| noisy(p, sigma_deg.to_radians(), sigma_t, rng)).collect();
    let c = s.c.iter().map(|p| noisy(p, sigma_deg.to_radians(), sigma_t, rng)).collect();
    Scene { g, c, ..s }
}

/// `camera_from_board` of a camera looking at the board from its front side (board z pointing
/// away from the camera, as OpenCV's chessboard frame), 0.4–0.7 m away, within 35° of the
/// board normal, aimed within 5 cm of the board centre, any roll.
pub fn facing_camera(rng: &mut impl Rng) -> Isometry3 {
    let tilt = rng.random_range(0.0..35f64).to_radians();
    let az = rng.random_range(0.0..std::f64::consts::TAU);
    let d = DVec3::new(tilt.sin() * az.cos(), tilt.sin() * az.sin(), -tilt.cos());
    let p = d * rng.random_range(0.4..0.7);
    let q = DVec3::new(rng.random_range(-0.05..0.05), rng.random_range(-0.05..0.05), 0.0);
    let z = (q - p).normalize();
    let helper = if z.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let x0 = helper.cross(z).normalize();
    let y0 = z.cross(x0);
    let roll = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let x = x0 * roll.cos() + y0 * roll.sin();
    let y = z.cross(x);
    let board_from_camera = Isometry3::from_rotation_translation(glam::DMat3::from_cols(x, y, z), p).unwrap();
    board_from_camera.inverse()
}

/// A realistic eye-in-hand scene: the camera a few centimetres off the flange looking along
/// roughly the flange's z axis, the board 0.6 m in front of the base, every view facing the board.
pub fn realistic_scene(rng: &mut impl Rng, stations: usize) -> Scene {
    let x = Isometry3::from_quat_translation(
        rand_rot(rng, Some(20.0)),
        DVec3::new(rng.random_range(-0.08..0.08), rng.random_range(-0.08..0.08), rng.random_range(0.0..0.1)),
    );
    let w = Isometry3::from_quat_translation(
        rand_rot(rng, Some(30.0)),
        DVec3::new(0.6, rng.random_range(-0.2..0.2), rng.random_range(-0.1..0.1)),
    );
    let c: Vec<Isometry3> = (0..stations).map(|_| facing_camera(rng)).collect();
    let g = c.iter().map(|ci| w * ci.inverse() * x.inverse()).collect();
    Scene { g, c, x, w }
}

/// A realistic eye-to-hand scene: the camera fixed (`x` = `base_from_camera`), the board on the
/// gripper (`w` = `gripper_from_board`), every view facing the board. `g` = `base_from_gripper`.
pub fn realistic_eye_to_hand(rng: &mut impl Rng, stations: usize) -> Scene {
    let y = Isometry3::from_quat_translation(
        rand_rot(rng, None),
        DVec3::new(rng.random_range(0.5..1.0), rng.random_range(-0.3..0.3), rng.random_range(0.3..0.8)),
    );
    let z = Isometry3::from_quat_translation(
        rand_rot(rng, Some(30.0)),
        DVec3::new(rng.random_range(-0.05..0.05), rng.random_range(-0.05..0.05), rng.random_range(0.05..0.15)),
    );
    let c: Vec<Isometry3> = (0..stations).map(|_| facing_camera(rng)).collect();
    // C = Y⁻¹ G Z  ⇒  G = Y C Z⁻¹
    let g = c.iter().map(|ci| y * *ci * z.inverse()).collect();
    Scene { g, c, x: y, w: z }
}

/// Right-multiplied noise on both pose lists.
pub fn with_noise(s: &Scene, rng: &mut impl Rng, sigma_deg: f64, sigma_t: f64) -> Scene {
    Scene {
        g: s.g.iter().map(|p| noisy(p, sigma_deg.to_radians(), sigma_t, rng)).collect(),
        c: s.c.iter().map(|p| noisy(p, sigma_deg.to_radians(), sigma_t, rng)).collect(),
        x: s.x,
        w: s.w,
    }
}

/// `p` with its translation multiplied by `s`.
pub fn scaled(p: &Isometry3, s: f64) -> Isometry3 {
    p.with_translation(p.translation * s)
}
