//! `cargo xtask calibrate`: mono or stereo calibration from chessboard images.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use parallax_camera_model::{Chessboard, CornerGrid};
use parallax_interop::{
    Calibration, MonoCalibration, MonoRecord, PoseRecord, RectificationMatrices, StereoCalibration, StereoRecord,
};
use parallax_planar_calibration::{
    CalibrationConfig, IntrinsicStdDevs, StereoConfig, calibrate_chessboard, calibrate_stereo_chessboard,
};
use serde::Serialize;

/// Arguments of `cargo xtask calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// Images of the (left) camera, glob pattern (quote it), e.g. '../shared/data/opencv-stereo-chessboard/left*.jpg'.
    #[arg(long, required_unless_present = "corners", conflicts_with = "corners")]
    images: Option<String>,
    /// Images of the right camera for a stereo calibration (paired with --images in sorted order).
    #[arg(long, conflicts_with = "corners")]
    right: Option<String>,
    /// Corners of the (left) camera as `corners --out` wrote them (RON or JSON), instead of --images.
    #[arg(long)]
    corners: Option<PathBuf>,
    /// Corners of the right camera (`corners --out` on the right images), for a stereo calibration.
    #[arg(long, requires = "corners")]
    right_corners: Option<PathBuf>,
    /// Inner corners of the board as COLSxROWS (OpenCV's patternSize), e.g. 9x6.
    #[arg(long, value_parser = crate::util::parse_board_size)]
    board: (usize, usize),
    /// Square size; every length in the result is in this unit (e.g. mm).
    #[arg(long)]
    square: f64,
    /// Write the calibration: `.ron` / `.json` (the whole result, matrices row-major), `.yml` / `.yaml` /
    /// `.xml` (OpenCV FileStorage, the keys of OpenCV's calibration samples), or `--format ros|kalibr`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Format of --out: ron, json, opencv, ros (one camera_info per camera) or kalibr (camchain);
    /// default from the extension.
    #[arg(long, requires = "out")]
    format: Option<String>,
    /// Hold p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST).
    #[arg(long)]
    zero_tangential: bool,
    /// Hold k3 = 0 (CALIB_FIX_K3).
    #[arg(long)]
    fix_k3: bool,
    /// Hold the principal point at the image centre (CALIB_FIX_PRINCIPAL_POINT).
    #[arg(long)]
    fix_principal_point: bool,
    /// Estimate fy only, fx = fy (CALIB_FIX_ASPECT_RATIO).
    #[arg(long)]
    fix_aspect_ratio: bool,
    /// Also estimate k4..k6 (CALIB_RATIONAL_MODEL).
    #[arg(long)]
    rational: bool,
    /// Stereo: hold both cameras at their mono calibrations and refine only the rig (CALIB_FIX_INTRINSIC).
    #[arg(long)]
    fix_intrinsics: bool,
    /// Accept a rig whose right camera is to the left of the left one (refused by default: the
    /// images are then almost always swapped).
    #[arg(long)]
    allow_swapped: bool,
    /// Write the calibration pictures (PNG/SVG) and a self-contained report.html into this directory.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// One image: path, size, and the corner grid if a board was found.
type Detected = (PathBuf, (u32, u32), Option<CornerGrid>);

/// Detected corners of one image list (images read in order, detected in parallel).
fn detect(paths: &[PathBuf], board: &Chessboard) -> anyhow::Result<Vec<Detected>> {
    let images = paths.iter().map(|p| parallax_composition::io::load_gray(p)).collect::<Result<Vec<_>, _>>()?;
    let grids = parallax_composition::detect_boards(&images, board, &Default::default())?;
    for (p, g) in paths.iter().zip(&grids) {
        if g.is_none() {
            eprintln!("  no {}x{} board found in {}", board.cols, board.rows, p.display());
        }
    }
    Ok(paths.iter().zip(&images).zip(grids).map(|((p, i), g)| (p.clone(), i.dimensions(), g)).collect())
}

/// The views of a `corners --out` file (checked against `--board`).
fn from_corners_file(path: &std::path::Path, board: &Chessboard) -> anyhow::Result<Vec<Detected>> {
    let file: crate::corners::CornersFile = parallax_interop::read_native(path)?;
    anyhow::ensure!(
        (file.cols, file.rows) == (board.cols, board.rows),
        "{} holds {}x{} corners but --board is {}x{}",
        path.display(),
        file.cols,
        file.rows,
        board.cols,
        board.rows
    );
    Ok(file.images.into_iter().map(|i| (PathBuf::from(i.image), (i.width, i.height), i.grid)).collect())
}

fn common_size(found: &[&Detected]) -> anyhow::Result<(u32, u32)> {
    let size = found.first().context("no image with a detected board")?.1;
    for f in found {
        anyhow::ensure!(f.1 == size, "{} is {}x{}, the others {}x{}", f.0.display(), f.1.0, f.1.1, size.0, size.1);
    }
    Ok(size)
}

fn config(args: &Args) -> CalibrationConfig {
    CalibrationConfig {
        zero_tangential: args.zero_tangential,
        fix_k3: args.fix_k3,
        fix_principal_point: args.fix_principal_point,
        fix_aspect_ratio: args.fix_aspect_ratio,
        rational_model: args.rational,
        ..CalibrationConfig::default()
    }
}

fn pm(v: f64, s: Option<f64>) -> String {
    match s {
        Some(s) => format!("{v:.6} ± {s:.6}"),
        None => format!("{v:.6} (fixed)"),
    }
}

fn print_camera(name: &str, c: &parallax_camera_model::Camera, s: &IntrinsicStdDevs) {
    let k = c.intrinsics;
    let d = c.distortion;
    println!("{name}: {}x{}", c.width, c.height);
    println!("  fx {}  fy {}", pm(k.fx, s.fx), pm(k.fy, s.fy));
    println!("  cx {}  cy {}", pm(k.cx, s.cx), pm(k.cy, s.cy));
    println!("  k1 {}  k2 {}  k3 {}", pm(d.k1, s.k1), pm(d.k2, s.k2), pm(d.k3, s.k3));
    println!("  p1 {}  p2 {}", pm(d.p1, s.p1), pm(d.p2, s.p2));
    if d.is_rational() || s.k4.is_some() {
        println!("  k4 {}  k5 {}  k6 {}", pm(d.k4, s.k4), pm(d.k5, s.k5), pm(d.k6, s.k6));
    }
}

fn key_lines(prefix: &str, rms: f64, c: &parallax_camera_model::Camera) {
    let k = c.intrinsics;
    let d = c.distortion;
    println!("{prefix}rms_px: {rms:.6}");
    for (name, v) in [("fx", k.fx), ("fy", k.fy), ("cx", k.cx), ("cy", k.cy)] {
        println!("{prefix}{name}: {v:.6}");
    }
    for (name, v) in [("k1", d.k1), ("k2", d.k2), ("p1", d.p1), ("p2", d.p2), ("k3", d.k3)] {
        println!("{prefix}{name}: {v:.8}");
    }
}

/// What a RON / JSON `--out` holds for a mono calibration (matrices row-major, poses in every
/// convention; `calibration` is what every command reads back).
#[derive(Serialize)]
struct MonoOutput<'a> {
    images: Vec<String>,
    board: Chessboard,
    calibration: MonoRecord,
    /// Per-view `camera_from_board`.
    camera_from_board: Vec<PoseRecord>,
    std_devs: &'a IntrinsicStdDevs,
    sigma_px: f64,
    dof: usize,
    iterations: usize,
    converged: bool,
    warnings: &'a [parallax_planar_calibration::CalibrationWarning],
}

/// What a RON / JSON `--out` holds for a stereo calibration (`calibration` holds the rig, its
/// OpenCV matrices `M1 D1 M2 D2 R T E F` and the rectification `R1 R2 P1 P2 Q` that `rectify`
/// computes by default: alpha 0, zero disparity).
#[derive(Serialize)]
struct StereoOutput<'a> {
    left_images: Vec<String>,
    right_images: Vec<String>,
    board: Chessboard,
    calibration: StereoRecord,
    left_rms_px: f64,
    right_rms_px: f64,
    /// Per-view left `camera_from_board`.
    left_camera_from_board: Vec<PoseRecord>,
    left_std_devs: &'a IntrinsicStdDevs,
    right_std_devs: &'a IntrinsicStdDevs,
    rig_std_devs: &'a parallax_planar_calibration::RigStdDevs,
    sigma_px: f64,
    dof: usize,
    iterations: usize,
    converged: bool,
    warnings: &'a [parallax_planar_calibration::CalibrationWarning],
}

fn names(v: &[&Detected]) -> Vec<String> {
    v.iter().map(|f| f.0.display().to_string()).collect()
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(args.square.is_finite() && args.square > 0.0, "--square must be positive, got {}", args.square);
    let board = Chessboard::new(args.board.0, args.board.1, args.square)?;
    // Refuse an unknown output format before any work.
    let format = args.out.as_deref().map(|o| crate::files::output_format(o, args.format.as_deref())).transpose()?;
    if let Some(out) = &args.out {
        let mut outputs = vec![out.clone()];
        if format == Some(parallax_interop::Format::Ros) {
            outputs.extend(parallax_interop::ros_pair_paths(out));
        }
        let mut inputs: Vec<PathBuf> = args.corners.iter().chain(&args.right_corners).cloned().collect();
        for spec in args.images.iter().chain(&args.right) {
            inputs.extend(parallax_composition::io::input_paths(spec));
        }
        parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    }
    let t0 = Instant::now();
    let (left, right) = match (&args.corners, &args.images) {
        (Some(file), _) => {
            let left = from_corners_file(file, &board)?;
            let right = args.right_corners.as_deref().map(|f| from_corners_file(f, &board)).transpose()?;
            (left, right)
        }
        (None, Some(pattern)) => {
            let left_paths = parallax_composition::io::expand_glob(pattern)?;
            let left = detect(&left_paths, &board)?;
            let right = match &args.right {
                None => None,
                Some(pattern) => Some(detect(&parallax_composition::io::expand_glob(pattern)?, &board)?),
            };
            (left, right)
        }
        (None, None) => anyhow::bail!("give --images or --corners"),
    };
    match right {
        None => run_mono(&args, format, &board, &left, t0),
        Some(right) => {
            anyhow::ensure!(right.len() == left.len(), "{} left images but {} right images", left.len(), right.len());
            run_stereo(&args, format, &board, &left, &right, t0)
        }
    }
}

/// The library's "too few views" suggests an intrinsic guess, which this command cannot take:
/// name what the user can do instead.
fn too_few_views_hint(e: parallax_planar_calibration::CalibrationError) -> anyhow::Error {
    match e {
        parallax_planar_calibration::CalibrationError::TooFewViews { got, needed, .. } => anyhow::anyhow!(
            "the board was found in {got} image(s) but a calibration needs at least {needed} views of it at \
             different tilts (10 to 20 recommended): add images where the whole board is visible \
             (`cargo xtask corners` shows in which images it is found)"
        ),
        e => e.into(),
    }
}

fn run_mono(
    args: &Args,
    format: Option<parallax_interop::Format>,
    board: &Chessboard,
    views: &[Detected],
    t0: Instant,
) -> anyhow::Result<ExitCode> {
    let found: Vec<_> = views.iter().filter(|v| v.2.is_some()).collect();
    println!("board found in {}/{} images ({:.0} ms)", found.len(), views.len(), t0.elapsed().as_secs_f64() * 1e3);
    let size = common_size(&found)?;
    let grids: Vec<CornerGrid> = found.iter().filter_map(|v| v.2.clone()).collect();
    let t1 = Instant::now();
    let r = calibrate_chessboard(board, &grids, size.0, size.1, &config(args)).map_err(too_few_views_hint)?;
    println!(
        "calibrated {} views in {:.1} ms, {} iterations",
        grids.len(),
        t1.elapsed().as_secs_f64() * 1e3,
        r.iterations
    );
    print_camera("camera", &r.camera, &r.std_devs);
    println!("RMS {:.4} px (σ per coordinate {:.4} px, dof {})", r.rms_px, r.sigma_px, r.dof);
    for (f, e) in found.iter().zip(&r.per_view_rms_px) {
        println!("  {:<40} {e:.4} px", f.0.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()));
    }
    for w in &r.warnings {
        println!("warning: {w}");
    }
    if let (Some(out), Some(format)) = (&args.out, format) {
        let calibration =
            MonoCalibration { camera: r.camera, rms_px: Some(r.rms_px), per_view_rms_px: r.per_view_rms_px.clone() };
        let native = MonoOutput {
            images: names(&found),
            board: *board,
            calibration: MonoRecord::of(&calibration),
            camera_from_board: r.camera_from_board.iter().map(PoseRecord::of).collect(),
            std_devs: &r.std_devs,
            sigma_px: r.sigma_px,
            dof: r.dof,
            iterations: r.iterations,
            converged: r.converged,
            warnings: &r.warnings,
        };
        for p in crate::files::write_result(out, format, &native, Some(&Calibration::Mono(calibration)))? {
            println!("wrote {} ({})", p.display(), format.name());
        }
    }
    if let Some(dir) = &args.report {
        let t = Instant::now();
        parallax_composition::plots::calibration::write_mono_report(
            dir,
            board,
            &grids,
            &names(&found),
            &r,
            &config(args),
        )?;
        println!("wrote {} ({:.0} ms)", dir.join("report.html").display(), t.elapsed().as_secs_f64() * 1e3);
    }
    key_lines("", r.rms_px, &r.camera);
    Ok(ExitCode::SUCCESS)
}

fn run_stereo(
    args: &Args,
    format: Option<parallax_interop::Format>,
    board: &Chessboard,
    left: &[Detected],
    right: &[Detected],
    t0: Instant,
) -> anyhow::Result<ExitCode> {
    let pairs: Vec<_> = left.iter().zip(right).filter(|(l, r)| l.2.is_some() && r.2.is_some()).collect();
    println!(
        "board found in both images of {}/{} pairs ({:.0} ms)",
        pairs.len(),
        left.len(),
        t0.elapsed().as_secs_f64() * 1e3
    );
    let lf: Vec<_> = pairs.iter().map(|p| p.0).collect();
    let rf: Vec<_> = pairs.iter().map(|p| p.1).collect();
    let lsize = common_size(&lf)?;
    let rsize = common_size(&rf)?;
    let lg: Vec<CornerGrid> = lf.iter().filter_map(|v| v.2.clone()).collect();
    let rg: Vec<CornerGrid> = rf.iter().filter_map(|v| v.2.clone()).collect();
    let mono = config(args);
    // Mono calibrations of each camera for the summary (the stereo solver starts from the same).
    let ml = calibrate_chessboard(board, &lg, lsize.0, lsize.1, &mono)?;
    let mr = calibrate_chessboard(board, &rg, rsize.0, rsize.1, &mono)?;
    println!("mono: left RMS {:.4} px, right RMS {:.4} px", ml.rms_px, mr.rms_px);
    let cfg = StereoConfig {
        fix_intrinsics: args.fix_intrinsics,
        left: mono.clone(),
        right: mono,
        ..StereoConfig::default()
    };
    let t1 = Instant::now();
    let r = calibrate_stereo_chessboard(board, &lg, &rg, lsize, rsize, &cfg).map_err(too_few_views_hint)?;
    // Plausibility before anything is written: swapped cameras, pairs out of order.
    let checks = parallax_composition::StereoChecks { allow_swapped: args.allow_swapped, ..Default::default() };
    parallax_composition::check_stereo(&r, &checks)?;
    println!(
        "stereo calibration of {} pairs in {:.1} ms, {} iterations",
        lg.len(),
        t1.elapsed().as_secs_f64() * 1e3,
        r.iterations
    );
    print_camera("left", &r.rig.left, &r.left_std_devs);
    print_camera("right", &r.rig.right, &r.right_std_devs);
    let e = r.rig.right_from_left;
    let rv = e.rvec();
    let s = r.rig_std_devs;
    println!(
        "right_from_left: rvec [{:.6}, {:.6}, {:.6}] ± [{:.6}, {:.6}, {:.6}] rad",
        rv.x, rv.y, rv.z, s.rotation_rad.x, s.rotation_rad.y, s.rotation_rad.z
    );
    println!(
        "                 t [{:.4}, {:.4}, {:.4}] ± [{:.4}, {:.4}, {:.4}]",
        e.translation.x, e.translation.y, e.translation.z, s.translation.x, s.translation.y, s.translation.z
    );
    println!("baseline {:.4} ± {:.4} (square units)", r.rig.baseline(), s.baseline);
    println!("RMS: both {:.4} px, left {:.4} px, right {:.4} px", r.rms_px, r.left_rms_px, r.right_rms_px);
    for (p, [a, b]) in pairs.iter().zip(&r.per_view_rms_px) {
        let n = p.0.0.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
        println!("  {n:<30} left {a:.4} px  right {b:.4} px");
    }
    for w in &r.warnings {
        println!("warning: {w}");
    }
    if let (Some(out), Some(format)) = (&args.out, format) {
        // The rectification `rectify` computes by default, so that `disparity --calib` on this
        // file and on rectify's output agree.
        let file_rect = parallax_stereo_rectify::stereo_rectify(&r.rig, &crate::rectify::default_config())?;
        let calibration = StereoCalibration {
            rig: r.rig,
            rectification: Some(RectificationMatrices::from(&file_rect)),
            rms_px: Some(r.rms_px),
            per_view_rms_px: r.per_view_rms_px.clone(),
        };
        let native = StereoOutput {
            left_images: names(&lf),
            right_images: names(&rf),
            board: *board,
            calibration: StereoRecord::of(&calibration),
            left_rms_px: r.left_rms_px,
            right_rms_px: r.right_rms_px,
            left_camera_from_board: r.camera_from_board.iter().map(PoseRecord::of).collect(),
            left_std_devs: &r.left_std_devs,
            right_std_devs: &r.right_std_devs,
            rig_std_devs: &r.rig_std_devs,
            sigma_px: r.sigma_px,
            dof: r.dof,
            iterations: r.iterations,
            converged: r.converged,
            warnings: &r.warnings,
        };
        for p in crate::files::write_result(out, format, &native, Some(&Calibration::Stereo(calibration)))? {
            println!("wrote {} ({})", p.display(), format.name());
        }
    }
    if let Some(dir) = &args.report {
        let t = Instant::now();
        parallax_composition::plots::calibration::write_stereo_report(dir, board, &lg, &rg, &names(&lf), &r, &cfg)?;
        println!("wrote {} ({:.0} ms)", dir.join("report.html").display(), t.elapsed().as_secs_f64() * 1e3);
    }
    // Rectification of the detected corners (point-level, no resampling) and triangulated
    // distances between adjacent corners, both from the calibration just made.
    let views = parallax_composition::StereoViews { index: (0..lg.len()).collect(), left: lg, right: rg };
    let rectified = parallax_composition::rectify(&r.rig, &views, &Default::default())?;
    let (rect, dv) = (rectified.rectification, &rectified.abs_dv);
    let tri = parallax_triangulation::TriangulationConfig { pixel_sigma: r.sigma_px, ..Default::default() };
    let distances = parallax_composition::adjacent_distances(&r.rig, &views, &tri)?;
    let mean_dv = parallax_composition::stats::mean(dv);
    let max_dv = dv.iter().fold(0.0f64, |a, b| a.max(*b));
    let dist_rms = parallax_triangulation::distance_rms(&distances, board.square_size).unwrap_or(f64::NAN);
    println!(
        "rectified: focal {:.3} px, {} corners, mean |Δv| {mean_dv:.4} px, max {max_dv:.4} px",
        rect.focal(),
        dv.len()
    );
    println!("adjacent corners: {} distances, RMS error {dist_rms:.4} (square units)", distances.len());
    key_lines("left_", r.left_rms_px, &r.rig.left);
    key_lines("right_", r.right_rms_px, &r.rig.right);
    println!("stereo_rms_px: {:.6}", r.rms_px);
    println!("baseline: {:.6}", r.rig.baseline());
    println!("rotation_deg: {:.6}", e.angle().to_degrees());
    println!("rectified_mean_abs_dv_px: {mean_dv:.6}");
    println!("adjacent_corner_distance_rms: {dist_rms:.6}");
    Ok(ExitCode::SUCCESS)
}
