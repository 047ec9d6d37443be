//! `cargo xtask pipeline`: the whole chain on a synthetic scene, checked against ground truth.
//!
//! render a stereo calibration session and a robot trajectory → detect corners → calibrate both
//! cameras and the rig → rectify → block-match a rendered stereo scene → triangulate → measure the
//! distances between four target points (the thesis's Table 3) → hand-eye → report the targets in
//! the robot base frame. Every stage is compared with the scene's ground truth and its tolerance
//! (stored in the scene file); the run exits non-zero when any stage is out of tolerance.

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
    /// Scene description (RON, `synthetic::SceneDescription`); the built-in scene when absent.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Directory for the artifacts (RON results, overlays, rectified pair, disparity PNG/PFM,
    /// PLY, report.md / report.html). Default `target/pipeline/<scene>/`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Corrupt one stage's input on purpose (checks that the pipeline fails and names the stage).
    #[arg(long, value_enum)]
    corrupt: Option<Corruption>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let (name, scene) = match &args.scene {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading scene {}", path.display()))?;
            let scene = synthetic::SceneDescription::from_ron(&text)
                .with_context(|| format!("parsing scene {}", path.display()))?;
            let name = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            (name, scene)
        }
        None => ("builtin".to_string(), synthetic::SceneDescription::builtin()),
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
        let report = stages::run_all("test", &synthetic::SceneDescription::builtin(), &dir, corrupt).unwrap();
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
}
