//! ChArUco acceptance (issue 18): 50 synthetic views (blur 0.8 px, noise σ 2 grey levels), a
//! third of them partial and a quarter with an occluder: zero wrong ids, corner RMS ≤ 0.03 px
//! against the exact projections, and views with 30–60 % of the board visible detected.
//! `CHARUCO_DUMP=DIR` writes the rendered views there (for looking at them or running
//! OpenCV on them).

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, CharucoBoard, Chessboard, Distortion, Intrinsics, Isometry3, MarkerDictionary};
use parallax_corner_detection::{CharucoConfig, detect_charuco};
use parallax_synthetic::{Occluder, RenderOptions, ViewSetConfig, calibration_poses, render_charuco, rng};
use rand::Rng;

fn camera() -> Camera {
    Camera {
        intrinsics: Intrinsics::new(760.0, 760.0, 402.0, 297.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width: 800,
        height: 600,
    }
}

fn board() -> CharucoBoard {
    CharucoBoard::new(9, 7, 25.0, 18.0, MarkerDictionary::predefined("DICT_4X4_50").unwrap(), false).unwrap()
}

/// `camera_from_board` poses: the view generator's chessboard frame (origin at the first
/// inner corner) moved to the ChArUco frame (origin at the board's outer corner).
fn poses(cam: &Camera, b: &CharucoBoard, views: usize, seed: u64) -> Vec<Isometry3> {
    let chess = Chessboard { cols: b.squares_x() - 1, rows: b.squares_y() - 1, square_size: b.square_length() };
    let cfg = ViewSetConfig {
        views,
        seed,
        allow_partial: true,
        min_distance: 350.0,
        max_distance: 650.0,
        ..Default::default()
    };
    let shift = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-b.square_length(), -b.square_length(), 0.0));
    calibration_poses(cam, &chess, &cfg).unwrap().into_iter().map(|p| p * shift).collect()
}

/// With `CHARUCO_DUMP=DIR`: view `k` into `DIR/sub/viewKK.png` and its truth, `id u v visible`
/// per corner with a projection, into `viewKK.truth.txt` (for OpenCV's script).
fn dump(sub: &str, k: usize, view: &parallax_synthetic::TargetView) {
    let Ok(dir) = std::env::var("CHARUCO_DUMP") else { return };
    let dir = std::path::Path::new(&dir).join(sub);
    std::fs::create_dir_all(&dir).unwrap();
    view.image.save(dir.join(format!("view{k:02}.png"))).unwrap();
    let truth: String = view
        .points
        .iter()
        .enumerate()
        .filter_map(|(id, p)| p.map(|p| format!("{id} {} {} {}\n", p.x, p.y, view.visible[id] as u8)))
        .collect();
    std::fs::write(dir.join(format!("view{k:02}.truth.txt")), truth).unwrap();
}

/// Corners against the truth: visible, found within 1 px of their id's truth, further off.
#[derive(Default, Clone, Copy)]
struct Tally {
    visible: usize,
    found: usize,
    wrong: usize,
    sum_sq: f64,
}

impl Tally {
    fn add(&mut self, det: &parallax_corner_detection::CharucoDetection, view: &parallax_synthetic::TargetView) {
        self.visible += view.visible.iter().filter(|&&v| v).count();
        for (&id, &p) in det.observation.ids().iter().zip(det.observation.points()) {
            let e = (p - view.points[id as usize].expect("a detected corner has a projection")).length();
            if e > 1.0 {
                self.wrong += 1;
            } else {
                self.found += 1;
                self.sum_sq += e * e;
            }
        }
    }

    fn rms(&self) -> f64 {
        (self.sum_sq / self.found.max(1) as f64).sqrt()
    }
}

#[derive(Default, Debug)]
struct Stats {
    views: usize,
    detected_views: usize,
    visible: usize,
    found: usize,
    wrong_ids: usize,
    sum_sq: f64,
    worst: f64,
    mid_views: usize,
    mid_detected: usize,
}

#[test]
fn fifty_views_zero_wrong_ids_and_exact_corners() {
    let cam = camera();
    let b = board();
    let mut s = Stats::default();
    let mut r = rng(77);
    for (k, pose) in poses(&cam, &b, 50, 41).iter().enumerate() {
        let occluders = if k % 4 == 3 {
            // A quadrilateral "hand" over a random part of the image.
            let c = DVec2::new(r.random_range(150.0..650.0), r.random_range(100.0..500.0));
            let (a, l): (f64, f64) = (r.random_range(0.0..3.1), r.random_range(60.0..140.0));
            let d = DVec2::new(a.cos(), a.sin()) * l;
            let e = d.perp() * 0.6;
            vec![Occluder { polygon: vec![c - d - e, c + d - e, c + d + e, c - d + e], grey: 90 }]
        } else {
            vec![]
        };
        let opts = RenderOptions { blur_sigma: 0.8, noise_sigma: 2.0, seed: 900 + k as u64, ..Default::default() };
        let view = render_charuco(&cam, &b, pose, &opts, &occluders, 4.0).unwrap();
        let det = detect_charuco(&view.image, &b, &CharucoConfig::default()).unwrap();
        assert_eq!(det.square_frame, None, "view {k}: a solid print taken for an outlined one");
        dump("", k, &view);
        s.views += 1;
        let visible = view.visible.iter().filter(|&&v| v).count();
        s.visible += visible;
        let frac = view.visible_fraction();
        let mut found_visible = 0;
        for (&id, &p) in det.observation.ids().iter().zip(det.observation.points()) {
            let t = view.points[id as usize].expect("a detected corner has a projection");
            let e = (p - t).length();
            if e > 1.0 {
                s.wrong_ids += 1;
                println!("view {k}: corner {id} is {e:.2} px from its truth");
                continue;
            }
            s.found += 1;
            if e > 0.1 {
                println!("view {k}: corner {id} error {e:.3} px (visible {})", view.visible[id as usize]);
            }
            s.sum_sq += e * e;
            s.worst = s.worst.max(e);
            if view.visible[id as usize] {
                found_visible += 1;
            }
        }
        if !det.observation.is_empty() {
            s.detected_views += 1;
        }
        if (0.3..=0.6).contains(&frac) {
            s.mid_views += 1;
            if found_visible as f64 >= 0.5 * visible as f64 {
                s.mid_detected += 1;
            }
        }
        println!(
            "view {k}: visible {visible} ({:.0} %), found {} ({found_visible} of the visible), markers {}{}",
            100.0 * frac,
            det.observation.len(),
            det.markers.len(),
            if occluders.is_empty() { "" } else { ", occluded" }
        );
    }
    let rms = (s.sum_sq / s.found.max(1) as f64).sqrt();
    println!(
        "ChArUco 50 views: detected in {}/{} views, corners found {} of {} visible ({:.1} %), wrong ids {}, RMS {rms:.4} px, worst {:.4} px; views 30-60 % visible: {}/{} with at least half their corners",
        s.detected_views,
        s.views,
        s.found,
        s.visible,
        100.0 * s.found as f64 / s.visible.max(1) as f64,
        s.wrong_ids,
        s.worst,
        s.mid_detected,
        s.mid_views
    );
    assert_eq!(s.wrong_ids, 0);
    assert!(rms <= 0.03, "RMS {rms}");
    assert!(s.mid_views >= 3 && s.mid_detected == s.mid_views, "{s:?}");
    assert!(s.found as f64 >= 0.9 * s.visible as f64, "{s:?}");
}

/// Issue 49: boards printed with outlined black squares (a dark frame around a light
/// interior; the markers as usual), frames of 0.03, 0.06 and 0.12 of a square (about 1.2, 2.4
/// and 4.8 px here), 20 views each, blur 0.8 px, noise σ 2: the corners are located from the
/// squares' edges. Found: at least 93 % of the visible corners in every set (OpenCV 5.1's
/// `CharucoDetector` on these views: 92.0–94.0 %, see `scripts/charuco_vs_opencv.py`), no
/// wrong id, RMS within 0.06 px of the truth (OpenCV: 0.11–0.24 px, and 11 corners more than 1 px
/// off on the thinnest frame). The frame's width is
/// measured within 0.01 of a square plus a quarter of its width (the profile is read
/// through the markers' homographies, a square beyond them); solid prints report none.
/// `CHARUCO_DUMP=DIR` writes each set's views to `DIR/outlined-<frame>/`.
#[test]
fn outlined_squares_are_found_from_the_markers() {
    let cam = camera();
    let b = board();
    for frame in [0.03, 0.06, 0.12] {
        let mut tally = Tally::default();
        for (k, pose) in poses(&cam, &b, 20, 41).iter().enumerate() {
            let opts = RenderOptions {
                blur_sigma: 0.8,
                noise_sigma: 2.0,
                square_outline: frame,
                seed: 300 + k as u64,
                ..Default::default()
            };
            let view = render_charuco(&cam, &b, pose, &opts, &[], 4.0).unwrap();
            dump(&format!("outlined-{frame}"), k, &view);
            let det = detect_charuco(&view.image, &b, &CharucoConfig::default()).unwrap();
            let measured = det.square_frame.expect("an outlined print is recognised");
            assert!(
                (measured - frame).abs() <= 0.01 + 0.25 * frame,
                "view {k}: frame {measured:.3} measured for {frame}"
            );
            tally.add(&det, &view);
        }
        let Tally { visible, found, wrong, .. } = tally;
        let rms = tally.rms();
        println!(
            "outlined squares, frame {frame}: found {found} of {visible} visible, wrong ids {wrong}, RMS {rms:.4} px"
        );
        assert_eq!(wrong, 0, "frame {frame}");
        assert!(found as f64 >= 0.93 * visible as f64, "frame {frame}: {found} of {visible}");
        assert!(rms <= 0.06, "frame {frame}: RMS {rms}");
    }
}

/// Issue 49: an outlined print (frame 0.06 of a square) photographed as the issue's: 720x540,
/// farther away (squares of 15–30 px), blur 1.2 px, noise σ 3, light falling off across the
/// image (gradient ±40 %, vignetting 30 %), 12 views. One marker is misread in two views (a
/// bit corrected, no neighbour agreeing): it is left out, not taken for a layout mismatch that
/// would reject the board. Found at least 70 % of the visible corners (406 of 517 when
/// written; OpenCV 5.1's `CharucoDetector` on the same views: 175, 24 of them more than 1 px
/// off, RMS 0.32 px), no wrong id, RMS within 0.08 px.
#[test]
fn outlined_print_under_uneven_light_and_blur() {
    let cam = Camera {
        intrinsics: Intrinsics::new(700.0, 700.0, 362.0, 268.0),
        lens: Distortion::new(-0.15, 0.05, 0.0, 0.0, 0.0).into(),
        width: 720,
        height: 540,
    };
    let b = board();
    let chess = Chessboard { cols: b.squares_x() - 1, rows: b.squares_y() - 1, square_size: b.square_length() };
    let cfg = ViewSetConfig {
        views: 12,
        seed: 5,
        allow_partial: true,
        min_distance: 450.0,
        max_distance: 750.0,
        ..Default::default()
    };
    let shift = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-b.square_length(), -b.square_length(), 0.0));
    let mut tally = Tally::default();
    for (k, pose) in calibration_poses(&cam, &chess, &cfg).unwrap().into_iter().map(|p| p * shift).enumerate() {
        let opts = RenderOptions {
            blur_sigma: 1.2,
            noise_sigma: 3.0,
            square_outline: 0.06,
            illumination_gradient: 0.4,
            vignetting: 0.3,
            seed: 77 + k as u64,
            ..Default::default()
        };
        let view = render_charuco(&cam, &b, &pose, &opts, &[], 4.0).unwrap();
        dump("outlined-uneven", k, &view);
        let det = detect_charuco(&view.image, &b, &CharucoConfig::default()).unwrap();
        assert!(det.misplaced.is_empty(), "view {k}: {:?} taken as misplaced", det.misplaced);
        tally.add(&det, &view);
    }
    let Tally { visible, found, wrong, .. } = tally;
    let rms = tally.rms();
    println!("outlined print, uneven light: found {found} of {visible} visible, wrong ids {wrong}, RMS {rms:.4} px");
    assert_eq!(wrong, 0);
    assert!(found as f64 >= 0.7 * visible as f64, "{found} of {visible}");
    assert!(rms <= 0.08, "RMS {rms}");
}

/// A board printed in inverted colours (light squares and markers on dark paper; OpenCV reads
/// such markers only with `detectInvertedMarker`): found from the negative image, said so, every
/// corner within 0.1 px of its truth; the ordinary print is not reported as inverted.
#[test]
fn inverted_print_is_found_and_said_so() {
    let cam = camera();
    let b = board();
    let mut tally = Tally::default();
    for (k, pose) in poses(&cam, &b, 4, 43).iter().enumerate() {
        let opts = RenderOptions {
            blur_sigma: 0.8,
            noise_sigma: 2.0,
            black: 220,
            white: 30,
            seed: k as u64,
            ..Default::default()
        };
        let view = render_charuco(&cam, &b, pose, &opts, &[], 4.0).unwrap();
        let det = detect_charuco(&view.image, &b, &CharucoConfig::default()).unwrap();
        assert!(det.inverted, "view {k}");
        tally.add(&det, &view);
        for (&id, &p) in det.observation.ids().iter().zip(det.observation.points()) {
            let e = (p - view.points[id as usize].unwrap()).length();
            assert!(e < 0.1, "view {k}: corner {id} {e:.3} px off");
        }
        let plain = RenderOptions { black: 30, white: 220, ..opts };
        let view = render_charuco(&cam, &b, pose, &plain, &[], 4.0).unwrap();
        assert!(!detect_charuco(&view.image, &b, &CharucoConfig::default()).unwrap().inverted);
    }
    println!("inverted print: found {} of {} visible, RMS {:.4} px", tally.found, tally.visible, tally.rms());
    assert!(tally.found as f64 >= 0.9 * tally.visible as f64, "{} of {}", tally.found, tally.visible);
}
