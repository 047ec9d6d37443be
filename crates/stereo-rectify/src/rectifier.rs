//! The build-once [`Rectifier`]: a rig's rectification and both maps.

use std::sync::OnceLock;

use parallax_camera_model::StereoRig;

use crate::maps::{MapRow, fill_fast_table, fill_map, map_params, size_fast_table};
use crate::remap::{FastBilinear, Image, Sample, remap_fast};
use crate::{Border, Interpolation, Rectification, RectifyConfig, RectifyError, RemapTable, Result, stereo_rectify};

/// Rectifies image pairs of one rig: built once (rectification + both fixed-point tables),
/// then applied to every frame with [`Rectifier::rectify_pair`].
///
/// The `f32` maps ([`Rectifier::left_map`], [`Rectifier::right_map`]) are built on first use
/// and kept: resampling needs only the fixed-point tables (6 bytes per pixel against the 8 of
/// a pair of `f32` maps), and the fresh pages of the maps were most of the cost of a build.
/// For the same reason the tables of a dropped rectifier are kept (at most two per kind and 48
/// MiB in the process) and a later rectifier of the same size builds into them;
/// [`Rectifier::rebuild`] reuses this rectifier's own.
#[derive(Debug, Clone)]
pub struct Rectifier {
    rectification: Rectification,
    left: Side,
    right: Side,
    input_size: (u32, u32),
    interpolation: Interpolation,
}

/// One camera's part: the map's per-row formula, its fixed-point table, and the `f32` map once
/// asked for.
#[derive(Debug, Clone)]
struct Side {
    params: MapRow,
    fast: FastBilinear,
    map: OnceLock<RemapTable>,
}

/// The `f32` map of `params`.
fn new_map(params: &MapRow, width: u32, height: u32) -> RemapTable {
    let mut map = RemapTable::empty();
    fill_map(params, width, height, &mut map);
    map
}

impl Side {
    fn map(&self, width: u32, height: u32) -> &RemapTable {
        self.map.get_or_init(|| new_map(&self.params, width, height))
    }

    /// Builds the nearest-neighbour table (from the `f32` map, built first if needed).
    fn fill_nearest(&mut self, width: u32, height: u32) {
        let Side { params, fast, map } = self;
        fast.fill_nearest(map.get_or_init(|| new_map(params, width, height)));
    }

    /// Builds the table (and the nearest-neighbour table, and refills the `f32` map in place
    /// when one was built) for new parameters.
    fn fill(&mut self, width: u32, height: u32, src: (u32, u32), nearest: bool) {
        fill_fast_table(&self.params, width, height, src, &mut self.fast);
        if let Some(map) = self.map.get_mut() {
            fill_map(&self.params, width, height, map);
        }
        if nearest {
            self.fill_nearest(width, height);
        }
    }
}

/// Equal when the rectification, the settings and the tables are: the `f32` maps are a
/// function of those, built or not.
impl PartialEq for Rectifier {
    fn eq(&self, other: &Self) -> bool {
        self.rectification == other.rectification
            && self.input_size == other.input_size
            && self.interpolation == other.interpolation
            && [(&self.left, &other.left), (&self.right, &other.right)]
                .iter()
                .all(|(a, b)| a.params == b.params && a.fast == b.fast)
    }
}

impl Rectifier {
    /// Rectifies the rig ([`stereo_rectify`]) and builds both tables (bilinear by default).
    pub fn new(rig: &StereoRig, config: &RectifyConfig) -> Result<Self> {
        let rectification = stereo_rectify(rig, config)?;
        Self::from_rectification(rig, rectification)
    }

    /// Builds the tables of an existing rectification of `rig`.
    pub fn from_rectification(rig: &StereoRig, rectification: Rectification) -> Result<Self> {
        let (w, h) = (rectification.width, rectification.height);
        let side = |params| Side { params, fast: FastBilinear::empty(), map: OnceLock::new() };
        let mut rectifier = Self {
            rectification,
            left: side(map_params(&rig.left, rectification.r1, rectification.left_camera_matrix(), w, h)?),
            right: side(map_params(&rig.right, rectification.r2, rectification.right_camera_matrix(), w, h)?),
            input_size: (rig.left.width, rig.left.height),
            interpolation: Interpolation::Bilinear,
        };
        rectifier.rebuild_from_rectification(rig, rectification)?;
        Ok(rectifier)
    }

    /// Re-rectifies `rig` (a new calibration, or new [`RectifyConfig`]) into this rectifier,
    /// reusing its tables: when the rectified size is unchanged nothing is allocated (no fresh
    /// pages to fault in, which is most of the cost of [`Self::new`]). The interpolation chosen
    /// with [`Self::with_interpolation`] is kept, and `f32` maps already built are rebuilt in
    /// place. On error the rectifier is left unchanged.
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
        // for sources of the calibrated size
        let src = (rig.left.width, rig.left.height);
        let nearest = self.interpolation == Interpolation::Nearest;
        (self.left.params, self.right.params) = (lp, rp);
        // size the tables on this thread (see `size_fast_table`), then fill both in parallel
        size_fast_table(w, h, src, &mut self.left.fast);
        size_fast_table(w, h, src, &mut self.right.fast);
        let (l, r) = (&mut self.left, &mut self.right);
        rayon::join(|| l.fill(w, h, src, nearest), || r.fill(w, h, src, nearest));
        self.rectification = rectification;
        self.input_size = src;
        Ok(())
    }

    /// Chooses the interpolation of [`Self::rectify_pair`].
    pub fn with_interpolation(mut self, interpolation: Interpolation) -> Self {
        self.interpolation = interpolation;
        if interpolation == Interpolation::Nearest && self.left.fast.nearest.is_none() {
            // nearest-neighbour offsets, built once (bilinear users do not pay for them)
            let (w, h) = (self.rectification.width, self.rectification.height);
            let (l, r) = (&mut self.left, &mut self.right);
            rayon::join(|| l.fill_nearest(w, h), || r.fill_nearest(w, h));
        }
        self
    }

    /// The rectification (`R1`, `R2`, `P1`, `P2`, `Q`, ROIs).
    pub fn rectification(&self) -> &Rectification {
        &self.rectification
    }

    /// The left map (built on first use).
    pub fn left_map(&self) -> &RemapTable {
        self.left.map(self.rectification.width, self.rectification.height)
    }

    /// The right map (built on first use).
    pub fn right_map(&self) -> &RemapTable {
        self.right.map(self.rectification.width, self.rectification.height)
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
            || remap_fast(left, &self.left.fast, self.interpolation, border),
            || remap_fast(right, &self.right.fast, self.interpolation, border),
        );
        Ok((l?, r?))
    }
}
