//! `cargo xtask disparity`: dense disparity of a rectified pair with the block-matching crate,
//! optional evaluation against a ground truth (Middlebury style, both conventions), rejection
//! counts by reason, a swapped-pair check, timing in Mde/s.
//!
//! Output contract (one `key: value` per line, scripts read it): `bad1`, `bad2` (missing =
//! bad), `bad2_returned`, `density` (with `--gt`; over the mask), `rejected_texture`,
//! `rejected_uniqueness`, `rejected_lr`, `rejected_confidence`, `rejected_speckle`, `filled`
//! (percent of the image), `seconds`, `mdes`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use parallax_block_matching::{BlockMatcher, CostFunction, Gray16Image, MatcherConfig, Prefilter, SgmConfig, SgmPaths};
use parallax_camera_model::DisparityMap;

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
    /// Sequences: pairs decoded ahead of the matcher (default 2).
    #[arg(long, default_value_t = 2)]
    prefetch: usize,
    /// Method: bm (block matching) or sgm (semi-global matching, SAD on the prefilter with a
    /// 5x5 window; see --sgm-paths).
    #[arg(long, default_value = "bm")]
    method: String,
    /// Semi-global matching paths: 5 (one pass, default) or 8.
    #[arg(long, default_value_t = 5)]
    sgm_paths: u32,
    /// Matching cost: sad, ssd or ncc.
    #[arg(long, default_value = "sad")]
    cost: String,
    /// Window side in pixels (odd, 3..=31).
    #[arg(long, default_value_t = 9)]
    block: usize,
    /// Number of disparities searched.
    #[arg(long, default_value_t = 64)]
    disparities: usize,
    /// Smallest disparity searched.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    min_disparity: i32,
    /// Prefilter: xsobel (cap 31), norm (9x9, cap 31), rank (9x9 rank transform; rank:N for
    /// N x N) or none (default: the crate's default, rank; xsobel with --fill).
    #[arg(long)]
    prefilter: Option<String>,
    /// Uniqueness ratio in percent (default: the crate's default).
    #[arg(long)]
    uniqueness: Option<u32>,
    /// Texture threshold (default: the crate's default).
    #[arg(long)]
    texture: Option<u32>,
    /// Left–right tolerance in px; negative disables the check (default: the crate's default).
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
    /// (exit code 2).
    #[arg(long)]
    allow_swapped: bool,
    /// Ground-truth disparity (PFM, or PNG of disparity x --gt-scale with 0 = unknown).
    #[arg(long)]
    gt: Option<PathBuf>,
    /// Ground-truth PNG value per pixel of disparity (Middlebury: info.txt).
    #[arg(long, default_value_t = 1.0)]
    gt_scale: f32,
    /// Evaluation mask (pixels > 128 are evaluated), e.g. Middlebury nonocc.png.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Timed runs after one warm-up run; the median is reported.
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Output directory (disparity.pfm, disparity16.png at 1/256 px, disparity_colour.png).
    #[arg(long)]
    out: PathBuf,
    /// The rectification of the pair (`rectify`'s rectification file, any format; two files are
    /// read together): adds points.ply and the depth figures.
    #[arg(long, num_args = 1..=2)]
    calib: Vec<PathBuf>,
}

enum Pair {
    U8(image::GrayImage, image::GrayImage),
    U16(Gray16Image, Gray16Image),
}

fn is_16_bit(path: &Path) -> anyhow::Result<bool> {
    let img = image::open(path).with_context(|| format!("reading image {}", path.display()))?;
    Ok(img.color().bytes_per_pixel() / img.color().channel_count() > 1)
}

fn load_pair(left: &Path, right: &Path) -> anyhow::Result<Pair> {
    if is_16_bit(left)? || is_16_bit(right)? {
        let l = image::open(left).with_context(|| format!("reading image {}", left.display()))?.into_luma16();
        let r = image::open(right).with_context(|| format!("reading image {}", right.display()))?.into_luma16();
        Ok(Pair::U16(l, r))
    } else {
        Ok(Pair::U8(parallax_composition::io::load_gray(left)?, parallax_composition::io::load_gray(right)?))
    }
}

fn load_truth(path: &Path, scale: f32) -> anyhow::Result<DisparityMap> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pfm")) {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        return Ok(parallax_block_matching::from_pfm(&bytes, &path.display().to_string())?);
    }
    let img = image::open(path).with_context(|| format!("reading ground truth {}", path.display()))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let values: Vec<u16> = if img.color().bytes_per_pixel() / img.color().channel_count() > 1 {
        img.into_luma16().into_raw()
    } else {
        img.into_luma8().into_raw().into_iter().map(u16::from).collect()
    };
    parallax_block_matching::from_scaled(&values, w, h, scale)
        .with_context(|| format!("ground truth {}", path.display()))
}

impl parallax_block_matching::StereoPair for Pair {
    fn match_into(&self, m: &mut BlockMatcher, out: &mut DisparityMap) -> parallax_block_matching::Result<()> {
        match self {
            Pair::U8(l, r) => m.compute_into(l, r, out),
            Pair::U16(l, r) => m.compute_u16_into(l, r, out),
        }
    }
}

/// The paired left and right files when `--left` / `--right` name folders or glob patterns
/// (`None`: a single pair).
fn sequence(left: &Path, right: &Path) -> anyhow::Result<Option<(Vec<PathBuf>, Vec<PathBuf>)>> {
    let is_pattern = |p: &Path| p.to_string_lossy().contains(['*', '?', '[']);
    let list = |p: &Path| -> anyhow::Result<Vec<PathBuf>> {
        if p.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("listing {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.is_file()
                        && f.extension().is_some_and(|e| {
                            ["png", "jpg", "jpeg", "pgm", "ppm", "pnm"]
                                .contains(&e.to_ascii_lowercase().to_str().unwrap_or(""))
                        })
                })
                .collect();
            v.sort();
            anyhow::ensure!(!v.is_empty(), "no image in folder {}", p.display());
            Ok(v)
        } else {
            Ok(parallax_composition::io::expand_glob(&p.to_string_lossy())?)
        }
    };
    let (ls, rs) = (left.is_dir() || is_pattern(left), right.is_dir() || is_pattern(right));
    if !ls && !rs {
        return Ok(None);
    }
    anyhow::ensure!(ls && rs, "--left and --right must both be single images or both folders / glob patterns");
    let (l, r) = (list(left)?, list(right)?);
    anyhow::ensure!(
        l.len() == r.len(),
        "{} left images but {} right images: the sequences must pair up one to one",
        l.len(),
        r.len()
    );
    Ok(Some((l, r)))
}

/// `disparity` over an image sequence: decode (prefetch thread), match (this thread) and write
/// (writer thread) overlapped, a progress bar, and the throughput.
fn run_sequence(
    args: &Args,
    matcher: BlockMatcher,
    lefts: Vec<PathBuf>,
    rights: Vec<PathBuf>,
) -> anyhow::Result<ExitCode> {
    let n = lefts.len();
    // the first pair decides whether the sequence looks swapped
    let first = load_pair(&lefts[0], &rights[0])?;
    let swap = match &first {
        Pair::U8(l, r) => matcher.check_swap(l, r)?,
        Pair::U16(l, r) => matcher.check_swap_u16(l, r)?,
    };
    if swap.looks_swapped {
        eprintln!(
            "warning: the pairs look swapped (left and right exchanged): {:.1} % of the pixels pass the checks as \
             given, {:.1} % with the images exchanged (first pair, half resolution)",
            100.0 * swap.forward_density,
            100.0 * swap.reverse_density
        );
        if !args.allow_swapped {
            eprintln!("error: refusing swapped-looking pairs; exchange --left and --right, or pass --allow-swapped");
            return Ok(ExitCode::from(2));
        }
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let names: Vec<String> = lefts
        .iter()
        .map(|p| p.file_stem().map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned()))
        .collect();
    let source = lefts.into_iter().zip(rights).map(|(l, r)| load_pair(&l, &r).map_err(|e| format!("{e:#}")));
    let bar = indicatif::ProgressBar::new(n as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames {per_sec} eta {eta} {msg}")
            .context("progress bar template")?,
    );
    // the writer thread: PFM and 16-bit PNG (1/256 px) per frame, atomically
    let (tx, rx) = std::sync::mpsc::sync_channel::<(String, DisparityMap)>(2);
    let out_dir = args.out.clone();
    let writer = std::thread::spawn(move || -> anyhow::Result<()> {
        for (name, map) in rx {
            parallax_composition::io::write_atomic(
                &out_dir.join(format!("{name}.pfm")),
                &parallax_block_matching::to_pfm(&map),
            )?;
            parallax_composition::io::save_png(
                &out_dir.join(format!("{name}.png")),
                &parallax_block_matching::to_png16(&map, 256.0),
            )?;
        }
        Ok(())
    });
    let t0 = Instant::now();
    let (mut failed, mut density, mut done) = (0usize, 0.0f64, 0usize);
    for frame in matcher.frames(source, args.prefetch) {
        match frame {
            Ok(f) => {
                density += f.stats.density;
                done += 1;
                if f.stats.density < 0.5 {
                    bar.println(format!(
                        "warning: {}: most of the map was rejected ({:.1} % returned)",
                        names[f.index],
                        100.0 * f.stats.density
                    ));
                }
                if tx.send((names[f.index].clone(), f.disparity)).is_err() {
                    break; // the writer failed: its error is reported below
                }
            }
            Err(e) => {
                failed += 1;
                bar.println(format!("error: frame {}: {e}", done + failed - 1));
            }
        }
        bar.inc(1);
    }
    drop(tx);
    let written = writer.join().map_err(|_| anyhow::anyhow!("the writer thread panicked"))?;
    let seconds = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    written.context("writing the disparity maps")?;
    println!("wrote {done} maps to {} (<name>.pfm, <name>.png at 1/256 px)", args.out.display());
    println!("frames: {done}");
    println!("failed: {failed}");
    println!("density: {:.2}", if done > 0 { 100.0 * density / done as f64 } else { 0.0 });
    println!("seconds: {seconds:.3}");
    println!("fps: {:.2}", (done + failed) as f64 / seconds);
    Ok(if failed > 0 { ExitCode::FAILURE } else { ExitCode::SUCCESS })
}

fn parse_prefilter(p: &str) -> anyhow::Result<Prefilter> {
    Ok(match p {
        p if p.starts_with("rank:") => {
            let size = p["rank:".len()..]
                .parse()
                .map_err(|_| anyhow::anyhow!("--prefilter rank:N needs an odd N in 3..=15 (got {p:?})"))?;
            Prefilter::Rank { size }
        }
        "xsobel" => Prefilter::XSobel { cap: 31 },
        "norm" => Prefilter::NormalizedResponse { size: 9, cap: 31 },
        "rank" => Prefilter::Rank { size: 9 },
        "none" => Prefilter::None,
        other => anyhow::bail!("--prefilter must be xsobel, norm, rank, rank:N or none (got {other:?})"),
    })
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let cost = match args.cost.to_ascii_lowercase().as_str() {
        "sad" => CostFunction::Sad,
        "ssd" => CostFunction::Ssd,
        "ncc" => CostFunction::Ncc,
        other => anyhow::bail!("--cost must be sad, ssd or ncc (got {other:?})"),
    };
    let sgm = match args.method.to_ascii_lowercase().as_str() {
        "bm" => false,
        "sgm" => true,
        other => anyhow::bail!("--method must be bm or sgm (got {other:?})"),
    };
    let d = match (sgm, args.fill) {
        (false, false) => MatcherConfig::default(),
        (false, true) => MatcherConfig::dense(),
        (true, false) => MatcherConfig::sgm(),
        (true, true) => MatcherConfig::sgm_dense(),
    };
    let paths = match args.sgm_paths {
        5 => SgmPaths::Five,
        8 => SgmPaths::Eight,
        n => anyhow::bail!("--sgm-paths must be 5 or 8 (got {n})"),
    };
    let prefilter = match args.prefilter.as_deref().map(str::to_ascii_lowercase) {
        None => d.prefilter,
        Some(p) => parse_prefilter(&p)?,
    };
    anyhow::ensure!(args.runs >= 1, "--runs must be at least 1");
    let cfg = MatcherConfig {
        cost,
        block_size: args.block,
        min_disparity: args.min_disparity,
        num_disparities: args.disparities,
        prefilter,
        uniqueness_ratio: args.uniqueness.unwrap_or(d.uniqueness_ratio),
        texture_threshold: args.texture.unwrap_or(d.texture_threshold),
        lr_max_diff: match args.lr_max_diff {
            Some(v) if v < 0 => None,
            Some(v) => Some(v as u32),
            None => d.lr_max_diff,
        },
        speckle_window_size: args.speckle_window.unwrap_or(d.speckle_window_size),
        min_confidence: args.min_confidence.unwrap_or(d.min_confidence),
        confidence_map: args.confidence,
        fill: args.fill,
        threads: args.threads,
        sgm: SgmConfig { paths, ..d.sgm },
        ..d
    };
    let mut matcher = BlockMatcher::new(cfg.clone()).context("block-matching configuration")?;
    let outputs = ["disparity.pfm", "disparity16.png", "disparity_colour.png", "confidence.pfm", "points.ply"]
        .map(|n| args.out.join(n));
    let inputs: Vec<&PathBuf> =
        [&args.left, &args.right].into_iter().chain(&args.gt).chain(&args.mask).chain(&args.calib).collect();
    parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    if let Some((lefts, rights)) = sequence(&args.left, &args.right)? {
        return run_sequence(&args, matcher, lefts, rights);
    }
    let pair = load_pair(&args.left, &args.right)?;
    let truth = args.gt.as_deref().map(|p| load_truth(p, args.gt_scale)).transpose()?;
    // Ground truth and mask are checked against the pair before anything is computed or written.
    let (w, h) = match &pair {
        Pair::U8(l, _) => l.dimensions(),
        Pair::U16(l, _) => l.dimensions(),
    };
    if let (Some(t), Some(p)) = (&truth, &args.gt) {
        anyhow::ensure!(
            (t.width(), t.height()) == (w as usize, h as usize),
            "ground truth {} is {}x{} but the images are {w}x{h}: give the ground truth of this pair",
            p.display(),
            t.width(),
            t.height()
        );
    }
    let mask = match &args.mask {
        Some(p) => {
            let m = parallax_composition::io::load_gray(p)?;
            anyhow::ensure!(
                m.dimensions() == (w, h),
                "mask {} is {}x{} but the images are {w}x{h}: give the mask of this pair",
                p.display(),
                m.width(),
                m.height()
            );
            Some(m.into_raw().into_iter().map(|v| v > 128).collect::<Vec<bool>>())
        }
        None => None,
    };
    // a swapped pair gives a confident-looking wrong map: refuse it unless told otherwise
    let swap = match &pair {
        Pair::U8(l, r) => matcher.check_swap(l, r)?,
        Pair::U16(l, r) => matcher.check_swap_u16(l, r)?,
    };
    if swap.looks_swapped {
        eprintln!(
            "warning: the pair looks swapped (left and right exchanged): {:.1} % of the pixels pass the checks \
             as given, {:.1} % with the images exchanged (half resolution)",
            100.0 * swap.forward_density,
            100.0 * swap.reverse_density
        );
        if !args.allow_swapped {
            eprintln!("error: refusing a swapped-looking pair; exchange --left and --right, or pass --allow-swapped");
            return Ok(ExitCode::from(2));
        }
    }
    // the output map is reused across runs, as a video loop would
    let mut map = DisparityMap::new_invalid(0, 0);
    let mut compute = |map: &mut DisparityMap| -> anyhow::Result<()> {
        match &pair {
            Pair::U8(l, r) => matcher.compute_into(l, r, map)?,
            Pair::U16(l, r) => matcher.compute_u16_into(l, r, map)?,
        }
        Ok(())
    };
    compute(&mut map)?; // warm-up (buffers, thread pool, caches)
    let mut times = Vec::with_capacity(args.runs);
    for _ in 0..args.runs {
        let t = Instant::now();
        compute(&mut map)?;
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    let seconds = times[times.len() / 2];
    let stats = matcher.last_stats();
    let mdes = (map.width() * map.height() * cfg.num_disparities) as f64 / seconds / 1e6;

    parallax_composition::io::write_atomic(&args.out.join("disparity.pfm"), &parallax_block_matching::to_pfm(&map))?;
    parallax_composition::io::save_png(
        &args.out.join("disparity16.png"),
        &parallax_block_matching::to_png16(&map, 256.0),
    )?;
    let lo = cfg.min_disparity as f32;
    let range = (lo, lo + cfg.num_disparities as f32 - 1.0);
    parallax_composition::io::save_png(
        &args.out.join("disparity_colour.png"),
        &parallax_block_matching::false_colour(&map, Some(range)),
    )?;

    println!(
        "{}x{} {:?} cost {:?} block {} disparities [{}, {}) simd {:?}, median of {} runs",
        map.width(),
        map.height(),
        cfg.method,
        cfg.cost,
        cfg.block_size,
        cfg.min_disparity,
        cfg.min_disparity + cfg.num_disparities as i32,
        matcher.simd(),
        args.runs
    );
    if let Some(conf) = matcher.confidence() {
        let cmap = DisparityMap::from_data(map.width(), map.height(), conf.to_vec())
            .context("confidence map of the matcher's size")?;
        parallax_composition::io::write_atomic(
            &args.out.join("confidence.pfm"),
            &parallax_block_matching::to_pfm(&cmap),
        )?;
    }
    println!(
        "rejected: {} no candidate, {} low texture, {} not unique, {} left-right, {} low confidence, {} speckle; \
         {} filled; returned map density {:.2} %{}",
        stats.no_candidate,
        stats.low_texture,
        stats.not_unique,
        stats.lr_inconsistent,
        stats.low_confidence,
        stats.speckle,
        stats.filled,
        100.0 * stats.density,
        if stats.filled > 0 { " (filled pixels are guesses)" } else { "" }
    );
    if stats.density < 0.5 {
        eprintln!(
            "warning: most of the map was rejected ({:.1} % returned): check the disparity range, the image \
             order and the texture",
            100.0 * stats.density
        );
    }
    println!("wrote {}/disparity.pfm, disparity16.png, disparity_colour.png", args.out.display());
    if let Some(truth) = &truth {
        let e = parallax_block_matching::evaluate(&map, truth, mask.as_deref(), &[1.0, 2.0])
            .context("evaluating against the ground truth")?;
        println!("evaluated {} px, rms {:.3} px", e.evaluated, e.rms);
        println!("bad1: {:.2}", e.bad_at(1.0).unwrap_or(f64::NAN));
        println!("bad2: {:.2}", e.bad_at(2.0).unwrap_or(f64::NAN));
        println!("bad2_returned: {:.2}", e.bad_returned_at(2.0).unwrap_or(f64::NAN));
        println!("density: {:.2}", e.density);
    } else {
        println!("density: {:.2}", 100.0 * stats.density);
    }
    println!("rejected_texture: {:.2}", stats.percent(stats.low_texture));
    println!("rejected_uniqueness: {:.2}", stats.percent(stats.not_unique));
    println!("rejected_lr: {:.2}", stats.percent(stats.lr_inconsistent));
    println!("rejected_confidence: {:.2}", stats.percent(stats.low_confidence));
    println!("rejected_speckle: {:.2}", stats.percent(stats.speckle));
    println!("filled: {:.2}", stats.percent(stats.filled));
    println!("seconds: {seconds:.6}");
    println!("mdes: {mdes:.0}");
    if !args.calib.is_empty() {
        crate::files::disparity_depth(&args.calib, &map, &args.out)?;
    }
    Ok(ExitCode::SUCCESS)
}
