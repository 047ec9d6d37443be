//! Resampling an image through a [`RemapTable`] (OpenCV's `remap`).

use image::{ImageBuffer, Pixel};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{RectifyError, RemapTable, Result};

/// Interpolation of [`remap`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Interpolation {
    /// Nearest neighbour (ties to even, as OpenCV's `INTER_NEAREST`).
    Nearest,
    /// Bilinear with exact `f32` weights (OpenCV's `INTER_LINEAR` quantises the position to
    /// 1/32 px and the weights to 15 bits; this does not).
    #[default]
    Bilinear,
}

/// What [`remap`] reads outside the source image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Border<P> {
    /// A constant pixel (OpenCV's `BORDER_CONSTANT`); outside neighbours of a bilinear sample
    /// take this value, so the valid region fades into it over one pixel.
    Constant(P),
    /// The nearest edge pixel (OpenCV's `BORDER_REPLICATE`).
    Replicate,
}

/// A channel type [`remap`] can interpolate (`u8` and `u16`).
pub trait Sample: Copy + Send + Sync + 'static {
    /// The value as `f32`.
    fn to_f32(self) -> f32;
    /// Rounds to nearest and saturates.
    fn from_f32(v: f32) -> Self;
    /// The value as `u32`.
    fn to_u32(self) -> u32;
    /// From a value known to be in range.
    fn from_u32(v: u32) -> Self;
    /// The samples as bytes when the channel type is `u8` (selects the vectorised 8-bit path).
    fn as_u8(samples: &[Self]) -> Option<&[u8]> {
        let _ = samples;
        None
    }
    /// As [`Sample::as_u8`], mutable.
    fn as_u8_mut(samples: &mut [Self]) -> Option<&mut [u8]> {
        let _ = samples;
        None
    }
}

impl Sample for u8 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        (v + 0.5) as u8
    }
    #[inline(always)]
    fn to_u32(self) -> u32 {
        self as u32
    }
    #[inline(always)]
    fn from_u32(v: u32) -> Self {
        v as u8
    }
    fn as_u8(samples: &[Self]) -> Option<&[u8]> {
        Some(samples)
    }
    fn as_u8_mut(samples: &mut [Self]) -> Option<&mut [u8]> {
        Some(samples)
    }
}

impl Sample for u16 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        (v + 0.5) as u16
    }
    #[inline(always)]
    fn to_u32(self) -> u32 {
        self as u32
    }
    #[inline(always)]
    fn from_u32(v: u32) -> Self {
        v as u16
    }
}

/// An owned image of pixel type `P`.
pub type Image<P> = ImageBuffer<P, Vec<<P as Pixel>::Subpixel>>;

/// Resamples `src` through `table`: output pixel `(u, v)` is `src` at the table's source
/// position, interpolated as asked, with `border` outside the source. The output has the
/// table's size. Works for any `image` pixel with `u8` or `u16` channels (`Luma<u8>`,
/// `Luma<u16>`, `Rgb<u8>`, …); rows run in parallel (rayon). Map entries that are NaN give
/// the constant border value (black for [`Border::Replicate`]).
pub fn remap<P>(src: &Image<P>, table: &RemapTable, interpolation: Interpolation, border: Border<P>) -> Result<Image<P>>
where
    P: Pixel + Send + Sync,
    P::Subpixel: Sample,
{
    remap_impl(src, table, interpolation, border)
}

/// The output of a resampling: `width x height` pixels of `src`'s type, each row filled in
/// parallel by `row(ctx, v, pixels)` with `border`'s handling in `ctx`. Refuses an empty source
/// and channel counts outside 1..=4.
fn resample<P, F>(src: &Image<P>, width: u32, height: u32, border: Border<P>, row: F) -> Result<Image<P>>
where
    P: Pixel + Send + Sync,
    P::Subpixel: Sample,
    F: Fn(&Ctx<'_, P::Subpixel>, usize, &mut [P::Subpixel]) + Sync,
{
    let (sw, sh) = src.dimensions();
    if sw == 0 || sh == 0 {
        return Err(RectifyError::Empty("source image"));
    }
    let c = P::CHANNEL_COUNT as usize;
    if !(1..=4).contains(&c) {
        return Err(RectifyError::Config(format!("remap supports 1 to 4 channels, the pixel type has {c}")));
    }
    let zero = <P::Subpixel as Sample>::from_f32(0.0);
    let (fill, replicate) = match border {
        Border::Constant(p) => (p.channels().to_vec(), false),
        Border::Replicate => (vec![zero; c], true),
    };
    let (w, h) = (width as usize, height as usize);
    let mut out: Vec<P::Subpixel> = vec![zero; w * h * c];
    let ctx = Ctx { raw: src.as_raw(), sw: sw as isize, sh: sh as isize, c, fill: &fill, replicate };
    if w > 0 {
        out.par_chunks_mut(w * c).enumerate().for_each(|(v, pixels)| row(&ctx, v, pixels));
    }
    ImageBuffer::from_raw(width, height, out).ok_or_else(|| RectifyError::SizeMismatch("remap output buffer".into()))
}

/// [`remap`] through the `f32` table.
fn remap_impl<P>(
    src: &Image<P>,
    table: &RemapTable,
    interpolation: Interpolation,
    border: Border<P>,
) -> Result<Image<P>>
where
    P: Pixel + Send + Sync,
    P::Subpixel: Sample,
{
    let n = table.width as usize * table.height as usize;
    if table.map_x.len() != n || table.map_y.len() != n {
        return Err(RectifyError::SizeMismatch(format!(
            "remap table {}x{} holds {} / {} entries",
            table.width,
            table.height,
            table.map_x.len(),
            table.map_y.len()
        )));
    }
    let w = table.width as usize;
    resample(src, table.width, table.height, border, |ctx, v, row| {
        let mx = &table.map_x[v * w..(v + 1) * w];
        let my = &table.map_y[v * w..(v + 1) * w];
        match (interpolation, ctx.c) {
            (Interpolation::Bilinear, _) => ctx.bilinear_row(mx, my, row),
            (Interpolation::Nearest, 1) => ctx.nearest_row::<1>(mx, my, row),
            (Interpolation::Nearest, 2) => ctx.nearest_row::<2>(mx, my, row),
            (Interpolation::Nearest, 3) => ctx.nearest_row::<3>(mx, my, row),
            (Interpolation::Nearest, _) => ctx.nearest_row::<4>(mx, my, row),
        }
    })
}

/// [`remap`] through a precompiled [`FastBilinear`] table (no `f32` map): bilinear in fixed
/// point, nearest through [`FastBilinear::nearest`]; border pixels take the exact path from the
/// table's border positions. The source must have the table's source size.
pub(crate) fn remap_fast<P>(
    src: &Image<P>,
    fast: &FastBilinear,
    interpolation: Interpolation,
    border: Border<P>,
) -> Result<Image<P>>
where
    P: Pixel + Send + Sync,
    P::Subpixel: Sample,
{
    let (sw, sh) = src.dimensions();
    if (sw, sh) != fast.source_size {
        return Err(RectifyError::SizeMismatch(format!(
            "image is {sw}x{sh}, the table was built for {}x{}",
            fast.source_size.0, fast.source_size.1
        )));
    }
    let w = fast.width as usize;
    let h = fast.border.len();
    if fast.index.len() != w * h || fast.frac.len() != w * h {
        return Err(RectifyError::SizeMismatch("fixed-point table".into()));
    }
    let near = match (interpolation, &fast.nearest) {
        (Interpolation::Nearest, Some(t)) => Some(t),
        (Interpolation::Nearest, None) => {
            return Err(RectifyError::Config("nearest-neighbour table not built".into()));
        }
        (Interpolation::Bilinear, _) => None,
    };
    resample(src, fast.width, h as u32, border, |ctx, v, row| {
        let rows = v * w..(v + 1) * w;
        match near {
            None => {
                let (idx, frac, border) = (&fast.index[rows.clone()], &fast.frac[rows], fast.border[v].as_slice());
                match ctx.c {
                    1 => ctx.fast_row_gray(idx, frac, border, row),
                    2 => ctx.fast_row::<2>(idx, frac, border, row),
                    3 => ctx.fast_row::<3>(idx, frac, border, row),
                    _ => ctx.fast_row::<4>(idx, frac, border, row),
                }
            }
            Some(t) => {
                let (idx, border) = (&t.index[rows], t.border[v].as_slice());
                match ctx.c {
                    1 => ctx.nearest_fast_row::<1>(idx, border, row),
                    2 => ctx.nearest_fast_row::<2>(idx, border, row),
                    3 => ctx.nearest_fast_row::<3>(idx, border, row),
                    _ => ctx.nearest_fast_row::<4>(idx, border, row),
                }
            }
        }
    })
}

struct Ctx<'a, S> {
    raw: &'a [S],
    sw: isize,
    sh: isize,
    c: usize,
    fill: &'a [S],
    replicate: bool,
}

impl<S: Sample> Ctx<'_, S> {
    /// Channel `ch` of source pixel `(x, y)` with border handling.
    #[inline(always)]
    fn at(&self, x: isize, y: isize, ch: usize) -> f32 {
        if x >= 0 && y >= 0 && x < self.sw && y < self.sh {
            self.raw[(y * self.sw + x) as usize * self.c + ch].to_f32()
        } else if self.replicate {
            let x = x.clamp(0, self.sw - 1);
            let y = y.clamp(0, self.sh - 1);
            self.raw[(y * self.sw + x) as usize * self.c + ch].to_f32()
        } else {
            self.fill[ch].to_f32()
        }
    }

    #[inline(always)]
    fn bilinear_row(&self, mx: &[f32], my: &[f32], row: &mut [S]) {
        let c = self.c;
        for (i, (&x, &y)) in mx.iter().zip(my).enumerate() {
            self.bilinear_px(x, y, &mut row[i * c..(i + 1) * c]);
        }
    }

    /// Fixed-point bilinear with precomputed offsets and 8-bit weights for the pixels whose
    /// four neighbours are inside; the others (`u32::MAX`) go through [`Self::bilinear_px`] at
    /// the next of the row's `border` positions.
    #[inline(always)]
    fn fast_row<const C: usize>(&self, idx: &[u32], frac: &[u16], border: &[[f32; 2]], row: &mut [S]) {
        let sw = self.sw as usize;
        let mut border = border.iter();
        for (i, dst) in row.chunks_exact_mut(C).enumerate() {
            let k = idx[i];
            if k == u32::MAX {
                let [x, y] = border.next().copied().unwrap_or([f32::NAN; 2]);
                self.bilinear_px(x, y, dst);
                continue;
            }
            let o = k as usize * C;
            let px = &self.raw[o..o + (sw + 1) * C + C];
            for ch in 0..C {
                let (p00, p01) = (px[ch].to_u32(), px[C + ch].to_u32());
                let (p10, p11) = (px[sw * C + ch].to_u32(), px[sw * C + C + ch].to_u32());
                dst[ch] = S::from_u32(bilinear_fixed([p00, p01, p10, p11], frac[i]));
            }
        }
    }

    /// [`Self::fast_row`] for one channel; 8-bit images on AVX2 CPUs take
    /// [`gray8_fast_row_avx2`] (same integer arithmetic, eight pixels per step).
    #[inline(always)]
    fn fast_row_gray(&self, idx: &[u32], frac: &[u16], border: &[[f32; 2]], row: &mut [S]) {
        #[cfg(target_arch = "x86_64")]
        if parallax_simd::Avx2::new().is_some()
            && let Some(raw) = S::as_u8(self.raw)
            && raw.len() < i32::MAX as usize
        {
            let zero = S::from_u32(0);
            // called for the border pixels only, in row order: the next border position
            let mut positions = border.iter();
            let mut slow = |_: usize| {
                let [x, y] = positions.next().copied().unwrap_or([f32::NAN; 2]);
                let mut t = [zero];
                self.bilinear_px(x, y, &mut t);
                t[0].to_u32() as u8
            };
            let out = S::as_u8_mut(row).expect("same channel type as the source");
            // SAFETY: the token (`Avx2::new`) proves AVX2.
            unsafe { gray8_fast_row_avx2(raw, self.sw as usize, idx, frac, out, &mut slow) };
            return;
        }
        self.fast_row::<1>(idx, frac, border, row)
    }

    #[inline(always)]
    fn bilinear_px(&self, x: f32, y: f32, dst: &mut [S]) {
        let c = self.c;
        let (last_x, last_y) = ((self.sw - 1) as f32, (self.sh - 1) as f32);
        // Fast path: all four neighbours inside (false for NaN); truncation is floor here
        // (`f32::floor` is a libm call on the x86-64 baseline).
        if x >= 0.0 && y >= 0.0 && x < last_x && y < last_y {
            let (xi, yi) = (x as usize, y as usize);
            let (a, b) = (x - xi as f32, y - yi as f32);
            let i00 = (yi * self.sw as usize + xi) * c;
            let i10 = i00 + (self.sw as usize) * c;
            for ch in 0..c {
                let p00 = self.raw[i00 + ch].to_f32();
                let p01 = self.raw[i00 + c + ch].to_f32();
                let p10 = self.raw[i10 + ch].to_f32();
                let p11 = self.raw[i10 + c + ch].to_f32();
                let top = p00 + (p01 - p00) * a;
                let bottom = p10 + (p11 - p10) * a;
                dst[ch] = S::from_f32(top + (bottom - top) * b);
            }
            return;
        }
        if !(x.is_finite() && y.is_finite()) {
            dst.copy_from_slice(self.fill);
            return;
        }
        // Positions far outside are clamped before the integer conversion (no overflow).
        let (x, y) = (x.clamp(-3.0, (self.sw + 2) as f32), y.clamp(-3.0, (self.sh + 2) as f32));
        let (xf, yf) = (x.floor(), y.floor());
        let (a, b) = (x - xf, y - yf);
        let (x0, y0) = (xf as isize, yf as isize);
        for ch in 0..c {
            let p00 = self.at(x0, y0, ch);
            let p01 = self.at(x0 + 1, y0, ch);
            let p10 = self.at(x0, y0 + 1, ch);
            let p11 = self.at(x0 + 1, y0 + 1, ch);
            let top = p00 + (p01 - p00) * a;
            let bottom = p10 + (p11 - p10) * a;
            dst[ch] = S::from_f32(top + (bottom - top) * b);
        }
    }

    #[inline(always)]
    fn nearest_row<const C: usize>(&self, mx: &[f32], my: &[f32], row: &mut [S]) {
        for (dst, (&x, &y)) in row.chunks_exact_mut(C).zip(mx.iter().zip(my)) {
            self.nearest_px::<C>(x, y, dst);
        }
    }

    /// [`Self::nearest_row`] with the precomputed source offsets of [`FastBilinear::nearest`]
    /// (`u32::MAX`: border handling at the next of the row's `border` positions).
    #[inline(always)]
    fn nearest_fast_row<const C: usize>(&self, near: &[u32], border: &[[f32; 2]], row: &mut [S]) {
        let mut border = border.iter();
        for (dst, &k) in row.chunks_exact_mut(C).zip(near) {
            if k == u32::MAX {
                let [x, y] = border.next().copied().unwrap_or([f32::NAN; 2]);
                self.nearest_px::<C>(x, y, dst);
            } else {
                let o = k as usize * C;
                dst.copy_from_slice(&self.raw[o..o + C]);
            }
        }
    }

    #[inline(always)]
    fn nearest_px<const C: usize>(&self, x: f32, y: f32, dst: &mut [S]) {
        if let Some(k) = nearest_inside(x, y, self.sw as usize, self.sh as usize) {
            let s = k * C;
            dst.copy_from_slice(&self.raw[s..s + C]);
        } else if !(x.is_finite() && y.is_finite()) {
            dst.copy_from_slice(self.fill);
        } else {
            let (lim_x, lim_y) = ((self.sw + 2) as f32, (self.sh + 2) as f32);
            let xi = x.clamp(-3.0, lim_x).round_ties_even() as isize;
            let yi = y.clamp(-3.0, lim_y).round_ties_even() as isize;
            for ch in 0..C {
                dst[ch] = S::from_f32(self.at(xi, yi, ch));
            }
        }
    }
}

/// A [`RemapTable`] precompiled for one source size (as OpenCV's `convertMaps` to fixed point):
/// per output pixel the offset of the top-left neighbour and the two fractions quantised to
/// 1/256 px (OpenCV: 1/32 px); `u32::MAX` marks pixels that need border handling, which take
/// the exact `f32` path from [`FastBilinear::border`]. Value error against the `f32` path: ≤ 1
/// grey level.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FastBilinear {
    pub source_size: (u32, u32),
    /// Output width (entries per row).
    pub width: u32,
    pub index: Vec<u32>,
    pub frac: Vec<u16>,
    /// Per output row, the source positions of the pixels whose `index` is `u32::MAX`, in row
    /// order: the only entries of the `f32` map the bilinear path needs.
    pub border: Vec<Vec<[f32; 2]>>,
    /// Nearest-neighbour table, built on demand by [`FastBilinear::fill_nearest`].
    pub nearest: Option<NearestTable>,
}

/// The index and fraction buffers go to the spares of the next table of their size
/// ([`crate::maps::Spares`]).
impl Drop for FastBilinear {
    fn drop(&mut self) {
        crate::maps::SPARE_INDEX.give(std::mem::take(&mut self.index));
        crate::maps::SPARE_FRAC.give(std::mem::take(&mut self.frac));
    }
}

/// Nearest-neighbour source pixel of every output pixel whose rounded position is inside
/// (`u32::MAX`: border handling), and per row the source positions of those border pixels.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NearestTable {
    pub index: Vec<u32>,
    pub border: Vec<Vec<[f32; 2]>>,
}

impl FastBilinear {
    /// The table of an existing map (the reference of the build without a map,
    /// `maps::fill_fast_table`, compared in its test).
    #[cfg(test)]
    pub(crate) fn new(table: &RemapTable, source_width: u32, source_height: u32) -> Self {
        let (last_x, last_y) = (source_width as f32 - 1.0, source_height as f32 - 1.0);
        // (sides below 2^24: `fast_table_row` converts positions to integers without saturation)
        let usable = (source_width as u64) * (source_height as u64) < u32::MAX as u64
            && source_width < 1 << 24
            && source_height < 1 << 24
            && table.width > 0;
        let n = table.map_x.len();
        let mut index = if usable { vec![0u32; n] } else { vec![u32::MAX; n] };
        let mut frac = vec![0u16; n];
        let w = table.width as usize;
        let mut border = vec![Vec::new(); table.height as usize];
        index.par_chunks_mut(w).zip(frac.par_chunks_mut(w)).zip(border.par_iter_mut()).enumerate().for_each(
            |(v, ((k, f), b))| {
                let (mx, my) = (&table.map_x[v * w..(v + 1) * w], &table.map_y[v * w..(v + 1) * w]);
                if usable {
                    fast_table_row(mx, my, k, f, b, source_width, last_x, last_y);
                } else {
                    b.extend(mx.iter().zip(my).map(|(&x, &y)| [x, y]));
                }
            },
        );
        Self { source_size: (source_width, source_height), width: table.width, index, frac, border, nearest: None }
    }

    /// A table with no entries, the starting point of buffers filled later.
    pub(crate) fn empty() -> Self {
        Self { source_size: (0, 0), width: 0, index: Vec::new(), frac: Vec::new(), border: Vec::new(), nearest: None }
    }

    /// (Re)computes the nearest-neighbour table of `table` (the positions `remap`'s nearest
    /// path rounds inside the source, half to even), reusing the buffers when they have the
    /// table's size.
    pub(crate) fn fill_nearest(&mut self, table: &RemapTable) {
        let (sw, sh) = (self.source_size.0 as usize, self.source_size.1 as usize);
        let usable = (sw as u64) * (sh as u64) < u32::MAX as u64;
        let t = self.nearest.get_or_insert_with(|| NearestTable { index: Vec::new(), border: Vec::new() });
        if t.index.len() != table.map_x.len() {
            t.index = vec![0; table.map_x.len()];
        }
        t.border.resize_with(table.height as usize, Vec::new);
        let w = table.width as usize;
        t.index.par_chunks_mut(w).zip(t.border.par_iter_mut()).enumerate().for_each(|(v, (near, border))| {
            border.clear();
            let (mx, my) = (&table.map_x[v * w..(v + 1) * w], &table.map_y[v * w..(v + 1) * w]);
            for ((k, &x), &y) in near.iter_mut().zip(mx).zip(my) {
                *k = match nearest_inside(x, y, sw, sh) {
                    Some(o) if usable => o as u32,
                    _ => {
                        border.push([x, y]);
                        u32::MAX
                    }
                };
            }
        });
    }
}

/// One row of [`FastBilinear`]: branch-free (selects) so it vectorises, through an AVX2 copy
/// when the CPU has it. The source sides must be below 2^24 (see the conversions).
#[allow(clippy::too_many_arguments)] // one row of each of the table's parts, and the source's extent
pub(crate) fn fast_table_row(
    mx: &[f32],
    my: &[f32],
    index: &mut [u32],
    frac: &mut [u16],
    border: &mut Vec<[f32; 2]>,
    sw: u32,
    last_x: f32,
    last_y: f32,
) {
    /// The row's table entries; returns how many pixels fall outside (a sum the loop carries in
    /// vector lanes).
    #[inline(always)]
    fn imp(mx: &[f32], my: &[f32], index: &mut [u32], frac: &mut [u16], sw: u32, last_x: f32, last_y: f32) -> u32 {
        let mut outside = 0u32;
        for (((&x, &y), k), f) in mx.iter().zip(my).zip(index.iter_mut()).zip(frac.iter_mut()) {
            // false for NaN
            let inside = x >= 0.0 && y >= 0.0 && x < last_x && y < last_y;
            outside += u32::from(!inside);
            // outside pixels get no index: convert 0 instead, so every conversion below is of a
            // value in [0, 2^24) and needs no saturation (Rust's saturating `as` casts compiled
            // to scalar code here: measured, the whole row ran scalar)
            let (x, y) = if inside { (x, y) } else { (0.0, 0.0) };
            // SAFETY: x, y are finite and in [0, last) with last < 2^24 (callers build tables
            // only for source sides below 2^24), so truncation to i32 is in range.
            let (xi, yi) = unsafe { (x.to_int_unchecked::<i32>(), y.to_int_unchecked::<i32>()) };
            // SAFETY: the fractional parts are in [0, 1): the values are in [0.5, 256.5).
            let (fx, fy) = unsafe {
                (
                    ((x - xi as f32) * 256.0 + 0.5).to_int_unchecked::<i32>().min(255) as u32,
                    ((y - yi as f32) * 256.0 + 0.5).to_int_unchecked::<i32>().min(255) as u32,
                )
            };
            *k = if inside { (yi as u32).wrapping_mul(sw).wrapping_add(xi as u32) } else { u32::MAX };
            *f = if inside { (fx | (fy << 8)) as u16 } else { 0 };
        }
        outside
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2(mx: &[f32], my: &[f32], index: &mut [u32], frac: &mut [u16], sw: u32, last_x: f32, last_y: f32) -> u32 {
        imp(mx, my, index, frac, sw, last_x, last_y)
    }
    fn dispatch(mx: &[f32], my: &[f32], index: &mut [u32], frac: &mut [u16], sw: u32, last_x: f32, last_y: f32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if parallax_simd::Avx2::new().is_some() {
            // SAFETY: the token proves AVX2.
            return unsafe { avx2(mx, my, index, frac, sw, last_x, last_y) };
        }
        imp(mx, my, index, frac, sw, last_x, last_y)
    }
    let outside = dispatch(mx, my, index, frac, sw, last_x, last_y);
    // the positions of the border pixels, for the exact path (the only part of the map kept);
    // a row with none (every row of an `alpha = 0` rectification) skips the scalar scan, which
    // was ~1/4 of `Rectifier::new`'s instructions (callgrind, `rectifier_speed`)
    border.clear();
    if outside > 0 {
        border.extend(index.iter().zip(mx.iter().zip(my)).filter(|(k, _)| **k == u32::MAX).map(|(_, (&x, &y))| [x, y]));
    }
}

/// The fixed-point bilinear blend of the four neighbours `[p00, p01, p10, p11]` with the
/// fractions of [`FastBilinear::frac`] (1/256 px), rounded to nearest.
#[inline(always)]
fn bilinear_fixed([p00, p01, p10, p11]: [u32; 4], frac: u16) -> u32 {
    let (fx, fy) = ((frac & 0xff) as u32, (frac >> 8) as u32);
    let top = p00 * (256 - fx) + p01 * fx;
    let bottom = p10 * (256 - fx) + p11 * fx;
    (top * (256 - fy) + bottom * fy + (1 << 15)) >> 16
}

/// The source pixel index `y·sw + x` nearest to `(x, y)` (half to even) when it lies inside a
/// `sw x sh` image; `None` outside and for NaN.
#[inline(always)]
fn nearest_inside(x: f32, y: f32, sw: usize, sh: usize) -> Option<usize> {
    let (last_x, last_y) = ((sw - 1) as f32, (sh - 1) as f32);
    if x >= -0.5 && y >= -0.5 && x < last_x + 0.5 && y < last_y + 0.5 {
        Some(round_half_even(y) * sw + round_half_even(x))
    } else {
        None
    }
}

/// Round half to even (OpenCV's `cvRound`) of `v ≥ −0.5` without a libm call.
#[inline(always)]
fn round_half_even(v: f32) -> usize {
    let t = v + 0.5;
    let r = t as usize;
    if r as f32 == t && r & 1 == 1 { r - 1 } else { r }
}

/// The fixed-point bilinear row of an 8-bit single-channel image, eight pixels per step: two
/// gathers fetch the top and bottom neighbour pairs, `madd` weighs each pair, and the vertical
/// blend and rounding are those of [`Ctx::fast_row`] (identical results, tested). Groups with a
/// border pixel (`u32::MAX`) or a read past the buffer go pixel by pixel (`slow` for border
/// pixels).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn gray8_fast_row_avx2(
    raw: &[u8],
    sw: usize,
    idx: &[u32],
    frac: &[u16],
    out: &mut [u8],
    slow: &mut dyn FnMut(usize) -> u8,
) {
    use std::arch::x86_64::*;
    let n = out.len().min(idx.len()).min(frac.len());
    // a group is vectorised when every offset k satisfies k + sw + 4 ≤ raw.len() (both 4-byte
    // gathers in bounds); the border sentinel u32::MAX never does
    let limit = raw.len().checked_sub(sw + 4).map_or(-1i64, |l| l as i64);
    let scalar = |i: usize, slow: &mut dyn FnMut(usize) -> u8| -> u8 {
        let k = idx[i];
        if k == u32::MAX {
            return slow(i);
        }
        let o = k as usize;
        let p = [raw[o], raw[o + 1], raw[o + sw], raw[o + sw + 1]].map(u32::from);
        bilinear_fixed(p, frac[i]) as u8
    };
    let mut i = 0;
    if limit >= 0 {
        let limv = _mm256_set1_epi32(limit as i32);
        let spread = _mm256_setr_epi8(
            0, -128, 1, -128, 4, -128, 5, -128, 8, -128, 9, -128, 12, -128, 13, -128, 0, -128, 1, -128, 4, -128, 5,
            -128, 8, -128, 9, -128, 12, -128, 13, -128,
        );
        let (c256, cff, half) = (_mm256_set1_epi32(256), _mm256_set1_epi32(0xff), _mm256_set1_epi32(1 << 15));
        let pick = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
        while i + 8 <= n {
            // SAFETY: i + 8 ≤ n ≤ idx.len(), frac.len().
            let (iv, fr) = unsafe {
                (
                    _mm256_loadu_si256(idx.as_ptr().add(i) as *const __m256i),
                    _mm256_cvtepu16_epi32(_mm_loadu_si128(frac.as_ptr().add(i) as *const __m128i)),
                )
            };
            let inside = _mm256_cmpeq_epi32(_mm256_max_epu32(iv, limv), limv);
            if _mm256_movemask_epi8(inside) != -1 {
                for j in i..i + 8 {
                    out[j] = scalar(j, slow);
                }
                i += 8;
                continue;
            }
            // SAFETY: every offset k ≤ limit, so bytes k..k + 4 and k + sw..k + sw + 4 are inside
            // `raw` (limit < 2^31, so the signed gather offsets are the offsets).
            let (top, bot) = unsafe {
                (
                    _mm256_i32gather_epi32::<1>(raw.as_ptr() as *const i32, iv),
                    _mm256_i32gather_epi32::<1>(raw.as_ptr().add(sw) as *const i32, iv),
                )
            };
            let fx = _mm256_and_si256(fr, cff);
            let fy = _mm256_srli_epi32::<8>(fr);
            // (256 − fx) in the low 16 bits, fx in the high: madd gives p0·(256 − fx) + p1·fx
            let wx = _mm256_or_si256(_mm256_sub_epi32(c256, fx), _mm256_slli_epi32::<16>(fx));
            let t = _mm256_madd_epi16(_mm256_shuffle_epi8(top, spread), wx);
            let b = _mm256_madd_epi16(_mm256_shuffle_epi8(bot, spread), wx);
            let v = _mm256_add_epi32(_mm256_mullo_epi32(t, _mm256_sub_epi32(c256, fy)), _mm256_mullo_epi32(b, fy));
            let v = _mm256_srli_epi32::<16>(_mm256_add_epi32(v, half));
            // eight u32 → eight bytes in order
            let v = _mm256_packus_epi32(v, v);
            let v = _mm256_packus_epi16(v, v);
            let v = _mm256_permutevar8x32_epi32(v, pick);
            let bytes = (_mm256_extract_epi64::<0>(v) as u64).to_le_bytes();
            out[i..i + 8].copy_from_slice(&bytes);
            i += 8;
        }
    }
    for j in i..n {
        out[j] = scalar(j, slow);
    }
}
