//! `tune`: a search of the matcher's parameters over a set of scenes with ground truth —
//! rendered worlds ([`parallax_synthetic::StereoWorld`], the zoo in `fixtures/zoo`) or real
//! pairs in Middlebury's layout — scored by bad-2 (missing = bad), bad-2 where OpenCV's matchers
//! also answer, density and time; the Pareto front of accuracy against time; the chosen
//! configuration as a file `disparity --config` reads ([`DisparityConfig`]); and the realism
//! check, the rank correlation between the zoo's and the real pairs' rankings of a fixed set of
//! configurations ([`realism_configs`], [`spearman`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use image::{GrayImage, RgbImage};
use parallax_block_matching::{
    BlockMatcher, CostFunction, MatcherConfig, Method, Prefilter, SgmPaths, evaluate, evaluate_overlap,
};
use parallax_camera_model::DisparityMap;
use parallax_synthetic::{StereoWorld, render_world};
use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::{PipelineError, Result};

fn input(msg: impl Into<String>) -> PipelineError {
    PipelineError::Input(msg.into())
}

/// A matcher configuration as a file (`tune`'s choice, read by `disparity --config`): the
/// matcher's settings for grey input, and whether colour input is matched in colour (the cost
/// summed over the three channels, semi-global matching's penalties times 3, as
/// `disparity --colour`). The disparity range and the thread count are the command's.
/// Checked when read: a configuration the matcher refuses never deserialises.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DisparityConfigFile", into = "DisparityConfigFile")]
pub struct DisparityConfig {
    matcher: MatcherConfig,
    colour: bool,
}

/// The unchecked form of [`DisparityConfig`] on disk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisparityConfigFile {
    /// The matcher's settings (its range and threads are replaced by the command's).
    pub matcher: MatcherConfig,
    /// Match colour input in colour.
    #[serde(default)]
    pub colour: bool,
}

impl TryFrom<DisparityConfigFile> for DisparityConfig {
    type Error = PipelineError;

    fn try_from(f: DisparityConfigFile) -> Result<Self> {
        Self::new(f.matcher, f.colour)
    }
}

impl From<DisparityConfig> for DisparityConfigFile {
    fn from(c: DisparityConfig) -> Self {
        Self { matcher: c.matcher, colour: c.colour }
    }
}

impl DisparityConfig {
    /// Checks `matcher` (the matcher's own checks, at its range) and the colour option (block
    /// matching in colour sums SAD or SSD, not NCC).
    pub fn new(matcher: MatcherConfig, colour: bool) -> Result<Self> {
        if colour && matcher.method == Method::BlockMatching && matcher.cost == CostFunction::Ncc {
            return Err(input("colour block matching sums sad or ssd over the channels: ncc matches grey pairs only"));
        }
        BlockMatcher::new(matcher.clone())?;
        let c = Self { matcher, colour };
        // some limits depend on the input (semi-global matching's 16-bit sums over the
        // channels): a match of a small pair in every form the configuration reads checks them
        let (grey, rgb) = (GrayImage::new(48, 24), RgbImage::new(48, 24));
        BlockMatcher::new(c.matcher_for(false, (0, 16), 1))?.compute(&grey, &grey)?;
        if colour {
            BlockMatcher::new(c.matcher_for(true, (0, 16), 1))?.compute_rgb(&rgb, &rgb)?;
        }
        Ok(c)
    }

    /// The matcher's settings for grey input.
    pub fn matcher(&self) -> &MatcherConfig {
        &self.matcher
    }

    /// Whether colour input is matched in colour.
    pub fn colour(&self) -> bool {
        self.colour
    }

    /// The matcher for a pair: `colour_input` (the pair is matched in colour, so semi-global
    /// matching's penalties are tripled), the range `[min_disparity, min_disparity + n)` and
    /// the threads.
    pub fn matcher_for(&self, colour_input: bool, (min_disparity, n): (i32, usize), threads: usize) -> MatcherConfig {
        let mut m = self.matcher.clone();
        m.min_disparity = min_disparity;
        m.num_disparities = n;
        m.threads = threads;
        if colour_input && m.method == Method::Sgm {
            m.sgm.p1 *= 3;
            m.sgm.p2 *= 3;
        }
        m
    }

    /// Reads a configuration file (RON, or JSON by its `.json` extension), checked.
    pub fn read(path: &Path) -> Result<Self> {
        if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
            let text = parallax_interop::read_text_file(path).map_err(crate::io::io_err("reading", path))?;
            serde_json::from_str(&text)
                .map_err(|e| PipelineError::Format { path: path.to_path_buf(), message: e.to_string() })
        } else {
            crate::io::read_ron(path)
        }
    }

    /// A short description: method, cost, window, penalties, filters.
    pub fn describe(&self) -> String {
        let m = &self.matcher;
        let lr = m.lr_max_diff.map_or("off".to_string(), |d| d.to_string());
        let pre = match m.prefilter {
            Prefilter::None => "none".to_string(),
            Prefilter::XSobel { .. } => "xsobel".to_string(),
            Prefilter::NormalizedResponse { .. } => "norm".to_string(),
            Prefilter::Rank { size } => format!("rank:{size}"),
        };
        let colour = if self.colour { " colour" } else { "" };
        match m.method {
            Method::BlockMatching => format!(
                "bm {:?} {}x{} prefilter {pre} uniqueness {} lr {lr} speckle {}{colour}",
                m.cost, m.block_size, m.block_size, m.uniqueness_ratio, m.speckle_window_size
            )
            .to_lowercase(),
            Method::Sgm => format!(
                "sgm paths {} block {} p1 {} p2 {} prefilter {pre} uniqueness {} lr {lr} speckle {}{colour}",
                paths_count(m.sgm.paths),
                m.sgm.block,
                m.sgm.p1,
                m.sgm.p2,
                m.uniqueness_ratio,
                m.speckle_window_size
            ),
        }
    }

    /// `bm` or `sgm`.
    pub fn method_name(&self) -> &'static str {
        match self.matcher.method {
            Method::BlockMatching => "bm",
            Method::Sgm => "sgm",
        }
    }
}

fn paths_count(p: SgmPaths) -> u32 {
    match p {
        SgmPaths::Three => 3,
        SgmPaths::Five => 5,
        SgmPaths::Eight => 8,
    }
}

/// Integer values `min, min + step, …` up to `max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Steps {
    /// First value.
    pub min: u32,
    /// Last value at most.
    pub max: u32,
    /// Step (at least 1).
    pub step: u32,
}

impl Steps {
    /// The single value `v`.
    pub const fn one(v: u32) -> Self {
        Self { min: v, max: v, step: 1 }
    }

    fn values(&self) -> Vec<u32> {
        (self.min..=self.max).step_by(self.step.max(1) as usize).collect()
    }

    /// Checks the range and every value against `[lo, hi]` (and oddness), naming `field`.
    fn check(&self, field: &str, lo: u32, hi: u32, odd: bool) -> Result<()> {
        if self.step == 0 || self.min > self.max {
            return Err(input(format!(
                "tune space: {field} must have min ≤ max and a step of at least 1 (got {}..={} step {})",
                self.min, self.max, self.step
            )));
        }
        for v in self.values() {
            if v < lo || v > hi || (odd && v % 2 == 0) {
                let odd = if odd { "odd values " } else { "values " };
                return Err(input(format!(
                    "tune space: {field} takes {odd}in {lo}..={hi}, and its range {}..={} step {} gives {v}",
                    self.min, self.max, self.step
                )));
            }
        }
        Ok(())
    }
}

/// The parameters `tune` searches and their declared ranges (a RON file; every field has a
/// default). Block matching draws `cost`, `prefilter`, `block`; semi-global matching draws
/// `prefilter`, `sgm_block`, `sgm_paths`, `p1`, `p2` (pairs with `p2 < p1` are left out) on
/// the default SGM preset's pixel cost; both draw `uniqueness`, `lr_max_diff`,
/// `speckle_window` and `colour` (colour scenes only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TuneSpace {
    /// Methods.
    pub method: Vec<Method>,
    /// Block matching's costs.
    pub cost: Vec<CostFunction>,
    /// Prefilters.
    pub prefilter: Vec<Prefilter>,
    /// Block matching's window (odd, 3..=31).
    pub block: Steps,
    /// Semi-global matching's cost window (odd, 1..=11).
    pub sgm_block: Steps,
    /// Semi-global matching's paths.
    pub sgm_paths: Vec<SgmPaths>,
    /// P1 per window pixel (1..=1000).
    pub p1: Steps,
    /// P2 per window pixel (1..=4000).
    pub p2: Steps,
    /// Uniqueness margin, percent (0..=100).
    pub uniqueness: Steps,
    /// Left–right tolerance, px (`None`: no check; at most 16).
    pub lr_max_diff: Vec<Option<u32>>,
    /// Speckle filter's region size (0..=10000; 0 off).
    pub speckle_window: Steps,
    /// Match colour scenes in colour.
    pub colour: Vec<bool>,
}

impl Default for TuneSpace {
    fn default() -> Self {
        Self {
            method: vec![Method::BlockMatching, Method::Sgm],
            cost: vec![CostFunction::Sad, CostFunction::Ssd, CostFunction::Ncc],
            prefilter: vec![Prefilter::XSobel { cap: 31 }, Prefilter::Rank { size: 9 }],
            block: Steps { min: 5, max: 15, step: 2 },
            sgm_block: Steps { min: 1, max: 5, step: 2 },
            sgm_paths: vec![SgmPaths::Three, SgmPaths::Five, SgmPaths::Eight],
            p1: Steps { min: 4, max: 24, step: 4 },
            p2: Steps { min: 32, max: 128, step: 16 },
            uniqueness: Steps { min: 0, max: 15, step: 5 },
            lr_max_diff: vec![Some(1), Some(2), None],
            speckle_window: Steps { min: 0, max: 200, step: 100 },
            colour: vec![false, true],
        }
    }
}

impl TuneSpace {
    /// Checks every declared range (before any scene is matched).
    pub fn check(&self) -> Result<()> {
        for (field, empty) in [
            ("method", self.method.is_empty()),
            ("prefilter", self.prefilter.is_empty()),
            ("lr_max_diff", self.lr_max_diff.is_empty()),
            ("colour", self.colour.is_empty()),
            ("cost", self.method.contains(&Method::BlockMatching) && self.cost.is_empty()),
            ("sgm_paths", self.method.contains(&Method::Sgm) && self.sgm_paths.is_empty()),
        ] {
            if empty {
                return Err(input(format!("tune space: {field} lists no value")));
            }
        }
        self.block.check("block", 3, 31, true)?;
        self.sgm_block.check("sgm_block", 1, 11, true)?;
        self.p1.check("p1", 1, 1000, false)?;
        self.p2.check("p2", 1, 4000, false)?;
        self.uniqueness.check("uniqueness", 0, 100, false)?;
        self.speckle_window.check("speckle_window", 0, 10_000, false)?;
        if let Some(d) = self.lr_max_diff.iter().flatten().find(|&&d| d > 16) {
            return Err(input(format!("tune space: lr_max_diff takes values in 0..=16 or None, got {d}")));
        }
        for p in &self.prefilter {
            let mut m = MatcherConfig { prefilter: *p, ..MatcherConfig::default() };
            m.num_disparities = 16;
            BlockMatcher::new(m).map_err(|e| input(format!("tune space: prefilter {p:?}: {e}")))?;
        }
        Ok(())
    }

    /// Every combination of the space, unchecked, in a fixed order (`p2 < p1` left out).
    fn candidates(&self) -> Vec<(MatcherConfig, bool)> {
        let mut out = Vec::new();
        let common = self.common();
        for &method in &self.method {
            let mut specific = Vec::new();
            match method {
                Method::BlockMatching => {
                    for &cost in &self.cost {
                        for &prefilter in &self.prefilter {
                            for block in self.block.values() {
                                specific.push(MatcherConfig {
                                    cost,
                                    prefilter,
                                    block_size: block as usize,
                                    ..MatcherConfig::default()
                                });
                            }
                        }
                    }
                }
                Method::Sgm => {
                    for &prefilter in &self.prefilter {
                        for block in self.sgm_block.values() {
                            for &paths in &self.sgm_paths {
                                for p1 in self.p1.values() {
                                    for p2 in self.p2.values().into_iter().filter(|&p2| p2 >= p1) {
                                        let mut m = MatcherConfig { prefilter, ..MatcherConfig::sgm() };
                                        m.sgm.block = block as usize;
                                        m.sgm.paths = paths;
                                        m.sgm.p1 = p1;
                                        m.sgm.p2 = p2;
                                        specific.push(m);
                                    }
                                }
                            }
                        }
                    }
                }
            }
            for m in specific {
                for &(uniqueness, lr, speckle, colour) in &common {
                    let mut m = m.clone();
                    m.uniqueness_ratio = uniqueness;
                    m.lr_max_diff = lr;
                    m.speckle_window_size = speckle as usize;
                    out.push((m, colour));
                }
            }
        }
        out
    }

    /// The number of combinations of the space (the grid's size before the matcher's checks).
    pub fn size(&self) -> usize {
        self.candidates().len()
    }

    /// Every configuration of the space (the grid), in a fixed order; combinations the matcher
    /// refuses (e.g. a semi-global window whose sums could overflow) and `p2 < p1` are left out.
    pub fn grid(&self) -> Vec<DisparityConfig> {
        self.candidates().into_iter().filter_map(|(m, c)| DisparityConfig::new(m, c).ok()).collect()
    }

    fn common(&self) -> Vec<(u32, Option<u32>, u32, bool)> {
        let mut v = Vec::new();
        for u in self.uniqueness.values() {
            for &lr in &self.lr_max_diff {
                for s in self.speckle_window.values() {
                    for &c in &self.colour {
                        v.push((u, lr, s, c));
                    }
                }
            }
        }
        v
    }

    /// `count` distinct configurations drawn uniformly from the grid with `seed` (all of them,
    /// in the grid's order, when it holds no more).
    pub fn random(&self, count: usize, seed: u64) -> Vec<DisparityConfig> {
        let mut all = self.candidates();
        // a partial Fisher–Yates shuffle: a uniform draw without repeats, skipping what the
        // matcher refuses
        let mut rng = parallax_synthetic::rng(seed);
        let mut out = Vec::with_capacity(count);
        for i in 0..all.len() {
            if out.len() == count {
                break;
            }
            let j = rng.random_range(i..all.len());
            all.swap(i, j);
            if let Ok(c) = DisparityConfig::new(all[i].0.clone(), all[i].1) {
                out.push(c);
            }
        }
        out
    }
}

/// A scene of a tuning set: a rectified pair (grey, and colour when it has colour), its true
/// left disparity, the pixels scored (known truth, not occluded) and the range searched.
#[derive(Debug, Clone)]
pub struct TuneScene {
    /// Its name (the world's file stem, or the pair's folder).
    pub name: String,
    grey: (GrayImage, GrayImage),
    rgb: Option<(RgbImage, RgbImage)>,
    truth: DisparityMap,
    mask: Vec<bool>,
    disparities: usize,
}

impl TuneScene {
    /// A scene from its parts, checked: both images and the truth of one size, the mask of
    /// its pixel count, a range of `1..width` disparities.
    pub fn new(
        name: String,
        grey: (GrayImage, GrayImage),
        rgb: Option<(RgbImage, RgbImage)>,
        truth: DisparityMap,
        mask: Vec<bool>,
        disparities: usize,
    ) -> Result<Self> {
        let (w, h) = grey.0.dimensions();
        let sizes_agree = grey.1.dimensions() == (w, h)
            && rgb.as_ref().is_none_or(|(l, r)| l.dimensions() == (w, h) && r.dimensions() == (w, h))
            && (truth.width(), truth.height()) == (w as usize, h as usize);
        if !sizes_agree {
            return Err(input(format!(
                "scene {name}: the images and the ground truth differ in size (left {w}x{h}, truth {}x{})",
                truth.width(),
                truth.height()
            )));
        }
        if mask.len() != (w * h) as usize {
            return Err(input(format!("scene {name}: the mask has {} pixels, not {}", mask.len(), w * h)));
        }
        if disparities == 0 || disparities >= w as usize {
            return Err(input(format!("scene {name}: {disparities} disparities for a {w}-pixel-wide image")));
        }
        Ok(Self { name, grey, rgb, truth, mask, disparities })
    }

    /// Renders a world: its views, its truth, the non-occluded pixels scored.
    pub fn from_world(name: String, world: &StereoWorld) -> Result<Self> {
        let v = render_world(world)?;
        let (grey, rgb) = if world.colour {
            let (l, r) = (v.left.to_rgb8(), v.right.to_rgb8());
            ((image::imageops::grayscale(&l), image::imageops::grayscale(&r)), Some((l, r)))
        } else {
            ((v.left.to_luma8(), v.right.to_luma8()), None)
        };
        let mask = v.occluded.iter().map(|o| !o).collect();
        Self::new(name, grey, rgb, v.disparity, mask, world.disparities)
    }

    /// A real pair in Middlebury's layout: `imL.png`, `imR.png`, `groundtruth.png` (disparity
    /// times the scale, 0 unknown), `nonocc.png` (> 128 scored) and `info.txt` (the scale, then
    /// the largest disparity); the range searched is the largest disparity + 1 rounded up to 16.
    pub fn from_middlebury(dir: &Path) -> Result<Self> {
        let name = dir.file_name().map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into_owned());
        let info_path = dir.join("info.txt");
        let info = parallax_interop::read_text_file(&info_path).map_err(crate::io::io_err("reading", &info_path))?;
        let numbers: Vec<f64> = info.split_whitespace().filter_map(|t| t.parse().ok()).collect();
        let [scale, max_d, ..] = numbers[..] else {
            return Err(input(format!("{}: expected the scale and the largest disparity", info_path.display())));
        };
        if !(scale > 0.0 && max_d > 0.0 && max_d < 1024.0) {
            return Err(input(format!("{}: scale {scale} and largest disparity {max_d}", info_path.display())));
        }
        let (l, r) = (crate::io::load_image(&dir.join("imL.png"))?, crate::io::load_image(&dir.join("imR.png"))?);
        if (l.width(), l.height()) != (r.width(), r.height()) {
            return Err(input(format!("{name}: imL.png and imR.png differ in size")));
        }
        let size = (l.width(), l.height());
        let truth = crate::disparity::load_truth(&dir.join("groundtruth.png"), scale as f32, size)?;
        let mask = crate::disparity::load_mask(&dir.join("nonocc.png"), size)?;
        let disparities = ((max_d as usize + 1).div_ceil(16) * 16).min(size.0 as usize - 1);
        let colour = l.color().channel_count() >= 3;
        let grey = (l.to_luma8(), r.to_luma8());
        let rgb = colour.then(|| (l.to_rgb8(), r.to_rgb8()));
        Self::new(name, grey, rgb, truth, mask, disparities)
    }

    /// The disparities searched.
    pub fn disparities(&self) -> usize {
        self.disparities
    }

    /// `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        self.grey.0.dimensions()
    }

    /// Matches the scene with `config` (in colour when both have colour): the map and the
    /// median time of `runs` runs, seconds.
    pub fn run(&self, config: &DisparityConfig, threads: usize, runs: usize) -> Result<(DisparityMap, f64)> {
        let colour = config.colour() && self.rgb.is_some();
        let mut matcher = BlockMatcher::new(config.matcher_for(colour, (0, self.disparities), threads))?;
        let mut times = Vec::with_capacity(runs.max(1));
        let mut map = None;
        for _ in 0..runs.max(1) {
            let t = Instant::now();
            let m = match (&self.rgb, colour) {
                (Some((l, r)), true) => matcher.compute_rgb(l, r)?,
                _ => matcher.compute(&self.grey.0, &self.grey.1)?,
            };
            times.push(t.elapsed().as_secs_f64());
            map.get_or_insert(m);
        }
        times.sort_by(f64::total_cmp);
        Ok((map.expect("at least one run"), times[times.len() / 2]))
    }

    /// Scores a map: bad-2 (missing = bad) and density over the scored pixels, and bad-2 over
    /// those where OpenCV's matchers also answer (`NaN` when none does), percent.
    pub fn score(&self, map: &DisparityMap) -> Result<(f64, f64, f64)> {
        let e = evaluate(map, &self.truth, Some(&self.mask), &[2.0])?;
        let overlap = match evaluate_overlap(map, &self.truth, Some(&self.mask), (0, self.disparities), &[2.0]) {
            Ok(o) => o.bad_at(2.0).unwrap_or(f64::NAN),
            Err(parallax_block_matching::BlockMatchingError::NothingToEvaluate(_)) => f64::NAN,
            Err(e) => return Err(e.into()),
        };
        Ok((e.bad_at(2.0).unwrap_or(f64::NAN), overlap, e.density))
    }
}

/// Reads and checks the worlds of `paths` (RON), named by their file stems; refuses an empty
/// set and names the file of any world that does not parse or is out of range (beyond the
/// memory budget included), before any is rendered.
pub fn read_worlds(paths: &[PathBuf]) -> Result<Vec<(String, StereoWorld)>> {
    if paths.is_empty() {
        return Err(input("the scene set is empty: give at least one world"));
    }
    paths
        .iter()
        .map(|p| {
            let text = parallax_interop::read_text_file(p).map_err(crate::io::io_err("reading", p))?;
            parallax_interop::check_nesting(&text, &p.display().to_string())?;
            let w = StereoWorld::from_ron(&text)
                .map_err(|e| PipelineError::Format { path: p.clone(), message: e.to_string() })?;
            let name = p.file_stem().map_or_else(|| p.display().to_string(), |s| s.to_string_lossy().into_owned());
            Ok((name, w))
        })
        .collect()
}

/// Renders the worlds of `paths` ([`read_worlds`]) as scenes.
pub fn scenes_from_worlds(paths: &[PathBuf]) -> Result<Vec<TuneScene>> {
    read_worlds(paths)?.iter().map(|(n, w)| TuneScene::from_world(n.clone(), w)).collect()
}

/// The scores of one configuration over a scene set (means over the scenes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Score {
    /// Bad-2, missing = bad, percent of the scored pixels.
    pub bad2: f64,
    /// Bad-2 where OpenCV's matchers also answer.
    pub bad2_overlap: f64,
    /// Density, percent of the scored pixels.
    pub density: f64,
    /// Time per scene, milliseconds.
    pub ms: f64,
}

/// Scores `config` over `scenes`.
pub fn score(config: &DisparityConfig, scenes: &[TuneScene], threads: usize, runs: usize) -> Result<Score> {
    let mut s = Score { bad2: 0.0, bad2_overlap: 0.0, density: 0.0, ms: 0.0 };
    let mut overlap_n = 0usize;
    for scene in scenes {
        let (map, seconds) = scene.run(config, threads, runs)?;
        let (bad2, overlap, density) = scene.score(&map)?;
        s.bad2 += bad2;
        s.density += density;
        s.ms += 1e3 * seconds;
        if overlap.is_finite() {
            s.bad2_overlap += overlap;
            overlap_n += 1;
        }
    }
    let n = scenes.len() as f64;
    s.bad2 /= n;
    s.density /= n;
    s.ms /= n;
    s.bad2_overlap = if overlap_n > 0 { s.bad2_overlap / overlap_n as f64 } else { f64::NAN };
    Ok(s)
}

/// Whether each score is on the Pareto front of bad-2 against time (no other is at least as
/// good on both and better on one).
pub fn pareto(scores: &[Score]) -> Vec<bool> {
    scores
        .iter()
        .map(|a| !scores.iter().any(|b| b.bad2 <= a.bad2 && b.ms <= a.ms && (b.bad2 < a.bad2 || b.ms < a.ms)))
        .collect()
}

/// The index of the lowest bad-2 (ties: the faster).
pub fn best(scores: &[Score]) -> Option<usize> {
    (0..scores.len())
        .min_by(|&i, &j| scores[i].bad2.total_cmp(&scores[j].bad2).then(scores[i].ms.total_cmp(&scores[j].ms)))
}

/// Ranks (1-based) with ties given their mean rank.
fn ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut r = vec![0.0; values.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && values[order[j + 1]] == values[order[i]] {
            j += 1;
        }
        let mean = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            r[k] = mean;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation of two equally long samples (Pearson's correlation of their
/// ranks, ties at their mean rank); `NaN` when either has no spread.
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "samples of one length");
    let (ra, rb) = (ranks(a), ranks(b));
    let n = ra.len() as f64;
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

/// The defaults `tune` always scores first: block matching's and semi-global matching's.
pub fn default_configs() -> Vec<DisparityConfig> {
    [MatcherConfig::default(), MatcherConfig::sgm()]
        .into_iter()
        .map(|m| DisparityConfig::new(m, false).expect("the presets are valid"))
        .collect()
}

/// The fixed configurations the realism check ranks: block matching (SAD 5x5, 9x9 and 15x15,
/// SSD 9x9, NCC 9x9 on raw grey levels, SAD 9x9 on ranks) and semi-global matching (the
/// default, with 5 and 8 paths, the accurate preset, a 1x1 window of plain SAD).
pub fn realism_configs() -> Vec<DisparityConfig> {
    let bm = |cost, block, prefilter| MatcherConfig { cost, block_size: block, prefilter, ..MatcherConfig::default() };
    let xs = Prefilter::XSobel { cap: 31 };
    let mut sgm5 = MatcherConfig::sgm();
    sgm5.sgm.paths = SgmPaths::Five;
    let mut sgm8 = MatcherConfig::sgm();
    sgm8.sgm.paths = SgmPaths::Eight;
    let mut plain = MatcherConfig::sgm();
    plain.sgm.block = 1;
    plain.sgm.sampling_insensitive = false;
    plain.sgm.intensity_cost = false;
    [
        bm(CostFunction::Sad, 5, xs),
        bm(CostFunction::Sad, 9, xs),
        bm(CostFunction::Sad, 15, xs),
        bm(CostFunction::Ssd, 9, xs),
        bm(CostFunction::Ncc, 9, Prefilter::None),
        bm(CostFunction::Sad, 9, Prefilter::Rank { size: 9 }),
        MatcherConfig::sgm(),
        sgm5,
        sgm8,
        MatcherConfig::sgm_accurate(),
        plain,
    ]
    .into_iter()
    .map(|m| DisparityConfig::new(m, false).expect("the realism set is valid"))
    .collect()
}

/// Stages the files of a rendered world in `dir`: `left.png`, `right.png`, `disparity.pfm`
/// and `disparity_right.pfm` (the truth of both views), `occluded.png` and
/// `occluded_right.png` (255 = occluded) and `world.ron` (the description).
pub fn add_world_files(
    set: &mut crate::io::OutputSet,
    dir: &Path,
    world: &StereoWorld,
    views: &parallax_synthetic::WorldViews,
) -> Result<()> {
    let png = |img: &image::DynamicImage| -> Result<Vec<u8>> {
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png)?;
        Ok(out.into_inner())
    };
    let mask = |m: &[bool]| -> Result<Vec<u8>> {
        let bytes = m.iter().map(|&o| if o { 255 } else { 0 }).collect();
        let img = GrayImage::from_raw(world.width, world.height, bytes).expect("a mask of w x h");
        png(&image::DynamicImage::ImageLuma8(img))
    };
    set.add(dir.join("left.png"), png(&views.left)?)?;
    set.add(dir.join("right.png"), png(&views.right)?)?;
    set.add(dir.join("disparity.pfm"), parallax_block_matching::to_pfm(&views.disparity))?;
    set.add(dir.join("disparity_right.pfm"), parallax_block_matching::to_pfm(&views.disparity_right))?;
    set.add(dir.join("occluded.png"), mask(&views.occluded)?)?;
    set.add(dir.join("occluded_right.png"), mask(&views.occluded_right)?)?;
    set.add(dir.join("world.ron"), world.to_ron())
}
