//! Rectified pairs as files: a pair resampled at its pixel type (8- or 16-bit grey, RGB),
//! written as `left_rectified.png` / `right_rectified.png`, and the side-by-side picture with
//! guide lines along the epipolar direction.

use std::path::Path;

use image::{DynamicImage, GrayImage, Luma, Rgb, RgbImage};
use parallax_stereo_rectify::{Border, Image, Rectifier};

use crate::Result;

/// A rectified pair at the pixel type of its source images.
#[derive(Debug, Clone)]
pub enum RectifiedPair {
    /// 8-bit grey (both sources 8-bit grey).
    Luma8(GrayImage, GrayImage),
    /// 16-bit grey (either source 16-bit grey).
    Luma16(Image<Luma<u16>>, Image<Luma<u16>>),
    /// RGB (any other source).
    Rgb8(RgbImage, RgbImage),
}

/// Resamples a pair with `rectifier` (bilinear, black outside the image), keeping the pixel
/// type: 16-bit grey when either image is, 8-bit grey when both are, else RGB.
pub fn rectify_pair(rectifier: &Rectifier, left: &DynamicImage, right: &DynamicImage) -> Result<RectifiedPair> {
    Ok(match (left, right) {
        (DynamicImage::ImageLuma16(_), _) | (_, DynamicImage::ImageLuma16(_)) => {
            let (l, r) =
                rectifier.rectify_pair(&left.to_luma16(), &right.to_luma16(), Border::Constant(Luma([0u16])))?;
            RectifiedPair::Luma16(l, r)
        }
        (DynamicImage::ImageLuma8(_), DynamicImage::ImageLuma8(_)) => {
            let (l, r) = rectifier.rectify_pair(&left.to_luma8(), &right.to_luma8(), Border::Constant(Luma([0u8])))?;
            RectifiedPair::Luma8(l, r)
        }
        _ => {
            let (l, r) = rectifier.rectify_pair(&left.to_rgb8(), &right.to_rgb8(), Border::Constant(Rgb([0u8; 3])))?;
            RectifiedPair::Rgb8(l, r)
        }
    })
}

/// 16-bit grey to 8-bit RGB (the high byte).
fn rgb_of_16(img: &Image<Luma<u16>>) -> RgbImage {
    RgbImage::from_fn(img.width(), img.height(), |u, v| {
        let g = (img.get_pixel(u, v)[0] >> 8) as u8;
        Rgb([g, g, g])
    })
}

impl RectifiedPair {
    /// Adds `left_rectified.png` and `right_rectified.png` in `dir` to `set` (at the pair's
    /// pixel type).
    pub fn add_to(&self, set: &mut crate::io::OutputSet, dir: &Path) -> Result<()> {
        let (l, r) = (dir.join("left_rectified.png"), dir.join("right_rectified.png"));
        match self {
            Self::Luma8(a, b) => set.add_png(l, a).and_then(|()| set.add_png(r, b)),
            Self::Luma16(a, b) => set.add_png(l, a).and_then(|()| set.add_png(r, b)),
            Self::Rgb8(a, b) => set.add_png(l, a).and_then(|()| set.add_png(r, b)),
        }
    }

    /// The pair as 8-bit RGB (16-bit grey keeps its high byte).
    pub fn to_rgb8(&self) -> (RgbImage, RgbImage) {
        match self {
            Self::Luma8(a, b) => {
                (DynamicImage::ImageLuma8(a.clone()).to_rgb8(), DynamicImage::ImageLuma8(b.clone()).to_rgb8())
            }
            Self::Luma16(a, b) => (rgb_of_16(a), rgb_of_16(b)),
            Self::Rgb8(a, b) => (a.clone(), b.clone()),
        }
    }
}

/// The two rectified images side by side (stacked for a vertical rig) with guide lines along
/// the epipolar direction every `spacing` pixels (the first at `spacing / 2`), alternating
/// green and magenta.
pub fn side_by_side(l: &RgbImage, r: &RgbImage, vertical: bool, spacing: u32) -> RgbImage {
    let (w, h) = l.dimensions();
    let (ow, oh) = if vertical { (w, 2 * h) } else { (2 * w, h) };
    let mut out = RgbImage::new(ow, oh);
    for (u, v, p) in l.enumerate_pixels() {
        out.put_pixel(u, v, *p);
    }
    for (u, v, p) in r.enumerate_pixels() {
        if vertical {
            out.put_pixel(u, v + h, *p);
        } else {
            out.put_pixel(u + w, v, *p);
        }
    }
    let colours = [Rgb([0, 255, 0]), Rgb([255, 0, 255])];
    let spacing = spacing.max(1);
    if vertical {
        for (k, u) in (spacing / 2..ow).step_by(spacing as usize).enumerate() {
            for v in 0..oh {
                out.put_pixel(u, v, colours[k % 2]);
            }
        }
    } else {
        for (k, v) in (spacing / 2..oh).step_by(spacing as usize).enumerate() {
            for u in 0..ow {
                out.put_pixel(u, v, colours[k % 2]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_by_side_places_both_images_and_draws_alternating_lines() {
        let l = RgbImage::from_pixel(10, 8, Rgb([10, 10, 10]));
        let r = RgbImage::from_pixel(10, 8, Rgb([200, 200, 200]));
        let s = side_by_side(&l, &r, false, 4);
        assert_eq!(s.dimensions(), (20, 8));
        assert_eq!((s.get_pixel(3, 1)[0], s.get_pixel(13, 1)[0]), (10, 200));
        // Lines at rows 2 and 6: green, then magenta, across both images.
        assert_eq!((*s.get_pixel(0, 2), *s.get_pixel(19, 2)), (Rgb([0, 255, 0]), Rgb([0, 255, 0])));
        assert_eq!(*s.get_pixel(5, 6), Rgb([255, 0, 255]));
        let v = side_by_side(&l, &r, true, 4);
        assert_eq!(v.dimensions(), (10, 16));
        assert_eq!((v.get_pixel(1, 3)[0], v.get_pixel(1, 11)[0]), (10, 200));
        assert_eq!((*v.get_pixel(2, 0), *v.get_pixel(6, 15)), (Rgb([0, 255, 0]), Rgb([255, 0, 255])));
    }

    #[test]
    fn sixteen_bit_pairs_stay_sixteen_bit_and_show_their_high_byte() {
        let l = image::ImageBuffer::<Luma<u16>, Vec<u16>>::from_pixel(4, 3, Luma([0x1234]));
        let pair = RectifiedPair::Luma16(l.clone(), l);
        let (a, _) = pair.to_rgb8();
        assert_eq!(*a.get_pixel(2, 1), Rgb([0x12, 0x12, 0x12]));
    }
}
