//! `cargo xtask disparity`: dense disparity of a rectified pair with the block-matching crate,
//! optional evaluation against a ground truth (Middlebury style, both conventions), rejection
//! counts by reason, a swapped-pair check, timing in Mde/s.
//!
//! Output contract (one `key: value` per line, scripts read it): `bad1`, `bad2` (missing =
//! bad), `bad2_returned`, `density` (with `--gt`; percent of the mask), `bad2_overlap`,
//! `density_overlap` (with `--gt`; percent of the mask's pixels in the columns where OpenCV's
//! matchers also answer, `x ≥ min_disparity + disparities`), `rejected_texture`,
//! `rejected_uniqueness`, `rejected_lr`, `rejected_confidence`, `rejected_speckle`,
//! `rejected_no_candidate`, `filled` (percent of the image), `seconds`, `mdes`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use parallax_block_matching::{BlockMatcher, MatcherConfig, SgmPaths, SwapCheck};
use parallax_composition::disparity::{self, FrameEvent};
use parallax_composition::io::OutputSet;
use parallax_composition::summary;
use parallax_composition::tune::DisparityConfig;

/// Arguments of `cargo xtask disparity`.
#[derive(clap::Args)]
pub struct Args {
    /// Left rectified image (8- or 16-bit grayscale; colour is converted), or a folder or glob
    /// pattern of left images (an image sequence: paired with the right ones in sorted order).
    #[arg(long)]
    left: PathBuf,
    /// Right rectified image, or a folder or glob pattern as --left.
    #[arg(long)]
    right: PathBuf,
    /// Sequences: pair the left and right files by sorted position even when their names do
    /// not correspond (by default what varies along the left names, a frame number, timestamp
    /// or folder, must vary alike along the right ones).
    #[arg(long)]
    pair_by_order: bool,
    /// Sequences: pairs decoded ahead of the matcher (default 2, at most 64).
    #[arg(long, default_value_t = 2, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=64))]
    prefetch: usize,
    /// Method: bm (block matching) or sgm (semi-global matching on the x-Sobel prefilter with a
    /// 3x3 window; see --sgm-paths, --sgm-cost and --lr-rule).
    #[arg(long, default_value = "bm")]
    method: String,
    /// Semi-global matching paths: 3 (one pass: left-to-right, right-to-left, down; OpenCV
    /// SGBM 3-way's directions; default), 5 (one pass, adds both diagonals from above) or 8
    /// (default with --accurate).
    #[arg(long)]
    sgm_paths: Option<u32>,
    /// With --method sgm: the accurate preset (OpenCV SGBM's cost and left–right rule, eight
    /// paths, no uniqueness margin): SGBM's density with fewer wrong pixels, about twice the
    /// time of the default SGM. Explicit options still apply. In the left band, where the image
    /// edge cuts a pixel's candidates short of the range (x < min_disparity + disparities − 1;
    /// with a negative min_disparity also the right band x > width − 1 + min_disparity), it
    /// still applies, as every SGM that is not filled, a uniqueness margin of 200 % (a rival
    /// further than one disparity must exist and cost more than three times the winner; counted
    /// in rejected_uniqueness) and, with the left–right check on, the exact integer left–right
    /// check (tolerance 0, and no winner on the right image's first column; counted in
    /// rejected_lr).
    #[arg(long)]
    accurate: bool,
    /// Match 8-bit colour images in colour, the cost summed over the three channels (each
    /// prefiltered): with --method sgm the pixel cost, with the penalties multiplied by 3 (as
    /// OpenCV's P1 = 8·channels·blockSize²); with --method bm the window cost of --cost sad or
    /// ssd (ncc is refused: it matches grey pairs only). The texture and the adaptive P2 read
    /// the grey conversion. Measured on Middlebury, grey matched better (SGM on all three
    /// pairs, block matching on two; `benches/RESULTS.md`, 2026-12-06 and 2026-12-07).
    #[arg(long)]
    colour: bool,
    /// Semi-global matching's pixel difference: sad (|L − R| on the prefilter), bt
    /// (Birchfield–Tomasi, sampling-insensitive), and either with +intensity (adds the raw
    /// grey-level difference / 4, as SGBM); default bt+intensity (sad with --fill).
    #[arg(long)]
    sgm_cost: Option<String>,
    /// Left–right rule: integer (the right image's own winner at the winning integer
    /// disparity), subpixel (at either integer next to the sub-pixel disparity) or, with
    /// --method sgm, sgbm (OpenCV SGBM's: subpixel, against the right disparities its left
    /// winners give — at each right pixel the winner of the left pixel of smallest cost
    /// matched there); default integer for block matching and with --fill, sgbm for
    /// --method sgm, subpixel with --accurate.
    #[arg(long)]
    lr_rule: Option<String>,
    /// Matching cost: sad, ssd or ncc.
    #[arg(long, default_value = "sad")]
    cost: String,
    /// Window side in pixels: block matching's (odd, 3..=31; default 9), or with `--method sgm`
    /// the cost window of semi-global matching (odd, 1..=11; default 3, 5 with --accurate or
    /// --fill; OpenCV SGBM's blockSize). Semi-global matching's sums are 16-bit: a window whose
    /// largest aggregated cost could exceed them (with the default cost and penalties, above 9
    /// with 3 paths, 7 with 5, 5 with 8) is refused, saying what to change.
    #[arg(long)]
    block: Option<usize>,
    /// Number of disparities searched.
    #[arg(long, default_value_t = 64)]
    disparities: usize,
    /// Smallest disparity searched.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    min_disparity: i32,
    /// Prefilter: xsobel (cap 31), norm (9x9, cap 31), rank (9x9 rank transform; rank:N for
    /// N x N) or none (default xsobel).
    #[arg(long)]
    prefilter: Option<String>,
    /// Uniqueness ratio in percent (default: the crate's default).
    #[arg(long)]
    uniqueness: Option<u32>,
    /// Texture threshold (default: the crate's default).
    #[arg(long)]
    texture: Option<u32>,
    /// Left–right tolerance in px; negative disables the check (default: the preset's: 1 px, 2 px
    /// for `--method sgm` without `--accurate`).
    #[arg(long, allow_hyphen_values = true)]
    lr_max_diff: Option<i32>,
    /// Speckle filter region size in px, 0 disables (default: the crate's default).
    #[arg(long)]
    speckle_window: Option<usize>,
    /// Reject pixels whose confidence (0..1: best against second-best non-adjacent cost, times
    /// the left–right agreement) is below this (default: the crate's default, off).
    #[arg(long)]
    min_confidence: Option<f32>,
    /// Also write the confidence map (confidence.pfm, 0 where invalid).
    #[arg(long)]
    confidence: bool,
    /// Fill left–right and confidence rejects from the background neighbour, with the dense
    /// benchmark preset (x-Sobel, uniqueness 0, no speckle filter; explicit options still
    /// apply): for benchmarks that count a missing pixel as bad. Filled pixels are guesses.
    #[arg(long)]
    fill: bool,
    /// Go on when the pair looks swapped (left and right exchanged); otherwise that is an error
    /// (exit code 2, nothing written). A sequence checks every frame: one swapped frame stops
    /// it (exit code 2, naming the frame, nothing written), or with this flag is matched with a
    /// warning naming it.
    #[arg(long)]
    allow_swapped: bool,
    /// Ground-truth disparity (PFM, or PNG of disparity x --gt-scale with 0 = unknown). Adds
    /// the keys bad1, bad2 (missing = bad), bad2_returned (among the returned pixels) and
    /// density in percent of the evaluated pixels (the mask's with known truth), and
    /// bad2_overlap (missing = bad) and density_overlap in percent of those that lie in the
    /// columns where OpenCV's matchers also answer (x ≥ min_disparity + disparities, and with a
    /// negative min_disparity x < width + min_disparity; NaN when none does). The rejected_*
    /// keys and filled are always percentages of the image.
    #[arg(long)]
    gt: Option<PathBuf>,
    /// Ground-truth PNG value per pixel of disparity (Middlebury: info.txt).
    #[arg(long, default_value_t = 1.0)]
    gt_scale: f32,
    /// Evaluation mask (pixels > 128 are evaluated), e.g. Middlebury nonocc.png.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// A matcher configuration file (`tune`'s config.ron, RON or JSON): every matching option
    /// comes from it (and colour images are matched in colour when it says so); the range,
    /// --threads and the outputs stay this command's. The matching options are refused with it.
    #[arg(long, conflicts_with_all = [
        "method", "sgm_paths", "accurate", "colour", "sgm_cost", "lr_rule", "cost", "block", "prefilter",
        "uniqueness", "texture", "lr_max_diff", "speckle_window", "min_confidence", "fill",
    ])]
    config: Option<PathBuf>,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Timed runs after one warm-up run; the median is reported (at most 1000).
    #[arg(long, default_value_t = 5, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    runs: usize,
    /// Output directory (disparity.pfm, disparity16.png at 1/256 px when the range lies within
    /// 0..=255.996 px, disparity_colour.png).
    #[arg(long)]
    out: PathBuf,
    /// The rectification of the pair (`rectify`'s rectification file, any format, or OpenCV's
    /// `intrinsics.yml extrinsics.yml`; two files are read together): adds points.ply and the
    /// depth figures, through the file's own Q.
    #[arg(long, num_args = 1..=2)]
    calib: Vec<PathBuf>,
}

/// Warns of a swapped-looking pair; `Some(exit code 2)` when that refuses the run.
fn refuse_swapped(swap: &SwapCheck, allow: bool) -> Option<ExitCode> {
    if !swap.looks_swapped {
        return None;
    }
    eprintln!("{}", disparity::swap_warning(swap, None));
    if allow {
        return None;
    }
    eprintln!("error: refusing a swapped-looking pair; exchange --left and --right, or pass --allow-swapped");
    Some(ExitCode::from(2))
}

/// `disparity` over an image sequence: decode, check, match and write overlapped
/// (`parallax_composition::disparity::run_sequence`: every frame is checked for a swapped or
/// doubled pair, and a refused frame leaves nothing written), a progress bar, and the
/// throughput.
fn run_sequence(
    args: &Args,
    matcher: BlockMatcher,
    lefts: Vec<PathBuf>,
    rights: Vec<PathBuf>,
) -> anyhow::Result<ExitCode> {
    // options of a single pair are refused, not ignored
    let single = [
        ("--gt", args.gt.is_some()),
        ("--mask", args.mask.is_some()),
        ("--confidence", args.confidence),
        ("--calib", !args.calib.is_empty()),
    ];
    if let Some((name, _)) = single.iter().find(|(_, given)| *given) {
        anyhow::bail!(
            "{name} applies to a single pair, not to an image sequence: give --left and --right as single images"
        );
    }
    // where every frame goes is checked before any is decoded
    let (min, n) = (matcher.config().min_disparity, matcher.config().num_disparities);
    let png = disparity::png16_holds(min, n);
    disparity::sequence_outputs(&lefts, &rights, &args.out, png)?;
    if !png {
        eprintln!("{}", disparity::png16_warning("<name>.png", min, n));
    }
    // a bar on a terminal; plain lines every few seconds otherwise (a pipe, a log file)
    let progress = crate::progress::Progress::new("disparity", lefts.len() as u64, "frames")?;
    let options =
        disparity::SequenceOptions { prefetch: args.prefetch, allow_swapped: args.allow_swapped, colour: args.colour };
    let s = disparity::run_sequence(matcher, lefts, rights, &args.out, options, |e| {
        match e {
            FrameEvent::Swapped { name, check, .. } => {
                // heard before the frame's own event: not a frame of the bar
                progress.println(disparity::swap_warning(check, Some(name)));
                return;
            }
            FrameEvent::Matched { name, density, warnings } => {
                if *density < 0.5 {
                    progress.println(format!(
                        "warning: {name}: most of the map was rejected ({:.1} % returned)",
                        100.0 * density
                    ));
                }
                for w in warnings {
                    progress.println(format!("warning: {name}: {w}"));
                }
            }
            FrameEvent::Failed { index, error } => progress.println(format!("error: frame {index}: {error}")),
        }
        progress.inc();
    });
    progress.finish();
    let s = match s {
        Err(e @ parallax_composition::PipelineError::SwappedFrame { .. }) => {
            // as a single pair: refused with exit code 2 before anything is written
            eprintln!("error: {e}");
            eprintln!(
                "error: refusing a sequence with a swapped-looking pair; exchange its left and right images, or pass --allow-swapped"
            );
            return Ok(ExitCode::from(2));
        }
        s => s?,
    };
    let files = if png { "<name>.pfm, <name>.png at 1/256 px" } else { "<name>.pfm" };
    println!("wrote {} maps to {} ({files})", s.frames, args.out.display());
    println!("frames: {}", s.frames);
    println!("failed: {}", s.failed);
    println!("density: {:.2}", s.density_pct);
    println!("seconds: {:.3}", s.seconds);
    println!("fps: {:.2}", (s.frames + s.failed) as f64 / s.seconds);
    Ok(if s.failed > 0 { ExitCode::FAILURE } else { ExitCode::SUCCESS })
}

pub fn run(mut args: Args) -> anyhow::Result<ExitCode> {
    let file = args.config.as_deref().map(DisparityConfig::read).transpose()?;
    // colour files are matched in colour when the configuration says so; grey ones in grey
    let colour_input = match &file {
        Some(f) => f.colour() && disparity::stored_in_colour(&args.left)?,
        None => args.colour,
    };
    args.colour = colour_input;
    let cfg = match &file {
        Some(f) => MatcherConfig {
            confidence_map: args.confidence,
            ..f.matcher_for(colour_input, (args.min_disparity, args.disparities), args.threads)
        },
        None => matcher_options(&args).config()?,
    };
    let sgm = cfg.method == parallax_block_matching::Method::Sgm;
    run_with(args, cfg, sgm)
}

/// The matcher options of the command line.
fn matcher_options(args: &Args) -> disparity::MatcherOptions {
    disparity::MatcherOptions {
        method: args.method.clone(),
        cost: args.cost.clone(),
        block: args.block,
        disparities: args.disparities,
        min_disparity: args.min_disparity,
        prefilter: args.prefilter.clone(),
        uniqueness: args.uniqueness,
        texture: args.texture,
        lr_max_diff: args.lr_max_diff,
        speckle_window: args.speckle_window,
        min_confidence: args.min_confidence,
        confidence: args.confidence,
        fill: args.fill,
        accurate: args.accurate,
        colour: args.colour,
        sgm_cost: args.sgm_cost.clone(),
        sgm_paths: args.sgm_paths,
        lr_rule: args.lr_rule.clone(),
        threads: args.threads,
    }
}

fn run_with(args: Args, cfg: MatcherConfig, sgm: bool) -> anyhow::Result<ExitCode> {
    let mut matcher = BlockMatcher::new(cfg.clone()).context("block-matching configuration")?;
    let outputs = ["disparity.pfm", "disparity16.png", "disparity_colour.png", "confidence.pfm", "points.ply"]
        .map(|n| args.out.join(n));
    let inputs: Vec<&PathBuf> = [&args.left, &args.right]
        .into_iter()
        .chain(&args.config)
        .chain(&args.gt)
        .chain(&args.mask)
        .chain(&args.calib)
        .collect();
    parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    if let Some((lefts, rights)) = disparity::image_sequence(&args.left, &args.right, args.pair_by_order)? {
        return run_sequence(&args, matcher, lefts, rights);
    }
    let pair = disparity::load_pair(&args.left, &args.right, args.colour)?;
    pair.refuse_identical(&args.left, &args.right)?;
    // Ground truth and mask are checked against the pair before anything is computed or written.
    let size = pair.dimensions();
    let truth = args.gt.as_deref().map(|p| disparity::load_truth(p, args.gt_scale, size)).transpose()?;
    let mask = args.mask.as_deref().map(|p| disparity::load_mask(p, size)).transpose()?;
    let stereo = if args.calib.is_empty() {
        None
    } else {
        // a file without an image size (OpenCV's `stereo_calib.cpp` writes none) is for images of
        // the rectified pair's size, OpenCV's default `newImageSize`; the depth uses only its Q
        Some(
            crate::files::read_calibration(&args.calib, Some(size))?
                .into_stereo(&args.calib[0].display().to_string())?,
        )
    };
    // images `rectify` wrote carry the rectification they went through: another is refused
    if let Some(m) = stereo.as_ref().and_then(|s| s.rectification) {
        for (side, path) in [("left", &args.left), ("right", &args.right)] {
            let Some(stamp) = parallax_composition::images::read_stamp(path)? else { continue };
            anyhow::ensure!(
                stamp.side == side || args.allow_swapped,
                "{} is the {} image of a rectified pair (recorded in it by `rectify`), given as --{side}",
                path.display(),
                stamp.side
            );
            stamp.check(&m, size, path, &args.calib[0].display().to_string())?;
        }
    }
    // a swapped pair gives a confident-looking wrong map: refuse it unless told otherwise
    if let Some(code) = refuse_swapped(&pair.check_swap(&matcher)?, args.allow_swapped) {
        return Ok(code);
    }
    let (map, seconds) = disparity::match_timed(&mut matcher, &pair, args.runs)?;
    let stats = matcher.last_stats();
    let mdes = (map.width() * map.height() * cfg.num_disparities) as f64 / seconds / 1e6;
    let (min, n) = (cfg.min_disparity, cfg.num_disparities);
    // every output is computed first and written as one set at the end
    let mut files = OutputSet::new();
    // a file of an earlier run into this folder that this run does not write goes
    for stale in &outputs {
        files.supersede(stale);
    }
    let png = disparity::add_maps(&mut files, &args.out, &map, (min, n))?;
    disparity::add_confidence(&mut files, &args.out, &matcher, &map)?;
    let evaluation = truth
        .as_ref()
        .map(|t| parallax_block_matching::evaluate(&map, t, mask.as_deref(), &[1.0, 2.0]))
        .transpose()
        .context("evaluating against the ground truth")?;
    // where OpenCV's matchers also answer; none of the mask may lie there (a range as wide as
    // the image): its keys are then NaN, never 0
    let overlap = match &truth {
        Some(t) => match parallax_block_matching::evaluate_overlap(&map, t, mask.as_deref(), (min, n), &[2.0]) {
            Ok(e) => Some(e),
            Err(parallax_block_matching::BlockMatchingError::NothingToEvaluate(_)) => None,
            Err(e) => return Err(anyhow::Error::new(e).context("evaluating against the ground truth")),
        },
        None => None,
    };
    let depth = stereo
        .map(|s| disparity::depth_from_rectification(&s, &map, &args.calib[0].display().to_string()))
        .transpose()?;
    let ply = args.out.join("points.ply");
    if let Some(d) = &depth {
        files.add(
            &ply,
            parallax_triangulation::ply_bytes(&d.cloud, parallax_triangulation::PlyFormat::BinaryLittleEndian)?,
        )?;
    }
    files.commit()?;
    println!(
        "{}x{} {:?} cost {:?} block {}{} disparities [{}, {}) simd {:?}, median of {} runs",
        map.width(),
        map.height(),
        cfg.method,
        cfg.cost,
        if sgm { cfg.sgm.block } else { cfg.block_size },
        if sgm {
            let g = &cfg.sgm;
            let cost = match (g.sampling_insensitive, g.intensity_cost) {
                (false, false) => "sad",
                (true, false) => "bt",
                (false, true) => "sad+intensity",
                (true, true) => "bt+intensity",
            };
            let paths = match g.paths {
                SgmPaths::Three => 3,
                SgmPaths::Five => 5,
                SgmPaths::Eight => 8,
            };
            format!(
                " paths {paths} pixel cost {cost}{}{}",
                if args.colour { " over 3 channels" } else { "" },
                match (cfg.lr_subpixel, cfg.lr_winners) {
                    (_, true) => " lr-rule sgbm",
                    (true, false) => " lr-rule subpixel",
                    (false, false) => "",
                }
            )
        } else if args.colour {
            " cost over 3 channels".to_string()
        } else {
            String::new()
        },
        cfg.min_disparity,
        cfg.min_disparity + cfg.num_disparities as i32,
        matcher.simd(),
        args.runs
    );
    println!("{}", summary::match_stats(&stats));
    if stats.density < 0.5 {
        eprintln!(
            "warning: most of the map was rejected ({:.1} % returned): check the disparity range, the image \
             order and the texture",
            100.0 * stats.density
        );
    }
    for w in disparity::range_warnings(&map, min, n) {
        eprintln!("warning: {w}");
    }
    if !png {
        eprintln!("{}", disparity::png16_warning("disparity16.png", min, n));
    }
    let png = if png { " disparity16.png," } else { "" };
    println!("wrote {}/disparity.pfm,{png} disparity_colour.png", args.out.display());
    println!("{}", summary::disparity_keys(&stats, evaluation.as_ref(), overlap.as_ref(), seconds, mdes));
    if let Some(depth) = depth {
        println!("wrote {} (points through the calibration file's Q)", ply.display());
        println!("points: {}", depth.cloud.len());
        println!("depth_min: {:.6}", depth.min);
        println!("depth_median: {:.6}", depth.median);
        println!("depth_max: {:.6}", depth.max);
    }
    Ok(ExitCode::SUCCESS)
}
