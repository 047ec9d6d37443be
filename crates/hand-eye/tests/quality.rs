//! Quality measures against hand computations, the relative-motion refinement, small motions.

mod common;

use common::{noisy_scene, rng, scene};
use glam::{DQuat, DVec3};
use parallax_camera_model::Isometry3;
use parallax_hand_eye::{
    DegeneracyConfig, HandEyeConfig, HandEyeError, Method, Motion, RefineConfig, calibrate, check_motions, evaluate,
    motion_residual, points_to_base, points_to_gripper,
};

#[test]
fn motion_residual_matches_hand_computation() {
    // A = B = Rz(90°), X = translation (1, 0, 0): A X = [Rz, (0, 1, 0)], X B = [Rz, (1, 0, 0)].
    let rz = Isometry3::from_quat_translation(DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2), DVec3::ZERO);
    let m = Motion { i: 0, j: 1, a: rz, b: rz };
    let x = Isometry3::from_quat_translation(DQuat::IDENTITY, DVec3::X);
    let r = motion_residual(&m, &x);
    assert!(r.rotation_deg.abs() < 1e-12);
    assert!((r.translation - 2f64.sqrt()).abs() < 1e-12);
    assert!((r.matrix_error - 2f64.sqrt()).abs() < 1e-12);
    // A rotation-only mismatch: A = Rz(90°), B = Rz(80°), X = I → angle 10°, ‖ΔR‖_F = 2√2 sin(5°)·√... computed directly.
    let b = Isometry3::from_quat_translation(DQuat::from_rotation_z(80f64.to_radians()), DVec3::ZERO);
    let r = motion_residual(&Motion { i: 0, j: 1, a: rz, b }, &Isometry3::IDENTITY);
    assert!((r.rotation_deg - 10.0).abs() < 1e-9);
    // Two 2x2 blocks differ: each entry of cos/sin differs; ‖ΔR‖_F² = 2[(cos90−cos80)² + (sin90−sin80)²].
    let (c9, s9, c8, s8) = (0.0f64, 1.0f64, 80f64.to_radians().cos(), 80f64.to_radians().sin());
    let expect = (2.0 * ((c9 - c8).powi(2) + (s9 - s8).powi(2))).sqrt();
    assert!((r.matrix_error - expect).abs() < 1e-12);
}

#[test]
fn board_spread_and_residuals_of_a_wrong_transform() {
    // Noise-free scene evaluated with X off by 1° and 2 mm: ViSP's spread (mean distance of
    // each station's G X C from the mean) and the pair residuals, recomputed here directly.
    let mut r = rng(3);
    let s = scene(&mut r, 8);
    let wrong = s.x * Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, 1f64.to_radians()), DVec3::new(0.002, 0.0, 0.0));
    let q = evaluate(&s.g, &s.c, &wrong, &HandEyeConfig::default()).unwrap();
    let boards: Vec<Isometry3> = s.g.iter().zip(&s.c).map(|(g, c)| *g * wrong * *c).collect();
    let mean_t = boards.iter().map(|b| b.translation).sum::<DVec3>() / boards.len() as f64;
    let expect_t = boards.iter().map(|b| (b.translation - mean_t).length()).sum::<f64>() / boards.len() as f64;
    assert!(expect_t > 1e-3);
    assert!((q.board_spread_translation - expect_t).abs() < 1e-12, "{} vs {expect_t}", q.board_spread_translation);
    assert!(q.board_spread_rotation_deg > 0.1 && q.board_spread_rotation_deg < 2.0);
    assert_eq!(q.motions.len(), 28);
    let m = &q.motions[5];
    let (i, j) = (m.i, m.j);
    let ax = s.g[j].inverse() * s.g[i] * wrong;
    let xb = wrong * s.c[j] * s.c[i].inverse();
    assert!((m.translation - (ax.translation - xb.translation).length()).abs() < 1e-12);
    assert!((m.rotation_deg - ax.distance(&xb).0.to_degrees()).abs() < 1e-9);
    // The true X has zero spread and residuals.
    let q = evaluate(&s.g, &s.c, &s.x, &HandEyeConfig::default()).unwrap();
    assert!(q.board_spread_translation < 1e-12 && q.mean_rotation_deg < 1e-7 && q.mean_matrix_error < 1e-12);
}

#[test]
fn relative_motion_refinement_improves_on_tsai() {
    let mut r = rng(5);
    let cfg =
        HandEyeConfig { refine: RefineConfig { estimate_board: false, ..Default::default() }, ..Default::default() };
    let (mut rel, mut tsai) = ((0.0, 0.0), (0.0, 0.0));
    for _ in 0..40 {
        let s = noisy_scene(&mut r, 10, 0.1, 0.001);
        let a = calibrate(&s.g, &s.c, Method::Refined, &cfg).unwrap();
        let b = calibrate(&s.g, &s.c, Method::Tsai, &cfg).unwrap();
        let (ar, at) = a.transform.distance(&s.x);
        let (br, bt) = b.transform.distance(&s.x);
        rel = (rel.0 + ar.to_degrees(), rel.1 + at * 1e3);
        tsai = (tsai.0 + br.to_degrees(), tsai.1 + bt * 1e3);
        assert!(a.refinement.unwrap().std_devs.is_some());
    }
    println!(
        "relative-motion refinement {:.4}° / {:.3} mm, Tsai {:.4}° / {:.3} mm (sums over 40)",
        rel.0, rel.1, tsai.0, tsai.1
    );
    assert!(rel.0 < tsai.0 && rel.1 < tsai.1);
    assert!(rel.0 / 40.0 < 0.3 && rel.1 / 40.0 < 3.5);
}

#[test]
fn rotations_too_small_for_the_noise_are_an_error_naming_the_stations() {
    let mut r = rng(9);
    let s = scene(&mut r, 4);
    // Stations 0..3 differ by rotations below 1° only (0.15° steps about varied axes).
    let g: Vec<Isometry3> = (0..4)
        .map(|k| {
            let axis = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE.normalize()][k];
            s.g[0]
                * Isometry3::from_rvec_tvec(
                    axis * (0.15 * k as f64).to_radians(),
                    DVec3::new(0.01 * k as f64, 0.0, 0.0),
                )
        })
        .collect();
    let c: Vec<Isometry3> = g.iter().map(|gi| s.x.inverse() * gi.inverse() * s.w).collect();
    match calibrate(&g, &c, Method::Refined, &HandEyeConfig::default()) {
        Err(HandEyeError::Degenerate(msg)) => {
            assert!(msg.contains("0 of 6") && msg.contains("0–1") && msg.contains("at least 1°"), "{msg}");
        }
        other => panic!("expected a degeneracy error, got {other:?}"),
    }
    // The same data is accepted (and solved exactly: no noise) when the threshold is lowered.
    let cfg = HandEyeConfig {
        degeneracy: DegeneracyConfig { min_rotation_deg: 0.01, ..Default::default() },
        ..Default::default()
    };
    let sol = calibrate(&g, &c, Method::Park, &cfg).unwrap();
    assert!(sol.transform.distance(&s.x).0 < 1e-7);
    assert!(check_motions(&[], &DegeneracyConfig::default()).is_err());
}

#[test]
fn points_follow_the_chain() {
    let g = Isometry3::from_rvec_tvec(DVec3::new(0.1, 0.2, 0.3), DVec3::new(0.4, -0.1, 0.5));
    let x = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, 1.5), DVec3::new(0.05, 0.0, 0.1));
    let p = [DVec3::new(0.01, -0.02, 0.4), DVec3::new(0.0, 0.0, 1.0)];
    let in_gripper = points_to_gripper(&x, &p);
    let in_base = points_to_base(&g, &x, &p);
    for k in 0..2 {
        // Independent: rotation matrices and vectors.
        let pg = x.rotation_matrix() * p[k] + x.translation;
        let pb = g.rotation_matrix() * pg + g.translation;
        assert!((in_gripper[k] - pg).length() < 1e-15 && (in_base[k] - pb).length() < 1e-15);
    }
}
