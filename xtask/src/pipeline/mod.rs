//! `cargo xtask pipeline`: the whole chain on a synthetic scene, checked against ground truth.
//!
//! render a stereo calibration session and a robot trajectory → detect corners → calibrate both
//! cameras and the rig → rectify → block-match a rendered stereo scene → triangulate → measure the
//! distances between four target points (the thesis's Table 3) → hand-eye → report the targets in
//! the robot base frame. Every stage is compared with the scene's ground truth and its tolerance
//! (stored in the scene file); the run exits non-zero when any stage is out of tolerance.

mod real;
mod report;

mod stages;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

/// A deliberate corruption of one stage's input, to check that the pipeline notices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Corruption {
    /// Calibrate with a square size 5 % larger than the rendered one.
    SquareSize,
    /// Swap the left and right images of the stereo calibration session.
    SwapStereo,
}

/// Arguments of `cargo xtask pipeline`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene description (RON, `parallax_synthetic::SceneDescription`); the built-in scene when absent.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Directory for the artifacts (RON results, overlays, rectified pair, disparity PNG/PFM,
    /// PLY, report.md / report.html). Default `target/pipeline/<scene>/`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Corrupt one stage's input on purpose (checks that the pipeline fails and names the stage).
    #[arg(long, value_enum)]
    corrupt: Option<Corruption>,
    /// Run the chain on real data instead (no truth columns): needs --left, --right, --board, --square.
    #[arg(long, requires_all = ["left", "right", "board", "square"])]
    real: bool,
    /// With --real: glob of the left chessboard images.
    #[arg(long)]
    left: Option<String>,
    /// With --real: glob of the right chessboard images (same order).
    #[arg(long)]
    right: Option<String>,
    /// With --real: inner corners, COLSxROWS (e.g. 9x6).
    #[arg(long)]
    board: Option<String>,
    /// With --real: square size (the length unit of every result).
    #[arg(long)]
    square: Option<f64>,
    /// With --real: the left image of the pair to block-match (default: the first calibration pair).
    #[arg(long, requires = "pair_right")]
    pair_left: Option<PathBuf>,
    /// With --real: the right image of the pair to block-match.
    #[arg(long, requires = "pair_left")]
    pair_right: Option<PathBuf>,
    /// With --real: disparities to search.
    #[arg(long, default_value_t = 128)]
    disparities: usize,
    /// With --real: robot base_from_gripper poses (file or glob; ViSP YAML, RON or text), one per
    /// image pair, for hand-eye with the left camera.
    #[arg(long)]
    robot: Option<String>,
}

fn run_real(args: &Args) -> anyhow::Result<ExitCode> {
    let spec = args.board.as_deref().unwrap_or_default();
    let (cols, rows) = spec
        .split_once(['x', 'X'])
        .and_then(|(c, r)| Some((c.trim().parse().ok()?, r.trim().parse().ok()?)))
        .with_context(|| format!("--board {spec:?}: expected COLSxROWS, e.g. 9x6"))?;
    let board = parallax_camera_model::Chessboard::new(cols, rows, args.square.unwrap_or(f64::NAN))
        .context("--board/--square")?;
    let inputs = real::RealInputs {
        left: args.left.clone().unwrap_or_default(),
        right: args.right.clone().unwrap_or_default(),
        board,
        pair: args.pair_left.clone().zip(args.pair_right.clone()),
        disparities: args.disparities,
        robot: args.robot.clone(),
    };
    let out = args.out.clone().unwrap_or_else(|| workspace_root().join("target").join("pipeline").join("real"));
    let started = std::time::Instant::now();
    let report = real::run_real(&inputs, &out)?;
    report.write(&out)?;
    println!();
    for (stage, text) in &report.notes {
        println!("{stage:<14} {text}");
    }
    println!("artifacts and report: {}", out.join("report.html").display());
    println!("total time: {:.1} s", started.elapsed().as_secs_f64());
    println!("{}", report.verdict());
    Ok(ExitCode::SUCCESS)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if args.real {
        return run_real(&args);
    }
    let (name, scene) = match &args.scene {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading scene {}", path.display()))?;
            let scene = parallax_synthetic::SceneDescription::from_ron(&text)
                .with_context(|| format!("parsing scene {}", path.display()))?;
            let name = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            (name, scene)
        }
        None => ("builtin".to_string(), parallax_synthetic::SceneDescription::builtin()),
    };
    let out = args.out.clone().unwrap_or_else(|| workspace_root().join("target").join("pipeline").join(&name));
    let started = std::time::Instant::now();
    let report = stages::run_all(&name, &scene, &out, args.corrupt)?;
    report.write(&out)?;
    println!("\n{}", report.table());
    println!("artifacts and report: {}", out.join("report.html").display());
    println!("total time: {:.1} s", started.elapsed().as_secs_f64());
    println!("{}", report.verdict());
    Ok(if report.failed_stages().is_empty() { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// The workspace root (the parent of this crate's directory).
fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().map(PathBuf::from).unwrap_or_else(|| PathBuf::from("."))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_scene(corrupt: Option<Corruption>) -> report::Report {
        let dir = std::env::temp_dir().join(format!("parallax-pipeline-{}-{:?}", std::process::id(), corrupt));
        let report = stages::run_all("test", &parallax_synthetic::SceneDescription::builtin(), &dir, corrupt).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        report
    }

    /// The built-in scene passes every tolerance; corrupting a stage input makes the stage that
    /// consumes it (and those downstream) fail by name.
    #[test]
    fn builtin_scene_passes_and_corruptions_name_the_stage() {
        let ok = run_scene(None);
        assert_eq!(ok.verdict(), "pipeline: PASS", "{}", ok.table());
        let square = run_scene(Some(Corruption::SquareSize));
        let failed = square.failed_stages();
        assert!(failed.contains(&"calibration".to_string()), "{failed:?}");
        assert!(failed.contains(&"measurement".to_string()), "{failed:?}");
        assert!(square.table().contains("baseline vector error"));
        let swapped = run_scene(Some(Corruption::SwapStereo));
        assert!(swapped.failed_stages().contains(&"corners".to_string()), "{:?}", swapped.failed_stages());
        assert!(swapped.verdict().starts_with("pipeline: FAIL (corners, calibration"));
    }

    /// `--real` on the committed synthetic stereo fixtures (5 pairs): every stage runs, the
    /// calibration it reports matches the fixtures' true rig, and the artifacts are written.
    #[test]
    fn real_mode_runs_on_the_stereo_fixtures() {
        let root = workspace_root().join("fixtures/stereo");
        let truth = parallax_synthetic::SceneDescription::builtin().rig;
        let inputs = real::RealInputs {
            left: root.join("left_*.png").to_string_lossy().into_owned(),
            right: root.join("right_*.png").to_string_lossy().into_owned(),
            board: parallax_camera_model::Chessboard::new(9, 6, 25.0).unwrap(),
            pair: None,
            disparities: 64,
            robot: None,
        };
        let dir = std::env::temp_dir().join(format!("parallax-real-{}", std::process::id()));
        let report = real::run_real(&inputs, &dir).unwrap();
        report.write(&dir).unwrap();
        assert!(report.notes.iter().any(|(s, t)| s == "corners" && t.contains("5/5")), "{:?}", report.notes);
        let cal: parallax_planar_calibration::StereoCalibrationResult =
            crate::util::read_ron(&dir.join("calibration.ron")).unwrap();
        // Five views only: fx within 0.5 %, baseline within 1 % of the rendered rig.
        assert!((cal.rig.left.intrinsics.fx / truth.left.intrinsics.fx - 1.0).abs() < 5e-3);
        assert!((cal.rig.baseline() / truth.baseline() - 1.0).abs() < 1e-2);
        for f in ["disparity.pfm", "cloud.ply", "report.html", "rectified-left.png"] {
            assert!(dir.join(f).is_file(), "{f} missing");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
