//! Detection of a swapped pair (left and right images exchanged): match the pair both ways
//! round on a half-resolution copy and compare how much of each survives the checks.
//!
//! A rectified pair has its disparities in the searched range `[dmin, dmin + nd)`; the same
//! pair the other way round has them in `(−dmin − nd, −dmin]`. Matching both orders over the
//! configured range, the right order keeps far more pixels through the uniqueness and
//! left–right checks than the wrong one, whose matches are chance minima.

use image::{GrayImage, ImageBuffer, Luma, Primitive};
use serde::{Deserialize, Serialize};

use crate::config::{MatcherConfig, Method};
use crate::engine::BlockMatcher;
use crate::error::Result;
use crate::frame::Gray16Image;
use parallax_camera_model::DisparityMap;

/// What [`BlockMatcher::check_swap`] found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SwapCheck {
    /// Share (`0..=1`) of the half-resolution pixels with a candidate that pass the checks,
    /// pair as given.
    pub forward_density: f64,
    /// The same with the two images exchanged.
    pub reverse_density: f64,
    /// Share of the pixels with a candidate rejected by the left–right check, pair as given.
    pub forward_lr_rejected: f64,
    /// True when the exchanged pair matches clearly better (density more than 1.5 times, and
    /// at least 20 %): the images are most likely swapped.
    pub looks_swapped: bool,
}

/// The 2x2 box average (rounded) of a grayscale image; odd last rows / columns are dropped.
fn half<P: Primitive + Into<u32> + TryFrom<u32>>(img: &ImageBuffer<Luma<P>, Vec<P>>) -> ImageBuffer<Luma<P>, Vec<P>> {
    let (w, h) = ((img.width() / 2).max(1), (img.height() / 2).max(1));
    let (iw, ih) = (img.width(), img.height());
    ImageBuffer::from_fn(w, h, |x, y| {
        let px = |xx: u32, yy: u32| -> u32 { img.get_pixel((xx).min(iw - 1), (yy).min(ih - 1)).0[0].into() };
        let s = px(2 * x, 2 * y) + px(2 * x + 1, 2 * y) + px(2 * x, 2 * y + 1) + px(2 * x + 1, 2 * y + 1);
        Luma([P::try_from((s + 2) / 4).unwrap_or(P::DEFAULT_MAX_VALUE)])
    })
}

impl SwapCheck {
    fn from_runs(fwd: crate::MatchStats, rev: crate::MatchStats) -> Self {
        let share = |s: &crate::MatchStats, n: usize| {
            let candidates = s.pixels - s.no_candidate;
            if candidates == 0 { 0.0 } else { n as f64 / candidates as f64 }
        };
        let (f, r) = (share(&fwd, fwd.valid), share(&rev, rev.valid));
        SwapCheck {
            forward_density: f,
            reverse_density: r,
            forward_lr_rejected: share(&fwd, fwd.lr_inconsistent),
            looks_swapped: r > 1.5 * f && r >= 0.2,
        }
    }
}

impl BlockMatcher {
    /// The configuration of the half-resolution matcher of [`BlockMatcher::check_swap`]: the
    /// same cost and prefilter, half the window and the range, with the reliability checks on
    /// and nothing filled.
    fn swap_config(&self) -> MatcherConfig {
        let c = self.config();
        let lo = c.min_disparity.div_euclid(2);
        let hi = (c.min_disparity + c.num_disparities as i32 - 1).div_euclid(2) + 1;
        MatcherConfig {
            method: Method::BlockMatching,
            block_size: ((c.block_size / 2) | 1).max(3),
            min_disparity: lo,
            num_disparities: (hi - lo + 1) as usize,
            uniqueness_ratio: c.uniqueness_ratio.max(10),
            lr_max_diff: Some(1),
            lr_winners: false,
            fill: false,
            min_confidence: 0.0,
            confidence_map: false,
            speckle_window_size: 0,
            threads: 0,
            ..c.clone()
        }
    }

    /// Matches a half-resolution copy of the pair as given and the other way round, and says
    /// whether the images look swapped (see [`SwapCheck`]). Builds its half-resolution matcher
    /// on each call: for many frames, [`SwapChecker`] keeps one.
    pub fn check_swap(&self, left: &GrayImage, right: &GrayImage) -> Result<SwapCheck> {
        SwapChecker::new(self)?.check(left, right)
    }

    /// As [`BlockMatcher::check_swap`] for a 16-bit pair.
    pub fn check_swap_u16(&self, left: &Gray16Image, right: &Gray16Image) -> Result<SwapCheck> {
        SwapChecker::new(self)?.check_u16(left, right)
    }
}

/// The swapped-pair check of [`BlockMatcher::check_swap`] for many frames: the
/// half-resolution matcher is built once and keeps its buffers. Its cost per frame is two
/// half-resolution block matchings over half the range (each an eighth of the disparity
/// evaluations of the frame at full resolution) plus the halving of both images: measured on
/// Middlebury teddy against matching the same frame (`examples/swap_check_cost.rs`, figures in
/// `benches/RESULTS.md`), a small share of a semi-global frame, a smaller one of an
/// `--accurate` frame, and for the default block matching (the fastest matcher) a larger share,
/// still well below the matching itself — cheap enough to check every frame of a sequence.
pub struct SwapChecker {
    matcher: BlockMatcher,
}

impl SwapChecker {
    /// The check for pairs that `matcher` (its range, cost and prefilter) will match.
    pub fn new(matcher: &BlockMatcher) -> Result<Self> {
        Ok(Self { matcher: BlockMatcher::new(matcher.swap_config())? })
    }

    /// Whether the 8-bit pair looks swapped (see [`SwapCheck`]).
    pub fn check(&mut self, left: &GrayImage, right: &GrayImage) -> Result<SwapCheck> {
        crate::frame::check_pair(left.width(), left.height(), right.width(), right.height())?;
        self.both_ways(&half(left), &half(right), BlockMatcher::compute)
    }

    /// Whether the 16-bit pair looks swapped (see [`SwapCheck`]).
    pub fn check_u16(&mut self, left: &Gray16Image, right: &Gray16Image) -> Result<SwapCheck> {
        crate::frame::check_pair(left.width(), left.height(), right.width(), right.height())?;
        self.both_ways(&half(left), &half(right), BlockMatcher::compute_u16)
    }

    /// The half-resolution pair matched as given and exchanged.
    fn both_ways<I>(
        &mut self,
        l: &I,
        r: &I,
        compute: impl Fn(&mut BlockMatcher, &I, &I) -> Result<DisparityMap>,
    ) -> Result<SwapCheck> {
        compute(&mut self.matcher, l, r)?;
        let fwd = self.matcher.last_stats();
        compute(&mut self.matcher, r, l)?;
        Ok(SwapCheck::from_runs(fwd, self.matcher.last_stats()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_averages_two_by_two_blocks() {
        let img = GrayImage::from_fn(5, 3, |x, y| Luma([(10 * x + y) as u8]));
        let h = half(&img);
        assert_eq!((h.width(), h.height()), (2, 1));
        // (0+1+10+11+2)/4 = 6 (rounded), (20+21+30+31+2)/4 = 26
        assert_eq!(h.get_pixel(0, 0).0[0], 6);
        assert_eq!(h.get_pixel(1, 0).0[0], 26);
    }
}
