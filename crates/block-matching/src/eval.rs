//! Middlebury-style evaluation in both conventions: bad-N over a mask with missing pixels
//! counted as bad, and bad-N among the pixels the matcher returned, with the density; and the
//! same over the columns where OpenCV's matchers also answer ([`evaluate_overlap`]), for a
//! like-for-like comparison with a map that leaves the left band empty.

use parallax_camera_model::DisparityMap;
use serde::{Deserialize, Serialize};

use crate::error::{BlockMatchingError, Result};

/// Accuracy of a disparity map against ground truth over the evaluated pixels (known truth and,
/// if given, inside the mask).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// Pixels evaluated.
    pub evaluated: usize,
    /// `(threshold px, percent bad)`: `|d − truth| > threshold` or no disparity, in percent of
    /// the evaluated pixels.
    pub bad: Vec<(f32, f64)>,
    /// `(threshold px, percent bad)` among the evaluated pixels that have a disparity
    /// (`NaN` when none has).
    pub bad_returned: Vec<(f32, f64)>,
    /// Percent of the evaluated pixels that have a disparity.
    pub density: f64,
    /// RMS error in px over the evaluated pixels that have a disparity.
    pub rms: f64,
}

impl Evaluation {
    /// Percent bad at `threshold` (`None` if it was not evaluated).
    pub fn bad_at(&self, threshold: f32) -> Option<f64> {
        self.bad.iter().find(|(t, _)| *t == threshold).map(|&(_, b)| b)
    }

    /// Percent bad at `threshold` among the returned pixels (`None` if it was not evaluated).
    pub fn bad_returned_at(&self, threshold: f32) -> Option<f64> {
        self.bad_returned.iter().find(|(t, _)| *t == threshold).map(|&(_, b)| b)
    }
}

/// The columns `x` of a `width`-pixel row where OpenCV's `StereoSGBM` answers for the range
/// `[min_disparity, min_disparity + num_disparities)`: `max(min_disparity + num_disparities, 0)
/// ≤ x < width + min(min_disparity, 0)` (its `minX1`, `maxX1`; for `min_disparity ≥ 0` that is
/// `x ≥ min_disparity + num_disparities`). Left of it some candidate of every pixel falls outside
/// the right image, and OpenCV returns nothing there. Empty when the range is as wide as the image.
pub fn overlap_columns(width: usize, min_disparity: i32, num_disparities: usize) -> std::ops::Range<usize> {
    let start = (min_disparity as i64 + num_disparities as i64).clamp(0, width as i64) as usize;
    let end = (width as i64 + (min_disparity as i64).min(0)).clamp(0, width as i64) as usize;
    start..end.max(start)
}

/// [`evaluate`] over the pixels of `mask` (`None`: every known pixel) in the
/// [`overlap_columns`] of the range `[min_disparity, min_disparity + num_disparities)`, where
/// OpenCV's matchers also answer: the like-for-like figures against a map that leaves the left
/// band empty. Refused as [`evaluate`] when no such pixel has known truth.
pub fn evaluate_overlap(
    disparity: &DisparityMap,
    truth: &DisparityMap,
    mask: Option<&[bool]>,
    range: (i32, usize),
    thresholds: &[f32],
) -> Result<Evaluation> {
    let w = disparity.width();
    let cols = overlap_columns(w, range.0, range.1);
    let n = w * disparity.height();
    if let Some(m) = mask.filter(|m| m.len() != n) {
        return Err(BlockMatchingError::LengthMismatch {
            what: "evaluation mask",
            width: w,
            height: disparity.height(),
            expected: n,
            got: m.len(),
        });
    }
    let inside: Vec<bool> = (0..n).map(|i| cols.contains(&(i % w.max(1))) && mask.is_none_or(|m| m[i])).collect();
    evaluate(disparity, truth, Some(&inside), thresholds)
}

/// Evaluates `disparity` against `truth` (invalid truth = unknown, skipped) over `mask`
/// (row-major, `true` = evaluate; `None` = every known pixel), for each threshold.
pub fn evaluate(
    disparity: &DisparityMap,
    truth: &DisparityMap,
    mask: Option<&[bool]>,
    thresholds: &[f32],
) -> Result<Evaluation> {
    let (w, h) = (disparity.width(), disparity.height());
    if (truth.width(), truth.height()) != (w, h) || truth.data().len() != w * h || disparity.data().len() != w * h {
        return Err(BlockMatchingError::SizeMismatch {
            what: "ground truth",
            width: w,
            height: h,
            got_width: truth.width(),
            got_height: truth.height(),
        });
    }
    if let Some(m) = mask.filter(|m| m.len() != w * h) {
        return Err(BlockMatchingError::LengthMismatch {
            what: "evaluation mask",
            width: w,
            height: h,
            expected: w.saturating_mul(h),
            got: m.len(),
        });
    }
    let mut evaluated = 0usize;
    let mut valid = 0usize;
    let mut bad = vec![0usize; thresholds.len()];
    let mut bad_valid = vec![0usize; thresholds.len()];
    let mut sq = 0.0f64;
    for i in 0..w * h {
        let t = truth.data()[i];
        if !t.is_finite() || mask.is_some_and(|m| !m[i]) {
            continue;
        }
        evaluated += 1;
        let d = disparity.data()[i];
        if d.is_finite() {
            valid += 1;
            let e = (d - t).abs();
            sq += (e as f64) * (e as f64);
            for ((b, bv), &th) in bad.iter_mut().zip(bad_valid.iter_mut()).zip(thresholds) {
                *b += (e > th) as usize;
                *bv += (e > th) as usize;
            }
        } else {
            bad.iter_mut().for_each(|b| *b += 1);
        }
    }
    if evaluated == 0 {
        return Err(BlockMatchingError::NothingToEvaluate("no pixel has known ground truth inside the mask".into()));
    }
    let pct = |n: usize| 100.0 * n as f64 / evaluated as f64;
    Ok(Evaluation {
        evaluated,
        bad: thresholds.iter().zip(&bad).map(|(&t, &b)| (t, pct(b))).collect(),
        bad_returned: thresholds
            .iter()
            .zip(&bad_valid)
            .map(|(&t, &b)| (t, if valid > 0 { 100.0 * b as f64 / valid as f64 } else { f64::NAN }))
            .collect(),
        density: pct(valid),
        rms: if valid > 0 { (sq / valid as f64).sqrt() } else { f64::NAN },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_columns_are_opencvs_for_any_range() {
        // x ≥ min + n, and with a negative min also x < width + min
        assert_eq!(overlap_columns(10, 0, 4), 4..10);
        assert_eq!(overlap_columns(10, 2, 4), 6..10);
        assert_eq!(overlap_columns(10, -3, 4), 1..7);
        assert_eq!(overlap_columns(10, -8, 4), 0..2);
        assert_eq!(overlap_columns(10, 0, 10), 10..10);
        assert_eq!(overlap_columns(10, 0, 64), 10..10);
        assert_eq!(overlap_columns(10, -20, 4), 0..0);
    }

    /// A 6x2 map and truth made by hand, range [0, 2): the overlap is x ≥ 2. Counted by hand,
    /// pixel by pixel (t = truth, d = disparity, m = mask):
    ///
    /// ```text
    /// row 0  x:  0    1    2    3    4    5
    ///        t:  1    1    3    3    3    NaN
    ///        d:  NaN  1    3.5  6    NaN  3
    ///        m:  1    1    1    1    1    1
    /// row 1  t:  2    2    2    2    2    2
    ///        d:  2    9    2    2.5  4.5  2
    ///        m:  1    1    1    0    1    1
    /// ```
    ///
    /// Whole mask: 10 evaluated (11 masked, (5, 0) unknown), 8 returned, bad-2 = (0,0) missing,
    /// (3,0) off 3, (4,0) missing, (1,1) off 7, (4,1) off 2.5 = 5 → 50 %, density 80 %.
    /// Overlap (x ≥ 2): (2,0) (3,0) (4,0) (2,1) (4,1) (5,1) = 6 evaluated, 5 returned, bad-2 =
    /// (3,0) (4,0) (4,1) = 3 → 50 %, density 5/6; bad-2 among the returned 2/5 = 40 %.
    #[test]
    fn the_overlap_figures_are_those_counted_by_hand() {
        let nan = f32::NAN;
        let truth =
            DisparityMap::from_data(6, 2, vec![1.0, 1.0, 3.0, 3.0, 3.0, nan, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0]).unwrap();
        let d =
            DisparityMap::from_data(6, 2, vec![nan, 1.0, 3.5, 6.0, nan, 3.0, 2.0, 9.0, 2.0, 2.5, 4.5, 2.0]).unwrap();
        let mut mask = vec![true; 12];
        mask[9] = false;
        let all = evaluate(&d, &truth, Some(&mask), &[2.0]).unwrap();
        assert_eq!(all.evaluated, 10);
        assert_eq!(all.bad_at(2.0), Some(50.0));
        assert_eq!(all.density, 80.0);
        let o = evaluate_overlap(&d, &truth, Some(&mask), (0, 2), &[2.0]).unwrap();
        assert_eq!(o.evaluated, 6);
        assert_eq!(o.bad_at(2.0), Some(50.0));
        assert_eq!(o.density, 500.0 / 6.0);
        assert_eq!(o.bad_returned_at(2.0), Some(40.0));
        // without a mask (3,1) is evaluated too: returned, off 0.5 → 7 evaluated, 6 returned
        let o = evaluate_overlap(&d, &truth, None, (0, 2), &[2.0]).unwrap();
        assert_eq!((o.evaluated, o.bad_at(2.0), o.density), (7, Some(300.0 / 7.0), 600.0 / 7.0));
        // range [1, 4): overlap x ≥ 5 holds (5,1) alone (truth unknown at (5,0)): good, returned
        let o = evaluate_overlap(&d, &truth, Some(&mask), (1, 4), &[2.0]).unwrap();
        assert_eq!((o.evaluated, o.bad_at(2.0), o.density), (1, Some(0.0), 100.0));
        // a range as wide as the image leaves nothing to compare: refused, not 0 %
        assert!(evaluate_overlap(&d, &truth, Some(&mask), (0, 6), &[2.0]).is_err());
        assert!(evaluate_overlap(&d, &truth, Some(&mask[..5]), (0, 2), &[2.0]).is_err());
    }

    #[test]
    fn a_mask_of_the_wrong_length_is_reported_as_a_length_never_as_nx1() {
        let m = DisparityMap::from_data(4, 3, vec![1.0; 12]).unwrap();
        let err = evaluate(&m, &m, Some(&[true; 5]), &[1.0]).unwrap_err().to_string();
        assert!(err.contains("evaluation mask has 5 values, expected 4x3 = 12"), "{err}");
        assert!(!err.contains("5x1"), "{err}");
        let err = crate::from_scaled(&[1, 2, 3], 2, 2, 1.0).unwrap_err().to_string();
        assert!(err.contains("3 values, expected 2x2 = 4"), "{err}");
    }

    #[test]
    fn counts_missing_as_bad_and_respects_mask_and_unknown_truth() {
        let truth = DisparityMap::from_data(4, 1, vec![10.0, 10.0, f32::NAN, 10.0]).unwrap();
        let d = DisparityMap::from_data(4, 1, vec![10.5, 13.0, 1.0, f32::NAN]).unwrap();
        let e = evaluate(&d, &truth, None, &[1.0, 2.0]).unwrap();
        assert_eq!(e.evaluated, 3);
        assert!((e.bad_at(1.0).unwrap() - 200.0 / 3.0).abs() < 1e-9);
        assert!((e.bad_at(2.0).unwrap() - 200.0 / 3.0).abs() < 1e-9);
        assert!((e.density - 200.0 / 3.0).abs() < 1e-9);
        // among the two returned pixels only 13.0 is off by more than 2 (and by more than 1)
        assert!((e.bad_returned_at(1.0).unwrap() - 50.0).abs() < 1e-9);
        assert!((e.bad_returned_at(2.0).unwrap() - 50.0).abs() < 1e-9);
        assert!((e.rms - ((0.25 + 9.0) / 2.0f64).sqrt()).abs() < 1e-9);
        let mask = [true, false, true, false];
        let e = evaluate(&d, &truth, Some(&mask), &[1.0]).unwrap();
        assert_eq!((e.evaluated, e.bad_at(1.0), e.density), (1, Some(0.0), 100.0));
        assert!(evaluate(&d, &truth, Some(&[false; 4]), &[1.0]).is_err());
        assert!(evaluate(&d, &DisparityMap::new_invalid(3, 1), None, &[1.0]).is_err());
    }
}
