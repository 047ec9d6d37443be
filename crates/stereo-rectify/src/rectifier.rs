//! The build-once [`Rectifier`]: a rig's rectification and both maps.

use parallax_camera_model::StereoRig;

use crate::maps::{fill_map_and_fast_table, map_params, size_map_and_fast_table};
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
        let mut rectifier = Self {
            rectification,
            left_map: RemapTable::empty(),
            right_map: RemapTable::empty(),
            left_fast: FastBilinear::empty(),
            right_fast: FastBilinear::empty(),
            input_size: (rig.left.width, rig.left.height),
            interpolation: Interpolation::Bilinear,
        };
        rectifier.rebuild_from_rectification(rig, rectification)?;
        Ok(rectifier)
    }

    /// Re-rectifies `rig` (a new calibration, or new [`RectifyConfig`]) into this rectifier,
    /// reusing its tables: when the rectified size is unchanged nothing is allocated (no fresh
    /// pages to fault in, which is most of the cost of [`Self::new`]). The interpolation chosen
    /// with [`Self::with_interpolation`] is kept. On error the rectifier is left unchanged.
    pub fn rebuild(&mut self, rig: &StereoRig, config: &RectifyConfig) -> Result<()> {
        let rectification = stereo_rectify(rig, config)?;
        self.rebuild_from_rectification(rig, rectification)
    }

    /// [`Self::rebuild`] from an existing rectification of `rig`.
    pub fn rebuild_from_rectification(&mut self, rig: &StereoRig, rectification: Rectification) -> Result<()> {
        let (w, h) = (rectification.width, rectification.height);
        // every check first: the fill below cannot fail, so an error leaves `self` as it was
        let lp = map_params(&rig.left, rectification.r1, rectification.left_camera_matrix(), w, h)?;
        let rp = map_params(&rig.right, rectification.r2, rectification.right_camera_matrix(), w, h)?;
        // each map and its fixed-point table in one pass (the table of a row is built while the
        // row is in cache), for sources of the calibrated size
        let src = (rig.left.width, rig.left.height);
        let nearest = self.interpolation == Interpolation::Nearest;
        // (re)size the tables on this thread: fresh buffers then come from this thread's malloc
        // arena, whose freed blocks the next build reuses (allocated inside the rayon tasks they
        // came from other threads' arenas and were returned to the OS on free: measured, every
        // `new` then faulted in all 8.6 MB of a 640x480 pair's tables again)
        size_map_and_fast_table(w, h, src, &mut self.left_map, &mut self.left_fast);
        size_map_and_fast_table(w, h, src, &mut self.right_map, &mut self.right_fast);
        let (lm, lf, rm, rf) = (&mut self.left_map, &mut self.left_fast, &mut self.right_map, &mut self.right_fast);
        rayon::join(
            || {
                fill_map_and_fast_table(&lp, w, h, src, lm, lf);
                if nearest {
                    lf.fill_nearest(lm);
                }
            },
            || {
                fill_map_and_fast_table(&rp, w, h, src, rm, rf);
                if nearest {
                    rf.fill_nearest(rm);
                }
            },
        );
        self.rectification = rectification;
        self.input_size = src;
        Ok(())
    }

    /// Chooses the interpolation of [`Self::rectify_pair`].
    pub fn with_interpolation(mut self, interpolation: Interpolation) -> Self {
        self.interpolation = interpolation;
        if interpolation == Interpolation::Nearest && self.left_fast.nearest.is_none() {
            // nearest-neighbour offsets, built once (bilinear users do not pay for them)
            let (lm, lf, rm, rf) = (&self.left_map, &mut self.left_fast, &self.right_map, &mut self.right_fast);
            rayon::join(|| lf.fill_nearest(lm), || rf.fill_nearest(rm));
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
