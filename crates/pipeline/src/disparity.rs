//! Disparity on files: a rectified pair loaded at its bit depth ([`StereoImages`]), ground truth
//! and evaluation masks, image sequences (folders or glob patterns) matched in a batch with
//! decoding, matching and writing overlapped ([`run_sequence`]), the map's output files, and the
//! point cloud and depth figures through a rectification's `Q` ([`depth_from_rectification`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use parallax_block_matching::{
    BlockMatcher, CostFunction, Gray16Image, MatcherConfig, Prefilter, SgmConfig, SgmPaths, StereoPair, SwapCheck,
};
use parallax_camera_model::DisparityMap;

use crate::{PipelineError, Result};

/// A rectified pair at its bit depth.
#[derive(Debug, Clone)]
pub enum StereoImages {
    /// 8-bit grey (colour converted).
    U8(image::GrayImage, image::GrayImage),
    /// 16-bit grey.
    U16(Gray16Image, Gray16Image),
    /// 8-bit colour, matched by [`BlockMatcher::compute_rgb`] (semi-global matching and block
    /// matching sum their cost over the channels; the checks read the grey conversion).
    Rgb(image::RgbImage, image::RgbImage),
}

impl StereoPair for StereoImages {
    fn match_into(&self, m: &mut BlockMatcher, out: &mut DisparityMap) -> parallax_block_matching::Result<()> {
        match self {
            Self::U8(l, r) => m.compute_into(l, r, out),
            Self::U16(l, r) => m.compute_u16_into(l, r, out),
            Self::Rgb(l, r) => m.compute_rgb_into(l, r, out),
        }
    }
}

impl StereoImages {
    /// `(width, height)` of the left image.
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            Self::U8(l, _) => l.dimensions(),
            Self::U16(l, _) => l.dimensions(),
            Self::Rgb(l, _) => l.dimensions(),
        }
    }

    /// Whether both images hold the same pixels (the same file given twice: every disparity
    /// would be 0, a plausible map of a scene at infinity).
    pub fn identical(&self) -> bool {
        match self {
            Self::U8(l, r) => l == r,
            Self::U16(l, r) => l == r,
            Self::Rgb(l, r) => l == r,
        }
    }

    /// Refuses the same image given twice ([`StereoImages::identical`]), naming the files.
    pub fn refuse_identical(&self, left: &Path, right: &Path) -> Result<()> {
        if self.identical() {
            return Err(PipelineError::Input(identical_message(left, right)));
        }
        Ok(())
    }

    /// Whether the pair looks swapped to `matcher` (see [`BlockMatcher::check_swap`]; colour
    /// on its grey conversion).
    pub fn check_swap(&self, matcher: &BlockMatcher) -> Result<SwapCheck> {
        self.check_swap_with(&mut parallax_block_matching::SwapChecker::new(matcher)?)
    }

    /// The same check with a sequence's [`parallax_block_matching::SwapChecker`].
    fn check_swap_with(&self, checker: &mut parallax_block_matching::SwapChecker) -> Result<SwapCheck> {
        Ok(match self {
            Self::U8(l, r) => checker.check(l, r)?,
            Self::U16(l, r) => checker.check_u16(l, r)?,
            Self::Rgb(l, r) => checker.check(&grey(l), &grey(r))?,
        })
    }
}

/// The refusal of the same image given twice.
fn identical_message(left: &Path, right: &Path) -> String {
    format!(
        "{} and {} are the same image: nothing to match (every disparity would be 0)",
        left.display(),
        right.display()
    )
}

/// The grey conversion [`BlockMatcher::compute_rgb`] reads.
fn grey(img: &image::RgbImage) -> image::GrayImage {
    image::imageops::grayscale(img)
}

fn is_16_bit(img: &image::DynamicImage) -> bool {
    img.color().bytes_per_pixel() / img.color().channel_count() > 1
}

/// Loads a pair through [`crate::io::load_image`]'s checks: 16-bit grey when either image has
/// 16-bit channels, else 8-bit grey, or with `colour` 8-bit colour (refused for 16-bit images,
/// which are matched as grey only).
pub fn load_pair(left: &Path, right: &Path, colour: bool) -> Result<StereoImages> {
    let (l, r) = (crate::io::load_image(left)?, crate::io::load_image(right)?);
    Ok(if is_16_bit(&l) || is_16_bit(&r) {
        if colour {
            let which = if is_16_bit(&l) { left } else { right };
            return Err(PipelineError::Input(format!(
                "{} has 16-bit channels: colour matching reads 8-bit images (match it as grey, without the \
                 colour option)",
                which.display()
            )));
        }
        StereoImages::U16(l.into_luma16(), r.into_luma16())
    } else if colour {
        StereoImages::Rgb(l.into_rgb8(), r.into_rgb8())
    } else {
        StereoImages::U8(l.into_luma8(), r.into_luma8())
    })
}

/// The matcher's options by the names of `disparity`'s flags (the Python package's
/// `StereoMatcher` takes the same): a preset (`method`, `accurate`, `fill`) and what differs
/// from it. [`MatcherOptions::config`] gives the command's exact configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct MatcherOptions {
    /// `bm` or `sgm`.
    pub method: String,
    /// `sad`, `ssd` or `ncc`.
    pub cost: String,
    /// Window side (block matching's, or semi-global matching's cost window).
    pub block: Option<usize>,
    /// Disparities searched.
    pub disparities: usize,
    /// Smallest disparity searched.
    pub min_disparity: i32,
    /// `xsobel`, `norm`, `rank`, `rank:N` or `none`.
    pub prefilter: Option<String>,
    /// Uniqueness ratio, percent.
    pub uniqueness: Option<u32>,
    /// Texture threshold.
    pub texture: Option<u32>,
    /// Left–right tolerance, px; negative disables the check.
    pub lr_max_diff: Option<i32>,
    /// Speckle filter region size, px (0 disables).
    pub speckle_window: Option<usize>,
    /// Confidence threshold.
    pub min_confidence: Option<f32>,
    /// Keep the confidence map.
    pub confidence: bool,
    /// The dense benchmark preset.
    pub fill: bool,
    /// Semi-global matching's accurate preset.
    pub accurate: bool,
    /// Match colour pairs in colour.
    pub colour: bool,
    /// Semi-global matching's pixel difference: `sad`, `bt`, `sad+intensity`, `bt+intensity`.
    pub sgm_cost: Option<String>,
    /// Semi-global matching's paths: 3, 5 or 8.
    pub sgm_paths: Option<u32>,
    /// Left–right rule: `integer`, `subpixel` or `sgbm`.
    pub lr_rule: Option<String>,
    /// Worker threads (0: all cores).
    pub threads: usize,
}

impl Default for MatcherOptions {
    /// `disparity`'s defaults: block matching, SAD, 64 disparities from 0.
    fn default() -> Self {
        Self {
            method: "bm".into(),
            cost: "sad".into(),
            block: None,
            disparities: 64,
            min_disparity: 0,
            prefilter: None,
            uniqueness: None,
            texture: None,
            lr_max_diff: None,
            speckle_window: None,
            min_confidence: None,
            confidence: false,
            fill: false,
            accurate: false,
            colour: false,
            sgm_cost: None,
            sgm_paths: None,
            lr_rule: None,
            threads: 0,
        }
    }
}

impl MatcherOptions {
    /// The matcher configuration of these options, checked against each other (the options of
    /// one method refused with the other, two presets refused together).
    pub fn config(&self) -> Result<MatcherConfig> {
        let cost = match self.cost.to_ascii_lowercase().as_str() {
            "sad" => CostFunction::Sad,
            "ssd" => CostFunction::Ssd,
            "ncc" => CostFunction::Ncc,
            other => return Err(PipelineError::Input(format!("--cost must be sad, ssd or ncc (got {other:?})"))),
        };
        let sgm = match self.method.to_ascii_lowercase().as_str() {
            "bm" => false,
            "sgm" => true,
            other => return Err(PipelineError::Input(format!("--method must be bm or sgm (got {other:?})"))),
        };
        if !sgm && (self.accurate || self.sgm_cost.is_some() || self.sgm_paths.is_some()) {
            return Err(PipelineError::Input(
                "--accurate, --sgm-cost and --sgm-paths are options of --method sgm".to_string(),
            ));
        }
        if self.accurate && self.fill {
            return Err(PipelineError::Input(
                "--accurate (measurement: nothing filled) and --fill (the dense benchmark preset) are two presets: \
                 choose one"
                    .to_string(),
            ));
        }
        if self.colour && !sgm && cost == CostFunction::Ncc {
            return Err(PipelineError::Input(
                "--colour with --method bm sums --cost sad or ssd over the three channels: --cost ncc matches grey \
                 pairs only (drop --colour, or choose sad or ssd)"
                    .to_string(),
            ));
        }
        let d = match (sgm, self.fill, self.accurate) {
            (false, false, _) => MatcherConfig::default(),
            (false, true, _) => MatcherConfig::dense(),
            (true, false, false) => MatcherConfig::sgm(),
            (true, false, true) => MatcherConfig::sgm_accurate(),
            (true, true, _) => MatcherConfig::sgm_dense(),
        };
        let paths = match self.sgm_paths {
            None => d.sgm.paths,
            Some(3) => SgmPaths::Three,
            Some(5) => SgmPaths::Five,
            Some(8) => SgmPaths::Eight,
            Some(n) => return Err(PipelineError::Input(format!("--sgm-paths must be 3, 5 or 8 (got {n})"))),
        };
        let (sampling_insensitive, intensity_cost) = match self.sgm_cost.as_deref().map(str::to_ascii_lowercase) {
            None => (d.sgm.sampling_insensitive, d.sgm.intensity_cost),
            Some(c) => match c.as_str() {
                "sad" => (false, false),
                "bt" => (true, false),
                "sad+intensity" => (false, true),
                "bt+intensity" => (true, true),
                other => {
                    return Err(PipelineError::Input(format!(
                        "--sgm-cost must be sad, bt, sad+intensity or bt+intensity (got {other:?})"
                    )));
                }
            },
        };
        let (lr_subpixel, lr_winners) = match self.lr_rule.as_deref().map(str::to_ascii_lowercase) {
            None => (d.lr_subpixel, d.lr_winners),
            Some(r) => match r.as_str() {
                "integer" => (false, false),
                "subpixel" => (true, false),
                "sgbm" if sgm => (true, true),
                "sgbm" => {
                    return Err(PipelineError::Input(
                        "--lr-rule sgbm is semi-global matching's (with --method sgm)".to_string(),
                    ));
                }
                other => {
                    return Err(PipelineError::Input(format!(
                        "--lr-rule must be integer, subpixel or sgbm (got {other:?})"
                    )));
                }
            },
        };
        let prefilter = match self.prefilter.as_deref().map(str::to_ascii_lowercase) {
            None => d.prefilter,
            Some(p) => parse_prefilter(&p)?,
        };
        let cfg = MatcherConfig {
            cost,
            block_size: if sgm { d.block_size } else { self.block.unwrap_or(d.block_size) },
            min_disparity: self.min_disparity,
            num_disparities: self.disparities,
            prefilter,
            uniqueness_ratio: self.uniqueness.unwrap_or(d.uniqueness_ratio),
            texture_threshold: self.texture.unwrap_or(d.texture_threshold),
            lr_max_diff: match self.lr_max_diff {
                Some(v) if v < 0 => None,
                Some(v) => Some(v as u32),
                None => d.lr_max_diff,
            },
            lr_subpixel,
            lr_winners,
            speckle_window_size: self.speckle_window.unwrap_or(d.speckle_window_size),
            min_confidence: self.min_confidence.unwrap_or(d.min_confidence),
            confidence_map: self.confidence,
            fill: self.fill,
            threads: self.threads,
            sgm: SgmConfig {
                paths,
                block: if sgm { self.block.unwrap_or(d.sgm.block) } else { d.sgm.block },
                sampling_insensitive,
                intensity_cost,
                // a cost summed over three channels: the penalties of one, three times
                p1: if self.colour { 3 * d.sgm.p1 } else { d.sgm.p1 },
                p2: if self.colour { 3 * d.sgm.p2 } else { d.sgm.p2 },
                ..d.sgm
            },
            ..d
        };
        Ok(cfg)
    }
}

/// A prefilter by the command line's name: `xsobel`, `norm`, `rank`, `rank:N` or `none`.
pub fn parse_prefilter(p: &str) -> Result<Prefilter> {
    Ok(match p {
        p if p.starts_with("rank:") => {
            let size = p["rank:".len()..].parse().map_err(|_| {
                PipelineError::Input(format!("--prefilter rank:N needs an odd N in 3..=15 (got {p:?})"))
            })?;
            Prefilter::Rank { size }
        }
        "xsobel" => Prefilter::XSobel { cap: 31 },
        "norm" => Prefilter::NormalizedResponse { size: 9, cap: 31 },
        "rank" => Prefilter::Rank { size: 9 },
        "none" => Prefilter::None,
        other => {
            return Err(PipelineError::Input(format!(
                "--prefilter must be xsobel, norm, rank, rank:N or none (got {other:?})"
            )));
        }
    })
}

/// Whether an image file holds colour (three or more channels; an image sequence's folder or
/// pattern: its first file), read from its header.
pub fn stored_in_colour(path: &Path) -> Result<bool> {
    let first = if path.is_file() {
        path.to_path_buf()
    } else if path.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .map_err(|e| PipelineError::Input(format!("reading {}: {e}", path.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        files.into_iter().next().ok_or_else(|| PipelineError::Input(format!("{} holds no image", path.display())))?
    } else {
        crate::io::expand_glob(&path.display().to_string())?.remove(0)
    };
    let fail = |e: &dyn std::fmt::Display| PipelineError::Input(format!("reading {}: {e}", first.display()));
    let decoder = image::ImageReader::open(&first)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| fail(&e))?
        .into_decoder()
        .map_err(|e| fail(&e))?;
    let colour = image::ImageDecoder::color_type(&decoder).channel_count() >= 3;
    Ok(colour)
}

/// Loads a ground-truth disparity: PFM, or a PNG of disparity x `scale` with 0 = unknown
/// (Middlebury's `info.txt` gives the scale).
///
/// Refused, naming both sizes as `WxH`, when it is not `size` (the pair's `(width, height)`).
pub fn load_truth(path: &Path, scale: f32, size: (u32, u32)) -> Result<DisparityMap> {
    let truth = read_truth(path, scale)?;
    if (truth.width(), truth.height()) != (size.0 as usize, size.1 as usize) {
        return Err(PipelineError::Input(format!(
            "ground truth {} is {}x{} but the images are {}x{}: give the ground truth of this pair",
            path.display(),
            truth.width(),
            truth.height(),
            size.0,
            size.1
        )));
    }
    Ok(truth)
}

fn read_truth(path: &Path, scale: f32) -> Result<DisparityMap> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pfm")) {
        if scale != 1.0 {
            // it was ignored: the evaluation then used other disparities than the user meant
            return Err(PipelineError::Input(format!(
                "ground truth {}: a PFM holds disparities in pixels, a scale ({scale}) applies to PNG ground truth only",
                path.display()
            )));
        }
        // a PFM is 4 bytes a pixel plus its header: larger than the largest image, refused unread
        let bytes = parallax_interop::read_bounded(path, crate::io::MAX_IMAGE_BYTES)
            .map_err(|source| PipelineError::Io { what: "reading", path: path.to_path_buf(), source })?;
        return Ok(parallax_block_matching::from_pfm(&bytes, &path.display().to_string())?);
    }
    let img = crate::io::load_image(path)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let values: Vec<u16> = if is_16_bit(&img) {
        img.into_luma16().into_raw()
    } else {
        img.into_luma8().into_raw().into_iter().map(u16::from).collect()
    };
    parallax_block_matching::from_scaled(&values, w, h, scale)
        .map_err(|e| PipelineError::Input(format!("ground truth {}: {e}", path.display())))
}

/// Loads an evaluation mask: pixels above 128 are evaluated (Middlebury's `nonocc.png`).
///
/// Refused, naming both sizes as `WxH`, when it is not `size` (the pair's `(width, height)`).
pub fn load_mask(path: &Path, size: (u32, u32)) -> Result<Vec<bool>> {
    let m = crate::io::load_gray(path)?;
    if m.dimensions() != size {
        return Err(PipelineError::Input(format!(
            "mask {} is {}x{} but the images are {}x{}: give the mask of this pair",
            path.display(),
            m.width(),
            m.height(),
            size.0,
            size.1
        )));
    }
    Ok(m.into_raw().into_iter().map(|v| v > 128).collect())
}

const IMAGE_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "pgm", "ppm", "pnm"];

/// The images of a folder (by extension) or a glob pattern, in natural order (`2` before `10`)
/// either way, so that a folder and a pattern list the same frames in the same order.
fn list_images(p: &Path) -> Result<Vec<PathBuf>> {
    if !p.is_dir() {
        return crate::io::expand_glob(&p.to_string_lossy());
    }
    let entries =
        std::fs::read_dir(p).map_err(|source| PipelineError::Io { what: "listing", path: p.to_path_buf(), source })?;
    let mut v: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|f| {
            f.is_file()
                && f.extension()
                    .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().to_str().unwrap_or("")))
        })
        .collect();
    crate::io::natural_sort(&mut v);
    if v.is_empty() {
        return Err(PipelineError::Input(format!("no image in folder {}", p.display())));
    }
    Ok(v)
}

/// The paired left and right files when `left` / `right` name folders or glob patterns
/// (`None`: a single pair; an existing file is one image even when its name holds `*`, `?` or
/// `[`). Both must be sequences, of the same length, whose files correspond (see
/// [`check_correspondence`]) unless `by_order` pairs them by position alone.
pub fn image_sequence(left: &Path, right: &Path, by_order: bool) -> Result<Option<(Vec<PathBuf>, Vec<PathBuf>)>> {
    let is_pattern = |p: &Path| !p.is_file() && p.to_string_lossy().contains(['*', '?', '[']);
    let (ls, rs) = (left.is_dir() || is_pattern(left), right.is_dir() || is_pattern(right));
    if !ls && !rs {
        return Ok(None);
    }
    if !(ls && rs) {
        return Err(PipelineError::Input(
            "--left and --right must both be single images or both folders / glob patterns".into(),
        ));
    }
    let (l, r) = (list_images(left)?, list_images(right)?);
    if l.len() != r.len() {
        return Err(PipelineError::Input(format!(
            "{} left images but {} right images: the sequences must pair up one to one",
            l.len(),
            r.len()
        )));
    }
    if !by_order {
        check_correspondence(&l, &r)?;
    }
    Ok(Some((l, r)))
}

/// What varies from frame to frame in each path of a sequence: the path without the prefix and
/// suffix all of them share (`cam0/000012.png` … → `000012` …; `scene_a/im0.png` … → `scene_a`
/// …). One path alone shares everything with itself: nothing varies.
fn varying_parts(paths: &[PathBuf]) -> Vec<Vec<char>> {
    let all: Vec<Vec<char>> = paths.iter().map(|p| p.to_string_lossy().chars().collect()).collect();
    let Some(first) = all.first() else { return Vec::new() };
    let shortest = all.iter().map(Vec::len).min().unwrap_or(0);
    let pre = (0..shortest).take_while(|&i| all.iter().all(|v| v[i] == first[i])).count();
    // the suffix does not reach into the prefix (`a1b`, `a11b`: prefix `a1`, suffix `b`)
    let at_end = |v: &Vec<char>, i: usize| v[v.len() - 1 - i];
    let suf = (0..shortest - pre).take_while(|&i| all.iter().all(|v| at_end(v, i) == at_end(first, i))).count();
    all.iter().map(|v| v[pre..v.len() - suf].to_vec()).collect()
}

/// Refuses left and right sequences whose files do not correspond frame by frame: what varies
/// along the left paths (the frame number, timestamp or scene folder) must be what varies along
/// the right ones, pair by pair (`left/000012.png` with `right/000012.png`, `left12.png` with
/// `right12.png`, `a/im0.png` with `a/im1.png`). Paired by sorted position alone, a missing or
/// extra frame on one side would shift every later pair by one and each map would be wrong.
pub fn check_correspondence(lefts: &[PathBuf], rights: &[PathBuf]) -> Result<()> {
    let (vl, vr) = (varying_parts(lefts), varying_parts(rights));
    for (i, (a, b)) in vl.iter().zip(&vr).enumerate() {
        if a != b {
            return Err(PipelineError::Input(format!(
                "frame {i}: {} and {} do not correspond ({:?} against {:?}): name the left and right files by the \
                 same frame number, timestamp or folder, or pass --pair-by-order to pair them by sorted position",
                lefts[i].display(),
                rights[i].display(),
                a.iter().collect::<String>(),
                b.iter().collect::<String>()
            )));
        }
    }
    Ok(())
}

/// Whether a 16-bit PNG at 1/256 px (KITTI's encoding, 0 = invalid) holds every disparity of
/// the range `[min_disparity, min_disparity + num_disparities)`: it stores `0..=255.996` px,
/// no negative value (written anyway, a negative disparity would read back as 1/256 px and one
/// above 256 px as 255.996).
pub fn png16_holds(min_disparity: i32, num_disparities: usize) -> bool {
    min_disparity >= 0 && min_disparity as u64 + num_disparities as u64 <= 256
}

/// Share of the returned pixels (`0..=1`) a map holds at the end of its range and (when `min`
/// is not 0) at its start: a range that ends below the nearest objects puts their pixels on
/// its last disparity (those the checks do not reject), one that starts above the farthest on
/// its first. Measured with the ranges right (Middlebury tsukuba, venus, teddy; block
/// matching and SGM defaults): at most 0.13 % at the end; teddy with 24 or 32 disparities
/// (true up to ~55): 4.2–20.8 %, venus with 16 (true up to ~20): 4.7 %.
pub fn share_at_range_ends(map: &DisparityMap, min: i32, n: usize) -> (f64, f64) {
    let (lo, hi) = (min as f32, min as f32 + n as f32 - 1.0);
    let (mut valid, mut end, mut start) = (0usize, 0usize, 0usize);
    for &d in map.data().iter().filter(|d| d.is_finite()) {
        valid += 1;
        // a winner on the last or first candidate has no sub-pixel step (no neighbour beyond)
        end += (d > hi - 0.25) as usize;
        start += (min != 0 && d < lo + 0.25) as usize;
    }
    let share = |k: usize| if valid == 0 { 0.0 } else { k as f64 / valid as f64 };
    (share(end), share(start))
}

/// The warnings (without a `warning:` prefix) of [`share_at_range_ends`] above 1 % of the
/// returned pixels.
pub fn range_warnings(map: &DisparityMap, min: i32, n: usize) -> Vec<String> {
    let (end, start) = share_at_range_ends(map, min, n);
    let mut w = Vec::new();
    if end > 0.01 {
        w.push(format!(
            "{:.1} % of the returned pixels sit on the largest disparity searched ({}): the range may end \
             below the nearest objects (raise --disparities)",
            100.0 * end,
            min as i64 + n as i64 - 1
        ));
    }
    if start > 0.01 {
        w.push(format!(
            "{:.1} % of the returned pixels sit on the smallest disparity searched ({min}): the range may \
             start above the farthest objects (lower --min-disparity)",
            100.0 * start
        ));
    }
    w
}

/// The warning when [`png16_holds`] is false: which PNG is not written and why.
pub fn png16_warning(what: &str, min_disparity: i32, num_disparities: usize) -> String {
    format!(
        "warning: {what} not written: a 16-bit PNG at 1/256 px holds disparities 0 to 255.996 px, the range \
         searched is [{min_disparity}, {}); the PFM holds the map",
        min_disparity as i64 + num_disparities as i64
    )
}

/// Adds a single map's files in `dir` to `set`: `disparity.pfm`, `disparity16.png` (1/256 px,
/// only when [`png16_holds`] the range `[min, min + n)`) and `disparity_colour.png` (false
/// colour over the range). Returns whether `disparity16.png` is among them.
pub fn add_maps(set: &mut crate::io::OutputSet, dir: &Path, map: &DisparityMap, range: (i32, usize)) -> Result<bool> {
    let (min, n) = range;
    set.add(dir.join("disparity.pfm"), parallax_block_matching::to_pfm(map))?;
    let png = png16_holds(min, n);
    if png {
        set.add_png(dir.join("disparity16.png"), &parallax_block_matching::to_png16(map, 256.0))?;
    }
    let colours = (min as f32, min as f32 + n as f32 - 1.0);
    set.add_png(dir.join("disparity_colour.png"), &parallax_block_matching::false_colour(map, Some(colours)))?;
    Ok(png)
}

/// Matches a pair `runs` times after one warm-up run, reusing the output map as a video loop
/// would; returns the map and the median time in seconds.
pub fn match_timed(matcher: &mut BlockMatcher, pair: &StereoImages, runs: usize) -> Result<(DisparityMap, f64)> {
    if runs == 0 {
        return Err(PipelineError::Input("--runs must be at least 1".into()));
    }
    let mut map = DisparityMap::new_invalid(0, 0);
    pair.match_into(matcher, &mut map)?; // warm-up (buffers, thread pool, caches)
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let t = Instant::now();
        pair.match_into(matcher, &mut map)?;
        times.push(t.elapsed().as_secs_f64());
    }
    Ok((map, crate::stats::median(times)))
}

/// Adds the matcher's confidence map of its last frame as `confidence.pfm` in `dir` to `set`
/// (0 where invalid), when the configuration asks for one; returns whether it did.
pub fn add_confidence(
    set: &mut crate::io::OutputSet,
    dir: &Path,
    matcher: &BlockMatcher,
    map: &DisparityMap,
) -> Result<bool> {
    let Some(conf) = matcher.confidence() else { return Ok(false) };
    let cmap = DisparityMap::from_data(map.width(), map.height(), conf.to_vec())?;
    set.add(dir.join("confidence.pfm"), parallax_block_matching::to_pfm(&cmap))?;
    Ok(true)
}

/// The warning for a pair (or the frame `frame` of a sequence, named by its file stem) that
/// looks swapped: the share of pixels that pass the checks as given and exchanged.
pub fn swap_warning(swap: &SwapCheck, frame: Option<&str>) -> String {
    let what = frame.map_or_else(|| "the pair looks".to_string(), |name| format!("frame {name} looks"));
    format!(
        "warning: {what} swapped (left and right exchanged): {:.1} % of the pixels pass the checks as given, {:.1} % \
         with the images exchanged (half resolution)",
        100.0 * swap.forward_density,
        100.0 * swap.reverse_density
    )
}

/// What happened to one frame of a sequence (for progress reports).
#[derive(Debug, Clone, PartialEq)]
pub enum FrameEvent {
    /// A frame was matched: its file stem, the share of pixels returned (`0..=1`) and the
    /// [`range_warnings`] of its map.
    Matched {
        /// File stem of the left image.
        name: String,
        /// Share of the pixels with a disparity.
        density: f64,
        /// What [`range_warnings`] says of the map.
        warnings: Vec<String>,
    },
    /// A frame looks swapped and the run goes on (`allow_swapped`): its file stem, position and
    /// what the check found.
    Swapped {
        /// File stem of the left image.
        name: String,
        /// Position of the frame in the sequence.
        index: usize,
        /// What the check found.
        check: SwapCheck,
    },
    /// A frame could not be read or matched.
    Failed {
        /// Position of the frame in the sequence.
        index: usize,
        /// The error.
        error: String,
    },
}

/// The figures of a sequence run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SequenceSummary {
    /// Frames matched and written.
    pub frames: usize,
    /// Frames that failed.
    pub failed: usize,
    /// Mean density of the matched frames, percent (0 without any).
    pub density_pct: f64,
    /// Wall time of decoding, matching and writing, seconds.
    pub seconds: f64,
}

/// The files a sequence run writes into `out`: `<left stem>.pfm` and (`png`) `<left
/// stem>.png` per frame. Refuses two frames with the same stem (the second would replace the
/// first's maps) and any output that is one of the input images (`--out` on the input folder).
pub fn sequence_outputs(lefts: &[PathBuf], rights: &[PathBuf], out: &Path, png: bool) -> Result<Vec<PathBuf>> {
    let mut stems: Vec<(String, &Path)> = Vec::with_capacity(lefts.len());
    for l in lefts {
        let stem = l.file_stem().map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned());
        if let Some((_, first)) = stems.iter().find(|(s, _)| *s == stem) {
            return Err(PipelineError::Input(format!(
                "{} and {} would both be written as {stem}.pfm / {stem}.png: give left images distinct names",
                first.display(),
                l.display()
            )));
        }
        stems.push((stem, l));
    }
    let outputs: Vec<PathBuf> = stems
        .iter()
        .flat_map(|(s, _)| [Some(out.join(format!("{s}.pfm"))), png.then(|| out.join(format!("{s}.png")))])
        .flatten()
        .collect();
    let inputs: Vec<&PathBuf> = lefts.iter().chain(rights).collect();
    crate::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    Ok(outputs)
}

/// How [`run_sequence`] reads and checks the frames.
#[derive(Debug, Clone, Copy)]
pub struct SequenceOptions {
    /// Pairs decoded and checked ahead of the matching (at least 1).
    pub prefetch: usize,
    /// Match a frame that looks swapped, with a warning, instead of stopping.
    pub allow_swapped: bool,
    /// Read the frames as 8-bit colour ([`load_pair`]).
    pub colour: bool,
}

/// What the prefetch thread found of a frame before it was matched.
enum Verdict {
    /// Matched as given (read or not: a read error is the frame's).
    Match,
    /// Looks swapped: refused, or with `allow_swapped` matched with a warning.
    Swapped(SwapCheck),
    /// The same image twice (every disparity would be 0): refused.
    Identical,
}

/// Matches a sequence of pairs into `out` (`<left stem>.pfm` and, when [`png16_holds`] the
/// matcher's range, `.png` per frame, checked by [`sequence_outputs`] before anything runs):
/// decoding and the checks of each pair on a prefetch thread (`prefetch` pairs ahead), matching
/// on this thread, staging the files on a writer thread, all overlapped; the files are
/// committed together at the end as one [`crate::io::OutputSet`]. `on_frame` hears of every
/// frame in order. A frame that fails to read or match is counted and the run goes on.
///
/// Every frame is checked as a single pair is, before it is matched: one that looks swapped
/// ([`parallax_block_matching::SwapChecker`]) stops the run with
/// [`PipelineError::SwappedFrame`] unless `allow_swapped` (then it is matched and heard of as
/// [`FrameEvent::Swapped`]), and one whose two images are the same stops it with an error; a
/// stopped run, or a failed write, writes nothing. The check runs on the prefetch thread, beside
/// the matching of the frame before; it costs a fraction of matching the frame (two
/// half-resolution block matchings over half the range; `benches/RESULTS.md`).
pub fn run_sequence(
    matcher: BlockMatcher,
    lefts: Vec<PathBuf>,
    rights: Vec<PathBuf>,
    out: &Path,
    options: SequenceOptions,
    mut on_frame: impl FnMut(&FrameEvent),
) -> Result<SequenceSummary> {
    let SequenceOptions { prefetch, allow_swapped, colour } = options;
    let (min, n) = (matcher.config().min_disparity, matcher.config().num_disparities);
    let png = png16_holds(min, n);
    sequence_outputs(&lefts, &rights, out, png)?;
    let names: Vec<String> = lefts
        .iter()
        .map(|p| p.file_stem().map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned()))
        .collect();
    let paths: Vec<(PathBuf, PathBuf)> = lefts.iter().cloned().zip(rights.iter().cloned()).collect();
    // the prefetch thread reads each pair and checks it; its verdicts come in frame order, one
    // per frame, each sent before its frame
    let mut checker = parallax_block_matching::SwapChecker::new(&matcher)?;
    let (verdict_tx, verdicts) = std::sync::mpsc::channel::<Verdict>();
    let source = lefts.into_iter().zip(rights).map(move |(l, r)| {
        let pair = load_pair(&l, &r, colour).map_err(|e| e.to_string());
        let verdict = match &pair {
            Err(_) => Ok(Verdict::Match),
            Ok(p) if p.identical() => Ok(Verdict::Identical),
            Ok(p) => p
                .check_swap_with(&mut checker)
                .map(|c| if c.looks_swapped { Verdict::Swapped(c) } else { Verdict::Match }),
        };
        let (verdict, pair) = match verdict {
            Ok(Verdict::Match) => (Verdict::Match, pair),
            Ok(Verdict::Swapped(c)) if allow_swapped => (Verdict::Swapped(c), pair),
            // a refused frame is not matched
            Ok(v) => (v, Err("refused".into())),
            // the check fails where the matching would (a size mismatch): the frame's error
            Err(e) => (Verdict::Match, Err(e.to_string())),
        };
        let _ = verdict_tx.send(verdict);
        pair
    });
    // the writer thread stages each frame's PFM and 16-bit PNG (1/256 px) as it comes
    let (tx, rx) = std::sync::mpsc::sync_channel::<(String, DisparityMap)>(2);
    let out_dir = out.to_path_buf();
    let writer = std::thread::spawn(move || -> Result<crate::io::OutputSet> {
        let mut set = crate::io::OutputSet::new();
        for (name, map) in rx {
            set.add(out_dir.join(format!("{name}.pfm")), parallax_block_matching::to_pfm(&map))?;
            if png {
                set.add_png(out_dir.join(format!("{name}.png")), &parallax_block_matching::to_png16(&map, 256.0))?;
            }
        }
        Ok(set)
    });
    let t0 = Instant::now();
    let (mut failed, mut density, mut done) = (0usize, 0.0f64, 0usize);
    let mut refused = None;
    for (index, frame) in matcher.frames(source, prefetch).enumerate() {
        let verdict = verdicts.recv().unwrap_or(Verdict::Match);
        let (l, r) = &paths[index];
        match verdict {
            Verdict::Match => {}
            Verdict::Swapped(check) if allow_swapped => {
                on_frame(&FrameEvent::Swapped { name: names[index].clone(), index, check });
            }
            Verdict::Swapped(check) => {
                refused = Some(PipelineError::SwappedFrame { index, left: l.clone(), right: r.clone(), check });
                break;
            }
            Verdict::Identical => {
                refused = Some(PipelineError::Input(format!(
                    "frame {index}: {}; nothing was written",
                    identical_message(l, r)
                )));
                break;
            }
        }
        match frame {
            Ok(f) => {
                density += f.stats.density;
                done += 1;
                let warnings = range_warnings(&f.disparity, min, n);
                on_frame(&FrameEvent::Matched { name: names[f.index].clone(), density: f.stats.density, warnings });
                if tx.send((names[f.index].clone(), f.disparity)).is_err() {
                    break; // the writer failed: its error is reported below
                }
            }
            Err(e) => {
                failed += 1;
                on_frame(&FrameEvent::Failed { index, error: e.to_string() });
            }
        }
    }
    drop(tx);
    let staged = writer.join().map_err(|_| PipelineError::Input("the writer thread panicked".into()))?;
    if let Some(e) = refused {
        // the staged files go with the set
        return Err(e);
    }
    let staged = staged.map_err(|e| PipelineError::Input(format!("writing the disparity maps: {e}")))?;
    staged.commit().map_err(|e| PipelineError::Input(format!("writing the disparity maps: {e}")))?;
    let seconds = t0.elapsed().as_secs_f64();
    let density_pct = if done > 0 { 100.0 * density / done as f64 } else { 0.0 };
    Ok(SequenceSummary { frames: done, failed, density_pct, seconds })
}

/// The point cloud of a disparity map and its depth figures.
#[derive(Debug, Clone)]
pub struct Depth {
    /// The points (rectified left frame, the calibration's length unit).
    pub cloud: parallax_triangulation::PointCloud,
    /// Smallest, median and largest depth.
    pub min: f64,
    /// Median depth.
    pub median: f64,
    /// Largest depth.
    pub max: f64,
}

/// The points of `map` through the rectification of `calibration` (named `what` in errors):
/// refuses a calibration without a rectification, one whose rectified principal point lies
/// outside the map (not the rectification of these images), and a map that gives no point in
/// front of the rig.
pub fn depth_from_rectification(
    calibration: &parallax_interop::StereoCalibration,
    map: &DisparityMap,
    what: &str,
) -> Result<Depth> {
    let rect = calibration.rectification.ok_or_else(|| {
        PipelineError::Input(format!(
            "{what}: no rectification (R1 R2 P1 P2 Q): give the file `rectify` wrote for this pair \
             (rectification.ron / .json / .yml in its --out folder)"
        ))
    })?;
    let (cx, cy) = (rect.p1.rows[0][2], rect.p1.rows[1][2]);
    let (w, h) = (map.width() as f64, map.height() as f64);
    if !((0.0..w).contains(&cx) && (0.0..h).contains(&cy)) {
        return Err(PipelineError::Input(format!(
            "the rectified principal point ({cx:.1}, {cy:.1}) lies outside the {w}x{h} disparity map: this \
             rectification is not the one of these images"
        )));
    }
    let cloud = crate::point_cloud(map, rect.q, None)?;
    let mut depths: Vec<f64> = cloud.points.iter().map(|p| p.z).collect();
    if depths.is_empty() {
        return Err(PipelineError::Input("no valid disparity gives a point in front of the rig".into()));
    }
    depths.sort_by(f64::total_cmp);
    let (min, median, max) = (depths[0], depths[depths.len() / 2], depths[depths.len() - 1]);
    Ok(Depth { cloud, min, median, max })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured pair whose right image is the left shifted by `d` pixels.
    fn opts(prefetch: usize, allow_swapped: bool) -> SequenceOptions {
        SequenceOptions { prefetch, allow_swapped, colour: false }
    }

    fn pair(d: u32) -> (image::GrayImage, image::GrayImage) {
        // a mixed hash: random texture without a period (a multiplicative hash's low bits repeat
        // closely enough at a lag of 5 px that a range ending below the shift matched there)
        let tex = |x: u32, y: u32| {
            let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
            h ^= h >> 29;
            h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            image::Luma([(h >> 56) as u8])
        };
        let l = image::GrayImage::from_fn(96, 64, tex);
        let r = image::GrayImage::from_fn(96, 64, |x, y| tex(x + d, y));
        (l, r)
    }

    #[test]
    fn sequences_pair_up_and_single_images_are_no_sequence() {
        let dir = crate::io::test_dir("seq");
        let (l, r) = pair(5);
        for k in 0..3 {
            l.save(dir.join(format!("l{k}.png"))).unwrap();
            r.save(dir.join(format!("r{k}.png"))).unwrap();
        }
        assert!(image_sequence(&dir.join("l0.png"), &dir.join("r0.png"), false).unwrap().is_none());
        let (ls, rs) = image_sequence(&dir.join("l*.png"), &dir.join("r*.png"), false).unwrap().unwrap();
        assert_eq!((ls.len(), rs.len()), (3, 3));
        let err = image_sequence(&dir.join("l*.png"), &dir.join("r0.png"), false).unwrap_err().to_string();
        assert!(err.contains("both"), "{err}");
        std::fs::remove_file(dir.join("r2.png")).unwrap();
        let err = image_sequence(&dir.join("l*.png"), &dir.join("r*.png"), false).unwrap_err().to_string();
        assert!(err.contains("3 left images but 2 right images"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes an (empty-content) file at each relative path under `dir`.
    fn touch(dir: &Path, names: &[&str]) {
        for n in names {
            let p = dir.join(n);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, b"").unwrap();
        }
    }

    #[test]
    fn sequences_pair_files_that_correspond_and_refuse_those_that_do_not() {
        let dir = crate::io::test_dir("seq-names");
        // a folder and a glob list the same frames in the same (natural) order: 1, 2, 10
        touch(&dir, &["L/1.png", "L/10.png", "L/2.png", "R/1.png", "R/10.png", "R/2.png"]);
        let (l, r) = image_sequence(&dir.join("L"), &dir.join("R/*.png"), false).unwrap().unwrap();
        let names =
            |v: &[PathBuf]| v.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect::<Vec<_>>();
        assert_eq!(names(&l), ["1.png", "2.png", "10.png"]);
        assert_eq!(names(&l), names(&r));
        // OpenCV's sample names, Middlebury's folders per scene, timestamps
        touch(&dir, &["cv/left01.jpg", "cv/left02.jpg", "cv/right01.jpg", "cv/right02.jpg"]);
        assert!(image_sequence(&dir.join("cv/left*.jpg"), &dir.join("cv/right*.jpg"), false).is_ok());
        touch(
            &dir,
            &["mb/Adirondack/im0.png", "mb/Jadeplant/im0.png", "mb/Adirondack/im1.png", "mb/Jadeplant/im1.png"],
        );
        assert!(image_sequence(&dir.join("mb/*/im0.png"), &dir.join("mb/*/im1.png"), false).is_ok());
        // a frame missing on each side: same counts, shifted pairs
        touch(&dir, &["a/f1.png", "a/f2.png", "b/f2.png", "b/f3.png"]);
        let err = image_sequence(&dir.join("a"), &dir.join("b"), false).unwrap_err().to_string();
        assert!(
            err.contains("frame 0") && err.contains("do not correspond") && err.contains("--pair-by-order"),
            "{err}"
        );
        assert!(image_sequence(&dir.join("a"), &dir.join("b"), true).unwrap().is_some());
        // unrelated names
        touch(&dir, &["x/a.png", "x/b.png", "y/b.png", "y/c.png"]);
        assert!(image_sequence(&dir.join("x"), &dir.join("y"), false).is_err());
        // a prefix that ends inside the numbers: 1b / 11b
        touch(&dir, &["p/a1b.png", "p/a11b.png", "q/a11b.png", "q/a1b.png"]);
        assert!(image_sequence(&dir.join("p"), &dir.join("q"), false).is_ok());
        assert_eq!(varying_parts(&[dir.join("p/a1b.png"), dir.join("p/a11b.png")]), [vec![], vec!['1']]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_16_bit_png_is_written_only_for_ranges_it_reads_back() {
        // every value of a range it holds reads back within 1/256 px (values at both ends and
        // half a pixel of sub-pixel step beyond the last), and a range it does not hold has a
        // value that would not
        let round_trip = |min: i32, n: usize| {
            let hi = min as f32 + n as f32 - 1.0;
            let vals = vec![min as f32, min as f32 + 0.3, hi, hi + 0.5];
            let map = DisparityMap::from_data(4, 1, vals.clone()).unwrap();
            let png = parallax_block_matching::to_png16(&map, 256.0);
            let back = parallax_block_matching::from_scaled(png.as_raw(), 4, 1, 256.0).unwrap();
            // 0 is "invalid" in the PNG: a disparity of 0 is written as 1/256
            vals.iter().zip(back.data()).all(|(a, b)| (a - b).abs() <= 1.0 / 256.0 + 1e-6)
        };
        for (min, n) in [(0, 64), (0, 256), (100, 156), (1, 256), (-1, 16), (-8, 48), (250, 16)] {
            assert_eq!(png16_holds(min, n), round_trip(min, n), "[{min}, {min} + {n})");
        }
    }

    #[test]
    fn an_existing_file_named_like_a_pattern_is_one_image() {
        let dir = crate::io::test_dir("seq-literal");
        touch(&dir, &["cam[0].png", "cam0.png", "camr[0].png", "camr0.png"]);
        assert!(image_sequence(&dir.join("cam[0].png"), &dir.join("camr[0].png"), false).unwrap().is_none());
        // a pattern that names no existing file still is one
        assert!(image_sequence(&dir.join("cam[0-9].png"), &dir.join("camr[0-9].png"), false).unwrap().is_some());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Every frame of a sequence is matched and written; the maps hold the true shift.
    #[test]
    fn a_sequence_is_matched_and_written_frame_by_frame() {
        let dir = crate::io::test_dir("run");
        let (l, r) = pair(7);
        let mut lefts = Vec::new();
        let mut rights = Vec::new();
        for k in 0..3 {
            lefts.push(dir.join(format!("left{k}.png")));
            rights.push(dir.join(format!("right{k}.png")));
            l.save(&lefts[k]).unwrap();
            r.save(&rights[k]).unwrap();
        }
        rights[2] = dir.join("missing.png");
        let cfg = parallax_block_matching::MatcherConfig { num_disparities: 16, ..Default::default() };
        let matcher = BlockMatcher::new(cfg).unwrap();
        let mut events = Vec::new();
        let out = dir.join("out");
        let s = run_sequence(matcher, lefts, rights, &out, opts(2, false), |e| events.push(e.clone())).unwrap();
        assert_eq!((s.frames, s.failed), (2, 1));
        assert!(matches!(&events[2], FrameEvent::Failed { index: 2, error } if error.contains("missing.png")));
        assert!(matches!(&events[0], FrameEvent::Matched { warnings, .. } if warnings.is_empty()), "{events:?}");
        let bytes = std::fs::read(out.join("left1.pfm")).unwrap();
        let map = parallax_block_matching::from_pfm(&bytes, "left1.pfm").unwrap();
        let valid: Vec<f32> = map.data().iter().copied().filter(|v| v.is_finite()).collect();
        assert!(valid.len() > 1000, "{} valid pixels", valid.len());
        let right = valid.iter().filter(|v| (**v - 7.0).abs() < 0.5).count();
        assert!(right as f64 > 0.95 * valid.len() as f64, "{right} of {} at the true shift 7", valid.len());
        // a range that ends below the shift: each frame's event says so
        let cfg = parallax_block_matching::MatcherConfig { num_disparities: 4, ..Default::default() };
        let (l2, r2) = (vec![dir.join("left0.png")], vec![dir.join("right0.png")]);
        let mut events = Vec::new();
        run_sequence(BlockMatcher::new(cfg).unwrap(), l2, r2, &dir.join("out4"), opts(1, false), |e| {
            events.push(e.clone())
        })
        .unwrap();
        assert!(
            matches!(&events[0], FrameEvent::Matched { warnings, .. }
                if warnings.len() == 1 && warnings[0].contains("largest disparity searched (3)")),
            "{events:?}"
        );
        assert!(out.join("left0.png").exists());
        // the outputs of a sequence written into its own folder would replace its left images
        let (l3, r3) = (dir.join("3.png"), dir.join("3r.png"));
        l.save(&l3).unwrap();
        r.save(&r3).unwrap();
        let before = std::fs::read(&l3).unwrap();
        let m = BlockMatcher::new(parallax_block_matching::MatcherConfig { num_disparities: 16, ..Default::default() });
        let err =
            run_sequence(m.unwrap(), vec![l3.clone()], vec![r3], &dir, opts(1, false), |_| {}).unwrap_err().to_string();
        assert!(err.contains("is also an input"), "{err}");
        assert_eq!(std::fs::read(&l3).unwrap(), before);
        // two left images with one stem would share their outputs
        let err =
            sequence_outputs(&[dir.join("a/x.png"), dir.join("b/x.png")], &[], &out, true).unwrap_err().to_string();
        assert!(err.contains("would both be written as x.pfm"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A swapped or doubled frame anywhere in a sequence stops the run before anything is
    /// written; allowed, a swapped frame is matched and heard of.
    #[test]
    fn a_swapped_or_doubled_frame_anywhere_stops_the_sequence_and_nothing_is_written() {
        let dir = crate::io::test_dir("run-swap");
        // a rendered scene (the shifted hash texture of `pair` matches itself too well at other
        // shifts to look swapped at half resolution)
        let cfg = parallax_synthetic::StereoSceneConfig {
            width: 192,
            height: 128,
            max_disparity: 24.0,
            seed: 5,
            ..Default::default()
        };
        let scene = parallax_synthetic::render_stereo_scene(&cfg).unwrap();
        let (l, r) = (scene.left, scene.right);
        let (mut lefts, mut rights) = (Vec::new(), Vec::new());
        for k in 0..4 {
            lefts.push(dir.join(format!("left{k}.png")));
            rights.push(dir.join(format!("right{k}.png")));
            // frame 2 swapped
            let (a, b) = if k == 2 { (&r, &l) } else { (&l, &r) };
            a.save(&lefts[k]).unwrap();
            b.save(&rights[k]).unwrap();
        }
        let cfg = parallax_block_matching::MatcherConfig { num_disparities: 32, ..Default::default() };
        let m = || BlockMatcher::new(cfg.clone()).unwrap();
        let out = dir.join("out");
        let mut events = Vec::new();
        let err = run_sequence(m(), lefts.clone(), rights.clone(), &out, opts(2, false), |e| events.push(e.clone()));
        match err {
            Err(PipelineError::SwappedFrame { index, left, right, check }) => {
                assert_eq!((index, &left, &right), (2, &lefts[2], &rights[2]));
                assert!(check.looks_swapped && check.reverse_density > check.forward_density, "{check:?}");
            }
            other => panic!("not refused as swapped: {other:?}"),
        }
        // frames 0 and 1 were matched, then the run stopped: none of them written
        assert_eq!(events.len(), 2, "{events:?}");
        assert!(!out.exists(), "a refused sequence wrote {:?}", std::fs::read_dir(&out).unwrap().count());
        // allowed: matched, heard of, written
        let mut events = Vec::new();
        let s =
            run_sequence(m(), lefts.clone(), rights.clone(), &out, opts(2, true), |e| events.push(e.clone())).unwrap();
        assert_eq!((s.frames, s.failed), (4, 0));
        let swapped: Vec<_> = events.iter().filter(|e| matches!(e, FrameEvent::Swapped { .. })).collect();
        assert!(matches!(swapped[..], [FrameEvent::Swapped { index: 2, name, .. }] if name == "left2"), "{events:?}");
        assert!(out.join("left3.pfm").exists());
        std::fs::remove_dir_all(&out).unwrap();
        // the same image twice in frame 3: refused, naming it, nothing written
        l.save(&rights[3]).unwrap();
        r.save(&rights[2]).unwrap();
        l.save(&lefts[2]).unwrap();
        let err = run_sequence(m(), lefts, rights, &out, opts(2, false), |_| {}).unwrap_err().to_string();
        assert!(err.contains("frame 3") && err.contains("same image") && err.contains("nothing was written"), "{err}");
        assert!(!out.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn truth_pngs_are_scaled_and_zero_is_unknown() {
        let dir = crate::io::test_dir("truth");
        let img = image::GrayImage::from_fn(4, 2, |x, _| image::Luma([(x * 8) as u8]));
        img.save(dir.join("gt.png")).unwrap();
        let t = load_truth(&dir.join("gt.png"), 4.0, (4, 2)).unwrap();
        assert!(t.data()[0].is_nan());
        assert_eq!(&t.data()[1..4], &[2.0, 4.0, 6.0]);
        let mask = load_mask(&dir.join("gt.png"), (4, 2)).unwrap();
        assert_eq!(mask.iter().filter(|m| **m).count(), 0, "every value is ≤ 128");
        // A size that is not the pair's is named as WxH, never as a flat length.
        let err = load_truth(&dir.join("gt.png"), 4.0, (8, 1)).unwrap_err().to_string();
        assert!(err.contains("is 4x2 but the images are 8x1"), "{err}");
        let err = load_mask(&dir.join("gt.png"), (2, 4)).unwrap_err().to_string();
        assert!(err.contains("is 4x2 but the images are 2x4"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_swap_warning_gives_both_densities() {
        let swap = SwapCheck {
            forward_density: 0.123,
            reverse_density: 0.6789,
            forward_lr_rejected: 0.3,
            looks_swapped: true,
        };
        let w = swap_warning(&swap, None);
        assert!(w.starts_with("warning: the pair looks swapped"), "{w}");
        assert!(
            w.contains("12.3 % of the pixels") && w.contains("67.9 % with the images exchanged (half resolution)"),
            "{w}"
        );
        let w = swap_warning(&swap, Some("000123"));
        assert!(w.starts_with("warning: frame 000123 looks swapped") && w.contains("12.3 % of the pixels"), "{w}");
    }
}
