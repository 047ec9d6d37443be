//! The pictures of the reports: every image of the HTML is embedded and decodes; the figures the
//! pictures show agree with the calibration result and with independent computations; the
//! projection uncertainty map predicts the spread of re-calibrations.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::DVec2;
use parallax_camera_model::{Camera, Chessboard, CornerGrid, Distortion, Intrinsics, Isometry3};
use parallax_composition::plots::{self, Pictures, uncertainty::ProjectionUncertainty};
use parallax_composition::{StereoViews, io};
use parallax_planar_calibration::{CalibrationConfig, StereoConfig};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("parallax-plots-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Removes a test's output, unless `PARALLAX_KEEP_PLOTS` is set (to look at the pictures).
fn cleanup(out: &Path) {
    if std::env::var_os("PARALLAX_KEEP_PLOTS").is_none() {
        let _ = std::fs::remove_dir_all(out);
    } else {
        eprintln!("pictures kept in {}", out.display());
    }
}

/// Every `<img>` of `html` is a data URI of a PNG that decodes or an SVG that parses (its tags
/// balance), at least `min` pixels on each side; returns how many.
fn check_images(html: &str, min: u32) -> usize {
    let b64 = base64::engine::general_purpose::STANDARD;
    let mut n = 0;
    for part in html.split("<img ").skip(1) {
        let src = part.split("src=\"").nth(1).and_then(|s| s.split('"').next()).expect("img without src");
        if let Some(data) = src.strip_prefix("data:image/png;base64,") {
            let img = image::load_from_memory(&b64.decode(data).expect("base64")).expect("PNG decodes");
            assert!(img.width() >= min && img.height() >= min, "PNG {}x{}", img.width(), img.height());
            // Non-trivial: more than one colour.
            let rgb = img.to_rgb8();
            let first = rgb.get_pixel(0, 0);
            assert!(rgb.pixels().any(|p| p != first), "a PNG of one colour");
        } else if let Some(data) = src.strip_prefix("data:image/svg+xml;base64,") {
            let svg = String::from_utf8(b64.decode(data).expect("base64")).expect("utf-8");
            check_svg(&svg, min);
        } else {
            panic!("image not embedded: {}", &src[..src.len().min(60)]);
        }
        n += 1;
    }
    n
}

/// Minimal SVG parse: one `<svg>` root with a width and height of at least `min`, tags balanced.
fn check_svg(svg: &str, min: u32) {
    let start = svg.find("<svg").expect("no <svg>");
    let head = &svg[start..svg[start..].find('>').unwrap() + start];
    let attr = |name: &str| -> u32 {
        let v = head.split(&format!(" {name}=\"")).nth(1).and_then(|s| s.split('"').next()).expect(name);
        v.trim_end_matches("px").parse().expect("size")
    };
    assert!(attr("width") >= min && attr("height") >= min, "{head}");
    let mut stack: Vec<String> = Vec::new();
    let mut rest = &svg[start..];
    let mut elements = 0;
    while let Some(i) = rest.find('<') {
        let end = rest[i..].find('>').expect("unterminated tag") + i;
        let tag = &rest[i + 1..end];
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop().as_deref(), Some(name.trim()), "unbalanced </{name}>");
        } else if !tag.ends_with('/') && !tag.starts_with('?') && !tag.starts_with('!') {
            stack.push(tag.split_whitespace().next().unwrap_or("").to_string());
            elements += 1;
        } else {
            elements += 1;
        }
        rest = &rest[end + 1..];
    }
    assert!(stack.is_empty(), "unclosed {stack:?}");
    assert!(elements > 10, "an SVG of {elements} elements");
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/stereo")
}

fn stereo_fixture() -> (Chessboard, StereoViews, Vec<String>, (u32, u32)) {
    let dir = fixtures();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for i in 0..5 {
        left.push(io::load_gray(&dir.join(format!("left_{i:02}.png"))).unwrap());
        right.push(io::load_gray(&dir.join(format!("right_{i:02}.png"))).unwrap());
    }
    let size = left[0].dimensions();
    let l = parallax_composition::detect_boards(&left, &board, &Default::default()).unwrap();
    let r = parallax_composition::detect_boards(&right, &board, &Default::default()).unwrap();
    let det: Vec<[Option<CornerGrid>; 2]> = l.into_iter().zip(r).map(|(a, b)| [a, b]).collect();
    let views = StereoViews::from_detections(&det);
    assert_eq!(views.len(), 5);
    let names = (0..5).map(|i| format!("left_{i:02}.png")).collect();
    (board, views, names, size)
}

/// On the committed stereo fixtures: the per-view RMS bars equal the result's per-view errors,
/// the coverage warning names exactly the border strips without corners (checked by each
/// strip's nearest corner), and the report embeds every picture.
#[test]
fn stereo_calibration_pictures_on_the_fixtures() {
    let (board, views, names, size) = stereo_fixture();
    let cfg = StereoConfig::default();
    let result = parallax_composition::calibrate_stereo(&board, &views, size, size, &cfg, &Default::default()).unwrap();
    let [(left, ls), (right, rs)] =
        plots::calibration::stereo(&board, &views.left, &views.right, &names, &result, &cfg).unwrap();
    for (k, s) in [&ls, &rs].iter().enumerate() {
        assert_eq!(s.per_view_rms_px.len(), result.per_view_rms_px.len());
        for (a, b) in s.per_view_rms_px.iter().zip(&result.per_view_rms_px) {
            assert!((a - b[k]).abs() <= 1e-9 * b[k].max(1e-3), "bar {a} vs result {}", b[k]);
        }
        for (mine, theirs) in s.residuals_px.iter().zip(&result.residuals_px) {
            for (a, b) in mine.iter().zip(&theirs[k]) {
                assert!((*a - *b).length() < 1e-9, "{a} vs {b}");
            }
        }
    }
    for (s, sec, grids) in [(&ls, &left, &views.left), (&rs, &right, &views.right)] {
        let (w, h) = (f64::from(size.0), f64::from(size.1));
        let corners: Vec<DVec2> = grids.iter().flat_map(|g| g.corners.clone()).collect();
        let nearest = |d: &dyn Fn(&DVec2) -> f64| corners.iter().map(d).fold(f64::INFINITY, f64::min);
        let strips = [
            ("left edge", nearest(&|p| p.x + 0.5) / w),
            ("right edge", nearest(&|p| w - 0.5 - p.x) / w),
            ("top edge", nearest(&|p| p.y + 0.5) / h),
            ("bottom edge", nearest(&|p| h - 0.5 - p.y) / h),
        ];
        let warning = sec.warnings.iter().find(|w| w.starts_with("no corner within 15 %"));
        for (name, frac) in strips {
            let empty = frac >= 0.15;
            assert_eq!(s.empty_regions.iter().any(|r| r == name), empty, "{name}: nearest corner at {frac:.3}");
            if empty {
                let wn = warning.expect("a coverage warning");
                assert!(wn.contains(name) && wn.ends_with("distortion there is extrapolated"), "{wn}");
            }
        }
        assert_eq!(warning.is_some(), !s.empty_regions.is_empty());
        // The uncertainty is largest away from the corners and finite.
        assert!(s.max_sigma_px.is_finite() && s.max_sigma_px > 0.0);
    }
    let mut pics = Pictures::new("stereo calibration");
    pics.sections = vec![left, right];
    let out = temp("stereo");
    let files = pics.write(&out).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // Seven pictures per camera.
    assert_eq!(check_images(&html, 200), 14);
    assert!(files.iter().any(|f| f.ends_with("calibration-left-uncertainty.png")));
    assert!(files.iter().any(|f| f.ends_with("calibration-right-residual-vectors.svg")));
    cleanup(&out);
}

/// The projection-uncertainty map against Monte Carlo: a synthetic camera with distortion,
/// corners projected exactly plus Gaussian noise (σ 0.3 px), re-calibrated `runs` times; at 5
/// image points the predicted worst-direction σ of the first calibration agrees within 25 % with
/// the empirical spread of the projections of the same world points.
fn uncertainty_against_recalibrations(runs: usize) -> Vec<(f64, f64)> {
    let camera = Camera::new(
        Intrinsics::new(600.0, 600.0, 322.0, 238.0),
        Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0),
        640,
        480,
    )
    .unwrap();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let poses = parallax_synthetic::calibration_poses(
        &camera,
        &board,
        &parallax_synthetic::ViewSetConfig { views: 10, seed: 7, ..Default::default() },
    )
    .unwrap();
    let truth: Vec<Vec<DVec2>> =
        poses.iter().map(|p| parallax_synthetic::project_corners(&camera, &board, p).unwrap()).collect();
    let sigma = 0.3;
    let noise = Normal::new(0.0, sigma).unwrap();
    let cfg = CalibrationConfig { fix_k3: true, ..Default::default() };
    let calibrate = |seed: u64| {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let grids: Vec<CornerGrid> = truth
            .iter()
            .map(|c| {
                let noisy = c.iter().map(|p| *p + DVec2::new(noise.sample(&mut rng), noise.sample(&mut rng))).collect();
                CornerGrid::new(9, 6, noisy).unwrap()
            })
            .collect();
        let r = parallax_composition::calibrate_mono(&board, &grids, (640, 480), &cfg).unwrap();
        (grids, r)
    };
    let (grids0, r0) = calibrate(1);
    let unc = ProjectionUncertainty::new(&r0.camera, &board, &grids0, &r0.camera_from_board, &cfg).unwrap();
    let distance = unc.mean_distance;
    let points = [
        DVec2::new(320.0, 240.0),
        DVec2::new(40.0, 40.0),
        DVec2::new(600.0, 60.0),
        DVec2::new(100.0, 420.0),
        DVec2::new(500.0, 300.0),
    ];
    // The world points: defined by the true camera and true poses (the reference of `reprojected`).
    let runs: Vec<(Camera, Vec<Isometry3>)> = (0..runs)
        .map(|k| {
            let (_, r) = calibrate(1000 + k as u64);
            (r.camera, r.camera_from_board)
        })
        .collect();
    points
        .iter()
        .map(|q| {
            let predicted = unc.sigma_at(*q, distance).unwrap();
            let proj: Vec<DVec2> = runs
                .iter()
                .map(|(c, p)| plots::uncertainty::reprojected(&camera, &poses, c, p, *q, distance).unwrap())
                .collect();
            let mean = proj.iter().copied().sum::<DVec2>() / proj.len() as f64;
            let n = (proj.len() - 1) as f64;
            let mut c = [[0.0; 2]; 2];
            for p in &proj {
                let d = *p - mean;
                c[0][0] += d.x * d.x / n;
                c[0][1] += d.x * d.y / n;
                c[1][0] += d.x * d.y / n;
                c[1][1] += d.y * d.y / n;
            }
            (predicted, plots::uncertainty::worst_sigma(&c))
        })
        .collect()
}

/// The check: 100 re-calibrations (about 4 s in the test profile), 25 % at each point.
#[test]
fn uncertainty_map_predicts_the_spread_of_100_recalibrations() {
    for (p, e) in uncertainty_against_recalibrations(100) {
        eprintln!("predicted σ {p:.4} px, empirical {e:.4} px, ratio {:.3}", p / e);
        assert!((p / e - 1.0).abs() < 0.25, "predicted {p} vs empirical {e}");
    }
}

/// The synthetic pipeline report embeds the pictures of every stage it ran, every image decodes,
/// and the hand-eye table lists every linear method beside the refined one (at distance 0).
#[test]
fn the_synthetic_report_has_the_pictures_of_every_stage() {
    let out = temp("scene");
    let scene = parallax_synthetic::SceneDescription::builtin();
    let report = parallax_composition::run_scene("easy", &scene, &out, None).unwrap();
    let titles: Vec<&str> = report.sections.iter().map(|s| s.title.as_str()).collect();
    assert_eq!(
        titles,
        ["calibration — left camera", "calibration — right camera", "rectification", "disparity", "hand-eye"]
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let figures: usize = report.sections.iter().map(|s| s.figures.len()).sum();
    // The pictures plus the artifact images (corner overlay, rectified pair, scene, disparity).
    assert_eq!(check_images(&html, 100), figures + report.images.len());
    assert!(figures >= 7 + 7 + 1 + 2 + 2, "{figures}");
    let he = report.sections.iter().find(|s| s.title == "hand-eye").unwrap();
    let table = &he.tables[0];
    assert_eq!(table.rows.len(), 7);
    let refined = table.rows.iter().find(|r| r[0] == "Refined").unwrap();
    assert_eq!((refined[1].as_str(), refined[2].as_str()), ("0.0000", "0.0000"));
    for f in [
        "disparity-error.png",
        "handeye-station-residuals.svg",
        "calibration-left-uncertainty.png",
        "rectified-pair.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    cleanup(&out);
}

/// The real-data report (committed stereo fixtures) embeds its pictures too; the disparity bar
/// is in depth as well (the chain rectified the pair itself).
#[test]
fn the_real_report_has_the_pictures_of_every_stage() {
    let dir = fixtures();
    let calibration = (0..5)
        .map(|i| {
            let l = io::load_gray(&dir.join(format!("left_{i:02}.png"))).unwrap();
            let r = io::load_gray(&dir.join(format!("right_{i:02}.png"))).unwrap();
            ([l, r], format!("left_{i:02}.png"))
        })
        .collect();
    let inputs = parallax_composition::RealInputs {
        board: Chessboard::new(9, 6, 25.0).unwrap(),
        unit: "mm".into(),
        calibration,
        pair: None,
        disparities: 64,
        robot: None,
        checks: Default::default(),
    };
    let out = temp("real");
    let report = parallax_composition::run_real(inputs, &out).unwrap();
    let titles: Vec<&str> = report.sections.iter().map(|s| s.title.as_str()).collect();
    assert_eq!(titles, ["calibration — left camera", "calibration — right camera", "rectification", "disparity"]);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let figures: usize = report.sections.iter().map(|s| s.figures.len()).sum();
    assert_eq!(check_images(&html, 100), figures + report.images.len());
    let disparity = report.sections.iter().find(|s| s.title == "disparity").unwrap();
    assert!(disparity.figures[0].caption.contains("in depth"), "{}", disparity.figures[0].caption);
    // Per-view bars name the pairs by file.
    let svg =
        report.sections[0].figures.iter().find(|f| f.name.ends_with("per-view-rms")).unwrap().svg.clone().unwrap();
    assert!(svg.contains("left_03.png"));
    cleanup(&out);
}

/// The error image counts agree with the Middlebury evaluator: bad + missing = its bad-2.
#[test]
fn disparity_error_counts_match_the_evaluator() {
    use parallax_camera_model::DisparityMap;
    let (w, h) = (64usize, 40usize);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0f32, 1.5).unwrap();
    let truth: Vec<f32> = (0..w * h).map(|i| 10.0 + (i % w) as f32 * 0.2).collect();
    let est: Vec<f32> = truth
        .iter()
        .enumerate()
        .map(|(i, t)| if i % 17 == 0 { f32::NAN } else { t + noise.sample(&mut rng) })
        .collect();
    let mask: Vec<bool> = (0..w * h).map(|i| i % 11 != 0).collect();
    let truth = DisparityMap::from_data(w, h, truth).unwrap();
    let est = DisparityMap::from_data(w, h, est).unwrap();
    let q = [[1.0, 0.0, 0.0, -32.0], [0.0, 1.0, 0.0, -20.0], [0.0, 0.0, 0.0, 500.0], [0.0, 0.0, 0.02, 0.0]];
    let (section, counts) = plots::disparity::section(
        &est,
        Some(&q),
        Some(plots::disparity::DisparityTruth { disparity: &truth, mask: Some(&mask), bad_threshold_px: 2.0 }),
    )
    .unwrap();
    let c = counts.unwrap();
    let eval = parallax_block_matching::evaluate(&est, &truth, Some(&mask), &[2.0]).unwrap();
    assert_eq!(c.evaluated, eval.evaluated);
    let pct = 100.0 * (c.bad + c.missing) as f64 / c.evaluated as f64;
    assert!((pct - eval.bad_at(2.0).unwrap()).abs() < 1e-9, "{pct} vs {:?}", eval.bad);
    // Depth through Q: Z = 500 / (0.02 d) = 25000 / d.
    assert!((plots::disparity::depth(&q, 10.0) - 2500.0).abs() < 1e-9);
    assert_eq!(section.figures.len(), 2);
    let invalid = est.data().iter().filter(|d| !d.is_finite()).count();
    assert!(section.figures[0].caption.contains(&format!("{invalid} invalid pixels")));
}

/// The covariance rebuilt for the uncertainty map gives the calibration's own standard
/// deviations of every intrinsic (same free set, same Jacobian, same σ²), for the default flags
/// and for a fixed aspect ratio, no tangential terms and no k3.
#[test]
fn rebuilt_covariance_reproduces_the_calibration_std_devs() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/mono");
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let images: Vec<_> = (0..6).map(|i| io::load_gray(&dir.join(format!("view_{i:02}.png"))).unwrap()).collect();
    let grids: Vec<CornerGrid> = parallax_composition::detect_boards(&images, &board, &Default::default())
        .unwrap()
        .into_iter()
        .map(|g| g.expect("board in every fixture view"))
        .collect();
    let size = images[0].dimensions();
    for cfg in [
        CalibrationConfig::default(),
        CalibrationConfig { fix_aspect_ratio: true, zero_tangential: true, fix_k3: true, ..Default::default() },
    ] {
        let r = parallax_composition::calibrate_mono(&board, &grids, size, &cfg).unwrap();
        let unc = ProjectionUncertainty::new(&r.camera, &board, &grids, &r.camera_from_board, &cfg).unwrap();
        for (slot, (mine, theirs)) in unc.intrinsic_std_devs().iter().zip(r.std_devs.to_array()).enumerate() {
            match (mine, theirs) {
                (Some(a), Some(b)) => assert!((a / b - 1.0).abs() < 1e-3, "slot {slot}: {a} vs {b}"),
                (None, None) => {}
                _ => panic!("slot {slot}: free here {mine:?}, in the calibration {theirs:?}"),
            }
        }
        assert!((unc.sigma_px / r.sigma_px - 1.0).abs() < 1e-6, "{} vs {}", unc.sigma_px, r.sigma_px);
    }
}

/// A view whose corners were disturbed is above the outlier line, red, and named in the
/// warning; the line is the calibration's rule computed here by hand; the mono report embeds
/// its seven pictures.
#[test]
fn a_disturbed_view_is_flagged_by_name() {
    let camera =
        Camera::new(Intrinsics::new(600.0, 600.0, 322.0, 238.0), Distortion::new(-0.12, 0.05, 0.0, 0.0, 0.0), 640, 480)
            .unwrap();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let poses = parallax_synthetic::calibration_poses(
        &camera,
        &board,
        &parallax_synthetic::ViewSetConfig { views: 8, seed: 5, ..Default::default() },
    )
    .unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let grids: Vec<CornerGrid> = poses
        .iter()
        .enumerate()
        .map(|(v, p)| {
            let s = if v == 5 { 2.0 } else { 0.2 };
            let noise = Normal::new(0.0, s).unwrap();
            let c = parallax_synthetic::project_corners(&camera, &board, p).unwrap();
            let noisy = c.iter().map(|q| *q + DVec2::new(noise.sample(&mut rng), noise.sample(&mut rng))).collect();
            CornerGrid::new(9, 6, noisy).unwrap()
        })
        .collect();
    let cfg = CalibrationConfig::default();
    let r = parallax_composition::calibrate_mono(&board, &grids, (640, 480), &cfg).unwrap();
    let names: Vec<String> = (0..8).map(|i| format!("img_{i}.png")).collect();
    let (section, s) = plots::calibration::mono(&board, &grids, &names, &r, &cfg).unwrap();
    let mut sorted = r.per_view_rms_px.clone();
    sorted.sort_by(f64::total_cmp);
    let med = 0.5 * (sorted[3] + sorted[4]);
    let mut dev: Vec<f64> = r.per_view_rms_px.iter().map(|x| (x - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let line = (2.0 * med).max(med + 4.0 * 1.4826 * 0.5 * (dev[3] + dev[4]));
    let t = s.outlier_threshold_px.unwrap();
    assert!((t - line).abs() < 1e-9 * line, "{t} vs {line}");
    assert_eq!(s.flagged_views, vec![5]);
    // The calibration flags the same views.
    let theirs: Vec<usize> = r
        .warnings
        .iter()
        .filter_map(|w| match w {
            parallax_planar_calibration::CalibrationWarning::OutlierView { view, .. } => Some(*view),
            _ => None,
        })
        .collect();
    assert_eq!(theirs, s.flagged_views);
    let warning = section.warnings.iter().find(|w| w.starts_with("outlier views")).expect("an outlier warning");
    assert!(warning.contains("img_5.png") && !warning.contains("img_4.png"), "{warning}");
    let bars = section.figures.iter().find(|f| f.name == "calibration-camera-per-view-rms").unwrap();
    assert!(bars.caption.contains("flagged: img_5.png"), "{}", bars.caption);
    // The flagged bar is drawn red in the SVG.
    assert!(bars.svg.as_ref().unwrap().contains("#D21E1E"), "no red bar");
    let out = temp("mono");
    let mut set = parallax_composition::io::OutputSet::new();
    plots::calibration::add_mono_report(&mut set, &out, &board, &grids, &names, &r, &cfg).unwrap();
    set.commit().unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_eq!(check_images(&html, 200), 7);
    cleanup(&out);
}

/// Hand-eye pictures on a noisy eye-in-hand trajectory: each station's bar is the distance of
/// `base_from_gripper · X · camera_from_board` (computed here) from the mean board, and each
/// row of the table is that method's solution against the refined one.
#[test]
fn handeye_station_bars_are_the_stations_board_frames() {
    let cfg = parallax_synthetic::TrajectoryConfig { rot_noise_rad: 0.002, trans_noise: 0.0005, ..Default::default() };
    let traj = parallax_synthetic::hand_eye_trajectory(&cfg).unwrap();
    let he_cfg = parallax_hand_eye::HandEyeConfig::default();
    let sol = parallax_composition::hand_eye(
        &traj.base_from_gripper,
        &traj.camera_from_board,
        parallax_hand_eye::Method::Refined,
        &he_cfg,
    )
    .unwrap();
    let dev = plots::handeye::station_deviations(&sol);
    assert_eq!(dev.len(), traj.base_from_gripper.len());
    for ((g, c), (rot, trans)) in traj.base_from_gripper.iter().zip(&traj.camera_from_board).zip(&dev) {
        let board = *g * sol.transform * *c;
        let (r, t) = board.distance(&sol.quality.mean_board);
        assert!((r.to_degrees() - rot).abs() < 1e-9 && (t - trans).abs() < 1e-9 * t.max(1.0));
    }
    let names: Vec<String> = (0..dev.len()).map(|i| format!("station {i}")).collect();
    let section =
        plots::handeye::section(&sol, &traj.base_from_gripper, &traj.camera_from_board, &he_cfg, &names, "mm").unwrap();
    let rows = &section.tables[0].rows;
    assert_eq!(rows.len(), 7);
    // Each row is that method's own solution against the refined one.
    for (row, m) in rows.iter().zip([
        parallax_hand_eye::Method::Tsai,
        parallax_hand_eye::Method::Park,
        parallax_hand_eye::Method::Horaud,
        parallax_hand_eye::Method::Andreff,
        parallax_hand_eye::Method::Daniilidis,
        parallax_hand_eye::Method::Rodrigues,
        parallax_hand_eye::Method::Refined,
    ]) {
        assert_eq!(row[0], format!("{m:?}"));
        let x = parallax_hand_eye::calibrate(&traj.base_from_gripper, &traj.camera_from_board, m, &he_cfg).unwrap();
        let (r, t) = x.transform.distance(&sol.transform);
        eprintln!("{row:?}");
        assert_eq!(row[1], format!("{:.4}", r.to_degrees()));
        assert_eq!(row[2], format!("{t:.4}"));
    }
    let out = temp("handeye");
    let mut pics = Pictures::new("hand-eye");
    pics.sections.push(section);
    pics.write(&out).unwrap();
    assert_eq!(check_images(&std::fs::read_to_string(out.join("report.html")).unwrap(), 200), 2);
    cleanup(&out);
}
