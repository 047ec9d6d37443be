//! Seeded noise helpers.

use glam::{DVec2, DVec3};
use parallax_camera_model::Isometry3;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

/// The random generator of every `synthetic` function: ChaCha8 seeded from `seed`, so the same
/// seed gives the same stream on every platform.
pub fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

/// One `N(0, 1)` draw.
#[inline]
pub(crate) fn normal(rng: &mut (impl Rng + ?Sized)) -> f64 {
    rng.sample(StandardNormal)
}

/// Three independent `N(0, σ²)` draws.
pub(crate) fn normal3(rng: &mut (impl Rng + ?Sized), sigma: f64) -> DVec3 {
    let x = normal(rng);
    let y = normal(rng);
    let z = normal(rng);
    DVec3::new(x, y, z) * sigma
}

/// Adds `N(0, σ²)` noise (pixels) to each coordinate of every point, in order (`x` then `y`).
/// `sigma_px = 0` leaves the points unchanged (the draws are still consumed, so the stream
/// does not depend on σ).
pub fn add_pixel_noise(points: &mut [DVec2], sigma_px: f64, rng: &mut impl Rng) {
    for p in points.iter_mut() {
        let dx = normal(rng);
        let dy = normal(rng);
        if sigma_px != 0.0 {
            *p += DVec2::new(dx, dy) * sigma_px;
        }
    }
}

/// Right-multiplied pose noise, as `../shared/reference/peer/handeye.py`:
/// `pose * Exp(ω, v)` where `Exp(ω, v)` is the rigid transform with rotation vector `ω`
/// (Rodrigues, radians) and translation `v`, and `ω, v ~ N(0, σ²)` per axis
/// (`rot_sigma_rad` in radians, `trans_sigma` in the scene's length unit).
///
/// The noise is expressed in the pose's *source* frame (for `camera_from_board`: the board
/// frame). Three rotation draws then three translation draws are always consumed; with both
/// sigmas zero the pose is returned unchanged.
pub fn perturb_pose(pose: &Isometry3, rot_sigma_rad: f64, trans_sigma: f64, rng: &mut impl Rng) -> Isometry3 {
    let w = normal3(rng, rot_sigma_rad);
    let v = normal3(rng, trans_sigma);
    if rot_sigma_rad == 0.0 && trans_sigma == 0.0 {
        return *pose;
    }
    *pose * Isometry3::from_rvec_tvec(w, v)
}

/// A uniformly distributed random rotation (normalised 4-D Gaussian quaternion), as
/// `rand_rot(rng)` of handeye.py.
pub(crate) fn uniform_rotation(rng: &mut (impl Rng + ?Sized)) -> glam::DQuat {
    loop {
        let q = glam::DVec4::new(normal(rng), normal(rng), normal(rng), normal(rng));
        let n = q.length();
        if n > 1e-6 {
            let q = q / n;
            return glam::DQuat::from_xyzw(q.x, q.y, q.z, q.w);
        }
    }
}

/// A rotation about a uniformly random axis by an angle uniform in `[0, max_angle]` radians,
/// as `rand_rot(rng, max_deg)` of handeye.py.
pub(crate) fn bounded_rotation(rng: &mut (impl Rng + ?Sized), max_angle: f64) -> glam::DQuat {
    let axis = loop {
        let a = normal3(rng, 1.0);
        if a.length() > 1e-9 {
            break a.normalize();
        }
    };
    let angle = rng.random::<f64>() * max_angle;
    glam::DQuat::from_axis_angle(axis, angle)
}

/// Uniform draw in `[lo, hi)`.
#[inline]
pub(crate) fn uniform(rng: &mut (impl Rng + ?Sized), lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}
