//! `cargo xtask corners`: chessboard detection on the user's images.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use parallax_camera_model::CornerGrid;
use parallax_corner_detection::{
    ChessboardConfig, CornerRefinement, chessboard_candidates, detect_chessboard, draw_chessboard, draw_points,
};
use serde::{Deserialize, Serialize};

/// Arguments of `cargo xtask corners`.
#[derive(clap::Args)]
pub struct Args {
    /// Images to search (glob pattern, quote it), e.g. '../shared/data/opencv-stereo-chessboard/left*.jpg'.
    #[arg(long)]
    images: String,
    /// Inner corners of the board as COLSxROWS (OpenCV's patternSize), e.g. 9x6.
    #[arg(long, value_parser = crate::util::parse_board_size)]
    board: (usize, usize),
    /// Write the corners of every image to this file (`.ron` or `.json`; `calibrate --corners` reads it).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write an overlay PNG per image into this directory (the grid in OpenCV's order, or the
    /// X-junction candidates when no board was found).
    #[arg(long)]
    draw: Option<PathBuf>,
    /// Sub-pixel method: saddle (saddle-point fit, default), subpix (gradient orthogonality), none.
    #[arg(long, default_value = "saddle", value_parser = parse_refinement)]
    refine: CornerRefinement,
}

fn parse_refinement(s: &str) -> Result<CornerRefinement, String> {
    match s {
        "subpix" => Ok(CornerRefinement::SubPix),
        "saddle" => Ok(CornerRefinement::Saddle),
        "none" => Ok(CornerRefinement::None),
        _ => Err(format!("unknown refinement {s:?} (subpix, saddle, none)")),
    }
}

/// One image's result in the `--out` file.
#[derive(Serialize, Deserialize)]
pub struct ImageCorners {
    /// Path of the image as given by the glob.
    pub image: String,
    /// Image size in pixels.
    pub width: u32,
    /// Image size in pixels.
    pub height: u32,
    /// The corners in OpenCV's order, or `None` when the board was not found.
    pub grid: Option<CornerGrid>,
    /// Detection + refinement time, milliseconds.
    pub time_ms: f64,
}

/// The `--out` file (read back by `calibrate --corners`).
#[derive(Serialize, Deserialize)]
pub struct CornersFile {
    /// Inner corners per row.
    pub cols: usize,
    /// Inner corners per column.
    pub rows: usize,
    /// Refinement method used.
    pub refinement: CornerRefinement,
    /// One entry per image, in sorted path order.
    pub images: Vec<ImageCorners>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let (cols, rows) = args.board;
    let format = args.out.as_deref().map(|o| crate::files::output_format(o, None)).transpose()?;
    if let (Some(out), Some(f)) = (&args.out, format) {
        anyhow::ensure!(
            matches!(f, parallax_interop::Format::Ron | parallax_interop::Format::Json),
            "{}: corners are written as .ron or .json",
            out.display()
        );
    }
    if let Some(out) = &args.out {
        parallax_composition::io::refuse_overwriting_inputs(
            &[out],
            &parallax_composition::io::input_paths(&args.images),
        )?;
    }
    let paths = parallax_composition::io::expand_glob(&args.images)?;
    let cfg = ChessboardConfig { refinement: args.refine, ..ChessboardConfig::default() };
    let mut entries = Vec::new();
    let mut found = 0;
    let mut times = Vec::new();
    for path in &paths {
        let img = parallax_composition::io::load_gray(path)?;
        let t0 = Instant::now();
        let det =
            detect_chessboard(&img, cols, rows, &cfg).with_context(|| format!("detecting in {}", path.display()))?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        times.push(ms);
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        match &det {
            Some(d) => {
                found += 1;
                let unconverged = d.refinement.iter().filter(|r| !r.converged).count();
                println!(
                    "{name}: found {}x{} in {ms:.2} ms (min spacing {:.1} px, min contrast {:.0}, refinement not converged at {unconverged} corners)",
                    cols, rows, d.min_spacing, d.min_contrast
                );
            }
            None => println!("{name}: not found ({ms:.2} ms)"),
        }
        if let Some(dir) = &args.draw {
            let stem = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let overlay = match &det {
                Some(d) => draw_chessboard(&img, &d.grid),
                None => draw_points(&img, &chessboard_candidates(&img, &cfg)?, [255, 0, 0]),
            };
            parallax_composition::io::save_png(&dir.join(format!("{stem}-corners.png")), &overlay)?;
        }
        entries.push(ImageCorners {
            image: path.display().to_string(),
            width: img.width(),
            height: img.height(),
            grid: det.map(|d| d.grid),
            time_ms: ms,
        });
    }
    if let (Some(out), Some(format)) = (&args.out, format) {
        let file = CornersFile { cols, rows, refinement: args.refine, images: entries };
        crate::files::write_result(out, format, &file, None)?;
        println!("corners written to {}", out.display());
    }
    if let Some(dir) = &args.draw {
        println!("overlays written to {}", dir.display());
    }
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    println!(
        "time per image (detection + refinement): median {median:.2} ms, max {:.2} ms{}",
        sorted[sorted.len() - 1],
        if cfg!(debug_assertions) {
            " (debug build: use `cargo run --release -p xtask -- corners ...` for timing)"
        } else {
            ""
        }
    );
    println!("found: {found}/{}", paths.len());
    Ok(ExitCode::SUCCESS)
}
