//! Small image helpers shared by the detectors: `f32` conversion, Gaussian smoothing (through
//! imageproc's separable filter), bilinear sampling and Hessian/saddle responses.

use image::{GrayImage, ImageBuffer, Luma};

use parallax_simd::Avx2;

use crate::{CornerError, Result};

/// A single-channel `f32` image (grey levels keep the 0..255 scale of the input).
pub type ImageF32 = ImageBuffer<Luma<f32>, Vec<f32>>;

/// The instruction set a hand-vectorised kernel runs: `None` the baseline (SSE2 on x86-64, or
/// any other architecture), `Some(token)` AVX2, which the `parallax_simd` token proves the CPU
/// runs (what makes calling the matching `#[target_feature]` copy sound).
pub(crate) type Isa = Option<Avx2>;

/// Every instruction set this CPU runs, baseline first (tests run each kernel on each).
#[cfg(test)]
pub(crate) fn available_isas() -> Vec<Isa> {
    std::iter::once(None).chain(Avx2::new().map(Some)).collect()
}

/// Converts an 8-bit image to `f32` grey levels (0..255).
pub fn to_f32(img: &GrayImage) -> ImageF32 {
    ImageBuffer::from_raw(img.width(), img.height(), img.as_raw().iter().map(|&v| v as f32).collect())
        .expect("buffer size matches the image")
}

/// Normalised Gaussian kernel truncated at 3σ (imageproc's own truncates at 2σ, which leaves
/// a visible step in second derivatives).
pub(crate) fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let radius = (3.0 * sigma).ceil().max(1.0) as i32;
    let mut k: Vec<f32> = (-radius..=radius).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
    let sum: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    k
}

/// Gaussian smoothing of an `f32` image (kernel truncated at 3σ, borders replicated);
/// `sigma <= 0` returns a copy.
///
/// Our own separable filter rather than imageproc's `separable_filter_equal`: both passes are
/// whole-row filters (`fir`, over a padded row horizontally and over whole rows vertically),
/// vectorised per instruction set; on a 640x480 image with σ = 1.5 the first version (one
/// multiply-add pass per tap) measured ~1 ms against imageproc's ~9.6 ms (release build, same
/// machine).
pub fn gaussian_blur(img: &ImageF32, sigma: f64) -> ImageF32 {
    if sigma <= 0.0 || img.width() == 0 || img.height() == 0 {
        return img.clone();
    }
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut scratch = BlurScratch::default();
    let mut dst = Vec::new();
    gaussian_blur_into(img.as_raw(), w, h, sigma, &mut scratch, &mut dst);
    ImageBuffer::from_raw(w as u32, h as u32, dst).expect("buffer size matches the image")
}

/// Reusable buffers of [`gaussian_blur_into`] (the horizontal pass and one padded row).
#[derive(Debug, Default, Clone)]
pub(crate) struct BlurScratch {
    tmp: Vec<f32>,
    padded: Vec<f32>,
    offsets: Vec<usize>,
    kernel: Vec<f32>,
    kernel_sigma: f64,
}

/// [`gaussian_blur`] of the `w x h` buffer `src` into `dst` (resized), with buffers reused from
/// one call to the next (no allocation once they have grown to the image size).
pub(crate) fn gaussian_blur_into(
    src: &[f32],
    w: usize,
    h: usize,
    sigma: f64,
    scratch: &mut BlurScratch,
    dst: &mut Vec<f32>,
) {
    debug_assert_eq!(src.len(), w * h);
    if sigma <= 0.0 || w == 0 || h == 0 {
        dst.clear();
        dst.extend_from_slice(src);
        return;
    }
    if scratch.kernel.is_empty() || scratch.kernel_sigma != sigma {
        scratch.kernel = gaussian_kernel(sigma);
        scratch.kernel_sigma = sigma;
    }
    let k = &scratch.kernel;
    let r = k.len() / 2;
    // Buffers keep their length from one image of this size to the next: no clearing, since
    // every pass writes each output element (its first tap `k0·x` rather than `0 + k0·x`: the
    // same value, without a memset of the buffer).
    let tmp = &mut scratch.tmp;
    tmp.resize(w * h, 0.0);
    let padded = &mut scratch.padded;
    padded.resize(w + 2 * r, 0.0);
    let offsets = &mut scratch.offsets;
    let isa = Avx2::new();
    // Horizontal pass, row by row through a padded buffer.
    offsets.clear();
    offsets.extend(0..k.len());
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        padded[r..r + w].copy_from_slice(row);
        padded[..r].fill(row[0]);
        padded[r + w..].fill(row[w - 1]);
        fir(&mut tmp[y * w..(y + 1) * w], k, padded, offsets, isa);
    }
    // Vertical pass: each output row is a weighted sum of whole input rows (clamped).
    dst.resize(w * h, 0.0);
    for y in 0..h {
        offsets.clear();
        offsets.extend((0..k.len()).map(|j| (y + j).saturating_sub(r).min(h - 1) * w));
        fir(&mut dst[y * w..(y + 1) * w], k, tmp, offsets, isa);
    }
}

/// One filtered row: `out[i] = k₀·src[o₀ + i] + k₁·src[o₁ + i] + …`, summed tap by tap in that
/// order (no fused multiply-add), so every instruction set gives the same bits as the scalar
/// loop. Blocks of 32 outputs are accumulated in registers over all taps (one load per tap
/// and element, instead of a load and store of the output per tap as a sequence of `axpy`s);
/// our own kernel because the blur is the largest share of the chessboard detection.
pub(crate) fn fir(out: &mut [f32], k: &[f32], src: &[f32], offsets: &[usize], isa: Isa) {
    /// Outputs `i..i + B`, accumulated in registers.
    #[inline(always)]
    fn block<const B: usize>(out: &mut [f32], k: &[f32], src: &[f32], offsets: &[usize], i: usize) {
        let mut acc = [0.0f32; B];
        let s0 = &src[offsets[0] + i..offsets[0] + i + B];
        for (a, &x) in acc.iter_mut().zip(s0) {
            *a = k[0] * x;
        }
        for (&kj, &o) in k.iter().zip(offsets).skip(1) {
            let sj = &src[o + i..o + i + B];
            for (a, &x) in acc.iter_mut().zip(sj) {
                *a += kj * x;
            }
        }
        out[i..i + B].copy_from_slice(&acc);
    }
    /// Blocks of `B`; a ragged end is covered by one more block ending at `n` (its overlap
    /// recomputes the same values). Returns false when `n < B`.
    #[inline(always)]
    fn blocks<const B: usize>(out: &mut [f32], k: &[f32], src: &[f32], offsets: &[usize]) -> bool {
        let n = out.len();
        if n < B {
            return false;
        }
        let mut i = 0;
        while i + B <= n {
            block::<B>(out, k, src, offsets, i);
            i += B;
        }
        if i < n {
            block::<B>(out, k, src, offsets, n - B);
        }
        true
    }
    #[inline(always)]
    fn imp(out: &mut [f32], k: &[f32], src: &[f32], offsets: &[usize]) {
        let n = out.len();
        assert!(!k.is_empty() && k.len() == offsets.len());
        assert!(offsets.iter().all(|&o| o + n <= src.len()), "filter taps reach past the source");
        if blocks::<32>(out, k, src, offsets) || blocks::<8>(out, k, src, offsets) {
            return;
        }
        for (i, o) in out.iter_mut().enumerate() {
            let mut a = k[0] * src[offsets[0] + i];
            for (&kj, &off) in k.iter().zip(offsets).skip(1) {
                a += kj * src[off + i];
            }
            *o = a;
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2(out: &mut [f32], k: &[f32], src: &[f32], offsets: &[usize]) {
        imp(out, k, src, offsets)
    }
    match isa {
        // SAFETY: the token proves AVX2.
        #[cfg(target_arch = "x86_64")]
        Some(_) => unsafe { avx2(out, k, src, offsets) },
        _ => imp(out, k, src, offsets),
    }
}

/// Halves an 8-bit image by 2x2 averaging into `f32` grey levels (`dst` resized to
/// `(w / 2) x (h / 2)`; an odd last row or column is dropped). Pixel `(i, j)` of the result is
/// centred on `(2i + ½, 2j + ½)` of the input.
pub(crate) fn halve_u8(src: &[u8], w: usize, h: usize, dst: &mut Vec<f32>) {
    halve_u8_on(src, w, h, dst, Avx2::new())
}

/// [`halve_u8`] compiled for `isa` (integer sums, exact on every instruction set; the pair
/// loads vectorise as shuffles with AVX2, about 4x the baseline loop).
pub(crate) fn halve_u8_on(src: &[u8], w: usize, h: usize, dst: &mut Vec<f32>, isa: Isa) {
    #[inline(always)]
    fn imp(src: &[u8], w: usize, h: usize, dst: &mut [f32]) {
        let (w2, h2) = (w / 2, h / 2);
        for y in 0..h2 {
            let (a, b) = (&src[2 * y * w..2 * y * w + 2 * w2], &src[(2 * y + 1) * w..(2 * y + 1) * w + 2 * w2]);
            let out = &mut dst[y * w2..(y + 1) * w2];
            for (o, (pa, pb)) in out.iter_mut().zip(a.chunks_exact(2).zip(b.chunks_exact(2))) {
                let s = pa[0] as u16 + pa[1] as u16 + pb[0] as u16 + pb[1] as u16;
                *o = s as f32 * 0.25;
            }
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2(src: &[u8], w: usize, h: usize, dst: &mut [f32]) {
        imp(src, w, h, dst)
    }
    // Every element is written: keep the length (no memset) when it already fits.
    dst.resize((w / 2) * (h / 2), 0.0);
    match isa {
        // SAFETY: the token proves AVX2.
        #[cfg(target_arch = "x86_64")]
        Some(_) => unsafe { avx2(src, w, h, dst) },
        _ => imp(src, w, h, dst),
    }
}

/// As [`halve_u8`] for an `f32` image.
pub(crate) fn halve_f32(src: &[f32], w: usize, h: usize, dst: &mut Vec<f32>) {
    let (w2, h2) = (w / 2, h / 2);
    // Every element is written below: keep the length (no memset) when it already fits.
    dst.resize(w2 * h2, 0.0);
    for y in 0..h2 {
        let (a, b) = (&src[2 * y * w..2 * y * w + 2 * w2], &src[(2 * y + 1) * w..(2 * y + 1) * w + 2 * w2]);
        let out = &mut dst[y * w2..(y + 1) * w2];
        for (x, o) in out.iter_mut().enumerate() {
            *o = 0.25 * ((a[2 * x] + a[2 * x + 1]) + (b[2 * x] + b[2 * x + 1]));
        }
    }
}

/// Bilinear sample at `(x, y)` (pixel centres at integers), clamped at the border.
#[inline(always)]
pub fn sample_bilinear(img: &ImageF32, x: f64, y: f64) -> f32 {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let x = x.clamp(0.0, (w - 1) as f64);
    let y = y.clamp(0.0, (h - 1) as f64);
    // x, y ≥ 0 here, so truncation is the floor (and avoids a libm call on the baseline target)
    let x0 = (x as i64).min(w - 2).max(0);
    let y0 = (y as i64).min(h - 2).max(0);
    let fx = (x - x0 as f64) as f32;
    let fy = (y - y0 as f64) as f32;
    let data = img.as_raw();
    let idx = (y0 * w + x0) as usize;
    let (x1, y1) = (if w > 1 { 1 } else { 0 }, if h > 1 { w as usize } else { 0 });
    let a = data[idx];
    let b = data[idx + x1];
    let c = data[idx + y1];
    let d = data[idx + y1 + x1];
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    top + (bottom - top) * fy
}

/// Saddle response `max(0, −det H)` of an already smoothed image, with the Hessian from central
/// differences (0 on the one-pixel border). Positive only where the surface is a saddle, as at
/// an X-junction of a chessboard.
pub fn saddle_response(smoothed: &ImageF32) -> ImageF32 {
    let (w, h) = (smoothed.width() as usize, smoothed.height() as usize);
    let mut out = Vec::new();
    saddle_response_into(smoothed.as_raw(), w, h, &mut out);
    ImageBuffer::from_raw(w as u32, h as u32, out).expect("buffer size matches the image")
}

/// [`saddle_response`] of the `w x h` buffer `s` into `out` (resized, reused).
pub(crate) fn saddle_response_into(s: &[f32], w: usize, h: usize, out: &mut Vec<f32>) {
    // The interior is written below and the one-pixel border zeroed here, so a buffer that
    // already has the length is reused without a memset.
    out.resize(w * h, 0.0);
    if w < 3 || h < 3 {
        out.fill(0.0);
        return;
    }
    out[..w].fill(0.0);
    out[(h - 1) * w..].fill(0.0);
    for y in 1..h - 1 {
        let row = y * w;
        out[row] = 0.0;
        out[row + w - 1] = 0.0;
        for x in 1..w - 1 {
            let i = row + x;
            let c = s[i];
            let dxx = s[i + 1] + s[i - 1] - 2.0 * c;
            let dyy = s[i + w] + s[i - w] - 2.0 * c;
            let dxy = 0.25 * (s[i + w + 1] + s[i - w - 1] - s[i + w - 1] - s[i - w + 1]);
            let det = dxx * dyy - dxy * dxy;
            out[i] = if det < 0.0 { -det } else { 0.0 };
        }
    }
}

/// Errors unless the image is at least `min x min` pixels.
pub(crate) fn check_size(img: &GrayImage, min: u32, what: &'static str) -> Result<()> {
    if img.width() < min || img.height() < min {
        return Err(CornerError::ImageTooSmall { width: img.width(), height: img.height(), what, min });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_reproduces_a_linear_ramp() {
        let img = ImageBuffer::from_fn(8, 6, |x, y| Luma([3.0 * x as f32 + 5.0 * y as f32]));
        for &(x, y) in &[(0.0, 0.0), (2.25, 3.5), (6.9, 4.1), (7.0, 5.0)] {
            let v = sample_bilinear(&img, x, y);
            assert!((v as f64 - (3.0 * x + 5.0 * y)).abs() < 1e-4, "({x}, {y}) -> {v}");
        }
    }

    #[test]
    fn gaussian_kernel_is_normalised_and_symmetric() {
        let k = gaussian_kernel(1.5);
        assert_eq!(k.len(), 11);
        assert!((k.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        for i in 0..k.len() {
            assert_eq!(k[i], k[k.len() - 1 - i]);
        }
    }

    #[test]
    fn own_blur_matches_a_direct_convolution() {
        let img = ImageBuffer::from_fn(23, 17, |x, y| {
            Luma([((x * 7 + y * 13) % 31) as f32 + if x == 11 && y == 8 { 100.0 } else { 0.0 }])
        });
        let sigma = 1.3;
        let k = gaussian_kernel(sigma);
        let r = (k.len() / 2) as i64;
        let out = gaussian_blur(&img, sigma);
        for y in 0..17i64 {
            for x in 0..23i64 {
                let mut acc = 0.0f64;
                for j in -r..=r {
                    for i in -r..=r {
                        let (xx, yy) = ((x + i).clamp(0, 22) as u32, (y + j).clamp(0, 16) as u32);
                        acc += (k[(i + r) as usize] * k[(j + r) as usize]) as f64 * img.get_pixel(xx, yy)[0] as f64;
                    }
                }
                let v = out.get_pixel(x as u32, y as u32)[0] as f64;
                assert!((v - acc).abs() < 1e-3, "({x}, {y}): {v} vs {acc}");
            }
        }
    }

    #[test]
    fn halving_is_identical_on_every_instruction_set() {
        // Odd sizes (the last row and column are dropped) and the full 0..=255 range.
        for (w, h) in [(1601usize, 7usize), (64, 64), (33, 9)] {
            let src: Vec<u8> = (0..w * h).map(|i| ((i * 7919 + i / 13) % 256) as u8).collect();
            let naive: Vec<f32> = (0..h / 2)
                .flat_map(|y| (0..w / 2).map(move |x| (y, x)))
                .map(|(y, x)| {
                    let p = |yy: usize, xx: usize| src[yy * w + xx] as f32;
                    (p(2 * y, 2 * x) + p(2 * y, 2 * x + 1) + p(2 * y + 1, 2 * x) + p(2 * y + 1, 2 * x + 1)) / 4.0
                })
                .collect();
            for isa in available_isas() {
                let mut out = vec![f32::NAN; 3];
                halve_u8_on(&src, w, h, &mut out, isa);
                assert_eq!(out, naive, "{isa:?} {w}x{h}");
            }
        }
    }

    #[test]
    fn filter_rows_equal_the_tap_by_tap_sum_on_every_instruction_set() {
        // Lengths around the 32-wide blocks, 11 and 3 taps, scattered row offsets.
        let src: Vec<f32> = (0..4000).map(|i| ((i * 37 % 251) as f32) * 0.731 - 20.0).collect();
        for taps in [gaussian_kernel(1.5), gaussian_kernel(0.4), vec![0.3, -1.7, 2.25]] {
            for n in [1usize, 7, 8, 13, 31, 32, 33, 57, 95, 800] {
                let offsets: Vec<usize> = (0..taps.len()).map(|j| (j * 277) % (4000 - n)).collect();
                let naive: Vec<f32> = (0..n)
                    .map(|i| {
                        let mut a = taps[0] * src[offsets[0] + i];
                        for j in 1..taps.len() {
                            a += taps[j] * src[offsets[j] + i];
                        }
                        a
                    })
                    .collect();
                for isa in available_isas() {
                    let mut out = vec![f32::NAN; n];
                    fir(&mut out, &taps, &src, &offsets, isa);
                    let same = out.iter().zip(&naive).all(|(a, b)| a.to_bits() == b.to_bits());
                    assert!(same, "{isa:?}, {} taps, n = {n}", taps.len());
                }
            }
        }
    }

    #[test]
    fn reused_buffers_give_the_same_blur_and_response() {
        // Buffers left from a larger image (and garbage in them) must not leak into a smaller one.
        let img = |w: u32, h: u32, s: u32| {
            ImageBuffer::from_fn(w, h, |x, y| Luma([((x * s + y * 13 + x * y) % 97) as f32 * 2.5]))
        };
        let mut scratch = BlurScratch::default();
        let (mut blurred, mut resp) = (Vec::new(), Vec::new());
        for (w, h, s) in [(60u32, 40u32, 7u32), (23, 31, 11), (60, 40, 5), (5, 3, 3)] {
            let f = img(w, h, s);
            let fresh = gaussian_blur(&f, 1.5);
            gaussian_blur_into(f.as_raw(), w as usize, h as usize, 1.5, &mut scratch, &mut blurred);
            assert_eq!(&blurred, fresh.as_raw(), "blur {w}x{h}");
            resp.iter_mut().for_each(|v| *v = f32::NAN);
            saddle_response_into(&blurred, w as usize, h as usize, &mut resp);
            // Independent: the formula at each interior pixel, 0 on the border.
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let i = y * w as usize + x;
                    let expect = if x == 0 || y == 0 || x + 1 == w as usize || y + 1 == h as usize {
                        0.0
                    } else {
                        let (s, w) = (&blurred, w as usize);
                        let dxx = s[i + 1] + s[i - 1] - 2.0 * s[i];
                        let dyy = s[i + w] + s[i - w] - 2.0 * s[i];
                        let dxy = 0.25 * (s[i + w + 1] + s[i - w - 1] - s[i + w - 1] - s[i - w + 1]);
                        (-(dxx * dyy - dxy * dxy)).max(0.0)
                    };
                    assert_eq!(resp[i], expect, "response {w}x{h} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn saddle_response_of_xy_surface() {
        // I = x·y has H = [[0, 1], [1, 0]], det = −1 everywhere.
        let img = ImageBuffer::from_fn(7, 7, |x, y| Luma([(x as f32 - 3.0) * (y as f32 - 3.0)]));
        let r = saddle_response(&img);
        assert!((r.get_pixel(3, 3)[0] - 1.0).abs() < 1e-6);
        // A paraboloid (a blob) is not a saddle.
        let img = ImageBuffer::from_fn(7, 7, |x, y| Luma([(x as f32 - 3.0).powi(2) + (y as f32 - 3.0).powi(2)]));
        assert_eq!(saddle_response(&img).get_pixel(3, 3)[0], 0.0);
    }
}
