//! The dense disparity map handed from block matching to triangulation.

use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Result};

/// A dense left-view disparity map, `d = u_left − u_right` in pixels, row-major `f32`.
/// Invalid pixels hold [`DisparityMap::INVALID`] (NaN), never a silent 0: read them through
/// [`DisparityMap::get`], which returns `None` for them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisparityMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width · height` disparities, row-major; NaN where invalid.
    pub data: Vec<f32>,
}

impl DisparityMap {
    /// The invalid marker (NaN: no comparison treats it as a disparity).
    pub const INVALID: f32 = f32::NAN;

    /// A map with every pixel invalid.
    pub fn new_invalid(width: usize, height: usize) -> Self {
        Self { width, height, data: vec![Self::INVALID; width * height] }
    }

    /// A map from row-major data; errors when the length is not `width · height`.
    pub fn from_data(width: usize, height: usize, data: Vec<f32>) -> Result<Self> {
        if data.len() != width * height {
            return Err(CameraModelError::SizeMismatch(format!(
                "disparity map {width}x{height} needs {} values, got {}",
                width * height,
                data.len()
            )));
        }
        Ok(Self { width, height, data })
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
