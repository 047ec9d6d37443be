//! `cargo xtask corners`: target detection on the user's images (chessboards, ChArUco boards,
//! circle grids, AprilGrids, single markers); the corners file is
//! `parallax_composition::session::CornersFile`.

use std::path::PathBuf;
use std::process::ExitCode;

use parallax_composition::session::{self, CornersFile};
use parallax_corner_detection::CornerRefinement;

/// Arguments of `cargo xtask corners`.
#[derive(clap::Args)]
pub struct Args {
    /// Images to search (glob pattern, quote it), e.g. '../shared/data/opencv-stereo-chessboard/left*.jpg'.
    #[arg(long)]
    images: String,
    /// The target: a chessboard's inner corners as COLSxROWS (OpenCV's patternSize), e.g. 9x6,
    /// or any target description (`charuco:7x5:40:30:DICT_5X5_100`, `circles:…`, `aprilgrid:…`);
    /// or a target file (Kalibr's target YAML, a TargetDescription record); the file then holds
    /// the ids of the points found.
    #[arg(long)]
    board: String,
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
    #[command(flatten)]
    detector: crate::util::DetectorArgs,
}

fn parse_refinement(s: &str) -> Result<CornerRefinement, String> {
    match s {
        "subpix" => Ok(CornerRefinement::SubPix),
        "saddle" => Ok(CornerRefinement::Saddle),
        "none" => Ok(CornerRefinement::None),
        _ => Err(format!("unknown refinement {s:?} (subpix, saddle, none)")),
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    // Corner positions need no unit: a COLSxROWS board gets squares of 1.
    let target = crate::util::target_for_corners(&args.board)?;
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
    let overlay_path = |dir: &std::path::Path, path: &std::path::Path| {
        let stem = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        dir.join(format!("{stem}-corners.png"))
    };
    if let Some(dir) = &args.draw {
        let overlays: Vec<_> = paths.iter().map(|p| overlay_path(dir, p)).collect();
        parallax_composition::io::refuse_overwriting_inputs(&overlays, &paths)?;
    }
    let cfg = args.detector.config(args.refine);
    let mut entries = Vec::new();
    let mut found = 0;
    let mut times = Vec::new();
    // the corners file and the overlays are written as one set once every image is searched
    let mut files = parallax_composition::io::OutputSet::new();
    for path in &paths {
        let search = session::search_corners(path, &target, &cfg, args.draw.is_some())?;
        println!("{}", search.line);
        if let Some(why) = &search.why {
            println!("why: {why}");
        }
        found += usize::from(search.found());
        times.push(search.entry.time_ms);
        if let (Some(dir), Some(overlay)) = (&args.draw, &search.overlay) {
            files.add_png(overlay_path(dir, path), overlay)?;
        }
        entries.push(search.entry);
    }
    if let (Some(out), Some(format)) = (&args.out, format) {
        files.add_result(out, format, &CornersFile::new(&target, args.refine, entries), None)?;
    }
    files.commit()?;
    if let Some(out) = &args.out {
        println!("corners written to {}", out.display());
    }
    if let Some(dir) = &args.draw {
        println!("overlays written to {}", dir.display());
    }
    let (median, max) =
        (parallax_composition::stats::median(times.clone()), times.iter().fold(0.0f64, |a, b| a.max(*b)));
    println!(
        "time per image (detection + refinement): median {median:.2} ms, max {:.2} ms{}",
        max,
        if cfg!(debug_assertions) {
            " (debug build: use `cargo run --release -p xtask -- corners ...` for timing)"
        } else {
            ""
        }
    );
    println!("found: {found}/{}", paths.len());
    Ok(ExitCode::SUCCESS)
}
