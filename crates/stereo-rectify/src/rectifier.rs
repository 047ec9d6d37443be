//! The build-once [`Rectifier`]: a rig's rectification and both maps.

use parallax_camera_model::StereoRig;

use crate::maps::rectify_map_and_fast_table;
use crate::remap::{FastBilinear, Image, Sample, remap_impl};
use crate::{Border, Interpolation, Rectification, RectifyConfig, RectifyError, RemapTable, Result, stereo_rectify};

/// Rectifies image pairs of one rig: built once (rectification + both undistort/rectify maps),
/// then applied to every frame with [`Rectifier::rectify_pair`].
#[derive(Debug, Clone, PartialEq)]
pub struct Rectifier {
    rectification: Rectification,
    left_map: RemapTable,
    right_map: RemapTable,
    left_fast: FastBilinear,
    right_fast: FastBilinear,
    input_size: (u32, u32),
    interpolation: Interpolation,
}

impl Rectifier {
    /// Rectifies the rig ([`stereo_rectify`]) and builds both maps (bilinear by default).
    pub fn new(rig: &StereoRig, config: &RectifyConfig) -> Result<Self> {
        let rectification = stereo_rectify(rig, config)?;
        Self::from_rectification(rig, rectification)
    }

    /// Builds the maps of an existing rectification of `rig`.
    pub fn from_rectification(rig: &StereoRig, rectification: Rectification) -> Result<Self> {
        let (w, h) = (rectification.width, rectification.height);
        // each map and its fixed-point table in one pass (the table of a row is built while the
        // row is in cache), for sources of the calibrated size
        let src = (rig.left.width, rig.left.height);
        let (left, right) = rayon::join(
            || rectify_map_and_fast_table(&rig.left, rectification.r1, rectification.left_camera_matrix(), w, h, src),
            || rectify_map_and_fast_table(&rig.right, rectification.r2, rectification.right_camera_matrix(), w, h, src),
        );
        let ((left_map, left_fast), (right_map, right_fast)) = (left?, right?);
        Ok(Self {
            rectification,
            left_map,
            right_map,
            left_fast,
            right_fast,
            input_size: (rig.left.width, rig.left.height),
            interpolation: Interpolation::Bilinear,
        })
    }

    /// Chooses the interpolation of [`Self::rectify_pair`].
    pub fn with_interpolation(mut self, interpolation: Interpolation) -> Self {
        self.interpolation = interpolation;
        if interpolation == Interpolation::Nearest && self.left_fast.nearest.is_none() {
            // nearest-neighbour offsets, built once (bilinear users do not pay for them)
            let (left, right) = (&self.left_map, &self.right_map);
            let (l, r) = (self.left_fast, self.right_fast);
            (self.left_fast, self.right_fast) = rayon::join(|| l.with_nearest(left), || r.with_nearest(right));
        }
        self
    }

    /// The rectification (`R1`, `R2`, `P1`, `P2`, `Q`, ROIs).
    pub fn rectification(&self) -> &Rectification {
        &self.rectification
    }

    /// The left map.
    pub fn left_map(&self) -> &RemapTable {
        &self.left_map
    }

    /// The right map.
    pub fn right_map(&self) -> &RemapTable {
        &self.right_map
    }

    /// Rectifies a left/right pair (both images at the rig's calibrated size); the two images
    /// are resampled in parallel. `border` fills pixels without a source. Bilinear resampling
    /// uses maps precompiled to fixed point (1/256 px, as OpenCV's `CV_16SC2` maps at 1/32 px):
    /// within 1 grey level of [`remap`](crate::remap) with the `f32` maps.
    pub fn rectify_pair<P>(&self, left: &Image<P>, right: &Image<P>, border: Border<P>) -> Result<(Image<P>, Image<P>)>
    where
        P: image::Pixel + Send + Sync,
        P::Subpixel: Sample,
    {
        for (what, img) in [("left", left), ("right", right)] {
            if img.dimensions() != self.input_size {
                return Err(RectifyError::SizeMismatch(format!(
                    "{what} image is {}x{}, the rig was calibrated at {}x{}",
                    img.width(),
                    img.height(),
                    self.input_size.0,
                    self.input_size.1
                )));
            }
        }
        let (l, r) = rayon::join(
            || remap_impl(left, &self.left_map, Some(&self.left_fast), self.interpolation, border),
            || remap_impl(right, &self.right_map, Some(&self.right_fast), self.interpolation, border),
        );
        Ok((l?, r?))
    }
}
