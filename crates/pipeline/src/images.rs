//! Rectified pairs as files: a pair resampled at its pixel type (8- or 16-bit grey, RGB),
//! written as `left_rectified.png` / `right_rectified.png`, and the side-by-side picture with
//! guide lines along the epipolar direction.

use std::path::Path;

use image::{DynamicImage, GrayImage, Luma, Rgb, RgbImage};
use parallax_interop::RectificationMatrices;
use parallax_stereo_rectify::{Border, Image, Rectifier};
use serde::{Deserialize, Serialize};

use crate::{PipelineError, Result};

/// Keyword of the PNG text chunk that holds a [`RectificationStamp`].
pub const STAMP_KEYWORD: &str = "parallax-rectification";

/// What `rectify` records in each image it writes (a PNG `tEXt` chunk, keyword
/// [`STAMP_KEYWORD`], one line of RON): the rectification the pair went through and how it was
/// made, so that a command given these images and a rectification file refuses a file that is
/// not theirs (`disparity --calib` with the alpha-0 file beside alpha-1 images gave depths 22 %
/// off with exit 0), and `measure`, which triangulates raw pixels, refuses rectified images.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RectificationStamp {
    /// `left` or `right`.
    pub side: String,
    /// Size of the rectified images, pixels.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// How the matrices were made (`alpha 0`, `alpha 1`, `the calibration file's`, …).
    pub made: String,
    /// Left rectified projection `P1`, rows.
    pub p1: [[f64; 4]; 3],
    /// Right rectified projection `P2`, rows.
    pub p2: [[f64; 4]; 3],
    /// Disparity-to-depth matrix `Q`, rows.
    pub q: [[f64; 4]; 4],
}

impl RectificationStamp {
    /// The stamp of `side` for images of `width` x `height` rectified with `m`.
    pub fn new(side: &str, (width, height): (u32, u32), made: &str, m: &RectificationMatrices) -> Self {
        Self { side: side.into(), width, height, made: made.into(), p1: m.p1.rows, p2: m.p2.rows, q: m.q }
    }

    /// The largest difference between this stamp's `P1`, `P2` and `Q` and `m`'s, each relative to
    /// the largest entry of its matrix.
    fn difference(&self, m: &RectificationMatrices) -> f64 {
        fn rel<const R: usize>(a: &[[f64; 4]; R], b: &[[f64; 4]; R]) -> f64 {
            let scale = a.iter().chain(b).flatten().fold(0.0f64, |s, v| s.max(v.abs())).max(f64::MIN_POSITIVE);
            a.iter().flatten().zip(b.iter().flatten()).fold(0.0f64, |d, (x, y)| d.max((x - y).abs() / scale))
        }
        rel(&self.p1, &m.p1.rows).max(rel(&self.p2, &m.p2.rows)).max(rel(&self.q, &m.q))
    }

    /// Refuses `m` (read from `file`) for the image `image` that carries this stamp unless they are
    /// the same rectification (`P1`, `P2`, `Q` to 1e-6 of their largest entries, which any of
    /// our file formats keeps) and `size` is the stamp's.
    pub fn check(&self, m: &RectificationMatrices, size: (u32, u32), image: &Path, file: &str) -> Result<()> {
        let diff = self.difference(m);
        if (self.width, self.height) == size && diff <= 1e-6 {
            return Ok(());
        }
        // depth = f·B / d: the ratio of the two f·B products is the depth error
        let fb = |q: &[[f64; 4]; 4]| q[2][3] / q[3][2];
        let ratio = fb(&m.q) / fb(&self.q);
        Err(PipelineError::Input(format!(
            "{} was rectified by `rectify` ({}; {}x{}, focal {:.2} px, recorded in the image) with another \
             rectification than {file} holds (focal {:.2} px; P1 P2 Q differ by {diff:.2e} of their largest \
             entries): depths through {file} would be {:.1} % off. Give the rectification file written with these \
             images (rectification.ron in the same --out folder)",
            image.display(),
            self.made,
            self.width,
            self.height,
            self.p1[0][0],
            m.p1.rows[0][0],
            100.0 * (ratio - 1.0).abs(),
        )))
    }
}

/// PNG bytes of `pixels` (`color`, `depth`; 16-bit samples big-endian as PNG stores them) with
/// a `tEXt` chunk `keyword: text` (the `image` crate writes no text chunks).
fn png_with_text(
    (width, height): (u32, u32),
    color: png::ColorType,
    depth: png::BitDepth,
    pixels: &[u8],
    (keyword, text): (&str, &str),
) -> Result<Vec<u8>> {
    let fail = |e: png::EncodingError| PipelineError::Input(format!("encoding a rectified PNG: {e}"));
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, width, height);
    encoder.set_color(color);
    encoder.set_depth(depth);
    encoder.add_text_chunk(keyword.into(), text.into()).map_err(fail)?;
    let mut writer = encoder.write_header().map_err(fail)?;
    writer.write_image_data(pixels).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(bytes)
}

/// How much of an image file [`read_stamp`] reads: the signature, the header and the text
/// chunks `rectify` writes before the image data.
const STAMP_HEAD_BYTES: u64 = 64 << 10;

/// The [`RectificationStamp`] an image file carries, `None` for an image without one (not a
/// PNG, or a PNG `rectify` did not write).
pub fn read_stamp(path: &Path) -> Result<Option<RectificationStamp>> {
    use std::io::Read;
    // `rectify` writes the chunk before the image data: the file's head is enough
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(STAMP_HEAD_BYTES).read_to_end(&mut bytes))
        .map_err(|e| PipelineError::Input(format!("reading {}: {e}", path.display())))?;
    if !bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Ok(None);
    }
    let bad = |e: &dyn std::fmt::Display| PipelineError::Input(format!("{}: {e}", path.display()));
    let reader = png::Decoder::new(std::io::Cursor::new(&bytes)).read_info().map_err(|e| bad(&e))?;
    let Some(chunk) = reader.info().uncompressed_latin1_text.iter().find(|c| c.keyword == STAMP_KEYWORD) else {
        return Ok(None);
    };
    ron::from_str(&chunk.text)
        .map(Some)
        .map_err(|e| bad(&format!("its {STAMP_KEYWORD} text chunk is not a rectification stamp: {e}")))
}

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
    /// Each image carries its [`RectificationStamp`] (`made` and the matrices `m`).
    pub fn add_to(
        &self,
        set: &mut crate::io::OutputSet,
        dir: &Path,
        made: &str,
        m: &RectificationMatrices,
    ) -> Result<()> {
        let size = self.dimensions();
        for (side, k) in [("left", 0), ("right", 1)] {
            let stamp = ron::to_string(&RectificationStamp::new(side, size, made, m))
                .map_err(|e| PipelineError::Input(format!("writing a rectification stamp: {e}")))?;
            let text = (STAMP_KEYWORD, stamp.as_str());
            let bytes = match self {
                Self::Luma8(a, b) => {
                    png_with_text(size, png::ColorType::Grayscale, png::BitDepth::Eight, [a, b][k].as_raw(), text)?
                }
                Self::Luma16(a, b) => {
                    let be: Vec<u8> = [a, b][k].as_raw().iter().flat_map(|v| v.to_be_bytes()).collect();
                    png_with_text(size, png::ColorType::Grayscale, png::BitDepth::Sixteen, &be, text)?
                }
                Self::Rgb8(a, b) => {
                    png_with_text(size, png::ColorType::Rgb, png::BitDepth::Eight, [a, b][k].as_raw(), text)?
                }
            };
            set.add(dir.join(format!("{side}_rectified.png")), bytes)?;
        }
        Ok(())
    }

    /// Width and height of the rectified images.
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            Self::Luma8(a, _) => a.dimensions(),
            Self::Luma16(a, _) => a.dimensions(),
            Self::Rgb8(a, _) => a.dimensions(),
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
    use glam::DMat3;
    use parallax_camera_model::ProjectionMatrix;

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

    fn matrices(f: f64, b: f64) -> RectificationMatrices {
        let p1 = ProjectionMatrix { rows: [[f, 0.0, 31.5, 0.0], [0.0, f, 23.5, 0.0], [0.0, 0.0, 1.0, 0.0]] };
        let p2 = ProjectionMatrix { rows: [[f, 0.0, 31.5, -f * b], [0.0, f, 23.5, 0.0], [0.0, 0.0, 1.0, 0.0]] };
        let q = [[1.0, 0.0, 0.0, -31.5], [0.0, 1.0, 0.0, -23.5], [0.0, 0.0, 0.0, f], [0.0, 0.0, 1.0 / b, 0.0]];
        RectificationMatrices { r1: DMat3::IDENTITY, r2: DMat3::IDENTITY, p1, p2, q }
    }

    /// Every pixel type is written with its stamp and decodes to the same pixels (16-bit too:
    /// PNG's big-endian samples); the stamp reads back and accepts its own matrices only.
    #[test]
    fn rectified_images_carry_their_rectification() {
        let (w, h) = (64u32, 48u32);
        let g8 = GrayImage::from_fn(w, h, |u, v| Luma([(u * 3 + v * 5) as u8]));
        let g16 = Image::<Luma<u16>>::from_fn(w, h, |u, v| Luma([(u * 997 + v * 1231) as u16]));
        let rgb = RgbImage::from_fn(w, h, |u, v| Rgb([u as u8, v as u8, (u ^ v) as u8]));
        let m = matrices(500.0, -0.1);
        for (k, pair) in [
            RectifiedPair::Luma8(g8.clone(), g8.clone()),
            RectifiedPair::Luma16(g16.clone(), g16.clone()),
            RectifiedPair::Rgb8(rgb.clone(), rgb.clone()),
        ]
        .into_iter()
        .enumerate()
        {
            let dir = crate::io::test_dir(&format!("stamp-{k}"));
            let mut set = crate::io::OutputSet::new();
            pair.add_to(&mut set, &dir, "alpha 1", &m).unwrap();
            set.commit().unwrap();
            for side in ["left", "right"] {
                let path = dir.join(format!("{side}_rectified.png"));
                let back = crate::io::load_image(&path).unwrap();
                match &pair {
                    RectifiedPair::Luma8(..) => assert_eq!(back.as_luma8().unwrap(), &g8),
                    RectifiedPair::Luma16(..) => assert_eq!(back.as_luma16().unwrap(), &g16),
                    RectifiedPair::Rgb8(..) => assert_eq!(back.as_rgb8().unwrap(), &rgb),
                }
                let stamp = read_stamp(&path).unwrap().expect("a stamp");
                assert_eq!(stamp, RectificationStamp::new(side, (w, h), "alpha 1", &m));
                stamp.check(&m, (w, h), &path, "r.ron").unwrap();
                // another focal length: refused with the depth error (f·B 5 % larger → 5.0 %)
                let err = stamp.check(&matrices(525.0, -0.1), (w, h), &path, "r.ron").unwrap_err().to_string();
                assert!(err.contains("5.0 % off") && err.contains("alpha 1"), "{err}");
                // another size: refused
                assert!(stamp.check(&m, (w, h + 2), &path, "r.ron").is_err());
            }
            std::fs::remove_dir_all(&dir).unwrap();
        }
        // an image rectify did not write has no stamp
        let plain = crate::io::test_dir("stamp-plain").join("p.png");
        crate::io::save_png(&plain, &g8).unwrap();
        assert_eq!(read_stamp(&plain).unwrap(), None);
    }
}
