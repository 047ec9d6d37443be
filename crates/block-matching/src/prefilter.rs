//! Image prefilters (OpenCV-style) and the window box sum used for texture and NCC statistics.
//!
//! Written by hand rather than with imageproc because the matcher needs exact integer output on
//! `u16` planes with clamp-to-edge borders (imageproc's Sobel returns `i16` per pixel and its box
//! filter rounds a mean), and because these run once per frame inside a build-once matcher.
//! They run on rayon's current pool (the matcher's own pool when it has one).

use rayon::prelude::*;

/// 3x3 x-Sobel (`[-1 0 1; -2 0 2; -1 0 1]`) with clamp-to-edge borders, clipped to `[−cap, cap]`
/// and shifted by `cap`: output in `0..=2·cap` (OpenCV's `PREFILTER_XSOBEL` with `preFilterCap`).
/// `src` is row-major `width x height`.
pub fn x_sobel(src: &[u16], width: usize, height: usize, cap: u32) -> Vec<u16> {
    let mut out = Vec::new();
    x_sobel_into(src, width, height, cap, &mut out);
    out
}

/// As [`x_sobel`], writing into `out` (resized to `width x height`; no allocation when it
/// already has that size).
pub fn x_sobel_into(src: &[u16], width: usize, height: usize, cap: u32, out: &mut Vec<u16>) {
    out.resize(width * height, 0);
    let cap = cap as i32;
    let w = width;
    if w == 0 || height == 0 {
        return;
    }
    // rows are independent: parallel over blocks of rows (rayon's current pool)
    out.par_chunks_mut(w * ROWS_PER_TASK).enumerate().for_each(|(t, block)| {
        for (i, o) in block.chunks_exact_mut(w).enumerate() {
            let y = t * ROWS_PER_TASK + i;
            let r0 = &src[y.saturating_sub(1) * w..][..w];
            let r1 = &src[y * w..][..w];
            let r2 = &src[(y + 1).min(height - 1) * w..][..w];
            sobel_row(r0, r1, r2, o, cap);
        }
    });
}

/// Declares `$name`, which runs `$body` compiled for AVX2 when the CPU has it and for the
/// baseline otherwise (the same code; the loops are written to vectorise, and the AVX2 copy runs
/// them at twice the baseline's width).
macro_rules! with_simd {
    (fn $name:ident($($a:ident: $t:ty),*) $body:block) => {
        fn $name($($a: $t),*) {
            #[inline(always)]
            fn imp($($a: $t),*) $body
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2($($a: $t),*) {
                imp($($a),*)
            }
            #[cfg(target_arch = "x86_64")]
            if is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2.
                return unsafe { avx2($($a),*) };
            }
            imp($($a),*)
        }
    };
}

with_simd! {
    fn sobel_row(r0: &[u16], r1: &[u16], r2: &[u16], o: &mut [u16], cap: i32) {
        let w = o.len();
        let at = |xm: usize, xp: usize| {
            let v = (r0[xp] as i32 - r0[xm] as i32) + 2 * (r1[xp] as i32 - r1[xm] as i32) + (r2[xp] as i32 - r2[xm] as i32);
            (v.clamp(-cap, cap) + cap) as u16
        };
        if w < 3 {
            for x in 0..w {
                o[x] = at(x.saturating_sub(1), (x + 1).min(w - 1));
            }
            return;
        }
        o[0] = at(0, 1);
        o[w - 1] = at(w - 2, w - 1);
        // interior without clamping, as zipped iterators so the compiler vectorises it
        let n = w - 2;
        let left = r0[..n].iter().zip(&r1[..n]).zip(&r2[..n]);
        let right = r0[2..].iter().zip(&r1[2..]).zip(&r2[2..]);
        for (v, (((&a0, &b0), &c0), ((&a2, &b2), &c2))) in o[1..1 + n].iter_mut().zip(left.zip(right)) {
            let s = (a2 as i32 - a0 as i32) + 2 * (b2 as i32 - b0 as i32) + (c2 as i32 - c0 as i32);
            *v = (s.clamp(-cap, cap) + cap) as u16;
        }
    }
}

with_simd! {
    fn abs_dev_update(col: &mut [u32], add: &[u16], sub: &[u16], cap: i32) {
        for ((c, &a), &s) in col.iter_mut().zip(add).zip(sub) {
            *c = *c + (a as i32 - cap).unsigned_abs() - (s as i32 - cap).unsigned_abs();
        }
    }
}

with_simd! {
    fn window_row_at_least(col: &[u32], pad: &mut [u32], acc: &mut [u32], r: usize, threshold: u32, out: &mut [bool]) {
        let w = col.len();
        pad[..r].fill(col[0]);
        pad[r..r + w].copy_from_slice(col);
        pad[r + w..].fill(col[w - 1]);
        acc.copy_from_slice(&pad[..w]);
        for k in 1..=2 * r {
            acc.iter_mut().zip(&pad[k..k + w]).for_each(|(a, &p)| *a += p);
        }
        for (o, &a) in out.iter_mut().zip(acc.iter()) {
            *o = a >= threshold;
        }
    }
}

/// OpenCV's texture measure: for every pixel, whether the `(2r+1) x (2r+1)` window sum of
/// `|sobel − cap|` (clamp-to-edge) reaches `threshold`. `sobel` is the output of [`x_sobel`] with
/// that `cap`. Exact in `u32` for every supported input (`cap ≤ 63·257`,
/// `r ≤ 15`).
pub fn texture_mask_into(
    sobel: &[u16],
    width: usize,
    height: usize,
    r: usize,
    cap: u32,
    threshold: u32,
    out: &mut Vec<bool>,
) {
    out.resize(width * height, false);
    if width == 0 || height == 0 {
        return;
    }
    let clamp_y = |y: isize| y.clamp(0, height as isize - 1) as usize;
    // per block of rows: vertical window sums of |sobel − cap| per column (running, vectorised
    // across columns), then the horizontal window as 2r+1 shifted adds of the clamp-padded row
    out.par_chunks_mut(width * ROWS_PER_TASK).enumerate().for_each(|(t, block)| {
        let y0 = t * ROWS_PER_TASK;
        let mut col = vec![0u32; width];
        let mut pad = vec![0u32; width + 2 * r];
        let mut acc = vec![0u32; width];
        let row = |y: isize| &sobel[clamp_y(y) * width..][..width];
        let zero = vec![cap as u16; width];
        for dy in -(r as isize)..=r as isize {
            abs_dev_update(&mut col, row(y0 as isize + dy), &zero, cap as i32);
        }
        for (i, o) in block.chunks_exact_mut(width).enumerate() {
            let y = (y0 + i) as isize;
            if i > 0 {
                abs_dev_update(&mut col, row(y + r as isize), row(y - r as isize - 1), cap as i32);
            }
            window_row_at_least(&col, &mut pad, &mut acc, r, threshold, o);
        }
    });
}

/// Rank transform: for every pixel, the number of pixels of its `size x size` neighbourhood
/// (clamp-to-edge) strictly darker than it, in `0..size² − 1`. Rows in parallel; each row is
/// `size²` vectorised compare-and-count passes over shifted padded rows.
pub fn rank_transform(src: &[u16], width: usize, height: usize, size: usize) -> Vec<u16> {
    let mut out = Vec::new();
    rank_transform_into(src, width, height, size, &mut out);
    out
}

/// As [`rank_transform`], writing into `out` (resized to `width x height`; no allocation when it
/// already has that size).
pub fn rank_transform_into(src: &[u16], width: usize, height: usize, size: usize, out: &mut Vec<u16>) {
    out.resize(width * height, 0);
    if width == 0 || height == 0 {
        return;
    }
    let r = size / 2;
    let wp = width + 2 * r;
    let clamp_y = |y: isize| y.clamp(0, height as isize - 1) as usize;
    out.par_chunks_mut(width * ROWS_PER_TASK).enumerate().for_each(|(t, block)| {
        // the window's rows, clamp-padded, in a ring: row `yy` (before clamping) in slot
        // `yy mod size` (the count does not depend on the order of the rows), so a new output
        // row pads one new row (padding all `size` for every row was ~2 % of a teddy frame)
        let mut pads = vec![0u16; size * wp];
        let pad_row = |pads: &mut [u16], yy: isize| {
            let row = &src[clamp_y(yy) * width..][..width];
            let pad = &mut pads[yy.rem_euclid(size as isize) as usize * wp..][..wp];
            pad[..r].fill(row[0]);
            pad[r..r + width].copy_from_slice(row);
            pad[r + width..].fill(row[width - 1]);
        };
        let (r, y0) = (r as isize, (t * ROWS_PER_TASK) as isize);
        for yy in y0 - r..y0 + r {
            pad_row(&mut pads, yy);
        }
        for (i, o) in block.chunks_exact_mut(width).enumerate() {
            let y = y0 + i as isize;
            pad_row(&mut pads, y + r);
            rank_row(o, &src[y as usize * width..][..width], &pads, size);
        }
    });
}

with_simd! {
    fn rank_row(count: &mut [u16], centre: &[u16], pads: &[u16], size: usize) {
        // 32 pixels at a time (two 256-bit vectors) with their counts held in
        // registers across the whole window (counting one window offset at a time over the row
        // loaded and stored every count size² times: measured 2.3 ms of an 11 ms default teddy
        // frame on one thread). Written so that the compiler vectorises it; unrolled (two
        // counts, or the window size as a constant) it did not, and took 2–8x the time.
        const L: usize = 32;
        let w = count.len();
        let wp = pads.len() / size;
        let full = w / L * L;
        for x0 in (0..full).step_by(L) {
            let c: [u16; L] = centre[x0..x0 + L].try_into().expect("L pixels");
            let mut acc = [0u16; L];
            for pad in pads.chunks_exact(wp) {
                for k in 0..size {
                    let o: [u16; L] = pad[x0 + k..x0 + k + L].try_into().expect("L pixels");
                    for l in 0..L {
                        acc[l] += (o[l] < c[l]) as u16;
                    }
                }
            }
            count[x0..x0 + L].copy_from_slice(&acc);
        }
        for x in full..w {
            let mut n = 0;
            for pad in pads.chunks_exact(wp) {
                n += pad[x..x + size].iter().filter(|&&o| o < centre[x]).count() as u16;
            }
            count[x] = n;
        }
    }
}

/// Rows per rayon task of the prefilters and box sums (small images stay on one task).
const ROWS_PER_TASK: usize = 32;

/// Intensity minus the mean of the `size x size` window (clamp-to-edge), rounded to the nearest
/// integer, clipped to `[−cap, cap]` and shifted by `cap` (output `0..=2·cap`): a local-contrast
/// response in the spirit of OpenCV's `PREFILTER_NORMALIZED_RESPONSE`.
pub fn normalized_response(src: &[u16], width: usize, height: usize, size: usize, cap: u32) -> Vec<u16> {
    let sums = box_sum(src, width, height, size / 2, |v| v as u64);
    let n = (size * size) as i64;
    let cap = cap as i64;
    src.iter()
        .zip(&sums)
        .map(|(&v, &s)| {
            // round((n·v − s) / n) with integer arithmetic, symmetric around zero
            let num = n * v as i64 - s as i64;
            let q = if num >= 0 { (2 * num + n) / (2 * n) } else { -((-2 * num + n) / (2 * n)) };
            (q.clamp(-cap, cap) + cap) as u16
        })
        .collect()
}

/// Sum of `f(pixel)` over the `(2r+1) x (2r+1)` window centred on every pixel, with clamp-to-edge
/// borders (a pixel outside the image takes the value of the nearest edge pixel), exact in `u64`.
pub fn box_sum(src: &[u16], width: usize, height: usize, r: usize, f: impl Fn(u16) -> u64 + Sync) -> Vec<u64> {
    let mut out = vec![0u64; width * height];
    if width == 0 || height == 0 {
        return out;
    }
    let clamp_x = |x: isize| x.clamp(0, width as isize - 1) as usize;
    // horizontal running sums, rows in parallel
    let mut horiz = vec![0u64; width * height];
    horiz.par_chunks_mut(width).zip(src.par_chunks(width)).for_each(|(h, row)| {
        let mut s: u64 = (-(r as isize)..=r as isize).map(|dx| f(row[clamp_x(dx)])).sum();
        h[0] = s;
        for x in 1..width {
            s += f(row[clamp_x(x as isize + r as isize)]);
            s -= f(row[clamp_x(x as isize - r as isize - 1)]);
            h[x] = s;
        }
    });
    // vertical running sums, blocks of rows in parallel (each block starts its own sum)
    let clamp_y = |y: isize| y.clamp(0, height as isize - 1) as usize;
    out.par_chunks_mut(width * ROWS_PER_TASK).enumerate().for_each(|(t, block)| {
        let y0 = t * ROWS_PER_TASK;
        let mut col = vec![0u64; width];
        for dy in -(r as isize)..=r as isize {
            let row = &horiz[clamp_y(y0 as isize + dy) * width..][..width];
            col.iter_mut().zip(row).for_each(|(c, &v)| *c += v);
        }
        for (i, o) in block.chunks_exact_mut(width).enumerate() {
            if i > 0 {
                let y = (y0 + i) as isize;
                let add = &horiz[clamp_y(y + r as isize) * width..][..width];
                let sub = &horiz[clamp_y(y - r as isize - 1) * width..][..width];
                for x in 0..width {
                    col[x] = col[x] + add[x] - sub[x];
                }
            }
            o.copy_from_slice(&col);
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_sum_matches_direct_sum_with_clamped_borders() {
        let (w, h) = (7, 5);
        let src: Vec<u16> = (0..w * h).map(|i| ((i * 37 + 11) % 251) as u16).collect();
        for r in 0..4 {
            let fast = box_sum(&src, w, h, r, |v| v as u64 * v as u64);
            for y in 0..h {
                for x in 0..w {
                    let mut s = 0u64;
                    for dy in -(r as i64)..=r as i64 {
                        for dx in -(r as i64)..=r as i64 {
                            let yy = (y as i64 + dy).clamp(0, h as i64 - 1) as usize;
                            let xx = (x as i64 + dx).clamp(0, w as i64 - 1) as usize;
                            s += src[yy * w + xx] as u64 * src[yy * w + xx] as u64;
                        }
                    }
                    assert_eq!(fast[y * w + x], s, "r {r} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn rank_transform_matches_its_definition() {
        // widths with and without a partial 32-pixel chunk, heights over several tasks (the
        // ring of padded rows restarts per task), 8- and 16-bit values with many equal ones
        for (w, h, size, modulo) in
            [(1, 1, 3, 7), (31, 5, 3, 7), (32, 40, 5, 300), (70, 70, 9, 11), (100, 33, 7, 65535), (45, 66, 11, 5)]
        {
            let src: Vec<u16> = (0..w * h).map(|i| (((i as u64 * 2654435761) >> 7) % modulo) as u16).collect();
            let fast = rank_transform(&src, w, h, size);
            let r = (size / 2) as i64;
            for y in 0..h {
                for x in 0..w {
                    let c = src[y * w + x];
                    let mut n = 0;
                    for dy in -r..=r {
                        for dx in -r..=r {
                            let yy = (y as i64 + dy).clamp(0, h as i64 - 1) as usize;
                            let xx = (x as i64 + dx).clamp(0, w as i64 - 1) as usize;
                            n += (src[yy * w + xx] < c) as u16;
                        }
                    }
                    assert_eq!(fast[y * w + x], n, "{w}x{h} size {size} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn x_sobel_of_a_ramp_is_eight_times_the_slope_clipped() {
        let (w, h) = (10, 4);
        let src: Vec<u16> = (0..w * h).map(|i| (3 * (i % w)) as u16).collect();
        let out = x_sobel(&src, w, h, 31);
        // interior: 4 · (2 · 3) = 24 → 24 + 31
        assert_eq!(out[w + 4], 55);
        // left edge (clamped): 4 · 3 = 12
        assert_eq!(out[w], 43);
        let clipped = x_sobel(&src, w, h, 10);
        assert_eq!(clipped[w + 4], 20);
    }

    #[test]
    fn normalized_response_removes_an_offset() {
        let (w, h) = (9, 9);
        let a: Vec<u16> = (0..w * h).map(|i| ((i * 13) % 40) as u16).collect();
        let b: Vec<u16> = a.iter().map(|v| v + 100).collect();
        assert_eq!(normalized_response(&a, w, h, 5, 31), normalized_response(&b, w, h, 5, 31));
    }
}
