//! Many frames: a [`BlockMatcher`] over an iterator of rectified pairs, with the next pair
//! pulled (decoded, if the source decodes lazily) on a prefetch thread while the current one is
//! matched. No file I/O here: the source iterator brings the images.

use std::sync::mpsc::{Receiver, sync_channel};
use std::thread::JoinHandle;

use image::GrayImage;
use parallax_camera_model::DisparityMap;

use crate::engine::BlockMatcher;
use crate::error::{BlockMatchingError, Result};
use crate::frame::{Gray16Image, MatchStats};

/// A rectified pair the matcher can run on: 8- or 16-bit images, or a source's `Result` (an
/// `Err` becomes [`BlockMatchingError::Source`] for that frame).
pub trait StereoPair {
    /// Matches the pair into `out`.
    fn match_into(&self, matcher: &mut BlockMatcher, out: &mut DisparityMap) -> Result<()>;
}

impl StereoPair for (GrayImage, GrayImage) {
    fn match_into(&self, matcher: &mut BlockMatcher, out: &mut DisparityMap) -> Result<()> {
        matcher.compute_into(&self.0, &self.1, out)
    }
}

impl StereoPair for (Gray16Image, Gray16Image) {
    fn match_into(&self, matcher: &mut BlockMatcher, out: &mut DisparityMap) -> Result<()> {
        matcher.compute_u16_into(&self.0, &self.1, out)
    }
}

impl<P: StereoPair, E: std::fmt::Display> StereoPair for std::result::Result<P, E> {
    fn match_into(&self, matcher: &mut BlockMatcher, out: &mut DisparityMap) -> Result<()> {
        match self {
            Ok(p) => p.match_into(matcher, out),
            Err(e) => Err(BlockMatchingError::Source(e.to_string())),
        }
    }
}

/// One matched frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Position of the pair in the source (0-based).
    pub index: usize,
    /// The disparity map.
    pub disparity: DisparityMap,
    /// Its rejection counts and density.
    pub stats: MatchStats,
    /// Its confidence map (row-major), when the configuration asks for one.
    pub confidence: Option<Vec<f32>>,
}

/// Iterator of [`Frame`]s: see [`BlockMatcher::frames`].
pub struct Frames<P> {
    matcher: BlockMatcher,
    rx: Option<Receiver<P>>,
    prefetch: Option<JoinHandle<()>>,
    index: usize,
}

/// Most pairs [`BlockMatcher::frames`] decodes ahead: more would hold memory without keeping
/// the matcher any busier.
pub const MAX_PREFETCH: usize = 64;

impl BlockMatcher {
    /// Matches every pair of `pairs` in order, as an iterator of frames. A prefetch thread
    /// pulls up to `prefetch` pairs ahead from the source (at least 1, at most
    /// [`MAX_PREFETCH`]: the queue's slots are allocated up front), so a source that
    /// decodes images lazily decodes the next pair while this one is matched. A failing frame
    /// yields its error and the iteration goes on with the next pair.
    ///
    /// ```
    /// use image::{GrayImage, Luma};
    /// use parallax_block_matching::{BlockMatcher, MatcherConfig};
    ///
    /// let tex = |x: i64, y: i64| (((x * 7919 + y * 104_729) ^ (x * y)) % 251) as u8;
    /// let pair = move |d: i64| {
    ///     let l = GrayImage::from_fn(96, 48, |x, y| Luma([tex(x as i64, y as i64)]));
    ///     let r = GrayImage::from_fn(96, 48, |x, y| Luma([tex(x as i64 + d, y as i64)]));
    ///     (l, r)
    /// };
    /// let matcher = BlockMatcher::new(MatcherConfig { num_disparities: 16, ..Default::default() })?;
    /// let frames: Vec<_> = matcher.frames((3..6).map(pair), 2).collect::<Result<_, _>>()?;
    /// assert_eq!(frames.len(), 3);
    /// assert!((frames[2].disparity.get(50, 20).unwrap() - 5.0).abs() < 0.05);
    /// # Ok::<(), parallax_block_matching::BlockMatchingError>(())
    /// ```
    pub fn frames<I>(self, pairs: I, prefetch: usize) -> Frames<I::Item>
    where
        I: IntoIterator + Send + 'static,
        I::IntoIter: Send,
        I::Item: StereoPair + Send + 'static,
    {
        let (tx, rx) = sync_channel(prefetch.clamp(1, MAX_PREFETCH));
        let handle = std::thread::spawn(move || {
            for p in pairs {
                if tx.send(p).is_err() {
                    // the consumer dropped the iterator
                    break;
                }
            }
        });
        Frames { matcher: self, rx: Some(rx), prefetch: Some(handle), index: 0 }
    }
}

impl<P> Frames<P> {
    /// The matcher (for its configuration and instruction set).
    pub fn matcher(&self) -> &BlockMatcher {
        &self.matcher
    }
}

impl<P: StereoPair> Iterator for Frames<P> {
    type Item = Result<Frame>;

    fn next(&mut self) -> Option<Self::Item> {
        let pair = self.rx.as_ref()?.recv().ok()?;
        let index = self.index;
        self.index += 1;
        let mut disparity = DisparityMap::new_invalid(0, 0);
        Some(pair.match_into(&mut self.matcher, &mut disparity).map(|()| Frame {
            index,
            disparity,
            stats: self.matcher.last_stats(),
            confidence: self.matcher.confidence().map(<[f32]>::to_vec),
        }))
    }
}

impl<P> Drop for Frames<P> {
    fn drop(&mut self) {
        // closing the channel stops the prefetch thread at its next send
        self.rx = None;
        if let Some(h) = self.prefetch.take() {
            let _ = h.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MatcherConfig;
    use image::Luma;

    #[test]
    fn frames_match_each_pair_in_order_and_report_source_errors() {
        let tex = |x: i64, y: i64| (((x * 7919 + y * 104_729) ^ (x * y)) % 251) as u8;
        let pair = move |d: i64| -> std::result::Result<(GrayImage, GrayImage), String> {
            if d == 4 {
                return Err("cannot decode frame 4".into());
            }
            let l = GrayImage::from_fn(80, 40, |x, y| Luma([tex(x as i64, y as i64)]));
            let r = GrayImage::from_fn(80, 40, |x, y| Luma([tex(x as i64 + d, y as i64)]));
            Ok((l, r))
        };
        let cfg = MatcherConfig { num_disparities: 16, confidence_map: true, ..Default::default() };
        let mut direct = BlockMatcher::new(cfg.clone()).unwrap();
        let out: Vec<Result<Frame>> = BlockMatcher::new(cfg).unwrap().frames((2..8).map(pair), 1).collect();
        assert_eq!(out.len(), 6);
        for (i, f) in out.iter().enumerate() {
            let d = 2 + i as i64;
            match f {
                Err(e) => {
                    assert_eq!(d, 4);
                    assert_eq!(e, &BlockMatchingError::Source("cannot decode frame 4".into()));
                }
                Ok(f) => {
                    assert_eq!(f.index, i);
                    // the same map as a direct call
                    let (l, r) = pair(d).unwrap();
                    let expect = direct.compute(&l, &r).unwrap();
                    assert!(f.disparity.data().iter().zip(expect.data()).all(|(a, b)| a.to_bits() == b.to_bits()));
                    assert_eq!(f.stats, direct.last_stats());
                    assert_eq!(f.confidence.as_deref(), direct.confidence());
                    assert!((f.disparity.get(40, 20).unwrap() - d as f32).abs() < 0.05);
                }
            }
        }
        // dropping early stops the prefetch thread
        let mut it = BlockMatcher::new(MatcherConfig { num_disparities: 16, ..Default::default() })
            .unwrap()
            .frames((2..1000).map(pair), 2);
        assert!(it.next().unwrap().is_ok());
        drop(it);
    }
}
