//! Speckle filter: invalidates small 4-connected regions of similar disparity (OpenCV's
//! `filterSpeckles`). Own code because imageproc's connected components join equal values only,
//! not values within a tolerance.
//!
//! Runs and union–find rather than OpenCV's flood fill: a row is cut into runs of valid pixels
//! whose horizontal neighbours are within the tolerance, a run is joined to each run of the row
//! above that it touches through a pair of pixels within the tolerance, and a region's size is
//! the sum of its runs' lengths. Every pixel is read a few times in row order (the flood fill
//! pushed and popped each pixel and read its four neighbours at random); the regions are the
//! same, and the tests compare the result with a flood fill.

use parallax_camera_model::DisparityMap;

/// Invalidates every 4-connected region of valid pixels (neighbours differing by at most
/// `max_diff` px) that has at most `max_size` pixels. Returns the number of pixels invalidated.
pub fn filter_speckles(map: &mut DisparityMap, max_size: usize, max_diff: f32) -> usize {
    let (w, h) = (map.width(), map.height());
    if max_size == 0 || w * h == 0 {
        return 0;
    }
    let data = map.data();
    let near = |a: f32, b: f32| (a - b).abs() <= max_diff;
    // run k: first pixel `start[k]`, `len[k]` pixels, all in one row
    let (mut start, mut len, mut parent) = (Vec::<usize>::new(), Vec::<usize>::new(), Vec::<usize>::new());
    let mut above = 0..0;
    for y in 0..h {
        let row = &data[y * w..][..w];
        let first = start.len();
        let mut x = 0;
        while x < w {
            if !row[x].is_finite() {
                x += 1;
                continue;
            }
            let s = x;
            x += 1;
            while x < w && row[x].is_finite() && near(row[x], row[x - 1]) {
                x += 1;
            }
            parent.push(start.len());
            start.push(y * w + s);
            len.push(x - s);
        }
        // join the runs of this row to the overlapping runs of the row above (both lists are
        // in x order: one merge walk)
        let here = first..start.len();
        let (mut a, mut b) = (above.start, here.start);
        while a < above.end && b < here.end {
            let (xa, xb) = (start[a] - (y - 1) * w, start[b] - y * w);
            let (ea, eb) = (xa + len[a], xb + len[b]);
            let (lo, hi) = (xa.max(xb), ea.min(eb));
            if (lo..hi).any(|x| near(row[x], data[(y - 1) * w + x])) {
                union(&mut parent, a, b);
            }
            // the run that ends first cannot overlap anything further
            if ea <= eb {
                a += 1;
            } else {
                b += 1;
            }
        }
        above = here;
    }
    let mut size = vec![0usize; start.len()];
    for k in 0..start.len() {
        let r = find(&mut parent, k);
        size[r] += len[k];
    }
    let mut removed = 0;
    let out = map.data_mut();
    for k in 0..start.len() {
        let r = find(&mut parent, k);
        if size[r] <= max_size {
            out[start[k]..][..len[k]].fill(DisparityMap::INVALID);
            removed += len[k];
        }
    }
    removed
}

/// The root of `k` (halving the path on the way).
fn find(parent: &mut [usize], mut k: usize) -> usize {
    while parent[k] != k {
        let up = parent[parent[k]];
        parent[k] = up;
        k = up;
    }
    k
}

/// Joins the sets of `a` and `b` (the smaller root becomes the parent).
fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (lo, hi) = (ra.min(rb), ra.max(rb));
    parent[hi] = lo;
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The definition: a flood fill from every unlabelled valid pixel (OpenCV's algorithm; the
    /// implementation before the runs).
    fn flood_fill(map: &mut DisparityMap, max_size: usize, max_diff: f32) -> usize {
        let (w, h) = (map.width(), map.height());
        if max_size == 0 || w * h == 0 {
            return 0;
        }
        let mut label = vec![false; w * h];
        let mut removed = 0;
        for seed in 0..w * h {
            if label[seed] || !map.data()[seed].is_finite() {
                continue;
            }
            label[seed] = true;
            let (mut stack, mut region) = (vec![seed], Vec::new());
            while let Some(p) = stack.pop() {
                region.push(p);
                let d = map.data()[p];
                let (x, y) = (p % w, p / w);
                let nb =
                    [(x > 0, p.wrapping_sub(1)), (x + 1 < w, p + 1), (y > 0, p.wrapping_sub(w)), (y + 1 < h, p + w)];
                for (inside, q) in nb {
                    if inside && !label[q] && map.data()[q].is_finite() && (map.data()[q] - d).abs() <= max_diff {
                        label[q] = true;
                        stack.push(q);
                    }
                }
            }
            if region.len() <= max_size {
                for &p in &region {
                    map.data_mut()[p] = DisparityMap::INVALID;
                }
                removed += region.len();
            }
        }
        removed
    }

    #[test]
    fn removes_small_islands_and_keeps_large_regions() {
        let (w, h) = (20, 10);
        let mut m = DisparityMap::from_data(w, h, vec![10.0; w * h]).unwrap();
        // a 2x2 island of 30 px disparity and a single invalid pixel
        for (x, y) in [(5, 5), (6, 5), (5, 6), (6, 6)] {
            m.set(x, y, Some(30.0));
        }
        m.set(15, 2, None);
        // gentle slope inside tolerance stays one region
        m.set(0, 0, Some(11.5));
        let removed = filter_speckles(&mut m, 4, 2.0);
        assert_eq!(removed, 4);
        assert_eq!(m.get(5, 5), None);
        assert_eq!(m.get(0, 0), Some(11.5));
        assert_eq!(m.valid_count(), w * h - 5);
        // region of exactly max_size + 1 survives
        let mut m2 = DisparityMap::from_data(3, 1, vec![1.0, 1.0, 9.0]).unwrap();
        assert_eq!(filter_speckles(&mut m2, 1, 0.5), 1);
        assert_eq!(m2.valid_count(), 2);
    }

    #[test]
    fn a_region_joined_only_through_a_later_row_is_one_region() {
        // a U shape: the two arms meet in the bottom row only, and the left arm's runs were
        // labelled before the join (7 + 7 + 5 = 19 pixels: kept at 18, removed at 19)
        let rows = ["a.....a", "a.....a", "a.....a", "a.....a", "a.....a", "a.....a", "aaaaaaa"];
        let (w, h) = (7, rows.len());
        let data: Vec<f32> =
            rows.iter().flat_map(|r| r.bytes().map(|c| if c == b'a' { 4.0 } else { DisparityMap::INVALID })).collect();
        let mut kept = DisparityMap::from_data(w, h, data.clone()).unwrap();
        assert_eq!(filter_speckles(&mut kept, 18, 0.5), 0);
        let mut gone = DisparityMap::from_data(w, h, data).unwrap();
        assert_eq!(filter_speckles(&mut gone, 19, 0.5), 19);
        assert_eq!(gone.valid_count(), 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

        /// The runs give the flood fill's map and count on maps of a few disparity levels (so
        /// that regions touch and join through any row), invalid pixels and ±inf included.
        #[test]
        fn runs_equal_the_flood_fill(
            w in 1usize..40,
            h in 1usize..30,
            seed in any::<u64>(),
            max_size in 0usize..60,
            max_diff in prop_oneof![Just(0.0f32), Just(0.5), Just(1.0), Just(2.5)],
        ) {
            let mut s = seed | 1;
            let data: Vec<f32> = (0..w * h)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    match s % 11 {
                        0 => DisparityMap::INVALID,
                        1 => f32::INFINITY,
                        k => 10.0 + (k % 4) as f32 * 0.75 + ((s >> 20) % 3) as f32 * 0.25,
                    }
                })
                .collect();
            let mut fast = DisparityMap::from_data(w, h, data.clone()).unwrap();
            let mut reference = DisparityMap::from_data(w, h, data).unwrap();
            let n = filter_speckles(&mut fast, max_size, max_diff);
            prop_assert_eq!(n, flood_fill(&mut reference, max_size, max_diff));
            for (a, b) in fast.data().iter().zip(reference.data()) {
                prop_assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
            }
        }
    }
}
