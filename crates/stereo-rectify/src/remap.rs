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
    let (sw, sh) = src.dimensions();
    if sw == 0 || sh == 0 {
        return Err(RectifyError::Empty("source image"));
    }
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
    let c = P::CHANNEL_COUNT as usize;
    let zero = <P::Subpixel as Sample>::from_f32(0.0);
    let (fill, replicate) = match border {
        Border::Constant(p) => (p.channels().to_vec(), false),
        Border::Replicate => (vec![zero; c], true),
    };
    let mut out: Vec<P::Subpixel> = vec![zero; n * c];
    let w = table.width as usize;
    let ctx = Ctx { raw: src.as_raw(), sw: sw as isize, sh: sh as isize, c, fill: &fill, replicate };
    out.par_chunks_mut(w * c).enumerate().for_each(|(v, row)| {
        let mx = &table.map_x[v * w..(v + 1) * w];
        let my = &table.map_y[v * w..(v + 1) * w];
        match interpolation {
            Interpolation::Bilinear => ctx.bilinear_row(mx, my, row),
            Interpolation::Nearest => ctx.nearest_row(mx, my, row),
        }
    });
    ImageBuffer::from_raw(table.width, table.height, out)
        .ok_or_else(|| RectifyError::SizeMismatch("remap output buffer".into()))
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
        // Positions far outside are clamped before the integer conversion (no overflow).
        let lim_x = (self.sw + 2) as f32;
        let lim_y = (self.sh + 2) as f32;
        for (i, (&x, &y)) in mx.iter().zip(my).enumerate() {
            let dst = &mut row[i * c..(i + 1) * c];
            if !(x.is_finite() && y.is_finite()) {
                dst.copy_from_slice(self.fill);
                continue;
            }
            let xf = x.clamp(-3.0, lim_x).floor();
            let yf = y.clamp(-3.0, lim_y).floor();
            let (a, b) = (x.clamp(-3.0, lim_x) - xf, y.clamp(-3.0, lim_y) - yf);
            let (x0, y0) = (xf as isize, yf as isize);
            if x0 >= 0 && y0 >= 0 && x0 + 1 < self.sw && y0 + 1 < self.sh {
                let i00 = (y0 * self.sw + x0) as usize * c;
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
            } else {
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
        }
    }

    #[inline(always)]
    fn nearest_row(&self, mx: &[f32], my: &[f32], row: &mut [S]) {
        let c = self.c;
        let lim_x = (self.sw + 2) as f32;
        let lim_y = (self.sh + 2) as f32;
        for (i, (&x, &y)) in mx.iter().zip(my).enumerate() {
            let dst = &mut row[i * c..(i + 1) * c];
            if !(x.is_finite() && y.is_finite()) {
                dst.copy_from_slice(self.fill);
                continue;
            }
            let xi = x.clamp(-3.0, lim_x).round_ties_even() as isize;
            let yi = y.clamp(-3.0, lim_y).round_ties_even() as isize;
            if xi >= 0 && yi >= 0 && xi < self.sw && yi < self.sh {
                let s = (yi * self.sw + xi) as usize * c;
                dst.copy_from_slice(&self.raw[s..s + c]);
            } else {
                for ch in 0..c {
                    dst[ch] = S::from_f32(self.at(xi, yi, ch));
                }
            }
        }
    }
}
