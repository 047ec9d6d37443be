//! `cargo xtask handeye`: every hand-eye method on the user's robot and camera poses.
//!
//! ```text
//! cargo xtask handeye --robot 'data/franka_pose_rPe_*.yaml' --camera-poses cam.ron [--method all] [--eye-to-hand]
//! cargo xtask handeye --robot POSES --images 'data/franka_image-*.png' --board 9x6 --square 0.0236 --intrinsics franka_camera.xml
//! ```
//!
//! Prints one line per method (`method: NAME tx: ty: tz: qx: qy: qz: qw: rot_residual_deg: …
//! trans_residual: …`, and `converged:` for the refinement), translation in the square-size unit
//! (which must be the robot poses' unit), rotation as the unit quaternion `(x, y, z, w)`, `w ≥ 0`;
//! under it the ROS `tf` line `x y z qx qy qz qw` and the rotation vector in radians; residuals
//! are means over the station pairs of `A X = X B`. Ends with `key: value` lines of the result
//! (the refined method, else the first that succeeded).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, ensure};
use parallax_camera_model::Isometry3;
use parallax_composition::poses;
use parallax_composition::records::{HandEyeOutput, chosen_solution, hand_eye_calibration};
use parallax_hand_eye::io::PoseFileFormat;
use parallax_hand_eye::{
    ConsistencyConfig, HandEyeConfig, ObservabilityConfig, PairSelection, RefineConfig, Setup, calibrate,
};
use parallax_interop::{Calibration, Side};

/// Format of a pose file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PoseFormat {
    /// By extension: `.ron` RON list, `.yaml`/`.yml` ViSP 6x1 `data:` file (one pose per
    /// file), anything else text lines `tx ty tz rx ry rz` (axis-angle, radians).
    Auto,
    /// RON list of `Isometry3`.
    Ron,
    /// ViSP `vpPoseVector` YAML: `[tx ty tz θux θuy θuz]`, metres and radians, one per file.
    Visp,
    /// Text lines `tx ty tz rx ry rz`, axis-angle in radians.
    AxisAngle,
    /// Text lines `x y z roll pitch yaw`, degrees, `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    RpyDeg,
}

/// Arguments of `cargo xtask handeye`.
#[derive(clap::Args)]
pub struct Args {
    /// Robot poses `base_from_gripper`: one file holding a list, or a glob of one-pose files
    /// (sorted by the number in the name, e.g. ViSP's `franka_pose_rPe_*.yaml`).
    #[arg(long)]
    robot: String,
    /// Format of the robot poses.
    #[arg(long, value_enum, default_value = "auto")]
    robot_format: PoseFormat,
    /// Camera poses `camera_from_board`: one file holding a list, or a glob of one-pose files
    /// (e.g. ViSP's `cPo_*.yaml`), sorted like `--robot` (instead of `--images`).
    #[arg(long, conflicts_with = "images")]
    camera_poses: Option<String>,
    /// Format of the camera poses.
    #[arg(long, value_enum, default_value = "auto")]
    camera_format: PoseFormat,
    /// Board images, one per station in the same order as the robot poses (glob, sorted by
    /// the number in the name).
    #[arg(long)]
    images: Option<String>,
    /// The target (with `--images`): a chessboard's inner corners `COLSxROWS` (with `--square`),
    /// or any target description: `chessboard:9x6:25`, `charuco:…`, `circles:…`, `acircles:…`,
    /// `aprilgrid:…`, or a single tag `marker:DICT:ID:SIZE` (e.g. `marker:apriltag_36h11:0:0.08`),
    /// or a target file (Kalibr's target YAML, lengths in metres; a TargetDescription record).
    #[arg(long, default_value = "9x6")]
    board: String,
    /// Square size, in the robot poses' length unit (with `--images`).
    #[arg(long)]
    square: Option<f64>,
    /// Camera intrinsics (with `--images`): any calibration file in any format (a `calibrate`
    /// result, mono or stereo, OpenCV YAML/XML, ROS camera_info, Kalibr, a RON `Camera`), or a
    /// ViSP XML (`perspectiveProjWithDistortion` when present, its `kud` as OpenCV's k1).
    #[arg(long)]
    intrinsics: Option<PathBuf>,
    /// Which camera of a stereo calibration given as --intrinsics: left or right.
    #[arg(long, default_value = "left")]
    camera: String,
    /// Method: all, tsai, park, horaud, andreff, daniilidis, rodrigues, refined, shah, li.
    #[arg(long, default_value = "all")]
    method: String,
    /// Eye-to-hand (camera fixed, board on the gripper): solves `base_from_camera`.
    #[arg(long)]
    eye_to_hand: bool,
    /// Use consecutive station pairs only (default: all pairs).
    #[arg(long)]
    consecutive: bool,
    /// Write the camera poses (`camera_from_board` of the kept stations, RON) to this file, for
    /// reuse with `--camera-poses`.
    #[arg(long)]
    save_camera_poses: Option<PathBuf>,
    /// Write the result: `.ron` / `.json` (the chosen solution in every convention and every
    /// solution with residuals and covariance), or `.yml` / `.yaml` / `.xml` (OpenCV FileStorage:
    /// `R_cam2gripper`, `t_cam2gripper`, or `R_cam2base`, `t_cam2base` eye-to-hand).
    #[arg(long, alias = "output")]
    out: Option<PathBuf>,
    /// Format of --out: ron, json or opencv (default: from the extension).
    #[arg(long, requires = "out")]
    format: Option<String>,
    /// Write `X` of the refined method (else the first that succeeded) as ViSP's `ePc` pose
    /// vector YAML (`eMc` 4x4 matrix when the name contains `eMc`).
    #[arg(long)]
    save_visp: Option<PathBuf>,
    /// Pose rotation noise of robot and camera for the refinement, degrees per axis.
    #[arg(long, default_value_t = 0.1)]
    rotation_noise_deg: f64,
    /// Pose translation noise of robot and camera, in the poses' length unit (default: estimated
    /// from the data, which makes the result independent of the unit).
    #[arg(long)]
    translation_noise: Option<f64>,
    /// Solve even when robot and camera rotations disagree (inverted poses, wrong mode or format).
    #[arg(long)]
    allow_rotation_mismatch: bool,
    /// Solve even when robot and camera lengths look like different units.
    #[arg(long)]
    allow_scale_mismatch: bool,
    /// Accept camera poses that put the board behind the camera.
    #[arg(long)]
    allow_board_behind_camera: bool,
    /// Report an unconverged refinement (`converged: false`) instead of failing.
    #[arg(long)]
    allow_unconverged: bool,
    /// Return solutions that fit the data implausibly (a rotation far worse than the data allow,
    /// translations that fit no transform) with a warning instead of refusing them.
    #[arg(long)]
    allow_poor_fit: bool,
}

impl PoseFormat {
    /// The pose file format (`None`: from each file's extension).
    pub fn file_format(self) -> Option<PoseFileFormat> {
        match self {
            PoseFormat::Auto => None,
            PoseFormat::Ron => Some(PoseFileFormat::Ron),
            PoseFormat::Visp => Some(PoseFileFormat::Visp),
            PoseFormat::AxisAngle => Some(PoseFileFormat::AxisAngle),
            PoseFormat::RpyDeg => Some(PoseFileFormat::RollPitchYawDeg),
        }
    }
}

/// Camera poses from target images (`parallax_composition::poses::camera_poses_from_images`):
/// images where the target is not found are dropped with their robot pose (reported). Returns
/// the kept robot and camera poses.
fn camera_poses_from_images(args: &Args, robot: Vec<Isometry3>) -> anyhow::Result<(Vec<Isometry3>, Vec<Isometry3>)> {
    let pattern = args.images.as_deref().context("--images or --camera-poses is required")?;
    let images = parallax_composition::io::expand_glob(pattern)?;
    ensure!(
        images.len() == robot.len(),
        "{} images match {pattern:?} but there are {} robot poses",
        images.len(),
        robot.len()
    );
    let target = crate::util::target(&args.board, args.square)?;
    let intr = args.intrinsics.as_deref().context("--intrinsics is required with --images")?;
    let side = match args.camera.to_ascii_lowercase().as_str() {
        "left" => Side::Left,
        "right" => Side::Right,
        other => anyhow::bail!("--camera {other:?}: left or right"),
    };
    let intrinsics = poses::read_intrinsics(intr, side)?;
    println!("{}", parallax_composition::summary::intrinsics(intr, &intrinsics, side));
    let station = |s: &poses::StationImage| println!("{}", parallax_composition::summary::station(s));
    Ok(poses::camera_poses_from_images(&images, robot, &target, &intrinsics, station)?)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let format = args.out.as_deref().map(|o| crate::files::output_format(o, args.format.as_deref())).transpose()?;
    if let (Some(out), Some(f)) = (&args.out, format) {
        ensure!(
            !matches!(f, parallax_interop::Format::Ros | parallax_interop::Format::Kalibr),
            "{}: a hand-eye result is written as ron, json or opencv (ROS camera_info and Kalibr hold cameras)",
            out.display()
        );
    }
    let outputs: Vec<&PathBuf> = args.out.iter().chain(&args.save_camera_poses).chain(&args.save_visp).collect();
    let mut inputs = parallax_composition::io::input_paths(&args.robot);
    for spec in args.camera_poses.iter().chain(&args.images) {
        inputs.extend(parallax_composition::io::input_paths(spec));
    }
    inputs.extend(args.intrinsics.iter().cloned());
    parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    // two outputs at one path: the second write replaced the first
    let named: Vec<(&str, &std::path::Path, bool)> = [
        ("--out", args.out.as_deref()),
        ("--save-camera-poses", args.save_camera_poses.as_deref()),
        ("--save-visp", args.save_visp.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, p)| Some((flag, p?, false)))
    .collect();
    parallax_composition::io::refuse_colliding_outputs(&named)?;
    let robot = poses::read_poses(&args.robot, args.robot_format.file_format())
        .with_context(|| format!("robot poses {:?}", args.robot))?;
    let (robot, camera) = match &args.camera_poses {
        Some(spec) => {
            let c = poses::read_poses(spec, args.camera_format.file_format())
                .with_context(|| format!("camera poses {spec:?}"))?;
            (robot, c)
        }
        None => camera_poses_from_images(&args, robot)?,
    };
    ensure!(
        robot.len() == camera.len(),
        "{} robot poses but {} camera poses: they must pair up station by station",
        robot.len(),
        camera.len()
    );
    // every output is gathered here and written as one set after the solvers ran
    let mut files = parallax_composition::io::OutputSet::new();
    if let Some(path) = &args.save_camera_poses {
        files.add_ron(path, &camera)?;
    }
    let methods = poses::parse_methods(&args.method)?;
    let config = HandEyeConfig {
        setup: if args.eye_to_hand { Setup::EyeToHand } else { Setup::EyeInHand },
        pairs: if args.consecutive { PairSelection::Consecutive } else { PairSelection::All },
        refine: RefineConfig {
            robot_rotation_sigma_deg: args.rotation_noise_deg,
            camera_rotation_sigma_deg: args.rotation_noise_deg,
            estimate_translation_noise: args.translation_noise.is_none(),
            robot_translation_sigma: args.translation_noise.unwrap_or(1.0),
            camera_translation_sigma: args.translation_noise.unwrap_or(1.0),
            allow_unconverged: args.allow_unconverged,
            ..Default::default()
        },
        consistency: ConsistencyConfig {
            allow_rotation_mismatch: args.allow_rotation_mismatch,
            allow_scale_mismatch: args.allow_scale_mismatch,
            allow_board_behind_camera: args.allow_board_behind_camera,
            ..Default::default()
        },
        observability: ObservabilityConfig { allow_poor_fit: args.allow_poor_fit, ..Default::default() },
        ..Default::default()
    };
    let what = if args.eye_to_hand { "base_from_camera" } else { "gripper_from_camera" };
    println!("hand-eye: {} stations, solving {what}, {:?} pairs", robot.len(), config.pairs);
    let mut ok = Vec::new();
    let mut failed = 0;
    for m in methods {
        let start = std::time::Instant::now();
        let r = calibrate(&robot, &camera, m, &config);
        let elapsed = start.elapsed();
        match r {
            Ok(s) => {
                println!("{}", parallax_composition::summary::hand_eye_solution(&s));
                println!("    time {:.1} µs", elapsed.as_secs_f64() * 1e6);
                ok.push(s);
            }
            Err(e) => {
                failed += 1;
                eprintln!("{m}: {e}");
            }
        }
    }
    let counts = |ok: usize| {
        println!("{ok} of {} methods succeeded", ok + failed);
        println!("succeeded: {ok}");
        println!("failed: {failed}");
    };
    if ok.is_empty() {
        // every method refused: nothing is written (the camera poses alone used to be)
        counts(0);
        eprintln!("error: no hand-eye method gave a solution: nothing written");
        return Ok(ExitCode::FAILURE);
    }
    let chosen = chosen_solution(&ok);
    let mut wrote = Vec::new();
    if let (Some(out), Some(format)) = (&args.out, format) {
        let result = hand_eye_calibration(chosen.context("no solution to write")?);
        let native = HandEyeOutput::new(&result, &ok);
        for p in files.add_result(out, format, &native, Some(&Calibration::HandEye(result)))? {
            wrote.push(format!("wrote {} ({})", p.display(), format.name()));
        }
    }
    if let Some(out) = &args.save_visp {
        let s = chosen.context("no solution to write")?;
        let emc = out.file_name().is_some_and(|n| n.to_string_lossy().contains("eMc"));
        let text = if emc {
            parallax_hand_eye::visp::homogeneous_matrix_yaml(&s.transform)
        } else {
            parallax_hand_eye::visp::pose_vector_yaml(&s.transform)
        };
        files.add(out, text)?;
        wrote.push(format!("wrote {} ({} of {})", out.display(), if emc { "eMc" } else { "ePc" }, s.method));
    }
    files.commit()?;
    if let Some(path) = &args.save_camera_poses {
        println!("wrote camera poses to {}", path.display());
    }
    for line in wrote {
        println!("{line}");
    }
    counts(ok.len());
    if let Some(s) = chosen {
        println!("{}", parallax_composition::summary::hand_eye_keys(s, what));
    }
    Ok(ExitCode::SUCCESS)
}
