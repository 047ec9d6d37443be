//! `cargo xtask pipeline`: the whole chain on a synthetic scene, checked against ground truth,
//! or (`--real`) on the user's stereo chessboard folder, checked for self-consistency.
//!
//! The chain, the truth scoring and the checks live in `parallax-composition`; this module
//! parses the arguments, reads the input files and prints the table and the verdict.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use parallax_composition::{Corruption, RealInputs, Report, io};

use crate::util;

/// A deliberate corruption of one stage's input, to check that the pipeline notices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CorruptionArg {
    /// Calibrate with a square size 5 % larger than the rendered one.
    SquareSize,
    /// Swap the left and right images of the stereo calibration session.
    SwapStereo,
}

/// Arguments of `cargo xtask pipeline`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene description (RON, `parallax_synthetic::SceneDescription`); the built-in scene when absent.
    #[arg(long, conflicts_with = "real")]
    scene: Option<PathBuf>,
    /// A stereo world (RON, `parallax_synthetic::StereoWorld`, e.g. `fixtures/zoo/clutter.ron`)
    /// that replaces the scene's stereo scene: rendered through the scene's rig with its lenses
    /// (scaled to its baseline), rectified by the chain with the rig it calibrated, and scored
    /// against the world's truth in the true rig's rectification.
    #[arg(long, conflicts_with = "real")]
    world: Option<PathBuf>,
    /// Directory for the artifacts (RON results, overlays, rectified pair, disparity PNG/PFM,
    /// PLY, report.md / report.html / report.ron). Default `target/pipeline/<scene>/`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Reseed every generator of the scene (views, noise, stereo scene, trajectory): the same
    /// scene drawn again, to check that its tolerances hold for any draw.
    #[arg(long, conflicts_with = "real")]
    seed: Option<u64>,
    /// Corrupt one stage's input on purpose (checks that the pipeline fails and names the stage).
    #[arg(long, value_enum, conflicts_with = "real")]
    corrupt: Option<CorruptionArg>,
    /// Run the chain on real data instead (no truth; self-consistency checks): needs --left,
    /// --right, --board, --square.
    #[arg(long, requires_all = ["left", "right", "board", "square"])]
    real: bool,
    /// With --real: glob of the left chessboard images.
    #[arg(long, requires = "real")]
    left: Option<String>,
    /// With --real: glob of the right chessboard images (same order).
    #[arg(long, requires = "real")]
    right: Option<String>,
    /// With --real: inner corners, COLSxROWS (e.g. 9x6).
    #[arg(long, requires = "real", value_parser = util::parse_board_size)]
    board: Option<(usize, usize)>,
    /// With --real: square size (the length unit of every result).
    #[arg(long, requires = "real", allow_negative_numbers = true)]
    square: Option<f64>,
    /// With --real: name of the square size's unit, for the report.
    #[arg(long, requires = "real", default_value = "mm")]
    unit: String,
    /// With --real: the left image of the pair to block-match (default: the first calibration pair).
    #[arg(long, requires_all = ["pair_right", "real"])]
    pair_left: Option<PathBuf>,
    /// With --real: the right image of the pair to block-match.
    #[arg(long, requires_all = ["pair_left", "real"])]
    pair_right: Option<PathBuf>,
    /// With --real: disparities to search.
    #[arg(long, default_value_t = 128)]
    disparities: usize,
    /// With --real: robot base_from_gripper poses (file or glob; ViSP YAML, RON or text), one per
    /// image pair, for hand-eye with the left camera.
    #[arg(long, requires = "real")]
    robot: Option<String>,
}

fn print_summary(report: &Report, out: &std::path::Path, started: std::time::Instant) {
    println!();
    for (stage, text) in &report.notes {
        println!("{stage:<14} {text}");
    }
    println!("\n{}", report.table());
    println!("artifacts and report: {}", out.join("report.html").display());
    println!("total time: {:.1} s", started.elapsed().as_secs_f64());
    println!("{}", report.verdict());
}

fn run_real(args: &Args) -> anyhow::Result<ExitCode> {
    let (cols, rows) = args.board.context("--board is required with --real")?;
    let board = util::board(cols, rows, args.square.unwrap_or(f64::NAN))?;
    let lp = io::expand_glob(args.left.as_deref().unwrap_or_default())?;
    let rp = io::expand_glob(args.right.as_deref().unwrap_or_default())?;
    let robot = args.robot.as_deref().map(|spec| parallax_composition::poses::read_poses(spec, None)).transpose()?;
    let pair = args.pair_left.as_deref().zip(args.pair_right.as_deref()).map(|(l, r)| [l, r]);
    let inputs = RealInputs::from_files(board, &args.unit, &lp, &rp, pair, args.disparities, robot)?;
    let out = args.out.clone().unwrap_or_else(|| workspace_root().join("target").join("pipeline").join("real"));
    let started = std::time::Instant::now();
    let report = parallax_composition::run_real(inputs, &out)?;
    print_summary(&report, &out, started);
    println!("checks run: {}", report.rows.len());
    Ok(if report.passed() { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// Runs `cargo xtask pipeline`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if args.real {
        return run_real(&args);
    }
    let (name, scene) = match &args.scene {
        Some(path) => {
            let text =
                parallax_interop::read_text_file(path).with_context(|| format!("reading scene {}", path.display()))?;
            parallax_interop::check_nesting(&text, &path.display().to_string())?;
            let scene = parallax_synthetic::SceneDescription::from_ron(&text)
                .with_context(|| format!("parsing scene {}", path.display()))?;
            let name = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            (name, scene)
        }
        None => ("builtin".to_string(), parallax_synthetic::SceneDescription::builtin()),
    };
    let (name, scene) = match &args.world {
        Some(path) => {
            let text =
                parallax_interop::read_text_file(path).with_context(|| format!("reading world {}", path.display()))?;
            let world = parallax_synthetic::StereoWorld::from_ron(&text)
                .with_context(|| format!("parsing world {}", path.display()))?;
            let stem = path.file_stem().map_or("world".into(), |s| s.to_string_lossy().into_owned());
            let scene = parallax_synthetic::SceneDescription { stereo_world: Some(world), ..scene };
            scene.validate().with_context(|| format!("the scene with the world {}", path.display()))?;
            (format!("{name}-{stem}"), scene)
        }
        None => (name, scene),
    };
    let (name, scene) = match args.seed {
        Some(seed) => (format!("{name}-seed{seed}"), scene.with_seed(seed)),
        None => (name, scene),
    };
    let out = args.out.clone().unwrap_or_else(|| workspace_root().join("target").join("pipeline").join(&name));
    let corrupt = args.corrupt.map(|c| match c {
        CorruptionArg::SquareSize => Corruption::SquareSize,
        CorruptionArg::SwapStereo => Corruption::SwapStereo,
    });
    let started = std::time::Instant::now();
    let report = parallax_composition::run_scene(&name, &scene, &out, corrupt)?;
    println!("\n{}", report.table());
    println!("artifacts and report: {}", out.join("report.html").display());
    println!("total time: {:.1} s", started.elapsed().as_secs_f64());
    println!("{}", report.verdict());
    Ok(if report.passed() { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// The workspace root (the parent of this crate's directory).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().map(PathBuf::from).unwrap_or_else(|| PathBuf::from("."))
}
