//! Disparity on files: a rectified pair loaded at its bit depth ([`StereoImages`]), ground truth
//! and evaluation masks, image sequences (folders or glob patterns) matched in a batch with
//! decoding, matching and writing overlapped ([`run_sequence`]), the map's output files, and the
//! point cloud and depth figures through a rectification's `Q` ([`depth_from_rectification`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use parallax_block_matching::{BlockMatcher, Gray16Image, StereoPair, SwapCheck};
use parallax_camera_model::DisparityMap;

use crate::{PipelineError, Result};

/// A rectified pair at its bit depth.
#[derive(Debug, Clone)]
pub enum StereoImages {
    /// 8-bit grey (colour converted).
    U8(image::GrayImage, image::GrayImage),
    /// 16-bit grey.
    U16(Gray16Image, Gray16Image),
}

impl StereoPair for StereoImages {
    fn match_into(&self, m: &mut BlockMatcher, out: &mut DisparityMap) -> parallax_block_matching::Result<()> {
        match self {
            Self::U8(l, r) => m.compute_into(l, r, out),
            Self::U16(l, r) => m.compute_u16_into(l, r, out),
        }
    }
}

impl StereoImages {
    /// `(width, height)` of the left image.
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            Self::U8(l, _) => l.dimensions(),
            Self::U16(l, _) => l.dimensions(),
        }
    }

    /// Whether the pair looks swapped to `matcher` (see [`BlockMatcher::check_swap`]).
    pub fn check_swap(&self, matcher: &BlockMatcher) -> Result<SwapCheck> {
        Ok(match self {
            Self::U8(l, r) => matcher.check_swap(l, r)?,
            Self::U16(l, r) => matcher.check_swap_u16(l, r)?,
        })
    }
}

fn is_16_bit(img: &image::DynamicImage) -> bool {
    img.color().bytes_per_pixel() / img.color().channel_count() > 1
}

/// Loads a pair through [`crate::io::load_image`]'s checks: 16-bit grey when either image has
/// 16-bit channels, else 8-bit grey.
pub fn load_pair(left: &Path, right: &Path) -> Result<StereoImages> {
    let (l, r) = (crate::io::load_image(left)?, crate::io::load_image(right)?);
    Ok(if is_16_bit(&l) || is_16_bit(&r) {
        StereoImages::U16(l.into_luma16(), r.into_luma16())
    } else {
        StereoImages::U8(l.into_luma8(), r.into_luma8())
    })
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
        let bytes = std::fs::read(path).map_err(|source| PipelineError::Io {
            what: "reading",
            path: path.to_path_buf(),
            source,
        })?;
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

/// The images of a folder (by extension, sorted) or a glob pattern (natural order).
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
    v.sort();
    if v.is_empty() {
        return Err(PipelineError::Input(format!("no image in folder {}", p.display())));
    }
    Ok(v)
}

/// The paired left and right files when `left` / `right` name folders or glob patterns
/// (`None`: a single pair). Both must be sequences, of the same length.
pub fn image_sequence(left: &Path, right: &Path) -> Result<Option<(Vec<PathBuf>, Vec<PathBuf>)>> {
    let is_pattern = |p: &Path| p.to_string_lossy().contains(['*', '?', '[']);
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
    Ok(Some((l, r)))
}

/// Writes a map as `<stem>.pfm` and `<stem>.png` (16-bit, 1/256 px) into `dir`, as a set.
pub fn write_frame(dir: &Path, stem: &str, map: &DisparityMap) -> Result<()> {
    let mut set = crate::io::OutputSet::new();
    set.add(dir.join(format!("{stem}.pfm")), parallax_block_matching::to_pfm(map))?;
    set.add_png(dir.join(format!("{stem}.png")), &parallax_block_matching::to_png16(map, 256.0))?;
    set.commit().map(|_| ())
}

/// Adds a single map's files in `dir` to `set`: `disparity.pfm`, `disparity16.png` (1/256 px)
/// and `disparity_colour.png` (false colour over `range`).
pub fn add_maps(set: &mut crate::io::OutputSet, dir: &Path, map: &DisparityMap, range: (f32, f32)) -> Result<()> {
    set.add(dir.join("disparity.pfm"), parallax_block_matching::to_pfm(map))?;
    set.add_png(dir.join("disparity16.png"), &parallax_block_matching::to_png16(map, 256.0))?;
    set.add_png(dir.join("disparity_colour.png"), &parallax_block_matching::false_colour(map, Some(range)))
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

/// The warning for a pair (or, `sequence`, the first pair of a sequence) that looks swapped:
/// the share of pixels that pass the checks as given and exchanged.
pub fn swap_warning(swap: &SwapCheck, sequence: bool) -> String {
    let (what, looks) =
        if sequence { ("pairs look", "first pair, half resolution") } else { ("pair looks", "half resolution") };
    format!(
        "warning: the {what} swapped (left and right exchanged): {:.1} % of the pixels pass the checks as given, {:.1} % \
         with the images exchanged ({looks})",
        100.0 * swap.forward_density,
        100.0 * swap.reverse_density
    )
}

/// What happened to one frame of a sequence (for progress reports).
#[derive(Debug, Clone, PartialEq)]
pub enum FrameEvent {
    /// A frame was matched: its file stem and the share of pixels returned (`0..=1`).
    Matched {
        /// File stem of the left image.
        name: String,
        /// Share of the pixels with a disparity.
        density: f64,
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

/// The files a sequence run writes into `out`: `<left stem>.pfm` and `<left stem>.png` per
/// frame. Refuses two frames with the same stem (the second would replace the first's maps)
/// and any output that is one of the input images (`--out` on the input folder).
pub fn sequence_outputs(lefts: &[PathBuf], rights: &[PathBuf], out: &Path) -> Result<Vec<PathBuf>> {
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
    let outputs: Vec<PathBuf> =
        stems.iter().flat_map(|(s, _)| [out.join(format!("{s}.pfm")), out.join(format!("{s}.png"))]).collect();
    let inputs: Vec<&PathBuf> = lefts.iter().chain(rights).collect();
    crate::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    Ok(outputs)
}

/// Matches a sequence of pairs into `out` (`<left stem>.pfm` and `.png` per frame, checked by
/// [`sequence_outputs`] before anything runs): decoding on a prefetch thread (`prefetch` pairs
/// ahead), matching on this thread, writing on a writer thread, all overlapped. `on_frame`
/// hears of every frame in order. A frame that fails is counted and the run goes on; a failed
/// write stops the run with its error.
pub fn run_sequence(
    matcher: BlockMatcher,
    lefts: Vec<PathBuf>,
    rights: Vec<PathBuf>,
    out: &Path,
    prefetch: usize,
    mut on_frame: impl FnMut(&FrameEvent),
) -> Result<SequenceSummary> {
    sequence_outputs(&lefts, &rights, out)?;
    std::fs::create_dir_all(out).map_err(|source| PipelineError::Io {
        what: "creating",
        path: out.to_path_buf(),
        source,
    })?;
    let names: Vec<String> = lefts
        .iter()
        .map(|p| p.file_stem().map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned()))
        .collect();
    let source = lefts.into_iter().zip(rights).map(|(l, r)| load_pair(&l, &r).map_err(|e| e.to_string()));
    // the writer thread: PFM and 16-bit PNG (1/256 px) per frame, atomically
    let (tx, rx) = std::sync::mpsc::sync_channel::<(String, DisparityMap)>(2);
    let out_dir = out.to_path_buf();
    let writer = std::thread::spawn(move || -> Result<()> {
        for (name, map) in rx {
            write_frame(&out_dir, &name, &map)?;
        }
        Ok(())
    });
    let t0 = Instant::now();
    let (mut failed, mut density, mut done) = (0usize, 0.0f64, 0usize);
    for frame in matcher.frames(source, prefetch) {
        match frame {
            Ok(f) => {
                density += f.stats.density;
                done += 1;
                on_frame(&FrameEvent::Matched { name: names[f.index].clone(), density: f.stats.density });
                if tx.send((names[f.index].clone(), f.disparity)).is_err() {
                    break; // the writer failed: its error is reported below
                }
            }
            Err(e) => {
                failed += 1;
                on_frame(&FrameEvent::Failed { index: done + failed - 1, error: e.to_string() });
            }
        }
    }
    drop(tx);
    let written = writer.join().map_err(|_| PipelineError::Input("the writer thread panicked".into()))?;
    let seconds = t0.elapsed().as_secs_f64();
    written.map_err(|e| PipelineError::Input(format!("writing the disparity maps: {e}")))?;
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
    fn pair(d: u32) -> (image::GrayImage, image::GrayImage) {
        let tex = |x: u32, y: u32| image::Luma([((x.wrapping_mul(2654435761) ^ y.wrapping_mul(40503)) >> 7) as u8]);
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
        assert!(image_sequence(&dir.join("l0.png"), &dir.join("r0.png")).unwrap().is_none());
        let (ls, rs) = image_sequence(&dir.join("l*.png"), &dir.join("r*.png")).unwrap().unwrap();
        assert_eq!((ls.len(), rs.len()), (3, 3));
        let err = image_sequence(&dir.join("l*.png"), &dir.join("r0.png")).unwrap_err().to_string();
        assert!(err.contains("both"), "{err}");
        std::fs::remove_file(dir.join("r2.png")).unwrap();
        let err = image_sequence(&dir.join("l*.png"), &dir.join("r*.png")).unwrap_err().to_string();
        assert!(err.contains("3 left images but 2 right images"), "{err}");
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
        let s = run_sequence(matcher, lefts, rights, &out, 2, |e| events.push(e.clone())).unwrap();
        assert_eq!((s.frames, s.failed), (2, 1));
        assert!(matches!(&events[2], FrameEvent::Failed { index: 2, error } if error.contains("missing.png")));
        let bytes = std::fs::read(out.join("left1.pfm")).unwrap();
        let map = parallax_block_matching::from_pfm(&bytes, "left1.pfm").unwrap();
        let valid: Vec<f32> = map.data().iter().copied().filter(|v| v.is_finite()).collect();
        assert!(valid.len() > 1000, "{} valid pixels", valid.len());
        let right = valid.iter().filter(|v| (**v - 7.0).abs() < 0.5).count();
        assert!(right as f64 > 0.95 * valid.len() as f64, "{right} of {} at the true shift 7", valid.len());
        assert!(out.join("left0.png").exists());
        // the outputs of a sequence written into its own folder would replace its left images
        let (l3, r3) = (dir.join("3.png"), dir.join("3r.png"));
        l.save(&l3).unwrap();
        r.save(&r3).unwrap();
        let before = std::fs::read(&l3).unwrap();
        let m = BlockMatcher::new(parallax_block_matching::MatcherConfig { num_disparities: 16, ..Default::default() });
        let err = run_sequence(m.unwrap(), vec![l3.clone()], vec![r3], &dir, 1, |_| {}).unwrap_err().to_string();
        assert!(err.contains("is also an input"), "{err}");
        assert_eq!(std::fs::read(&l3).unwrap(), before);
        // two left images with one stem would share their outputs
        let err = sequence_outputs(&[dir.join("a/x.png"), dir.join("b/x.png")], &[], &out).unwrap_err().to_string();
        assert!(err.contains("would both be written as x.pfm"), "{err}");
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
        let w = swap_warning(&swap, false);
        assert!(w.starts_with("warning: the pair looks swapped"), "{w}");
        assert!(
            w.contains("12.3 % of the pixels") && w.contains("67.9 % with the images exchanged (half resolution)"),
            "{w}"
        );
        assert!(
            swap_warning(&swap, true).contains("pairs look swapped")
                && swap_warning(&swap, true).contains("first pair")
        );
    }
}
