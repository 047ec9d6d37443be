//! Property tests (fixed seed): round trips of distortion, poses and rotation vectors.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(Config { cases, ..Config::default() }, TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]))
}

/// Radial derivative `d(r·radial(r²))/dr` stays positive up to `r_max` (the lens does not fold).
fn monotonic(d: &Distortion, r_max: f64) -> bool {
    (0..=200).all(|i| {
        let r = r_max * i as f64 / 200.0;
        let h = 1e-6;
        let f = |r: f64| d.distort(DVec2::new(r, 0.0)).x;
        (f(r + h) - f(r)) / h > 0.1
    })
}

/// distort ∘ undistort returns every pixel of the image within 1e-6 px, for realistic
/// coefficients (|k1| ≤ 0.5, |k2| ≤ 0.3, |k3| ≤ 0.1, |p1|, |p2| ≤ 0.01) on lenses that do not fold
/// inside the image.
#[test]
fn undistort_then_distort_returns_the_pixel_over_the_whole_image() {
    let strategy = (
        400.0..1200.0f64,
        -0.5..0.5f64,
        -0.3..0.3f64,
        -0.01..0.01f64,
        -0.01..0.01f64,
        -0.1..0.1f64,
        0.0..1.0f64,
        0.0..1.0f64,
    );
    runner(256)
        .run(&strategy, |(f, k1, k2, p1, p2, k3, su, sv)| {
            let camera =
                Camera::new(Intrinsics::new(f, f * 1.001, 320.0, 240.0), Distortion::new(k1, k2, p1, p2, k3), 640, 480)
                    .unwrap();
            // Normalised radius of the image corner, and the undistorted range that must not fold.
            let r_corner = (320.0f64.hypot(240.0)) / f;
            prop_assume!(monotonic(camera.distortion().unwrap(), 2.0 * r_corner));
            prop_assume!(camera.distortion().unwrap().distort(DVec2::new(2.0 * r_corner, 0.0)).x > 1.2 * r_corner);
            let pixel = DVec2::new(-0.5 + su * 640.0, -0.5 + sv * 480.0);
            let ray = camera.unproject(pixel).unwrap();
            let back = camera.project(ray).unwrap();
            prop_assert!((back - pixel).length() < 1e-6, "pixel {pixel} came back as {back}");
            Ok(())
        })
        .unwrap();
}

fn rotation_strategy() -> impl Strategy<Value = DVec3> {
    // Axis on the sphere, angle anywhere in [0, π] with extra weight at both ends.
    let angle =
        prop_oneof![0.0..1e-9f64, 0.0..std::f64::consts::PI, (std::f64::consts::PI - 1e-9)..std::f64::consts::PI];
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, angle).prop_filter_map("axis", |(x, y, z, a)| {
        let axis = DVec3::new(x, y, z);
        (axis.length() > 1e-3).then(|| axis.normalize() * a)
    })
}

/// Rodrigues vector → matrix → vector, including angles near 0 and near π (where the axis sign
/// is ambiguous: compare the rotations, and the vector up to that sign).
#[test]
fn rvec_matrix_round_trip_near_zero_and_pi() {
    runner(512)
        .run(&rotation_strategy(), |rvec| {
            let iso = Isometry3::from_rvec_tvec(rvec, DVec3::ZERO);
            let m = iso.rotation_matrix();
            let back = Isometry3::from_rotation_translation(m, DVec3::ZERO).unwrap();
            let r2 = back.rvec();
            let close = (r2 - rvec).length() < 1e-9 * rvec.length().max(1e-12) + 1e-15
                || (rvec.length() > std::f64::consts::PI - 1e-6 && (r2 + rvec).length() < 1e-6);
            prop_assert!(close, "rvec {rvec} came back as {r2}");
            let dm = back.rotation_matrix() - m;
            prop_assert!(dm.abs().to_cols_array().iter().all(|v| *v < 1e-12));
            // The matrix is exactly Rodrigues' formula.
            let theta = rvec.length();
            if theta > 1e-6 {
                let k = rvec / theta;
                let kx = parallax_camera_model::skew_symmetric(k);
                let rodrigues = DMat3::IDENTITY + kx * theta.sin() + kx * kx * (1.0 - theta.cos());
                prop_assert!((rodrigues - m).abs().to_cols_array().iter().all(|v| *v < 1e-12));
            }
            Ok(())
        })
        .unwrap();
}

/// pose ∘ pose⁻¹ = identity and composition agrees with 4x4 matrices.
#[test]
fn pose_inverse_and_composition() {
    let strategy = (rotation_strategy(), rotation_strategy(), -5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64);
    runner(256)
        .run(&strategy, |(r1, r2, x, y, z)| {
            let a = Isometry3::from_rvec_tvec(r1, DVec3::new(x, y, z));
            let b = Isometry3::from_rvec_tvec(r2, DVec3::new(z, x, -y));
            let id = a * a.inverse();
            let (angle, dist) = id.distance(&Isometry3::IDENTITY);
            prop_assert!(angle < 1e-12 && dist < 1e-12);
            let m = a.to_mat4() * b.to_mat4();
            let ab = (a * b).to_mat4();
            prop_assert!((m - ab).abs().to_cols_array().iter().all(|v| *v < 1e-12));
            let back = Isometry3::from_mat4(ab).unwrap();
            let (angle, dist) = back.distance(&(a * b));
            prop_assert!(angle < 1e-12 && dist < 1e-12);
            Ok(())
        })
        .unwrap();
}
