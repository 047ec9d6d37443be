//! The dense disparity map handed from block matching to triangulation.

use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Result};

/// A dense left-view disparity map, `d = u_left − u_right` in pixels, row-major `f32`.
/// Invalid pixels hold [`DisparityMap::INVALID`] (NaN), never a silent 0: read them through
/// [`DisparityMap::get`], which returns `None` for them.
///
/// The length of the data always equals `width · height`: the fields are private, every
/// constructor checks it, and a deserialised map is checked the same way (`serde(try_from)`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DisparityMapFields")]
pub struct DisparityMap {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

/// The serialised form of [`DisparityMap`], checked on the way in.
#[derive(Deserialize)]
struct DisparityMapFields {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

impl TryFrom<DisparityMapFields> for DisparityMap {
    type Error = CameraModelError;
    fn try_from(f: DisparityMapFields) -> Result<Self> {
        Self::from_data(f.width, f.height, f.data)
    }
}

impl DisparityMap {
    /// The invalid marker (NaN: no comparison treats it as a disparity).
    pub const INVALID: f32 = f32::NAN;

    /// A map with every pixel invalid.
    ///
    /// # Panics
    /// When `width · height` overflows `usize` (no such map fits in memory).
    pub fn new_invalid(width: usize, height: usize) -> Self {
        let n = width.checked_mul(height).expect("disparity map size overflows usize");
        Self { width, height, data: vec![Self::INVALID; n] }
    }

    /// A map from row-major data; errors when the length is not `width · height`.
    pub fn from_data(width: usize, height: usize, data: Vec<f32>) -> Result<Self> {
        if width.checked_mul(height) != Some(data.len()) {
            let needs = width.checked_mul(height).map_or_else(|| "more than usize::MAX".to_string(), |n| n.to_string());
            return Err(CameraModelError::SizeMismatch(format!(
                "disparity map {width}x{height} needs {needs} values, got {}",
                data.len()
            )));
        }
        Ok(Self { width, height, data })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// The `width · height` disparities, row-major; NaN where invalid.
    #[inline]
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The disparities, mutable (the length cannot change).
    #[inline]
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    /// The disparities, by value.
    pub fn into_data(self) -> Vec<f32> {
        self.data
    }

    /// The disparity at `(u, v)`, `None` when invalid or out of bounds.
    #[inline]
    pub fn get(&self, u: usize, v: usize) -> Option<f32> {
        if u >= self.width || v >= self.height {
            return None;
        }
        let d = self.data[v * self.width + u];
        d.is_finite().then_some(d)
    }

    /// Sets the disparity at `(u, v)` (`None` marks it invalid).
    #[inline]
    pub fn set(&mut self, u: usize, v: usize, d: Option<f32>) {
        self.data[v * self.width + u] = d.unwrap_or(Self::INVALID);
    }

    /// Number of valid pixels.
    pub fn valid_count(&self) -> usize {
        self.data.iter().filter(|d| d.is_finite()).count()
    }

    /// Fraction of valid pixels in `[0, 1]`.
    pub fn density(&self) -> f64 {
        if self.data.is_empty() { 0.0 } else { self.valid_count() as f64 / self.data.len() as f64 }
    }
}
