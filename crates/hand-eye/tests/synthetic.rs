//! Hand-eye solvers against ground truth on synthetic trajectories (peer protocol).

mod common;

use common::{noisy_scene, realistic_scene, rng, scene, with_noise};
use glam::{DQuat, DVec3};
use parallax_camera_model::Isometry3;
use parallax_hand_eye::{
    ConsistencyConfig, HandEyeConfig, HandEyeError, HandEyeWarning, Method, PairSelection, Setup, calibrate,
    relative_motions, solve_motions,
};

fn err(a: &Isometry3, b: &Isometry3) -> (f64, f64) {
    let (r, t) = a.distance(b);
    (r.to_degrees(), t)
}

#[test]
fn every_method_is_exact_on_noise_free_data() {
    let mut r = rng(7);
    for trial in 0..20 {
        let s = scene(&mut r, 6);
        for pairs in [PairSelection::All, PairSelection::Consecutive] {
            let cfg = HandEyeConfig { pairs, ..Default::default() };
            for m in Method::ALL {
                let sol = calibrate(&s.g, &s.c, m, &cfg).unwrap_or_else(|e| panic!("{m} trial {trial}: {e}"));
                let (dr, dt) = sol.transform.distance(&s.x);
                assert!(dr < 1e-9 && dt < 1e-9, "{m} trial {trial} {pairs:?}: {dr:e} rad, {dt:e} m");
                let (br, bt) = sol.board.distance(&s.w);
                assert!(br < 1e-9 && bt < 1e-9, "{m} board trial {trial}: {br:e}, {bt:e}");
                assert!(sol.quality.mean_rotation_deg < 1e-7 && sol.quality.mean_translation < 1e-9);
                assert!(sol.quality.board_spread_rotation_deg < 1e-7 && sol.quality.board_spread_translation < 1e-9);
                assert!(sol.quality.mean_matrix_error < 1e-9);
            }
        }
    }
}

#[test]
fn eye_to_hand_is_exact_on_noise_free_data() {
    // Camera fixed in the base (base_from_camera = Y), board on the gripper (gripper_from_board = Z):
    // C_i = Y⁻¹ G_i Z.
    let mut r = rng(11);
    for trial in 0..10 {
        let s = scene(&mut r, 7);
        let y = s.x; // reuse the random transforms
        let z = Isometry3::from_rvec_tvec(DVec3::new(0.3, -0.2, 0.1), DVec3::new(0.0, 0.02, 0.1));
        let c: Vec<Isometry3> = s.g.iter().map(|g| y.inverse() * *g * z).collect();
        // Random Y: the board may be behind the camera (an algebra test, not a scene).
        let cfg = HandEyeConfig {
            setup: Setup::EyeToHand,
            consistency: ConsistencyConfig { allow_board_behind_camera: true, ..Default::default() },
            ..Default::default()
        };
        for m in Method::ALL {
            let sol = calibrate(&s.g, &c, m, &cfg).unwrap_or_else(|e| panic!("{m} trial {trial}: {e}"));
            let (dr, dt) = sol.transform.distance(&y);
            assert!(dr < 1e-9 && dt < 1e-9, "{m} trial {trial}: {dr:e} rad, {dt:e} m");
            let (br, bt) = sol.board.distance(&z);
            assert!(br < 1e-9 && bt < 1e-9, "{m} gripper_from_board trial {trial}: {br:e}, {bt:e}");
        }
    }
}

/// Stations whose relative motions include rotations of 1e-5 rad and π − 1e-6 rad, and an `X`
/// of 0, tiny, and nearly 180°.
#[test]
fn linear_solvers_exact_with_rotations_near_zero_and_near_180() {
    let w = Isometry3::from_rvec_tvec(DVec3::new(0.2, 2.9, 0.1), DVec3::new(0.6, 0.05, -0.02));
    let g0 = Isometry3::from_rvec_tvec(DVec3::new(0.1, -0.3, 0.2), DVec3::new(0.4, 0.1, 0.5));
    let step = |rv: DVec3, t: DVec3| g0 * Isometry3::from_rvec_tvec(rv, t);
    let g = vec![
        g0,
        step(DVec3::new(1e-5, 0.0, 0.0), DVec3::new(0.01, 0.0, 0.0)),
        step(DVec3::new(0.0, 1.0, 1.0).normalize() * (std::f64::consts::PI - 1e-6), DVec3::new(0.0, 0.05, 0.02)),
        step(DVec3::new(0.8, 0.0, 0.3), DVec3::new(-0.03, 0.02, 0.01)),
        step(DVec3::new(0.0, 0.0, 1e-6), DVec3::new(0.0, 0.0, 0.04)),
    ];
    let xs = [
        Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.05, -0.03, 0.1)),
        Isometry3::from_rvec_tvec(DVec3::new(1e-7, -2e-7, 0.0), DVec3::new(0.05, -0.03, 0.1)),
        Isometry3::from_rvec_tvec(DVec3::new(0.3, 0.2, -0.4), DVec3::new(0.05, -0.03, 0.1)),
        Isometry3::from_rvec_tvec(
            DVec3::new(1.0, -1.0, 0.5).normalize() * (std::f64::consts::PI - 1e-7),
            DVec3::new(0.05, -0.03, 0.1),
        ),
        Isometry3::from_quat_translation(DQuat::from_xyzw(0.0, 0.0, 1.0, 0.0), DVec3::new(0.05, -0.03, 0.1)),
    ];
    for (k, x) in xs.iter().enumerate() {
        let c: Vec<Isometry3> = g.iter().map(|gi| x.inverse() * gi.inverse() * w).collect();
        for pairs in [PairSelection::All, PairSelection::Consecutive] {
            let motions = relative_motions(&g, &c, Setup::EyeInHand, pairs).unwrap();
            let angles: Vec<f64> = motions.iter().map(|m| m.a.angle()).collect();
            assert!(angles.iter().any(|a| *a < 1e-4) && angles.iter().any(|a| *a > std::f64::consts::PI - 1e-3));
            for m in Method::LINEAR {
                let sol = solve_motions(m, &motions).unwrap_or_else(|e| panic!("{m} X#{k}: {e}"));
                let (dr, dt) = sol.distance(x);
                assert!(dr < 1e-9 && dt < 1e-9, "{m} X#{k} {pairs:?}: {dr:e} rad, {dt:e} m");
            }
        }
        // Random frames: the board is not in front of the camera (an algebra test, not a scene).
        let cfg = HandEyeConfig {
            consistency: ConsistencyConfig { allow_board_behind_camera: true, ..Default::default() },
            ..Default::default()
        };
        for m in [Method::Shah, Method::Li, Method::Refined] {
            let sol = calibrate(&g, &c, m, &cfg).unwrap();
            let (dr, dt) = sol.transform.distance(x);
            assert!(dr < 1e-9 && dt < 1e-9, "{m} X#{k}: {dr:e} rad, {dt:e} m");
        }
    }
}

/// OpenCV 4.14 on the same protocol (../shared/reference/opencv-baseline.md), mean errors.
const OPENCV_BEST_ROT_DEG: f64 = 0.230; // Andreff, Li
const OPENCV_BEST_TRANS_MM: f64 = 3.05; // Park, Horaud

#[test]
fn refined_beats_opencv_on_the_peer_protocol_and_its_std_devs_are_honest() {
    // The protocol's bars are expected errors. 100 trials estimate a mean translation error
    // only to about ±0.1 mm (seed 42's first 100 trials give 2.92 mm, seeds 1–4 2.67–2.94 mm,
    // 1000 trials 2.71 mm), so the check runs 500 trials (±0.05 mm).
    // HANDEYE_TRIALS / HANDEYE_SEED: other measurement runs.
    let trials: usize = std::env::var("HANDEYE_TRIALS").ok().and_then(|v| v.parse().ok()).unwrap_or(500);
    let seed: u64 = std::env::var("HANDEYE_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(42);
    let mut r = rng(seed);
    let mut sums = std::collections::BTreeMap::<&str, (f64, f64)>::new();
    let mut covered = 0;
    let mut variance = 0.0;
    // The protocol measures every solver as OpenCV's does, failures included: a solution the
    // fit check would refuse is let through, and each one it flags must be a real failure.
    let mut cfg = HandEyeConfig::default();
    cfg.observability.allow_poor_fit = true;
    let mut flagged = 0;
    for trial in 0..trials {
        let s = noisy_scene(&mut r, 10, 0.1, 0.001);
        for m in Method::ALL {
            let sol = calibrate(&s.g, &s.c, m, &cfg).unwrap_or_else(|e| panic!("{m} {trial}: {e}"));
            let (er, et) = err(&sol.transform, &s.x);
            if sol.warnings.iter().any(|w| matches!(w, HandEyeWarning::PoorRotationFit { .. })) {
                flagged += 1;
                assert!(er > 3.0, "{m} {trial}: flagged as a failed solver at {er:.3}° from the truth");
            }
            let e = sums.entry(m.name()).or_default();
            e.0 += er;
            e.1 += et * 1e3;
            if m == Method::Refined {
                let rf = sol.refinement.as_ref().unwrap();
                variance += rf.variance_factor;
                let sd = rf.std_devs.expect("covariance");
                // Error in the covariance's coordinates: R_true = Exp(ω) R, t_true = t + δt.
                let w = (s.x.rotation() * sol.transform.rotation().inverse()).normalize();
                let w = Isometry3::from_quat_translation(w, DVec3::ZERO).rvec();
                let dt = s.x.translation - sol.transform.translation;
                let e6 = [w.x, w.y, w.z, dt.x, dt.y, dt.z];
                if (0..6).all(|i| e6[i].abs() <= 3.0 * sd[i]) {
                    covered += 1;
                }
            }
        }
    }
    println!("method       mean rot (deg)  mean trans (mm)   [{trials} trials, 10 stations, 0.1°/1 mm noise]");
    for (name, (er, et)) in &sums {
        println!("{name:12} {:14.4} {:16.3}", er / trials as f64, et / trials as f64);
    }
    println!("solutions whose rotation fit was flagged (each > 3° from the truth): {flagged}");
    let coverage = covered as f64 / trials as f64;
    println!(
        "refined: 3σ coverage of all six components {:.1} %, mean variance factor {:.3}",
        100.0 * coverage,
        variance / trials as f64
    );
    let (rr, rt) = sums["refined"];
    let (rr, rt) = (rr / trials as f64, rt / trials as f64);
    assert!(rr <= 0.23 && rt <= 2.9, "refined mean error {rr:.4}° / {rt:.3} mm");
    assert!(rr < OPENCV_BEST_ROT_DEG && rt < OPENCV_BEST_TRANS_MM);
    for m in Method::ALL.iter().filter(|m| **m != Method::Refined) {
        let (mr, mt) = sums[m.name()];
        assert!(rr <= mr / trials as f64 + 1e-12 && rt <= mt / trials as f64 + 1e-12, "refined worse than {m}");
    }
    assert!(coverage >= 0.95, "3σ coverage {coverage}");
}

#[test]
fn degenerate_inputs_are_clear_errors() {
    let w = Isometry3::from_rvec_tvec(DVec3::new(0.0, 3.0, 0.0), DVec3::new(0.6, 0.0, 0.0));
    let x = Isometry3::from_rvec_tvec(DVec3::new(0.1, 0.2, 1.5), DVec3::new(0.05, -0.03, 0.1));
    let make = |g: &[Isometry3]| -> Vec<Isometry3> { g.iter().map(|gi| x.inverse() * gi.inverse() * w).collect() };
    // All rotations about one axis (z), with translations.
    let g: Vec<Isometry3> = (0..6)
        .map(|k| Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, 0.3 * k as f64), DVec3::new(0.4, 0.01 * k as f64, 0.5)))
        .collect();
    let c = make(&g);
    for m in Method::ALL {
        match calibrate(&g, &c, m, &HandEyeConfig::default()) {
            Err(HandEyeError::Degenerate(msg)) => assert!(msg.contains("same axis") && msg.contains("0–1"), "{msg}"),
            other => panic!("{m}: expected a degeneracy error, got {other:?}"),
        }
    }
    // Two stations.
    let g2 = vec![g[0], Isometry3::from_rvec_tvec(DVec3::new(0.5, 0.2, 0.0), DVec3::new(0.4, 0.0, 0.5))];
    let c2 = make(&g2);
    assert!(matches!(
        calibrate(&g2, &c2, Method::Tsai, &HandEyeConfig::default()),
        Err(HandEyeError::NotEnoughData(_))
    ));
    // Identical poses.
    let g3 = vec![g[1]; 5];
    let c3 = make(&g3);
    match calibrate(&g3, &c3, Method::Park, &HandEyeConfig::default()) {
        Err(HandEyeError::Degenerate(msg)) => assert!(msg.contains("0 of 10") && msg.contains("3–4"), "{msg}"),
        other => panic!("expected a degeneracy error, got {other:?}"),
    }
    // Mismatched lengths and NaN.
    assert!(matches!(
        calibrate(&g, &c[..5], Method::Park, &HandEyeConfig::default()),
        Err(HandEyeError::SizeMismatch(_))
    ));
    let mut bad = c.clone();
    bad[3].translation.x = f64::NAN;
    assert_eq!(
        calibrate(&g, &bad, Method::Park, &HandEyeConfig::default()).unwrap_err(),
        HandEyeError::NonFinite { what: "camera_from_board", index: 3 }
    );
}

#[test]
fn daniilidis_leaves_out_half_turns_instead_of_pairing_their_signs_by_noise() {
    // Realistic scenes (every view facing the board, any roll) have motions of nearly 180°
    // about the viewing axis; the sign of such a quaternion's scalar part is noise, and pairing
    // q_A with a flipped q_B gave Daniilidis rotation errors up to 86° (8 of 2000 trials at
    // 0.2° / 2 mm) where Park's were 0.27°. Every trial must now stay near Park's.
    // HANDEYE_SEED: other measurement runs.
    let seed: u64 = std::env::var("HANDEYE_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(7);
    let mut r = rng(seed);
    let mut worst: (f64, f64) = (0.0, 0.0);
    for trial in 0..1000 {
        let s0 = realistic_scene(&mut r, 10);
        let s = with_noise(&s0, &mut r, 0.2, 0.002);
        let cfg = HandEyeConfig::default();
        let d = calibrate(&s.g, &s.c, Method::Daniilidis, &cfg).unwrap_or_else(|e| panic!("trial {trial}: {e}"));
        let p = calibrate(&s.g, &s.c, Method::Park, &cfg).unwrap();
        let (ed, ep) = (err(&d.transform, &s.x).0, err(&p.transform, &s.x).0);
        assert!(ed <= 3.0 * ep + 1.0, "trial {trial}: Daniilidis {ed:.3}°, Park {ep:.3}°");
        if ed > worst.0 {
            worst = (ed, ep);
        }
    }
    println!("worst Daniilidis rotation error {:.3}° (Park {:.3}° on that trial)", worst.0, worst.1);
}

/// The trajectory on which Daniilidis landed 23° off (`hand_eye_trajectory`, seed 42, rotation
/// noise 0.002 rad and translation noise 0.5 per axis — metres, as large as the scene): the
/// translations are noise, every method's translation is 0.7 m off, and the two methods that
/// solve rotation and translation in one system (Daniilidis, Li) carry that noise into their
/// rotation. Every method is now refused; let through, the rotation-only methods keep their
/// rotation, and each solution whose rotation misfit is flagged is really off.
#[test]
fn translations_that_are_noise_are_refused_and_turn_only_the_coupled_solvers() {
    let cfg = parallax_synthetic::TrajectoryConfig { rot_noise_rad: 0.002, trans_noise: 0.5, ..Default::default() };
    let t = parallax_synthetic::hand_eye_trajectory(&cfg).unwrap();
    let x = t.truth.gripper_from_camera;
    for m in Method::ALL {
        match calibrate(&t.base_from_gripper, &t.camera_from_board, m, &HandEyeConfig::default()) {
            Err(HandEyeError::Implausible { message, .. }) => {
                assert!(message.contains("--allow-poor-fit"), "{m}: {message}")
            }
            other => panic!("{m}: expected an implausible solution, got {other:?}"),
        }
    }
    let mut allow = HandEyeConfig::default();
    allow.observability.allow_poor_fit = true;
    for m in Method::ALL {
        let sol = calibrate(&t.base_from_gripper, &t.camera_from_board, m, &allow).unwrap();
        let (er, et) = err(&sol.transform, &x);
        let flagged = sol.warnings.iter().any(|w| matches!(w, HandEyeWarning::PoorRotationFit { .. }));
        println!("{m:11} {er:7.2}° {:7.0} mm flagged {flagged}", et * 1e3);
        assert!(et > 0.3, "{m}: {et} m");
        assert!(sol.warnings.iter().any(|w| matches!(w, HandEyeWarning::PoorTranslationFit { .. })), "{m}");
        if matches!(m, Method::Daniilidis | Method::Li) {
            assert!(flagged && er > 10.0, "{m}: {er}°");
        } else {
            assert!(!flagged && er < 1.0, "{m}: {er}°");
        }
    }
    // The same trajectory with 1 mm of translation noise: every method solves, without a fit warning.
    let cfg = parallax_synthetic::TrajectoryConfig { rot_noise_rad: 0.002, trans_noise: 0.001, ..Default::default() };
    let t = parallax_synthetic::hand_eye_trajectory(&cfg).unwrap();
    for m in Method::ALL {
        let sol = calibrate(&t.base_from_gripper, &t.camera_from_board, m, &HandEyeConfig::default())
            .unwrap_or_else(|e| panic!("{m}: {e}"));
        assert!(err(&sol.transform, &x).0 < 1.0, "{m}");
        assert!(
            !sol.warnings.iter().any(|w| matches!(
                w,
                HandEyeWarning::PoorTranslationFit { .. } | HandEyeWarning::PoorRotationFit { .. }
            )),
            "{m}: {:?}",
            sol.warnings
        );
    }
}
