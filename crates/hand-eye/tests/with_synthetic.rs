//! Hand-eye on trajectories of the `synthetic` crate (eye-in-hand and eye-to-hand).

use parallax_camera_model::Isometry3;
use parallax_hand_eye::{HandEyeConfig, Method, Setup, calibrate};
use parallax_synthetic::{TrajectoryConfig, hand_eye_trajectory};

fn config(eye_in_hand: bool) -> HandEyeConfig {
    HandEyeConfig { setup: if eye_in_hand { Setup::EyeInHand } else { Setup::EyeToHand }, ..Default::default() }
}

fn truth(t: &parallax_synthetic::Trajectory) -> (Isometry3, Isometry3) {
    if t.eye_in_hand {
        (t.truth.gripper_from_camera, t.truth.base_from_board)
    } else {
        (t.truth.base_from_camera, t.truth.gripper_from_board)
    }
}

#[test]
fn noise_free_trajectories_are_solved_exactly_by_every_method() {
    for eye_in_hand in [true, false] {
        for seed in 0..5 {
            let cfg =
                TrajectoryConfig { eye_in_hand, rot_noise_rad: 0.0, trans_noise: 0.0, seed, ..Default::default() };
            let t = hand_eye_trajectory(&cfg).unwrap();
            let (x, w) = truth(&t);
            for m in Method::ALL {
                let sol = calibrate(&t.base_from_gripper, &t.camera_from_board, m, &config(eye_in_hand))
                    .unwrap_or_else(|e| panic!("{m} seed {seed} eye_in_hand {eye_in_hand}: {e}"));
                let (dr, dt) = sol.transform.distance(&x);
                assert!(dr < 1e-9 && dt < 1e-9, "{m} seed {seed} eye_in_hand {eye_in_hand}: {dr:e}, {dt:e}");
                let (br, bt) = sol.board.distance(&w);
                assert!(br < 1e-9 && bt < 1e-9, "{m} board, seed {seed}: {br:e}, {bt:e}");
            }
        }
    }
}

#[test]
fn noisy_trajectories_refined_error_and_std_devs() {
    for eye_in_hand in [true, false] {
        let trials = 100;
        let (mut sum_r, mut sum_t, mut park_r, mut park_t, mut covered) = (0.0, 0.0, 0.0, 0.0, 0);
        for seed in 0..trials {
            let t = hand_eye_trajectory(&TrajectoryConfig { eye_in_hand, seed: 1000 + seed, ..Default::default() })
                .unwrap();
            let (x, _) = truth(&t);
            let sol =
                calibrate(&t.base_from_gripper, &t.camera_from_board, Method::Refined, &config(eye_in_hand)).unwrap();
            let park =
                calibrate(&t.base_from_gripper, &t.camera_from_board, Method::Park, &config(eye_in_hand)).unwrap();
            let (er, et) = sol.transform.distance(&x);
            sum_r += er.to_degrees();
            sum_t += et * 1e3;
            let (pr, pt) = park.transform.distance(&x);
            park_r += pr.to_degrees();
            park_t += pt * 1e3;
            let sd = sol.refinement.unwrap().std_devs.unwrap();
            let w =
                Isometry3::from_quat_translation(x.rotation() * sol.transform.rotation().inverse(), glam::DVec3::ZERO)
                    .rvec();
            let d = x.translation - sol.transform.translation;
            let e = [w.x, w.y, w.z, d.x, d.y, d.z];
            if (0..6).all(|i| e[i].abs() <= 3.0 * sd[i]) {
                covered += 1;
            }
        }
        let n = trials as f64;
        println!(
            "eye_in_hand {eye_in_hand}: refined {:.4}° / {:.3} mm, park {:.4}° / {:.3} mm, 3σ coverage {covered}/{trials}",
            sum_r / n,
            sum_t / n,
            park_r / n,
            park_t / n
        );
        // Bars: the refined solution beats Park on the same data and stays near the
        // protocol's floor (0.2° / 2.7 mm measured over 1000 trials of the peer generator).
        assert!(sum_r < park_r && sum_t < park_t, "eye_in_hand {eye_in_hand}");
        assert!(sum_r / n < 0.25 && sum_t / n < 3.2, "eye_in_hand {eye_in_hand}: {} {}", sum_r / n, sum_t / n);
        assert!(covered as f64 >= 0.95 * n, "eye_in_hand {eye_in_hand}: coverage {covered}/{trials}");
    }
}
