//! Disparity map files: PFM (Middlebury's float format), 16-bit PNG and a false-colour image.

use image::{ImageBuffer, Luma, Rgb, RgbImage};
use parallax_camera_model::DisparityMap;

use crate::error::{BlockMatchingError, Result};
use crate::frame::Gray16Image;

/// Encodes `map` as a little-endian greyscale PFM (`Pf`, scale −1, rows bottom to top, as
/// Middlebury). Invalid pixels are written as `+inf` (Middlebury's convention).
pub fn to_pfm(map: &DisparityMap) -> Vec<u8> {
    let mut bytes = format!("Pf\n{} {}\n-1\n", map.width(), map.height()).into_bytes();
    bytes.reserve(map.data().len() * 4);
    for y in (0..map.height()).rev() {
        for &d in &map.data()[y * map.width()..][..map.width()] {
            let v = if d.is_finite() { d } else { f32::INFINITY };
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    bytes
}

/// Decodes a greyscale PFM (either endianness); non-finite values become invalid. `what` names
/// the input in errors.
pub fn from_pfm(bytes: &[u8], what: &str) -> Result<DisparityMap> {
    let err = |reason: &str| BlockMatchingError::Parse { what: what.to_string(), reason: reason.to_string() };
    // three whitespace-separated header tokens after the magic, then one whitespace byte
    let mut pos = 0;
    let mut tokens = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(err("truncated header"));
        }
        tokens.push(std::str::from_utf8(&bytes[start..pos]).map_err(|_| err("header is not text"))?);
    }
    pos += 1;
    if tokens[0] != "Pf" {
        return Err(err("not a greyscale PFM (magic must be Pf)"));
    }
    let width: usize = tokens[1].parse().map_err(|_| err("bad width"))?;
    let height: usize = tokens[2].parse().map_err(|_| err("bad height"))?;
    let scale: f32 = tokens[3].parse().map_err(|_| err("bad scale"))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(err("scale must be non-zero"));
    }
    if width == 0 || height == 0 {
        return Err(err("empty map (width or height 0)"));
    }
    let need = width.checked_mul(height).and_then(|n| n.checked_mul(4)).ok_or_else(|| err("size overflows"))?;
    let body = bytes.get(pos..).filter(|b| b.len() >= need).ok_or_else(|| err("truncated data"))?;
    let mut data = vec![DisparityMap::INVALID; width * height];
    for y in 0..height {
        for x in 0..width {
            let i = ((height - 1 - y) * width + x) * 4;
            let raw = [body[i], body[i + 1], body[i + 2], body[i + 3]];
            let v = if scale < 0.0 { f32::from_le_bytes(raw) } else { f32::from_be_bytes(raw) };
            data[y * width + x] = if v.is_finite() { v } else { DisparityMap::INVALID };
        }
    }
    map_from(width, height, data)
}

/// A map of `width · height` values (the length was checked by the caller; a mismatch is
/// reported as a size error, never a panic).
fn map_from(width: usize, height: usize, data: Vec<f32>) -> Result<DisparityMap> {
    let n = data.len();
    DisparityMap::from_data(width, height, data).map_err(|_| BlockMatchingError::LengthMismatch {
        what: "disparity data",
        width,
        height,
        expected: width.saturating_mul(height),
        got: n,
    })
}

/// 16-bit PNG image of `round(d · scale)` (e.g. scale 256 as KITTI, 16 as OpenCV's fixed
/// point). Invalid pixels are 0; valid values are clamped to `1..=65535`, so a valid disparity
/// below `1/scale` reads back as `1/scale`.
pub fn to_png16(map: &DisparityMap, scale: f32) -> Gray16Image {
    ImageBuffer::from_fn(map.width() as u32, map.height() as u32, |x, y| {
        let d = map.data()[y as usize * map.width() + x as usize];
        Luma([if d.is_finite() { (d * scale).round().clamp(1.0, 65535.0) as u16 } else { 0 }])
    })
}

/// A disparity map from a PNG of `d · scale` (8- or 16-bit values given as `u16`), 0 = unknown:
/// Middlebury's `groundtruth.png` with its `info.txt` scale, or [`to_png16`] output.
pub fn from_scaled(values: &[u16], width: usize, height: usize, scale: f32) -> Result<DisparityMap> {
    if values.len() != width * height {
        return Err(BlockMatchingError::LengthMismatch {
            what: "scaled disparity image",
            width,
            height,
            expected: width.saturating_mul(height),
            got: values.len(),
        });
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(BlockMatchingError::InvalidConfig {
            field: "scale",
            value: scale.to_string(),
            reason: "must be positive and finite",
        });
    }
    let data = values.iter().map(|&v| if v == 0 { DisparityMap::INVALID } else { v as f32 / scale }).collect();
    map_from(width, height, data)
}

/// False-colour rendering for people: a jet-like ramp from blue (`min`) to red (`max`), invalid
/// pixels black. With `None` the range is the map's valid minimum and maximum.
pub fn false_colour(map: &DisparityMap, range: Option<(f32, f32)>) -> RgbImage {
    let (lo, hi) = range.unwrap_or_else(|| {
        map.data()
            .iter()
            .filter(|d| d.is_finite())
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &d| (a.min(d), b.max(d)))
    });
    let span = if hi > lo { hi - lo } else { 1.0 };
    ImageBuffer::from_fn(map.width() as u32, map.height() as u32, |x, y| {
        let d = map.data()[y as usize * map.width() + x as usize];
        if !d.is_finite() {
            return Rgb([0, 0, 0]);
        }
        let t = ((d - lo) / span).clamp(0.0, 1.0);
        let ch = |c: f32| ((1.5 - (4.0 * t - c).abs()).clamp(0.0, 1.0) * 255.0).round() as u8;
        Rgb([ch(3.0), ch(2.0), ch(1.0)])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> DisparityMap {
        let mut m = DisparityMap::from_data(3, 2, vec![1.5, 2.25, 0.0, 63.75, 10.0, 7.0]).unwrap();
        m.set(1, 1, None);
        m
    }

    #[test]
    fn pfm_round_trip_keeps_values_and_invalid() {
        let m = sample();
        let bytes = to_pfm(&m);
        assert!(bytes.starts_with(b"Pf\n3 2\n-1\n"));
        // first stored row is the bottom row: 63.75, inf, 7.0
        assert_eq!(&bytes[10..14], &63.75f32.to_le_bytes());
        assert_eq!(&bytes[14..18], &f32::INFINITY.to_le_bytes());
        let back = from_pfm(&bytes, "mem").unwrap();
        assert_eq!(back.get(0, 0), Some(1.5));
        assert_eq!(back.get(1, 1), None);
        assert_eq!(back.get(2, 1), Some(7.0));
        assert!(from_pfm(b"P6\n1 1\n255\n", "x").is_err());
        assert!(from_pfm(b"Pf\n4 4\n-1\n\0\0", "short.pfm").unwrap_err().to_string().contains("short.pfm"));
    }

    #[test]
    fn png16_round_trip_at_scale_256() {
        let m = sample();
        let img = to_png16(&m, 256.0);
        assert_eq!(img.get_pixel(0, 0)[0], 384);
        assert_eq!(img.get_pixel(1, 1)[0], 0);
        assert_eq!(img.get_pixel(2, 0)[0], 1); // 0 clamps to the smallest valid code
        let back = from_scaled(img.as_raw(), 3, 2, 256.0).unwrap();
        assert_eq!(back.get(1, 0), Some(2.25));
        assert_eq!(back.get(0, 1), Some(63.75));
        assert_eq!(back.get(1, 1), None);
    }

    #[test]
    fn false_colour_ends_are_blue_and_red_and_invalid_is_black() {
        let m = sample();
        let img = false_colour(&m, Some((0.0, 64.0)));
        let blue = img.get_pixel(2, 0);
        assert!(blue[2] > 100 && blue[0] == 0, "{blue:?}");
        let red = img.get_pixel(0, 1);
        assert!(red[0] > 100 && red[2] == 0, "{red:?}");
        assert_eq!(img.get_pixel(1, 1), &Rgb([0, 0, 0]));
    }
}
