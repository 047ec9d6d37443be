use glam::{DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Distortion, KannalaBrandt, Lens, LensModel, Result};

/// Pinhole intrinsics in pixels: `K = [fx skew cx; 0 fy cy; 0 0 1]`.
///
/// `skew` is OpenCV's missing term (always 0 there); it multiplies the normalised `y`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along `u`, pixels.
    pub fx: f64,
    /// Focal length along `v`, pixels.
    pub fy: f64,
    /// Principal point column, pixels.
    pub cx: f64,
    /// Principal point row, pixels.
    pub cy: f64,
    /// Skew (`K[0][1]`), pixels; 0 for every modern sensor.
    #[serde(default)]
    pub skew: f64,
}

impl Intrinsics {
    /// Intrinsics without skew.
    pub fn new(fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Self { fx, fy, cx, cy, skew: 0.0 }
    }

    /// Intrinsics from a focal length in metres and a square pixel pitch in metres
    /// (`fx = fy = focal / pitch`).
    pub fn from_focal_length_and_pixel_pitch(focal: f64, pitch: f64, cx: f64, cy: f64) -> Self {
        Self::new(focal / pitch, focal / pitch, cx, cy)
    }

    /// Checks that every value is finite and both focal lengths are positive.
    pub fn validate(&self) -> Result<()> {
        if !(self.fx.is_finite() && self.fy.is_finite()) || self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(CameraModelError::InvalidFocalLength { fx: self.fx, fy: self.fy });
        }
        if !(self.cx.is_finite() && self.cy.is_finite()) {
            return Err(CameraModelError::NonFinite { what: "principal point" });
        }
        if !self.skew.is_finite() {
            return Err(CameraModelError::NonFinite { what: "skew" });
        }
        Ok(())
    }

    /// The camera matrix `K` (glam matrices are column-major: `K.col(2) = (cx, cy, 1)`).
    pub fn matrix(&self) -> DMat3 {
        DMat3::from_cols(
            DVec3::new(self.fx, 0.0, 0.0),
            DVec3::new(self.skew, self.fy, 0.0),
            DVec3::new(self.cx, self.cy, 1.0),
        )
    }

    /// Intrinsics from an upper-triangular camera matrix (normalised so `K[2][2] = 1`).
    pub fn from_matrix(k: DMat3) -> Result<Self> {
        let s = k.z_axis.z;
        if !s.is_finite() || s == 0.0 {
            return Err(CameraModelError::NonFinite { what: "K[2][2]" });
        }
        let k = k * (1.0 / s);
        let out = Self { fx: k.x_axis.x, fy: k.y_axis.y, cx: k.z_axis.x, cy: k.z_axis.y, skew: k.y_axis.x };
        out.validate()?;
        Ok(out)
    }

    /// Maps normalised (distorted) image coordinates to pixels.
    #[inline]
    pub fn to_pixel(&self, normalized: DVec2) -> DVec2 {
        DVec2::new(self.fx * normalized.x + self.skew * normalized.y + self.cx, self.fy * normalized.y + self.cy)
    }

    /// Maps pixels to normalised (still distorted) image coordinates; inverse of [`Self::to_pixel`].
    #[inline]
    pub fn to_normalized(&self, pixel: DVec2) -> DVec2 {
        let y = (pixel.y - self.cy) / self.fy;
        DVec2::new((pixel.x - self.cx - self.skew * y) / self.fx, y)
    }
}

/// A calibrated camera: pinhole intrinsics `K`, a [`Lens`] (Brown–Conrady, Kannala–Brandt or
/// double sphere) and the image size they belong to. One type for every lens: the stages
/// project, unproject and differentiate through it (or the [`crate::CameraModel`] trait) and
/// match on [`Camera::lens`] only where a lens really needs other code.
///
/// In files a Brown–Conrady camera is written as before lenses were a choice
/// (`intrinsics, distortion, width, height`), a wide-angle one as `intrinsics, lens, width,
/// height`; both forms are read, and every camera read is checked as by [`Camera::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Pinhole intrinsics (for the wide-angle lenses OpenCV fisheye's `K`, with
    /// `skew = K[0][1]`, OpenCV's `alpha · fx`).
    pub intrinsics: Intrinsics,
    /// The lens model and its parameters.
    pub lens: Lens,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// A validated camera: finite parameters, positive focal lengths, non-zero size. `lens`
    /// is a [`Lens`] or any model's parameters ([`Distortion`], [`KannalaBrandt`],
    /// [`crate::DoubleSphere`]).
    pub fn new(intrinsics: Intrinsics, lens: impl Into<Lens>, width: u32, height: u32) -> Result<Self> {
        let camera = Self { intrinsics, lens: lens.into(), width, height };
        camera.validate()?;
        Ok(camera)
    }

    /// A Kannala–Brandt camera from `cv::fisheye`'s `K` (3x3) and `D` (4 values).
    pub fn from_opencv_kannala_brandt(k: DMat3, d: &[f64], width: u32, height: u32) -> Result<Self> {
        Self::new(Intrinsics::from_matrix(k)?, KannalaBrandt::from_opencv(d)?, width, height)
    }

    /// Checks the invariants of [`Self::new`] (useful after building one field by field).
    pub fn validate(&self) -> Result<()> {
        self.intrinsics.validate()?;
        self.lens.validate()?;
        if self.width == 0 || self.height == 0 {
            return Err(CameraModelError::InvalidImageSize { width: self.width, height: self.height });
        }
        Ok(())
    }

    /// The pinhole part.
    pub fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }

    /// The lens.
    pub fn lens(&self) -> Lens {
        self.lens
    }

    /// The lens model's name ([`LensModel`]).
    pub fn lens_model(&self) -> LensModel {
        self.lens.model()
    }

    /// The Brown–Conrady coefficients; `None` for a wide-angle lens.
    pub fn distortion(&self) -> Option<&Distortion> {
        self.lens.distortion()
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// True when the pixel lies inside the image (pixel centres `0..width-1`, with half a
    /// pixel of border on each side).
    pub fn contains(&self, pixel: DVec2) -> bool {
        pixel.x >= -0.5 && pixel.y >= -0.5 && pixel.x <= self.width as f64 - 0.5 && pixel.y <= self.height as f64 - 0.5
    }

    /// The same lens and size with other intrinsics (checked).
    pub fn with_intrinsics(&self, intrinsics: Intrinsics) -> Result<Self> {
        Self::new(intrinsics, self.lens, self.width, self.height)
    }

    /// The same intrinsics and size with another lens (checked).
    pub fn with_lens(&self, lens: impl Into<Lens>) -> Result<Self> {
        Self::new(self.intrinsics, lens, self.width, self.height)
    }

    /// Largest angle from the optical axis that is imaged (exclusive), radians: π/2 for
    /// Brown–Conrady.
    pub fn max_field_angle(&self) -> f64 {
        self.lens.max_theta()
    }
}

impl Serialize for Camera {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("Camera", 4)?;
        st.serialize_field("intrinsics", &self.intrinsics)?;
        match &self.lens {
            Lens::BrownConrady(d) => st.serialize_field("distortion", d)?,
            lens => st.serialize_field("lens", lens)?,
        }
        st.serialize_field("width", &self.width)?;
        st.serialize_field("height", &self.height)?;
        st.end()
    }
}

impl<'de> Deserialize<'de> for Camera {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_struct("Camera", &["intrinsics", "distortion", "lens", "width", "height"], CameraVisitor)
    }
}

/// The field names of a camera in a file.
#[derive(Deserialize)]
#[serde(field_identifier, rename_all = "lowercase")]
enum CameraField {
    Intrinsics,
    Distortion,
    Lens,
    Width,
    Height,
    #[serde(other)]
    Other,
}

/// Reads either form of a camera (a visitor, not a derived struct of options: RON reads an
/// `Option` only as `Some(…)`, and the pinhole form has the bare coefficients).
struct CameraVisitor;

impl<'de> serde::de::Visitor<'de> for CameraVisitor {
    type Value = Camera;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a camera: intrinsics, distortion or lens, width, height")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> std::result::Result<Camera, A::Error> {
        use serde::de::Error;
        let (mut intrinsics, mut lens, mut width, mut height) = (None, None, None, None);
        while let Some(key) = map.next_key::<CameraField>()? {
            let twice = |name: &'static str| A::Error::duplicate_field(name);
            match key {
                CameraField::Intrinsics if intrinsics.is_some() => return Err(twice("intrinsics")),
                CameraField::Intrinsics => intrinsics = Some(map.next_value::<Intrinsics>()?),
                CameraField::Distortion | CameraField::Lens if lens.is_some() => {
                    return Err(A::Error::custom("a camera has `distortion` or `lens`, once"));
                }
                CameraField::Distortion => lens = Some(Lens::BrownConrady(map.next_value::<Distortion>()?)),
                CameraField::Lens => lens = Some(map.next_value::<Lens>()?),
                CameraField::Width if width.is_some() => return Err(twice("width")),
                CameraField::Width => width = Some(map.next_value::<u32>()?),
                CameraField::Height if height.is_some() => return Err(twice("height")),
                CameraField::Height => height = Some(map.next_value::<u32>()?),
                CameraField::Other => {
                    map.next_value::<serde::de::IgnoredAny>()?;
                }
            }
        }
        let intrinsics = intrinsics.ok_or_else(|| A::Error::missing_field("intrinsics"))?;
        let lens = lens.ok_or_else(|| A::Error::custom("a camera needs `distortion` (Brown–Conrady) or `lens`"))?;
        let width = width.ok_or_else(|| A::Error::missing_field("width"))?;
        let height = height.ok_or_else(|| A::Error::missing_field("height"))?;
        Camera::new(intrinsics, lens, width, height).map_err(A::Error::custom)
    }
}
