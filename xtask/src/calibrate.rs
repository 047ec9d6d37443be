//! `cargo xtask calibrate`: mono, stereo or rig (any number of cameras: `--camera` repeated)
//! calibration from images of any target (chessboards, ChArUco boards, circle grids,
//! AprilGrids; partial views of ChArUco and AprilGrid), or from `corners --out` files.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use parallax_camera_model::{LensModel, TargetDescription};
use parallax_composition::io::OutputSet;
use parallax_composition::records::{MonoOutput, StereoOutput, mono_calibration, stereo_calibration};
use parallax_composition::session::{self, ImageView};
use parallax_composition::summary;
use parallax_interop::Calibration;
use parallax_planar_calibration::{CalibrationConfig, StereoConfig};

mod rig;

/// Arguments of `cargo xtask calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// Images of the (left) camera, glob pattern (quote it), e.g. '../shared/data/opencv-stereo-chessboard/left*.jpg'.
    #[arg(long, required_unless_present_any = ["corners", "cameras", "camera_corners"], conflicts_with_all = ["corners", "cameras", "camera_corners"])]
    images: Option<String>,
    /// Images of the right camera for a stereo calibration (paired with --images in sorted order).
    #[arg(long, conflicts_with = "corners")]
    right: Option<String>,
    /// Corners of the (left) camera as `corners --out` wrote them (RON or JSON), instead of --images.
    #[arg(long, conflicts_with_all = ["cameras", "camera_corners"])]
    corners: Option<PathBuf>,
    /// Images of one camera of a rig, glob pattern (quote it); repeat once per camera, camera 0
    /// (the reference) first. Frames are matched across cameras by file name: `cam0/0007.png`
    /// and `cam2/0007.png` are one frame; a camera without that file did not see it.
    #[arg(long = "camera", value_name = "GLOB", conflicts_with = "camera_corners")]
    cameras: Vec<String>,
    /// Corners file of one camera of a rig (`corners --out` on its images); repeat once per
    /// camera, camera 0 first. Frames are matched by the image file names the files list.
    #[arg(long = "camera-corners", value_name = "FILE")]
    camera_corners: Vec<PathBuf>,
    /// Corners of the right camera (`corners --out` on the right images), for a stereo calibration.
    #[arg(long, requires = "corners")]
    right_corners: Option<PathBuf>,
    /// The target: a chessboard's inner corners COLSxROWS (OpenCV's patternSize, e.g. 9x6, with
    /// --square), or any target description: `chessboard:9x6:25`, `charuco:…`, `circles:…`,
    /// `acircles:…`, `aprilgrid:…` (partial ChArUco and AprilGrid views are used as seen), or a
    /// target file (Kalibr's target YAML, lengths in metres; a TargetDescription record).
    #[arg(long)]
    board: String,
    /// Square size of a COLSxROWS chessboard; every length in the result is in this unit (e.g. mm).
    #[arg(long, allow_negative_numbers = true)]
    square: Option<f64>,
    /// Write the calibration: `.ron` / `.json` (the whole result, matrices row-major), `.yml` / `.yaml` /
    /// `.xml` (OpenCV FileStorage, the keys of OpenCV's calibration samples), or `--format ros|kalibr`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Format of --out: ron, json, opencv, ros (one camera_info per camera) or kalibr (camchain);
    /// default from the extension.
    #[arg(long, requires = "out")]
    format: Option<String>,
    /// The lens model: pinhole (Brown–Conrady, OpenCV's calibrateCamera), kannala-brandt
    /// (OpenCV's cv::fisheye, Kalibr's pinhole-equi) or double-sphere (Kalibr's ds).
    /// With a rig, give it once for every camera or once per camera in `--camera` order.
    #[arg(long, default_value = "pinhole", value_parser = ["pinhole", "kannala-brandt", "double-sphere"])]
    lens: Vec<String>,
    /// Hold p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST; pinhole).
    #[arg(long)]
    zero_tangential: bool,
    /// Hold k1 at 0 (CALIB_FIX_K1; pinhole and kannala-brandt).
    #[arg(long)]
    fix_k1: bool,
    /// Hold k2 at 0 (CALIB_FIX_K2; pinhole and kannala-brandt).
    #[arg(long)]
    fix_k2: bool,
    /// Hold k3 at 0 (CALIB_FIX_K3; pinhole and kannala-brandt).
    #[arg(long)]
    fix_k3: bool,
    /// Hold k4 at 0 (CALIB_FIX_K4; kannala-brandt, and pinhole with --rational: without it the
    /// pinhole k4..k6 are held anyway).
    #[arg(long)]
    fix_k4: bool,
    /// Hold the rational k5 at 0 (CALIB_FIX_K5; pinhole).
    #[arg(long)]
    fix_k5: bool,
    /// Hold the rational k6 at 0 (CALIB_FIX_K6; pinhole).
    #[arg(long)]
    fix_k6: bool,
    /// Hold the principal point at the image centre (CALIB_FIX_PRINCIPAL_POINT).
    #[arg(long)]
    fix_principal_point: bool,
    /// Estimate fy only, fx = fy (CALIB_FIX_ASPECT_RATIO).
    #[arg(long)]
    fix_aspect_ratio: bool,
    /// Also estimate k4..k6 (CALIB_RATIONAL_MODEL; pinhole).
    #[arg(long)]
    rational: bool,
    /// Stereo: hold both cameras at their mono calibrations and refine only the rig (CALIB_FIX_INTRINSIC).
    #[arg(long)]
    fix_intrinsics: bool,
    /// Accept a rig whose right camera is to the left of the left one (refused by default: the
    /// images are then almost always swapped).
    #[arg(long)]
    allow_swapped: bool,
    /// Write the calibration pictures (PNG/SVG) and a self-contained report.html into this directory
    /// (chessboard sessions).
    #[arg(long)]
    report: Option<PathBuf>,
    #[command(flatten)]
    detector: crate::util::DetectorArgs,
}

/// The lens model of `--lens` (its values are checked by clap).
fn lens(args: &Args) -> LensModel {
    args.lens.first().and_then(|l| l.parse().ok()).unwrap_or_default()
}

/// Refuses the flags that do not apply to the chosen lens, naming the flag and the lens, before
/// any work (the rule is the library's, [`CalibrationConfig::check`]; its field names are given
/// here as the command line's flags).
fn refuse_foreign_flags(args: &Args) -> anyhow::Result<()> {
    refuse_foreign_flags_of(&config(args))
}

fn refuse_foreign_flags_of(config: &CalibrationConfig) -> anyhow::Result<()> {
    const FLAGS: [(&str, &str); 8] = [
        ("zero_tangential", "--zero-tangential"),
        ("rational_model", "--rational"),
        ("fix_k1", "--fix-k1"),
        ("fix_k2", "--fix-k2"),
        ("fix_k3", "--fix-k3"),
        ("fix_k4", "--fix-k4"),
        ("fix_k5", "--fix-k5"),
        ("fix_k6", "--fix-k6"),
    ];
    config.check().map_err(|e| {
        let message = FLAGS.iter().fold(e.to_string(), |m, (field, flag)| m.replace(field, flag));
        anyhow::anyhow!("{message}")
    })
}

/// Refuses, before any work, a model that the output format cannot hold (the library's rule,
/// `parallax_interop::check_model_fits`, on the terms `config` estimates).
fn check_model_fits(format: parallax_interop::Format, config: &CalibrationConfig) -> anyhow::Result<()> {
    let terms = parallax_interop::ModelTerms {
        lens: config.lens,
        skew: config.estimate_skew,
        k3: !config.fix_k3,
        rational: config.rational_model,
    };
    Ok(parallax_interop::check_model_fits(format, terms)?)
}

fn config(args: &Args) -> CalibrationConfig {
    CalibrationConfig {
        lens: lens(args),
        fix_k4: args.fix_k4,
        fix_k5: args.fix_k5,
        fix_k6: args.fix_k6,
        zero_tangential: args.zero_tangential,
        fix_k1: args.fix_k1,
        fix_k2: args.fix_k2,
        fix_k3: args.fix_k3,
        fix_principal_point: args.fix_principal_point,
        fix_aspect_ratio: args.fix_aspect_ratio,
        rational_model: args.rational,
        ..CalibrationConfig::default()
    }
}

/// Stages `--out` (the result file of either target form: a chessboard's file keeps its form) in
/// the set `$files`; evaluates to the paths it takes.
macro_rules! stage_out {
    ($files:expr, $args:expr, $format:expr, $target:expr, $calibration:expr, |$b:ident| $native:expr) => {
        match (&$args.out, $format) {
            (Some(out), Some(format)) => match $target {
                TargetDescription::Chessboard($b) => $files.add_result(out, format, &$native, Some($calibration))?,
                $b => $files.add_result(out, format, &$native, Some($calibration))?,
            },
            _ => Vec::new(),
        }
    };
}

/// Prints what one committed set wrote: the result files, then the report.
fn print_written(written: &[PathBuf], format: Option<parallax_interop::Format>, report: Option<(&Path, f64)>) {
    if let Some(format) = format {
        for p in written {
            println!("wrote {} ({})", p.display(), format.name());
        }
    }
    if let Some((dir, ms)) = report {
        println!("wrote {} ({ms:.0} ms)", dir.join("report.html").display());
    }
}

/// The report folder must be a folder (or not exist yet) holding none of the inputs: the
/// report's pictures would replace an input of the same name (`calibration-*.png`), and a glob
/// over the folder would take them for views next time. Checked before any work, so a refusal
/// leaves `--out` unwritten too.
fn refuse_report_folder(dir: &Path, inputs: &[PathBuf]) -> anyhow::Result<()> {
    if !dir.exists() {
        return Ok(());
    }
    anyhow::ensure!(dir.is_dir(), "--report {} is a file: give a folder for the report", dir.display());
    let folder = dir.canonicalize()?;
    if let Some(i) =
        inputs.iter().find(|i| i.canonicalize().ok().and_then(|c| c.parent().map(|p| p == folder)).unwrap_or(false))
    {
        anyhow::bail!(
            "--report {} holds an input ({}): the report writes its pictures there; choose another folder",
            dir.display(),
            i.display()
        );
    }
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if !args.cameras.is_empty() || !args.camera_corners.is_empty() {
        return rig::run(&args);
    }
    anyhow::ensure!(
        args.lens.len() == 1,
        "--lens is given {} times: repeat it only for a rig (--camera, once per camera)",
        args.lens.len()
    );
    refuse_foreign_flags(&args)?;
    let target = crate::util::target(&args.board, args.square)?;
    anyhow::ensure!(
        args.report.is_none() || matches!(target, TargetDescription::Chessboard(_)),
        "--report draws chessboard sessions only (the target is {target})"
    );
    // Refuse an unknown output format before any work.
    let format = args.out.as_deref().map(|o| crate::files::output_format(o, args.format.as_deref())).transpose()?;
    // a stereo result in ROS or Kalibr files: its baseline is read as metres
    if let Some(f) = format.filter(|_| args.right.is_some() || args.right_corners.is_some()) {
        crate::files::refuse_unit_for_metres(f, &target)?;
    }
    // a model the format cannot hold is refused now, not after the calibration
    if let Some(f) = format {
        check_model_fits(f, &config(&args))?;
    }
    let mut inputs: Vec<PathBuf> = args.corners.iter().chain(&args.right_corners).cloned().collect();
    for spec in args.images.iter().chain(&args.right) {
        inputs.extend(parallax_composition::io::input_paths(spec));
    }
    if let Some(out) = &args.out {
        let outputs = format.map_or_else(|| vec![out.clone()], |f| crate::files::written_paths(out, f));
        parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    }
    if let Some(dir) = &args.report {
        refuse_report_folder(dir, &inputs)?;
    }
    // the result file(s) and the report folder must not meet (the report's pages replaced the
    // calibration written into its folder)
    let written = args.out.iter().zip(format).flat_map(|(o, f)| crate::files::written_paths(o, f)).collect::<Vec<_>>();
    let outputs: Vec<(&str, &Path, bool)> = (args.report.iter().map(|d| ("--report", d.as_path(), true)))
        .chain(written.iter().map(|p| ("--out", p.as_path(), false)))
        .collect();
    parallax_composition::io::refuse_colliding_outputs(&outputs)?;
    let t0 = Instant::now();
    let detect = |pattern: &str| -> anyhow::Result<Vec<ImageView>> {
        let paths = parallax_composition::io::expand_glob(pattern)?;
        let progress = crate::progress::Progress::new("calibrate", paths.len() as u64, "images searched")?;
        let views =
            session::detect_files_with_progress(&paths, &target, &args.detector.config(Default::default()), &|| {
                progress.inc()
            })?;
        progress.finish();
        for v in views.iter().filter(|v| !v.found()) {
            match &target {
                TargetDescription::Chessboard(b) => {
                    eprintln!("  no {}x{} board found in {}", b.cols, b.rows, v.image.display())
                }
                t => eprintln!("  no {t} found in {}", v.image.display()),
            }
        }
        Ok(views)
    };
    let (left, right) = match (&args.corners, &args.images) {
        (Some(file), _) => {
            let right = args.right_corners.as_deref().map(|f| session::read_corners_file(f, &target)).transpose()?;
            (session::read_corners_file(file, &target)?, right)
        }
        (None, Some(pattern)) => (detect(pattern)?, args.right.as_deref().map(detect).transpose()?),
        (None, None) => anyhow::bail!("give --images or --corners"),
    };
    session::require_found(&left, &target)?;
    match right {
        None => run_mono(&args, format, &target, &left, t0),
        Some(right) => {
            anyhow::ensure!(right.len() == left.len(), "{} left images but {} right images", left.len(), right.len());
            session::require_found(&right, &target)?;
            run_stereo(&args, format, &target, &left, &right, t0)
        }
    }
}

/// The library's "too few views" suggests an intrinsic guess, which this command cannot take:
/// name what the user can do instead.
fn too_few_views_hint(e: parallax_composition::PipelineError) -> anyhow::Error {
    use parallax_composition::PipelineError::Calibration;
    match e {
        Calibration(parallax_planar_calibration::CalibrationError::TooFewViews { got, needed, .. }) => anyhow::anyhow!(
            "the target was found in {got} image(s) but a calibration needs at least {needed} views of it at \
             different tilts (10 to 20 recommended): add images where the target is visible \
             (`cargo xtask corners` shows in which images it is found)"
        ),
        e => e.into(),
    }
}

fn run_mono(
    args: &Args,
    format: Option<parallax_interop::Format>,
    target: &TargetDescription,
    views: &[ImageView],
    t0: Instant,
) -> anyhow::Result<ExitCode> {
    let found: Vec<&ImageView> = views.iter().filter(|v| v.found()).collect();
    println!("board found in {}/{} images ({:.0} ms)", found.len(), views.len(), t0.elapsed().as_secs_f64() * 1e3);
    let size = session::common_size(&found)?;
    let t1 = Instant::now();
    let r = session::calibrate_views(target, &found, size, &config(args)).map_err(too_few_views_hint)?;
    println!(
        "calibrated {} views in {:.1} ms, {} iterations",
        found.len(),
        t1.elapsed().as_secs_f64() * 1e3,
        r.iterations
    );
    println!("{}", summary::camera("camera", &r.camera, &r.std_devs));
    println!("RMS {:.4} px (σ per coordinate {:.4} px, dof {})", r.rms_px, r.sigma_px, r.dof);
    for (f, e) in found.iter().zip(&r.per_view_rms_px) {
        println!("  {:<40} {e:.4} px", f.file_name());
    }
    for w in &r.warnings {
        println!("warning: {w}");
    }
    let names = session::view_names(&found);
    let calibration = Calibration::Mono(mono_calibration(&r));
    // the result file and the report are one set: both land, or neither
    let mut files = OutputSet::new();
    let written = stage_out!(files, args, format, target, &calibration, |b| MonoOutput::new(names.clone(), *b, &r));
    let mut report = None;
    if let (Some(dir), TargetDescription::Chessboard(board)) = (&args.report, target) {
        let t = Instant::now();
        let grids = session::points_of(&found).0;
        let cfg = config(args);
        parallax_composition::plots::calibration::add_mono_report(&mut files, dir, board, &grids, &names, &r, &cfg)?;
        report = Some((dir.as_path(), t.elapsed().as_secs_f64() * 1e3));
    }
    files.commit()?;
    print_written(&written, format, report);
    println!("{}", summary::camera_keys("", r.rms_px, &r.camera));
    Ok(ExitCode::SUCCESS)
}

fn run_stereo(
    args: &Args,
    format: Option<parallax_interop::Format>,
    target: &TargetDescription,
    left: &[ImageView],
    right: &[ImageView],
    t0: Instant,
) -> anyhow::Result<ExitCode> {
    let pairs = session::stereo_pairs(left, right);
    println!(
        "board found in both images of {}/{} pairs ({:.0} ms)",
        pairs.len(),
        left.len(),
        t0.elapsed().as_secs_f64() * 1e3
    );
    let lf: Vec<_> = pairs.iter().map(|p| p.0).collect();
    let rf: Vec<_> = pairs.iter().map(|p| p.1).collect();
    let (lsize, rsize) = (session::common_size(&lf)?, session::common_size(&rf)?);
    let mono = config(args);
    let cfg = StereoConfig {
        fix_intrinsics: args.fix_intrinsics,
        left: mono.clone(),
        right: mono.clone(),
        ..Default::default()
    };
    // Mono calibrations of each camera for the summary (the stereo solver starts from the same).
    let ml = session::calibrate_views(target, &lf, lsize, &mono)?;
    let mr = session::calibrate_views(target, &rf, rsize, &mono)?;
    println!("mono: left RMS {:.4} px, right RMS {:.4} px", ml.rms_px, mr.rms_px);
    let t1 = Instant::now();
    let r = session::calibrate_stereo_views(target, &lf, &rf, [lsize, rsize], &cfg).map_err(too_few_views_hint)?;
    let ((lg, lo), (rg, ro)) = (session::points_of(&lf), session::points_of(&rf));
    // Plausibility before anything is written: swapped cameras, pairs out of order.
    let checks = parallax_composition::StereoChecks { allow_swapped: args.allow_swapped, ..Default::default() };
    parallax_composition::check_stereo(&r, &checks)?;
    println!(
        "stereo calibration of {} pairs in {:.1} ms, {} iterations",
        lf.len(),
        t1.elapsed().as_secs_f64() * 1e3,
        r.iterations
    );
    println!("{}", summary::camera("left", &r.rig.left, &r.left_std_devs));
    println!("{}", summary::camera("right", &r.rig.right, &r.right_std_devs));
    println!("{}", summary::rig(&r));
    for (p, [a, b]) in pairs.iter().zip(&r.per_view_rms_px) {
        println!("  {:<30} left {a:.4} px  right {b:.4} px", p.0.file_name());
    }
    for w in &r.warnings {
        println!("warning: {w}");
    }
    let (ln, rn) = (session::view_names(&lf), session::view_names(&rf));
    let stereo = stereo_calibration(&r)?;
    let calibration = Calibration::Stereo(stereo.clone());
    // the result file and the report are one set, committed once the checks below have passed
    let mut files = OutputSet::new();
    let written = stage_out!(files, args, format, target, &calibration, |b| StereoOutput::new(
        ln.clone(),
        rn.clone(),
        *b,
        &stereo,
        &r
    ));
    let mut report = None;
    if let (Some(dir), TargetDescription::Chessboard(board)) = (&args.report, target) {
        let t = Instant::now();
        parallax_composition::plots::calibration::add_stereo_report(&mut files, dir, board, &lg, &rg, &ln, &r, &cfg)?;
        report = Some((dir.as_path(), t.elapsed().as_secs_f64() * 1e3));
    }
    // Rectification of the detected corners (point-level, no resampling) and triangulated
    // distances between adjacent corners, both from the calibration just made. A wide-lens rig
    // that no pinhole pair can hold is not checked this way (the figures are left out, and why
    // is printed); any other failure is an error.
    let wide = r.rig.has_wide_lens();
    let checks = match target {
        TargetDescription::Chessboard(b) => session::chessboard_corner_checks(&r.rig, b, lg, rg, r.sigma_px),
        t => session::target_corner_checks(&r.rig, t, &lo, &ro),
    };
    let checks = match checks {
        Ok(c) => Some(c),
        Err(e) if wide => {
            println!("rectified: not checked, the rig has no pinhole rectification: {e}");
            None
        }
        Err(e) => return Err(e.into()),
    };
    files.commit()?;
    print_written(&written, format, report);
    if let Some(c) = &checks {
        println!(
            "rectified: focal {:.3} px, {} corners, mean |Δv| {:.4} px, max {:.4} px",
            c.rectification.focal(),
            c.abs_dv.len(),
            c.mean_abs_dv,
            c.max_abs_dv
        );
        println!("adjacent corners: {} distances, RMS error {:.4} (square units)", c.distances, c.distance_rms);
    }
    println!("{}", summary::camera_keys("left_", r.left_rms_px, &r.rig.left));
    println!("{}", summary::camera_keys("right_", r.right_rms_px, &r.rig.right));
    println!("stereo_rms_px: {:.6}", r.rms_px);
    println!("baseline: {:.6}", r.rig.baseline());
    println!("rotation_deg: {:.6}", r.rig.right_from_left.angle().to_degrees());
    if let Some(c) = &checks {
        println!("rectified_mean_abs_dv_px: {:.6}", c.mean_abs_dv);
        println!("adjacent_corner_distance_rms: {:.6}", c.distance_rms);
    }
    Ok(ExitCode::SUCCESS)
}
