//! Speckle filter: invalidates small 4-connected regions of similar disparity (OpenCV's
//! `filterSpeckles`). Own code because imageproc's connected components join equal values only,
//! not values within a tolerance.

use parallax_camera_model::DisparityMap;

/// Invalidates every 4-connected region of valid pixels (neighbours differing by at most
/// `max_diff` px) that has at most `max_size` pixels. Returns the number of pixels invalidated.
pub fn filter_speckles(map: &mut DisparityMap, max_size: usize, max_diff: f32) -> usize {
    let (w, h) = (map.width(), map.height());
    if max_size == 0 || w * h == 0 {
        return 0;
    }
    let mut label = vec![0u32; w * h];
    let mut stack = Vec::new();
    let mut region = Vec::new();
    let mut removed = 0;
    let mut next = 0u32;
    for start in 0..w * h {
        if label[start] != 0 || !map.data()[start].is_finite() {
            continue;
        }
        next += 1;
        label[start] = next;
        stack.push(start);
        region.clear();
        while let Some(p) = stack.pop() {
            region.push(p);
            let d = map.data()[p];
            let (x, y) = (p % w, p / w);
            let mut visit = |q: usize| {
                let dq = map.data()[q];
                if label[q] == 0 && dq.is_finite() && (dq - d).abs() <= max_diff {
                    label[q] = next;
                    stack.push(q);
                }
            };
            if x > 0 {
                visit(p - 1);
            }
            if x + 1 < w {
                visit(p + 1);
            }
            if y > 0 {
                visit(p - w);
            }
            if y + 1 < h {
                visit(p + w);
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
