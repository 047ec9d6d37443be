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
