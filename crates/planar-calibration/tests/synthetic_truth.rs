//! The synthetic-truth bar: 20 views, 0.1 px noise, 640x480, k1 = −0.3, k2 = 0.1.

mod common;

use common::{board, noisy_views, truth_camera};
use parallax_planar_calibration::{CalibrationConfig, calibrate_camera};

#[test]
fn one_calibration_is_accurate() {
    let truth = truth_camera();
    let (poses, object, image) = noisy_views(&truth, &board(), 20, 0.1, 7);
    let r = calibrate_camera(&object, &image, 640, 480, &CalibrationConfig::default()).unwrap();
    let k = r.camera.intrinsics;
    let t = truth.intrinsics;
    assert!((k.fx / t.fx - 1.0).abs() < 1e-3 && (k.fy / t.fy - 1.0).abs() < 1e-3);
    assert!((k.cx - t.cx).abs() < 0.5 && (k.cy - t.cy).abs() < 0.5);
    // σ per coordinate ≈ 0.1 px; RMS per corner ≈ √2 σ √(dof / 2N).
    assert!((r.sigma_px - 0.1).abs() < 0.01, "sigma {}", r.sigma_px);
    for (est, p) in r.camera_from_board.iter().zip(&poses) {
        let (da, dt) = est.distance(p);
        assert!(da < 5e-3 && dt < 1.0, "pose error {da} rad {dt} mm");
    }
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
}

struct TrialStats {
    inside: [usize; 9],
    inside1: [usize; 9],
    estimated: [bool; 9],
    within_bars: usize,
    worst_f: f64,
    worst_c: f64,
    median_sigma_fx: f64,
    median_sigma_cx: f64,
}

const NAMES: [&str; 9] = ["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"];

fn run_trials(cfg: &CalibrationConfig, trials: u64) -> TrialStats {
    let truth = truth_camera();
    let t = truth.intrinsics;
    let td = truth.distortion().copied().unwrap();
    let true_params = [t.fx, t.fy, t.cx, t.cy, td.k1, td.k2, td.p1, td.p2, td.k3];
    let mut st = TrialStats {
        inside: [0; 9],
        inside1: [0; 9],
        estimated: [false; 9],
        within_bars: 0,
        worst_f: 0.0,
        worst_c: 0.0,
        median_sigma_fx: 0.0,
        median_sigma_cx: 0.0,
    };
    let (mut sig_fx, mut sig_cx) = (Vec::new(), Vec::new());
    for seed in 0..trials {
        let (_, object, image) = noisy_views(&truth, &board(), 20, 0.1, 1000 + seed);
        let r = calibrate_camera(&object, &image, 640, 480, cfg).unwrap();
        let k = r.camera.intrinsics;
        let d = r.camera.distortion().copied().unwrap();
        let ef = (k.fx / t.fx - 1.0).abs().max((k.fy / t.fy - 1.0).abs());
        let ec = (k.cx - t.cx).abs().max((k.cy - t.cy).abs());
        st.worst_f = st.worst_f.max(ef);
        st.worst_c = st.worst_c.max(ec);
        if ef < 1e-3 && ec < 0.5 {
            st.within_bars += 1;
        }
        let s = r.std_devs;
        sig_fx.push(s.fx.unwrap());
        sig_cx.push(s.cx.unwrap());
        let est = [k.fx, k.fy, k.cx, k.cy, d.k1, d.k2, d.p1, d.p2, d.k3];
        let sig = [s.fx, s.fy, s.cx, s.cy, s.k1, s.k2, s.p1, s.p2, s.k3];
        for i in 0..9 {
            if let Some(sg) = sig[i] {
                st.estimated[i] = true;
                if (est[i] - true_params[i]).abs() <= 3.0 * sg {
                    st.inside[i] += 1;
                }
                if (est[i] - true_params[i]).abs() <= sg {
                    st.inside1[i] += 1;
                }
            }
        }
    }
    sig_fx.sort_by(f64::total_cmp);
    sig_cx.sort_by(f64::total_cmp);
    st.median_sigma_fx = sig_fx[sig_fx.len() / 2];
    st.median_sigma_cx = sig_cx[sig_cx.len() / 2];
    eprintln!(
        "{trials} trials: {} within bars; worst |f/f0 - 1| = {:.2e}, worst |c - c0| = {:.3} px; median sigma fx {:.3} px, cx {:.3} px",
        st.within_bars, st.worst_f, st.worst_c, st.median_sigma_fx, st.median_sigma_cx
    );
    for i in 0..9 {
        if st.estimated[i] {
            eprintln!("  {}: {}/{trials} inside 3 sigma, {} inside 1 sigma", NAMES[i], st.inside[i], st.inside1[i]);
        }
    }
    st
}

/// OpenCV's default model (k1, k2, p1, p2, k3 estimated) over 100 seeded trials: every true
/// parameter (including p1 = p2 = k3 = 0) lies within 3 reported sigmas in ≥ 95 % of them.
/// The reported sigmas are not inflated either: about 68 % of the errors fall within 1σ.
/// The principal point has σ ≈ 0.35 px with this geometry (as OpenCV's reported σ on the real
/// 14-view set, scaled to 0.1 px noise), so the 0.5 px bar holds in most trials, not all:
/// asserted for ≥ 75 % of them (the fixed-seed case above meets it).
#[test]
fn hundred_trials_default_model_coverage() {
    let st = run_trials(&CalibrationConfig::default(), 100);
    for i in 0..9 {
        assert!(st.estimated[i]);
        assert!(st.inside[i] >= 95, "{}: only {}/100 inside 3 sigma", NAMES[i], st.inside[i]);
        assert!((50..=85).contains(&st.inside1[i]), "{}: {}/100 inside 1 sigma", NAMES[i], st.inside1[i]);
    }
    assert!(st.within_bars >= 75, "only {} trials within the bars", st.within_bars);
}

/// The model of the truth (k1, k2 only: zero tangential, k3 fixed) over 100 seeded trials:
/// every estimated true parameter within 3 reported sigmas in ≥ 95 % of them; fx, fy within
/// 0.1 % in every trial; cx, cy within 1 px in every trial (σ ≈ 0.35 px).
#[test]
fn hundred_trials_truth_model_accuracy_and_coverage() {
    let cfg = CalibrationConfig { zero_tangential: true, fix_k3: true, ..CalibrationConfig::default() };
    let st = run_trials(&cfg, 100);
    assert!(st.worst_f < 1e-3, "focal length off by {}", st.worst_f);
    assert!(st.worst_c < 1.0, "principal point off by {} px", st.worst_c);
    for i in 0..6 {
        assert!(st.estimated[i]);
        assert!(st.inside[i] >= 95, "{}: only {}/100 inside 3 sigma", NAMES[i], st.inside[i]);
    }
    assert!(!st.estimated[6] && !st.estimated[7] && !st.estimated[8]);
}
