//! Image prefilters (OpenCV-style) and the window box sum used for texture and NCC statistics.
//!
//! Written by hand rather than with imageproc because the matcher needs exact integer output on
//! `u16` planes with clamp-to-edge borders (imageproc's Sobel returns `i16` per pixel and its box
//! filter rounds a mean), and because these run once per frame inside a build-once matcher.
//! They run on rayon's current pool (the matcher's own pool when it has one).

use std::ops::{Add, Sub};

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
    x_sobel_any(src, width, height, cap, out);
}

/// [`x_sobel_into`] of an 8-bit image, summed in 16-bit lanes (twice as many a vector as the
/// 16-bit image's 32-bit sums).
pub(crate) fn x_sobel_u8_into(src: &[u8], width: usize, height: usize, cap: u32, out: &mut Vec<u16>) {
    x_sobel_any(src, width, height, cap, out);
}

/// A pixel the x-Sobel reads, with the sum it needs.
trait SobelPixel: Copy + Send + Sync {
    /// `(a2 − a0) + 2 (b2 − b0) + (c2 − c0)` clipped to `[−cap, cap]`, plus `cap`.
    fn sobel(a0: Self, b0: Self, c0: Self, a2: Self, b2: Self, c2: Self, cap: u32) -> u16;
}

impl SobelPixel for u16 {
    #[inline(always)]
    fn sobel(a0: u16, b0: u16, c0: u16, a2: u16, b2: u16, c2: u16, cap: u32) -> u16 {
        let cap = cap as i32;
        let v = (a2 as i32 - a0 as i32) + 2 * (b2 as i32 - b0 as i32) + (c2 as i32 - c0 as i32);
        (v.clamp(-cap, cap) + cap) as u16
    }
}

impl SobelPixel for u8 {
    #[inline(always)]
    fn sobel(a0: u8, b0: u8, c0: u8, a2: u8, b2: u8, c2: u8, cap: u32) -> u16 {
        // |v| ≤ 4 · 255: exact in i16, and clipping at min(cap, 1020) is clipping at cap; the
        // output 0..=2·cap (cap < 2^15) is the wrapping sum in u16
        let c = cap.min(1020) as i16;
        let v = (a2 as i16 - a0 as i16) + 2 * (b2 as i16 - b0 as i16) + (c2 as i16 - c0 as i16);
        (v.clamp(-c, c) as u16).wrapping_add(cap as u16)
    }
}

fn x_sobel_any<P: SobelPixel>(src: &[P], width: usize, height: usize, cap: u32, out: &mut Vec<u16>) {
    out.resize(width * height, 0);
    assert!(cap < 1 << 15, "x-Sobel cap {cap}");
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
    (fn $name:ident $(<$g:ident: $bound:path>)? ($($a:ident: $t:ty),*) $body:block) => {
        fn $name $(<$g: $bound>)? ($($a: $t),*) {
            #[inline(always)]
            fn imp $(<$g: $bound>)? ($($a: $t),*) $body
            #[cfg(target_arch = "x86_64")]
            if let Some(t) = parallax_simd::Avx2::new() {
                return parallax_simd::Level::vectorize(t, #[inline(always)] || imp($($a),*));
            }
            imp($($a),*)
        }
    };
}

with_simd! {
    fn sobel_row<P: SobelPixel>(r0: &[P], r1: &[P], r2: &[P], o: &mut [u16], cap: u32) {
        let w = o.len();
        let at = |xm: usize, xp: usize| P::sobel(r0[xm], r1[xm], r2[xm], r0[xp], r1[xp], r2[xp], cap);
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
            *v = P::sobel(a0, b0, c0, a2, b2, c2, cap);
        }
    }
}

/// The texture measure's sums: `u16` when every window sum fits (8-bit input: at most
/// `(2r + 1)² · 31`), twice as many a vector as `u32`.
trait TexSum: Copy + Default + Send + Sync + PartialOrd + Add<Output = Self> + Sub<Output = Self> {
    /// `|v − cap|`.
    fn dev(v: u16, cap: u16) -> Self;
    fn from_u32(v: u32) -> Self;
}

impl TexSum for u16 {
    #[inline(always)]
    fn dev(v: u16, cap: u16) -> u16 {
        v.abs_diff(cap)
    }
    #[inline(always)]
    fn from_u32(v: u32) -> u16 {
        v as u16
    }
}

impl TexSum for u32 {
    #[inline(always)]
    fn dev(v: u16, cap: u16) -> u32 {
        v.abs_diff(cap) as u32
    }
    #[inline(always)]
    fn from_u32(v: u32) -> u32 {
        v
    }
}

with_simd! {
    fn abs_dev_update<S: TexSum>(col: &mut [S], add: &[u16], sub: &[u16], cap: u16) {
        // col holds |sub − cap|: never below zero
        for ((c, &a), &s) in col.iter_mut().zip(add).zip(sub) {
            *c = *c + S::dev(a, cap) - S::dev(s, cap);
        }
    }
}

with_simd! {
    fn abs_dev_add<S: TexSum>(col: &mut [S], add: &[u16], cap: u16) {
        for (c, &a) in col.iter_mut().zip(add) {
            *c = *c + S::dev(a, cap);
        }
    }
}

with_simd! {
    fn window_row_at_least<S: TexSum>(col: &[S], s: &mut [S], t: &mut [S], acc: &mut [S], r: usize, threshold: S, out: &mut [bool]) {
        // the window of n = 2r + 1 columns by doubling: s holds the sums of m = 1, 2, 4, …
        // consecutive padded columns, and acc adds those of the set bits of n, side by side
        // (5 passes instead of 9 at r = 4, 7 instead of 15 at r = 7; exact integers, so the
        // order does not matter)
        let (w, n) = (col.len(), 2 * r + 1);
        let wp = w + 2 * r;
        s[..r].fill(col[0]);
        s[r..r + w].copy_from_slice(col);
        s[r + w..wp].fill(col[w - 1]);
        let (mut s, mut t) = (&mut s[..wp], &mut t[..wp]);
        let (mut m, mut off, mut first) = (1, 0, true);
        loop {
            if n & m != 0 {
                if first {
                    acc.copy_from_slice(&s[off..off + w]);
                    first = false;
                } else {
                    acc.iter_mut().zip(&s[off..off + w]).for_each(|(a, &v)| *a = *a + v);
                }
                off += m;
            }
            if 2 * m > n {
                break;
            }
            // sums of 2m columns from those of m: valid at x while x + 2m ≤ wp
            let len = wp + 1 - 2 * m;
            t[..len].iter_mut().zip(s[..len].iter().zip(&s[m..m + len])).for_each(|(d, (&a, &b))| *d = a + b);
            (s, t) = (t, s);
            m *= 2;
        }
        for (o, &a) in out.iter_mut().zip(acc.iter()) {
            *o = a >= threshold;
        }
    }
}

/// Where [`TextureRows`] reads: the x-Sobel plane of the left image (output of [`x_sobel`] with
/// `cap`), its size, the window radius and the threshold, and which frame the plane is (a
/// row's running sums are only carried on within one frame).
#[derive(Clone, Copy)]
pub(crate) struct TextureSource<'a> {
    pub(crate) sobel: &'a [u16],
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) r: usize,
    pub(crate) cap: u32,
    pub(crate) threshold: u32,
    pub(crate) frame: u64,
}

/// The running sums of [`TextureRows`] in one sum type.
#[derive(Default)]
struct Sums<S> {
    /// Vertical window sums of `|sobel − cap|` per column.
    col: Vec<S>,
    s: Vec<S>,
    t: Vec<S>,
    acc: Vec<S>,
}

impl<S: TexSum> Sums<S> {
    /// Moves `col` to row `y` (from row `from` of the same frame when given) and writes the
    /// row's outcome.
    fn row(&mut self, src: &TextureSource, y: usize, from: Option<usize>, out: &mut [bool]) {
        let (w, h, r) = (src.w, src.h, src.r);
        if self.col.len() != w || self.s.len() != w + 2 * r {
            self.col.resize(w, S::default());
            self.s.resize(w + 2 * r, S::default());
            self.t.resize(w + 2 * r, S::default());
            self.acc.resize(w, S::default());
        }
        let row = |yy: isize| &src.sobel[yy.clamp(0, h as isize - 1) as usize * w..][..w];
        let (yi, ri, cap) = (y as isize, r as isize, src.cap as u16);
        match from {
            Some(a) if a + 1 == y => abs_dev_update(&mut self.col, row(yi + ri), row(yi - ri - 1), cap),
            Some(a) if a == y + 1 => abs_dev_update(&mut self.col, row(yi - ri), row(yi + ri + 1), cap),
            _ => {
                self.col.fill(S::default());
                for dy in -ri..=ri {
                    abs_dev_add(&mut self.col, row(yi + dy), cap);
                }
            }
        }
        // a threshold above every window sum (n · cap) fails every pixel, as n · cap + 1 does
        let n = ((2 * r + 1) * (2 * r + 1)) as u32;
        let threshold = S::from_u32(src.threshold.min(n * src.cap + 1));
        window_row_at_least(&self.col, &mut self.s, &mut self.t, &mut self.acc, r, threshold, out);
    }
}

/// OpenCV's texture measure ([`texture_mask_into`]) one row at a time: a band computes the rows
/// it decides on its own thread, the vertical window sums carried from row to row (up or down).
/// As its own parallel step before the bands it took ~7 % of a teddy frame on 2 threads, and
/// the frame ~16 % longer than without the measure (this Intel Xeon).
#[derive(Default)]
pub(crate) struct TextureRows {
    narrow: Sums<u16>,
    wide: Sums<u32>,
    row: Vec<bool>,
    /// Frame and row of the sums held (the frame decides the sum type).
    at: Option<(u64, usize)>,
}

impl TextureRows {
    /// Whether each pixel of row `y` passes the texture threshold.
    pub(crate) fn row(&mut self, src: &TextureSource, y: usize) -> &[bool] {
        let (w, h, r) = (src.w, src.h, src.r);
        assert!(y < h && src.sobel.len() == w * h && w > 0 && src.cap < 1 << 15 && r <= 15);
        let n = ((2 * r + 1) * (2 * r + 1)) as u64;
        // the threshold is clamped to n · cap + 1, which must fit too
        let narrow = n * (src.cap as u64) < u16::MAX as u64;
        if self.row.len() != w {
            self.row.resize(w, false);
            self.at = None;
        }
        let from = match self.at {
            Some((f, a)) if f == src.frame => {
                if a == y {
                    return &self.row;
                }
                Some(a)
            }
            _ => None,
        };
        if narrow {
            self.narrow.row(src, y, from, &mut self.row);
        } else {
            self.wide.row(src, y, from, &mut self.row);
        }
        self.at = Some((src.frame, y));
        &self.row
    }
}

/// OpenCV's texture measure: for every pixel, whether the `(2r+1) x (2r+1)` window sum of
/// `|sobel − cap|` (clamp-to-edge) reaches `threshold`. `sobel` is the output of [`x_sobel`] with
/// that `cap`. Exact in `u32` for every supported input (`cap ≤ 63·257`,
/// `r ≤ 15`). The matcher computes the same per band ([`TextureRows`]).
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
    let src = TextureSource { sobel, w: width, h: height, r, cap, threshold, frame: 0 };
    out.par_chunks_mut(width * ROWS_PER_TASK).enumerate().for_each(|(t, block)| {
        let mut rows = TextureRows::default();
        for (i, o) in block.chunks_exact_mut(width).enumerate() {
            o.copy_from_slice(rows.row(&src, t * ROWS_PER_TASK + i));
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
pub(crate) const ROWS_PER_TASK: usize = 32;

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

    /// A xorshift generator (deterministic test data).
    fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        }
    }

    /// The texture measure by its definition: the clamp-to-edge window sum of `|sobel − cap|`.
    fn texture_direct(sobel: &[u16], w: usize, h: usize, r: usize, cap: u32, threshold: u32, y: usize) -> Vec<bool> {
        let r = r as i64;
        (0..w)
            .map(|x| {
                let mut s = 0u64;
                for dy in -r..=r {
                    for dx in -r..=r {
                        let yy = (y as i64 + dy).clamp(0, h as i64 - 1) as usize;
                        let xx = (x as i64 + dx).clamp(0, w as i64 - 1) as usize;
                        s += (sobel[yy * w + xx] as i64 - cap as i64).unsigned_abs();
                    }
                }
                s >= threshold as u64
            })
            .collect()
    }

    #[test]
    fn texture_rows_match_the_definition_in_any_row_order_and_across_frames() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut seen = [0usize; 2];
        for (w, h) in [(1, 1), (2, 9), (17, 12), (40, 23)] {
            for r in [0, 1, 2, 4, 5, 7] {
                for cap in [31u32, 31 * 257] {
                    // one scratch for every frame: its sums must never carry over a frame
                    let mut rows = TextureRows::default();
                    for frame in 0..5u64 {
                        // values clustered near cap (many small deviations), some far off; in
                        // the last two frames every value 0 (the largest sums, n · cap), at a
                        // threshold of n · cap and one above any u16 sum
                        let n = ((2 * r + 1) * (2 * r + 1)) as u32;
                        let sobel: Vec<u16> = (0..w * h)
                            .map(|_| {
                                if frame >= 3 {
                                    return 0;
                                }
                                let v = next();
                                let dev = if v.is_multiple_of(4) { v >> 8 } else { (v >> 8) % 5 } % (cap as u64 + 1);
                                (if v & 2 == 0 { cap as u64 + dev } else { cap as u64 - dev }) as u16
                            })
                            .collect();
                        let threshold = match frame {
                            3 => n * cap,
                            4 => 70_000,
                            _ => 1 + (next() % (3 * n as u64)) as u32,
                        };
                        let src = TextureSource { sobel: &sobel, w, h, r, cap, threshold, frame };
                        // down, up, the same row twice, jumps
                        let mut order: Vec<usize> = (0..h).chain((0..h).rev()).collect();
                        order.extend((0..2 * h).map(|_| (next() % h as u64) as usize));
                        for &y in &order {
                            let want = texture_direct(&sobel, w, h, r, cap, threshold, y);
                            assert_eq!(rows.row(&src, y), &want[..], "{w}x{h} r {r} cap {cap} frame {frame} y {y}");
                            want.iter().for_each(|&t| seen[t as usize] += 1);
                        }
                        let mut all = Vec::new();
                        texture_mask_into(&sobel, w, h, r, cap, threshold, &mut all);
                        for y in 0..h {
                            let want = texture_direct(&sobel, w, h, r, cap, threshold, y);
                            assert_eq!(&all[y * w..][..w], &want[..], "texture_mask_into {w}x{h} r {r} y {y}");
                        }
                    }
                }
            }
        }
        // both outcomes, often
        assert!(seen[0] > 1000 && seen[1] > 1000, "{seen:?}");
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
    fn x_sobel_of_8_bit_pixels_in_16_bit_lanes_matches_the_32_bit_sums() {
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        for (w, h) in [(1, 1), (2, 3), (3, 2), (33, 7), (70, 40)] {
            // full-range noise, then columns 0, 0, 255, 255, … (|sum| 4 · 255 at the steps)
            let px: Vec<u8> = (0..w * h)
                .map(|i| {
                    let v = next();
                    if i / w < h / 2 {
                        (v >> 32) as u8
                    } else if i % w % 4 < 2 {
                        0
                    } else {
                        255
                    }
                })
                .collect();
            let wide: Vec<u16> = px.iter().map(|&v| v as u16).collect();
            for cap in [1, 31, 63, 1019, 1020, 1021, 63 * 257] {
                let mut narrow = Vec::new();
                x_sobel_u8_into(&px, w, h, cap, &mut narrow);
                assert_eq!(narrow, x_sobel(&wide, w, h, cap), "{w}x{h} cap {cap}");
            }
        }
    }

    #[test]
    fn normalized_response_removes_an_offset() {
        let (w, h) = (9, 9);
        let a: Vec<u16> = (0..w * h).map(|i| ((i * 13) % 40) as u16).collect();
        let b: Vec<u16> = a.iter().map(|v| v + 100).collect();
        assert_eq!(normalized_response(&a, w, h, 5, 31), normalized_response(&b, w, h, 5, 31));
    }
}
