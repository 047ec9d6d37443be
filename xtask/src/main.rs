//! `cargo xtask` — parallax's pipeline runner and developer commands.
//!
//! Every stage crate is usable alone; this binary is where they meet (the composition root).
//! Each subcommand lives in its own module with its clap `Args` and a `run` function.

mod bench;
mod calibrate;
mod corners;
mod disparity;
mod files;
mod fixtures;
mod handeye;
mod measure;
mod pipeline;
mod progress;
mod rectify;
mod scenes;
mod tune;
mod util;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// parallax developer commands: the pipeline, fixtures, benchmarks and each stage on real data.
#[derive(Parser)]
#[command(name = "cargo xtask", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the whole chain on a synthetic scene (the built-in one by default) and check every
    /// stage against ground truth.
    Pipeline(pipeline::Args),
    /// Regenerate the committed fixtures deterministically (`--check`: fail when stale).
    Fixtures(fixtures::Args),
    /// Run the criterion benchmarks.
    Bench(bench::Args),
    /// Detect a target (chessboard, ChArUco, circle grid, AprilGrid, marker) in images.
    Corners(corners::Args),
    /// Calibrate one camera or a stereo rig from target images (partial views of ChArUco / AprilGrid).
    Calibrate(calibrate::Args),
    /// Rectify a stereo pair with a stereo calibration.
    Rectify(rectify::Args),
    /// Dense disparity of a rectified pair by block matching.
    ///
    /// Ends with `key: value` lines. With --gt: bad1, bad2 (missing = bad), bad2_returned
    /// (among the returned pixels) and density in percent of the evaluated pixels (the mask's
    /// with known truth); bad2_overlap (missing = bad) and density_overlap in percent of the
    /// evaluated pixels in the columns where OpenCV's matchers also answer (x ≥ min_disparity +
    /// disparities). Without --gt: density in percent of the image. Always rejected_texture,
    /// rejected_uniqueness, rejected_lr, rejected_confidence, rejected_speckle,
    /// rejected_no_candidate (no candidate disparity inside the right image) and filled in
    /// percent of the image, then seconds and mdes.
    Disparity(disparity::Args),
    /// Triangulate points of a stereo pair and measure distances between them.
    Measure(measure::Args),
    /// Hand-eye calibration from robot poses and board images (or camera poses).
    Handeye(handeye::Args),
    /// List the stereo worlds of a scene set (the zoo by default) and render them with their truth.
    ///
    /// One line per scene: `scene: NAME size: WxH disparities: D factors: LIST`.
    Scenes(scenes::Args),
    /// Search the matcher's parameters over a scene set against its ground truth.
    ///
    /// One line per configuration: `config: N method: M bad2: X bad2_overlap: Y density: Z ms:
    /// T pareto: yes|no` (bad2 with missing = bad, density, in percent of the scored pixels;
    /// bad2_overlap where OpenCV's matchers also answer; ms per scene), then `best: N`; with
    /// --realism also `real: …` lines and `rank_correlation: R`.
    Tune(tune::Args),
}

fn main() -> std::process::ExitCode {
    // Negative numbers are values everywhere (`--square -30` reads as `--square=-30`, and the
    // command's own check then names the mistake), never taken for a flag.
    let command = Cli::command().mut_subcommands(|sub| sub.allow_negative_numbers(true));
    let cli = Cli::from_arg_matches(&command.get_matches()).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Pipeline(a) => pipeline::run(a),
        Command::Fixtures(a) => fixtures::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Corners(a) => corners::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Rectify(a) => rectify::run(a),
        Command::Disparity(a) => disparity::run(a),
        Command::Measure(a) => measure::run(a),
        Command::Handeye(a) => handeye::run(a),
        Command::Scenes(a) => scenes::run(a),
        Command::Tune(a) => tune::run(a),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            // The causes, each once: an error that already prints its source (`reading x: No
            // such file`) is not followed by that source again.
            let mut message = e.to_string();
            for cause in e.chain().skip(1).map(|c| c.to_string()) {
                if !message.contains(&cause) {
                    message = format!("{message}: {cause}");
                }
            }
            eprintln!("error: {message}");
            std::process::ExitCode::FAILURE
        }
    }
}
