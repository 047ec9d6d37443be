//! Stereo worlds: 3D scenes of planes, spheres, cylinders and height fields, ray-cast into a
//! rectified pair, with the exact disparity and occlusion of every pixel of both views.
//!
//! Frames follow OpenCV: the left camera at the origin, x right, y down, z forward, in the
//! scene's length unit; the right camera at `(baseline, 0, 0)` with the same orientation and
//! intrinsics (`right_from_left = (−baseline, 0, 0)`), so a point at depth `Z` has the
//! disparity `d = f · B / Z` exactly.

use glam::DVec3;
use image::{DynamicImage, GrayImage, ImageBuffer, Luma, RgbImage};
use parallax_camera_model::{Camera, DisparityMap, Distortion, Intrinsics, Isometry3, StereoRig};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::error::{non_negative, positive};
use rand::Rng;

use crate::noise::{normal, rng};
use crate::stereo::{splitmix, value_noise};

/// A point or a direction in the left camera's frame (scene units).
pub type Vec3 = [f64; 3];

/// The geometry of a surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// A plane through `centre` with the normal `normal` (any orientation: a wall, a slanted
    /// panel, a ground plane), bounded to a rectangle of `half_size` (along the plane's
    /// horizontal axis `normal × y` — `x` for a plane facing the camera along `z` — and the
    /// axis in the plane perpendicular to it) or unbounded (`None`).
    Plane {
        /// A point of the plane, the rectangle's centre.
        centre: Vec3,
        /// The plane's normal (any length but zero).
        normal: Vec3,
        /// Half extents of the rectangle; `None` for an unbounded plane.
        #[serde(default)]
        half_size: Option<[f64; 2]>,
    },
    /// A sphere.
    Sphere {
        /// Its centre.
        centre: Vec3,
        /// Its radius.
        radius: f64,
    },
    /// A closed cylinder (posts, wires, pipes: thin ones are thinner than a pixel).
    Cylinder {
        /// The centre of its axis.
        centre: Vec3,
        /// The direction of its axis (any length but zero).
        axis: Vec3,
        /// Its radius.
        radius: f64,
        /// Half its length along the axis (the end caps are discs).
        half_length: f64,
    },
    /// A relief facing the camera: `z = depth + amplitude · h(x / scale, y / scale)`, `h` a
    /// smooth noise in `[−1, 1]` (two octaves), over `x0 ≤ x ≤ x1, y0 ≤ y ≤ y1` (`bounds`;
    /// `None` for everywhere). Its slope is bounded so that every camera ray crosses it once.
    HeightField {
        /// Mean depth.
        depth: f64,
        /// Largest height above or below `depth`.
        amplitude: f64,
        /// Lateral size of its bumps (scene units).
        scale: f64,
        /// `[x0, x1, y0, y1]`, or `None`.
        #[serde(default)]
        bounds: Option<[f64; 4]>,
    },
}

/// The pattern of a surface's texture, a function of the point on the surface (so both views
/// see the same texture).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Pattern {
    /// 1/f ("pink") noise: six octaves of value noise from `scale` (the finest period) up, of
    /// equal amplitude (the same energy per octave, as the spectra of natural images).
    Pink,
    /// A checkerboard of squares of side `scale`: a repetitive pattern.
    Checker,
    /// Stripes of period `scale` at `angle_deg` from the surface's first axis: repetitive
    /// along one direction, uniform along the other.
    Stripes {
        /// Angle of the stripes' normal, degrees.
        angle_deg: f64,
    },
    /// A uniform colour: textureless.
    Uniform,
}

/// A surface's texture: `mean ± contrast` grey levels (radiance before the camera; for pink
/// noise `contrast` is about 2.5 standard deviations), tinted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Texture {
    /// The pattern.
    pub pattern: Pattern,
    /// Mean radiance, grey levels (default 128).
    pub mean: f64,
    /// Amplitude of the pattern, grey levels (default 60).
    pub contrast: f64,
    /// Period of the pattern's finest detail, scene units (default 0.02).
    pub scale: f64,
    /// Colour of the surface: the pattern's radiance times each channel's factor (default
    /// `[1, 1, 1]`, grey).
    pub tint: [f64; 3],
    /// Colour noise: each channel adds its own pink noise of this fraction of `contrast` (only
    /// in colour worlds; default 0).
    pub chroma: f64,
}

impl Default for Texture {
    fn default() -> Self {
        Self { pattern: Pattern::Pink, mean: 128.0, contrast: 60.0, scale: 0.02, tint: [1.0; 3], chroma: 0.0 }
    }
}

/// A surface of the world: a shape and its texture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    /// Its geometry.
    pub shape: Shape,
    /// Its texture.
    #[serde(default)]
    pub texture: Texture,
}

/// How a camera turns radiance into grey levels: `x = gain · L · (1 − vignetting · ρ²) +
/// offset` (ρ the distance to the image centre over the half diagonal), then
/// `255 · (x / 255)^gamma`, then the world's blur and noise, rounded to 8 bits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Photometry {
    /// Gain (default 1).
    pub gain: f64,
    /// Offset, grey levels (default 0).
    pub offset: f64,
    /// Gamma exponent (default 1).
    pub gamma: f64,
    /// Relative darkening at the image corners, `0..1` (default 0).
    pub vignetting: f64,
}

impl Default for Photometry {
    fn default() -> Self {
        Self { gain: 1.0, offset: 0.0, gamma: 1.0, vignetting: 0.0 }
    }
}

impl Photometry {
    fn validate(&self, which: &'static str) -> Result<(), SyntheticError> {
        positive(which, self.gain)?;
        positive(which, self.gamma)?;
        if !self.offset.is_finite() || !(0.0..1.0).contains(&self.vignetting) {
            return Err(SyntheticError::config(which, "offset must be finite and vignetting in [0, 1)"));
        }
        Ok(())
    }
}

/// A 3D stereo world (a RON description): a rectified pinhole pair and the surfaces it sees.
/// Every pixel of both views must see a surface (give a backdrop), and every true disparity
/// must lie in `(0, disparities)`; [`render_world`] refuses the world otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StereoWorld {
    /// Image width, pixels (32..=16384).
    pub width: u32,
    /// Image height, pixels (32..=16384).
    pub height: u32,
    /// Focal length of both rectified cameras, pixels (principal point at the image centre).
    pub focal_px: f64,
    /// Baseline, scene units.
    pub baseline: f64,
    /// Disparities a matcher searches (`[0, disparities)`): every true disparity lies inside.
    pub disparities: usize,
    /// The surfaces (at least one).
    pub surfaces: Vec<Surface>,
    /// The left camera's photometry.
    #[serde(default)]
    pub left: Photometry,
    /// The right camera's photometry.
    #[serde(default)]
    pub right: Photometry,
    /// Standard deviation of the sensor noise, grey levels (independent per pixel and view).
    #[serde(default)]
    pub noise_sigma: f64,
    /// Standard deviation of the optical blur (Gaussian), pixels; 0 for none.
    #[serde(default)]
    pub blur_sigma: f64,
    /// Render colour images (else grey: the luminance 0.299 R + 0.587 G + 0.114 B).
    #[serde(default)]
    pub colour: bool,
    /// Supersampling: `n x n` rays per pixel (1..=8; default 3).
    #[serde(default = "default_samples")]
    pub samples_per_axis: u32,
    /// Seed of the textures and the noise.
    #[serde(default)]
    pub seed: u64,
}

fn default_samples() -> u32 {
    3
}

/// A rendered world: both views and the truth of both.
#[derive(Debug, Clone)]
pub struct WorldViews {
    /// Left image (`Luma8`, or `Rgb8` for a colour world).
    pub left: DynamicImage,
    /// Right image.
    pub right: DynamicImage,
    /// True left disparity at every pixel centre (`u_left − u_right`).
    pub disparity: DisparityMap,
    /// True right disparity at every right pixel centre (the left column is `u + d`).
    pub disparity_right: DisparityMap,
    /// Left pixels whose surface point the right camera does not see (hidden by a nearer
    /// surface, or outside the right image).
    pub occluded: Vec<bool>,
    /// Right pixels whose surface point the left camera does not see.
    pub occluded_right: Vec<bool>,
    /// The rectified rig of the views.
    pub rig: StereoRig,
}

/// Hits closer than this (scene units along z) are ignored (a ray leaving a surface).
const T_MIN: f64 = 1e-9;
/// A hit nearer than this fraction short of a point hides it.
const SHADOW_TOLERANCE: f64 = 1e-9;
/// Largest slope-times-ray-obliquity of a height field (below 1 every ray crosses it once).
const HEIGHT_FIELD_MAX_SLOPE: f64 = 0.9;
/// Bound of `|∇h|` times `scale` of the two-octave noise `h` (the quintic fade's slope is at
/// most 15/8, a lattice step at most 1, `√2` for the diagonal, `2` for the `[−1, 1]` range,
/// `(1 + 0.5 · 2) / 1.5` for the octaves).
const HEIGHT_FIELD_LIPSCHITZ: f64 = 15.0 / 8.0 * std::f64::consts::SQRT_2 * 2.0 * 2.0 / 1.5;

fn vec3(v: Vec3) -> DVec3 {
    DVec3::from_array(v)
}

fn finite3(field: &'static str, v: Vec3) -> Result<DVec3, SyntheticError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(vec3(v))
    } else {
        Err(SyntheticError::config(field, format!("must be finite, got {v:?}")))
    }
}

fn unit3(field: &'static str, v: Vec3) -> Result<DVec3, SyntheticError> {
    let d = finite3(field, v)?;
    if d.length() < 1e-12 {
        return Err(SyntheticError::config(field, "must not be zero"));
    }
    Ok(d.normalize())
}

/// Two unit vectors perpendicular to `n` and to each other (the first horizontal when `n` is
/// not vertical).
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let e1 = if n.cross(DVec3::Y).length() > 1e-6 { n.cross(DVec3::Y).normalize() } else { DVec3::X };
    (e1, n.cross(e1).normalize())
}

/// A shape with its derived vectors, ready for ray casting.
#[derive(Debug, Clone, Copy)]
enum Prepared {
    Plane { c: DVec3, n: DVec3, e1: DVec3, e2: DVec3, half: Option<[f64; 2]> },
    Sphere { c: DVec3, r: f64 },
    Cylinder { c: DVec3, a: DVec3, e1: DVec3, e2: DVec3, r: f64, half: f64 },
    HeightField { depth: f64, amplitude: f64, scale: f64, bounds: Option<[f64; 4]>, seed: u64 },
}

/// Two octaves of value noise in `[−1, 1]`.
#[inline]
fn height(x: f64, y: f64, seed: u64) -> f64 {
    let a = 2.0 * value_noise(x, y, seed) - 1.0;
    let b = 2.0 * value_noise(2.0 * x, 2.0 * y, seed ^ 0x51ed_270b) - 1.0;
    (a + 0.5 * b) / 1.5
}

impl Prepared {
    /// The smallest `t > T_MIN` with `o + t·r` on the surface.
    #[inline]
    fn hit(&self, o: DVec3, r: DVec3) -> Option<f64> {
        match *self {
            Prepared::Plane { c, n, e1, e2, half } => {
                let den = n.dot(r);
                if den.abs() < 1e-15 {
                    return None;
                }
                let t = n.dot(c - o) / den;
                if t <= T_MIN {
                    return None;
                }
                if let Some([hw, hh]) = half {
                    let q = o + t * r - c;
                    if q.dot(e1).abs() > hw || q.dot(e2).abs() > hh {
                        return None;
                    }
                }
                Some(t)
            }
            Prepared::Sphere { c, r: radius } => {
                let w = o - c;
                let (a, b, cc) = (r.dot(r), w.dot(r), w.dot(w) - radius * radius);
                let disc = b * b - a * cc;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                [(-b - s) / a, (-b + s) / a].into_iter().find(|&t| t > T_MIN)
            }
            Prepared::Cylinder { c, a: axis, r: radius, half, .. } => {
                let w = o - c;
                let (rp, wp) = (r - r.dot(axis) * axis, w - w.dot(axis) * axis);
                let mut best: Option<f64> = None;
                let mut keep = |t: f64| {
                    if t > T_MIN && best.is_none_or(|b| t < b) {
                        best = Some(t);
                    }
                };
                let a2 = rp.dot(rp);
                if a2 > 1e-300 {
                    let (b, cc) = (wp.dot(rp), wp.dot(wp) - radius * radius);
                    let disc = b * b - a2 * cc;
                    if disc >= 0.0 {
                        let s = disc.sqrt();
                        for t in [(-b - s) / a2, (-b + s) / a2] {
                            if (w + t * r).dot(axis).abs() <= half {
                                keep(t);
                            }
                        }
                    }
                }
                let den = r.dot(axis);
                if den.abs() > 1e-15 {
                    for side in [-half, half] {
                        let t = (side - w.dot(axis)) / den;
                        let q = w + t * r;
                        if (q - q.dot(axis) * axis).length_squared() <= radius * radius {
                            keep(t);
                        }
                    }
                }
                best
            }
            Prepared::HeightField { depth, amplitude, scale, bounds, seed } => {
                // g(t) = z(t) − surface(x(t), y(t)) increases (the slope bound): bisect it
                if r.z <= 0.0 {
                    return None;
                }
                let g = |t: f64| {
                    let p = o + t * r;
                    p.z - depth - amplitude * height(p.x / scale, p.y / scale, seed)
                };
                let (mut lo, mut hi) = ((depth - amplitude - o.z) / r.z, (depth + amplitude - o.z) / r.z);
                if hi <= T_MIN {
                    return None;
                }
                lo = lo.max(T_MIN);
                if let Some([x0, x1, y0, y1]) = bounds {
                    // the ray's stretch through the slab of the relief misses the bounds
                    let (a, b) = (o + lo * r, o + hi * r);
                    if a.x.max(b.x) < x0 || a.x.min(b.x) > x1 || a.y.max(b.y) < y0 || a.y.min(b.y) > y1 {
                        return None;
                    }
                }
                let (mut g_lo, mut g_hi) = (g(lo), g(hi));
                if g_lo > 0.0 {
                    return None;
                }
                // the Illinois variant of regula falsi: a bracket that always holds the root
                let mut side = 0;
                for _ in 0..60 {
                    let mid = if g_hi - g_lo > 0.0 { (lo * g_hi - hi * g_lo) / (g_hi - g_lo) } else { 0.5 * (lo + hi) };
                    let g_mid = g(mid);
                    if g_mid <= 0.0 {
                        (lo, g_lo) = (mid, g_mid);
                        if side == -1 {
                            g_hi *= 0.5;
                        }
                        side = -1;
                    } else {
                        (hi, g_hi) = (mid, g_mid);
                        if side == 1 {
                            g_lo *= 0.5;
                        }
                        side = 1;
                    }
                    if hi - lo <= 1e-13 * hi || g_mid == 0.0 {
                        break;
                    }
                }
                let t = if g_hi - g_lo > 0.0 { (lo * g_hi - hi * g_lo) / (g_hi - g_lo) } else { 0.5 * (lo + hi) };
                let p = o + t * r;
                match bounds {
                    Some([x0, x1, y0, y1]) if p.x < x0 || p.x > x1 || p.y < y0 || p.y > y1 => None,
                    _ => Some(t),
                }
            }
        }
    }

    /// The surface coordinates of a point of the surface (scene units) for its texture.
    #[inline]
    fn texcoords(&self, p: DVec3) -> (f64, f64) {
        match *self {
            Prepared::Plane { c, e1, e2, .. } => ((p - c).dot(e1), (p - c).dot(e2)),
            Prepared::Sphere { c, r } => {
                let d = (p - c) / r;
                (r * d.x.atan2(-d.z), r * d.y.clamp(-1.0, 1.0).asin())
            }
            Prepared::Cylinder { c, a, e1, e2, r, .. } => {
                let w = p - c;
                (r * w.dot(e2).atan2(w.dot(e1)), w.dot(a))
            }
            Prepared::HeightField { .. } => (p.x, p.y),
        }
    }
}

impl Texture {
    fn validate(&self) -> Result<(), SyntheticError> {
        non_negative("texture.mean", self.mean)?;
        non_negative("texture.contrast", self.contrast)?;
        positive("texture.scale", self.scale)?;
        non_negative("texture.chroma", self.chroma)?;
        for t in self.tint {
            non_negative("texture.tint", t)?;
        }
        if let Pattern::Stripes { angle_deg } = self.pattern
            && !angle_deg.is_finite()
        {
            return Err(SyntheticError::config("texture.pattern", "the stripes' angle must be finite"));
        }
        Ok(())
    }

    /// 1/f noise: six octaves of value noise from the period `scale` up, of equal amplitude
    /// (an amplitude spectrum falling as 1/f has the same energy in every octave, as natural
    /// images), centred, their sum over √6: a standard deviation of about 0.2.
    #[inline]
    fn pink(x: f64, y: f64, scale: f64, seed: u64) -> f64 {
        let (mut sum, mut period) = (0.0, scale);
        for k in 0..6u64 {
            sum += value_noise(x / period, y / period, splitmix(seed ^ k)) - 0.5;
            period *= 2.0;
        }
        sum / 6f64.sqrt()
    }

    /// The pattern at surface coordinates `(x, y)`: `±1` (pink noise: a standard deviation of
    /// about 0.4, clipped by the 8 bits only).
    #[inline]
    fn pattern_at(&self, x: f64, y: f64, seed: u64) -> f64 {
        match self.pattern {
            Pattern::Pink => 2.0 * Self::pink(x, y, self.scale, seed),
            Pattern::Checker => {
                let (i, j) = ((x / self.scale).floor() as i64, (y / self.scale).floor() as i64);
                if (i + j).rem_euclid(2) == 0 { 1.0 } else { -1.0 }
            }
            Pattern::Stripes { angle_deg } => {
                let (s, c) = angle_deg.to_radians().sin_cos();
                let phase = (c * x + s * y) / self.scale;
                if phase - phase.floor() < 0.5 { 1.0 } else { -1.0 }
            }
            Pattern::Uniform => 0.0,
        }
    }

    /// Radiance (RGB) at surface coordinates `(x, y)`.
    #[inline]
    fn radiance(&self, x: f64, y: f64, seed: u64, colour: bool) -> [f64; 3] {
        let l = self.mean + self.contrast * self.pattern_at(x, y, seed);
        let mut rgb = self.tint.map(|t| t * l);
        if colour && self.chroma > 0.0 {
            for (k, c) in rgb.iter_mut().enumerate() {
                *c += 2.0
                    * self.chroma
                    * self.contrast
                    * Self::pink(x, y, 2.0 * self.scale, splitmix(seed ^ (7 + k as u64)));
            }
        }
        rgb
    }
}

/// Luminance weights of the grey images.
const LUMA: [f64; 3] = [0.299, 0.587, 0.114];

impl StereoWorld {
    /// Bytes per pixel of rendering: three `f32` radiance planes per view and one blurred
    /// copy, both 8-bit images (colour), both `f32` disparity maps and both masks.
    pub const BYTES_PER_PIXEL: u64 = 2 * 3 * 4 + 3 * 4 + 2 * 3 + 2 * 4 + 2;

    /// Largest [`Self::estimated_bytes`] of a world: 4 GiB (refused above, before rendering).
    pub const MEMORY_BUDGET: u64 = 4 << 30;

    /// Memory a render holds at once, bytes.
    pub fn estimated_bytes(&self) -> u64 {
        u64::from(self.width).saturating_mul(u64::from(self.height)).saturating_mul(Self::BYTES_PER_PIXEL)
    }

    /// Parses a RON description and checks it ([`Self::validate`]).
    pub fn from_ron(text: &str) -> Result<Self, SyntheticError> {
        let world: Self = ron::from_str(text).map_err(|e| SyntheticError::Scene(e.to_string()))?;
        world.validate()?;
        Ok(world)
    }

    /// The description as pretty RON.
    pub fn to_ron(&self) -> String {
        ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default()).expect("a world serialises")
    }

    /// The rectified cameras' intrinsics.
    pub fn intrinsics(&self) -> Intrinsics {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        Intrinsics::new(self.focal_px, self.focal_px, (w - 1.0) * 0.5, (h - 1.0) * 0.5)
    }

    /// Checks every field (the truth's range is checked while rendering).
    pub fn validate(&self) -> Result<(), SyntheticError> {
        for (field, v) in [("width", self.width), ("height", self.height)] {
            if !(32..=16384).contains(&v) {
                return Err(SyntheticError::config(field, format!("must be in 32..=16384, got {v}")));
            }
        }
        if self.estimated_bytes() > Self::MEMORY_BUDGET {
            return Err(SyntheticError::config(
                "width",
                format!(
                    "a {}x{} world needs about {} MB to render, above the budget of {} MB",
                    self.width,
                    self.height,
                    self.estimated_bytes() >> 20,
                    Self::MEMORY_BUDGET >> 20
                ),
            ));
        }
        positive("focal_px", self.focal_px)?;
        positive("baseline", self.baseline)?;
        if self.disparities == 0 || self.disparities >= self.width as usize {
            return Err(SyntheticError::config(
                "disparities",
                format!("must be in 1..{} (the width), got {}", self.width, self.disparities),
            ));
        }
        if self.surfaces.is_empty() {
            return Err(SyntheticError::config("surfaces", "a world needs at least one surface (a backdrop)"));
        }
        self.left.validate("left")?;
        self.right.validate("right")?;
        non_negative("noise_sigma", self.noise_sigma)?;
        non_negative("blur_sigma", self.blur_sigma)?;
        if !(1..=8).contains(&self.samples_per_axis) {
            return Err(SyntheticError::config(
                "samples_per_axis",
                format!("must be in 1..=8, got {}", self.samples_per_axis),
            ));
        }
        self.prepare()?;
        Ok(())
    }

    /// The largest `|(r_x, r_y)|` of a pixel ray (`r_z = 1`): the image corner's.
    fn max_obliquity(&self) -> f64 {
        let k = self.intrinsics();
        (k.cx + 0.5).hypot(k.cy + 0.5) / self.focal_px
    }

    fn prepare(&self) -> Result<Vec<(Prepared, Texture, u64)>, SyntheticError> {
        let seed = splitmix(self.seed);
        self.surfaces
            .iter()
            .enumerate()
            .map(|(k, s)| {
                s.texture.validate()?;
                let p = match s.shape {
                    Shape::Plane { centre, normal, half_size } => {
                        let n = unit3("surfaces.normal", normal)?;
                        let (e1, e2) = basis(n);
                        if let Some(h) = half_size {
                            positive("surfaces.half_size", h[0])?;
                            positive("surfaces.half_size", h[1])?;
                        }
                        Prepared::Plane { c: finite3("surfaces.centre", centre)?, n, e1, e2, half: half_size }
                    }
                    Shape::Sphere { centre, radius } => {
                        positive("surfaces.radius", radius)?;
                        let c = finite3("surfaces.centre", centre)?;
                        let b = DVec3::new(self.baseline, 0.0, 0.0);
                        if c.length() <= radius || (c - b).length() <= radius {
                            return Err(SyntheticError::config("surfaces", "a camera lies inside a sphere"));
                        }
                        Prepared::Sphere { c, r: radius }
                    }
                    Shape::Cylinder { centre, axis, radius, half_length } => {
                        positive("surfaces.radius", radius)?;
                        positive("surfaces.half_length", half_length)?;
                        let a = unit3("surfaces.axis", axis)?;
                        let (e1, e2) = basis(a);
                        Prepared::Cylinder {
                            c: finite3("surfaces.centre", centre)?,
                            a,
                            e1,
                            e2,
                            r: radius,
                            half: half_length,
                        }
                    }
                    Shape::HeightField { depth, amplitude, scale, bounds } => {
                        positive("surfaces.depth", depth)?;
                        non_negative("surfaces.amplitude", amplitude)?;
                        positive("surfaces.scale", scale)?;
                        if amplitude >= depth {
                            return Err(SyntheticError::config("surfaces.amplitude", "must be below the depth"));
                        }
                        let slope = amplitude * HEIGHT_FIELD_LIPSCHITZ / scale * self.max_obliquity();
                        if slope > HEIGHT_FIELD_MAX_SLOPE {
                            return Err(SyntheticError::config(
                                "surfaces.amplitude",
                                format!(
                                    "a height field this steep ({slope:.2}, the bound {HEIGHT_FIELD_MAX_SLOPE}) could \
                                     cross a ray twice: lower the amplitude or raise the scale"
                                ),
                            ));
                        }
                        if let Some(b) = bounds
                            && (b.iter().any(|v| !v.is_finite()) || b[0] >= b[1] || b[2] >= b[3])
                        {
                            return Err(SyntheticError::config(
                                "surfaces.bounds",
                                "must be finite with x0 < x1, y0 < y1",
                            ));
                        }
                        Prepared::HeightField {
                            depth,
                            amplitude,
                            scale,
                            bounds,
                            seed: splitmix(seed ^ (k as u64 + 101)),
                        }
                    }
                };
                Ok((p, s.texture, splitmix(seed ^ k as u64)))
            })
            .collect()
    }

    /// What the world exercises, from its content: `slanted`, `fronto-parallel`, `sphere`,
    /// `cylinder`, `thin` (a cylinder under 2 px wide where it is nearest), `height-field`,
    /// `textureless`, `repetitive`, `photometric` (the cameras differ), `vignetting`, `noise`,
    /// `blur`, `colour`.
    pub fn factors(&self) -> Vec<&'static str> {
        let mut f = Vec::new();
        let mut add = |name: &'static str, yes: bool| {
            if yes && !f.contains(&name) {
                f.push(name);
            }
        };
        for s in &self.surfaces {
            match s.shape {
                Shape::Plane { normal, .. } => {
                    let n = vec3(normal).normalize_or_zero();
                    add(if n.z.abs() > 0.9999 { "fronto-parallel" } else { "slanted" }, true);
                }
                Shape::Sphere { .. } => add("sphere", true),
                Shape::Cylinder { centre, radius, .. } => {
                    add("cylinder", true);
                    add("thin", 2.0 * radius * self.focal_px / centre[2].abs().max(1e-9) < 2.0);
                }
                Shape::HeightField { .. } => add("height-field", true),
            }
            add("textureless", s.texture.pattern == Pattern::Uniform || s.texture.contrast < 3.0);
            add("repetitive", matches!(s.texture.pattern, Pattern::Checker | Pattern::Stripes { .. }));
        }
        add("photometric", {
            let (l, r) = (self.left, self.right);
            (l.gain, l.offset, l.gamma) != (r.gain, r.offset, r.gamma)
        });
        add("vignetting", self.left.vignetting > 0.0 || self.right.vignetting > 0.0);
        add("noise", self.noise_sigma > 0.0);
        add("blur", self.blur_sigma > 0.0);
        add("colour", self.colour);
        f
    }
}

/// The nearest surface along `o + t·r`: `(t, index)`.
#[inline]
fn nearest(surfaces: &[(Prepared, Texture, u64)], o: DVec3, r: DVec3) -> Option<(f64, usize)> {
    let mut best: Option<(f64, usize)> = None;
    for (k, (s, _, _)) in surfaces.iter().enumerate() {
        if let Some(t) = s.hit(o, r)
            && best.is_none_or(|(b, _)| t < b)
        {
            best = Some((t, k));
        }
    }
    best
}

/// Whether the segment from `o` to `p` (at depth `p.z`) is blocked short of `p`.
#[inline]
fn blocked(surfaces: &[(Prepared, Texture, u64)], o: DVec3, p: DVec3) -> bool {
    let r = (p - o) / (p.z - o.z);
    let t_p = p.z - o.z;
    surfaces.iter().any(|(s, _, _)| s.hit(o, r).is_some_and(|t| t < t_p * (1.0 - SHADOW_TOLERANCE)))
}

/// The camera of one view being shaded: its size, its image centre (of the vignetting) and
/// its photometry.
struct View {
    size: (u32, u32),
    centre: (f64, f64),
    photometry: Photometry,
}

/// One view's image: the area-integrated radiance of `n x n` rays per pixel (`ray(x, y)`: the
/// origin and direction of the ray at image point `(x, y)` in the world's frame, `None` where the
/// lens images nothing: black), through the photometry, the blur and the noise, to 8 bits.
fn shade(
    world: &StereoWorld,
    surfaces: &[(Prepared, Texture, u64)],
    view: &View,
    ray: impl Fn(f64, f64) -> Option<(DVec3, DVec3)> + Sync,
    noise: &mut rand_chacha::ChaCha8Rng,
) -> DynamicImage {
    let (w, h) = (view.size.0 as usize, view.size.1 as usize);
    let n = world.samples_per_axis as usize;
    let offsets: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64 - 0.5).collect();
    let channels = if world.colour { 3 } else { 1 };
    let (cx, cy) = view.centre;
    let half_diagonal2 = (0.5 * w as f64).powi(2) + (0.5 * h as f64).powi(2);
    let p = view.photometry;
    // radiance planes, channel-major
    let mut planes = vec![vec![0f32; w * h]; channels];
    let rows: Vec<Vec<[f64; 3]>> = (0..h)
        .into_par_iter()
        .map(|v| {
            (0..w)
                .map(|u| {
                    let mut sum = [0.0; 3];
                    for &oy in &offsets {
                        for &ox in &offsets {
                            let Some((o, r)) = ray(u as f64 + ox, v as f64 + oy) else { continue };
                            if let Some((t, s)) = nearest(surfaces, o, r) {
                                let (shape, texture, seed) = &surfaces[s];
                                let (x, y) = shape.texcoords(o + t * r);
                                let rgb = texture.radiance(x, y, *seed, world.colour);
                                for c in 0..3 {
                                    sum[c] += rgb[c];
                                }
                            }
                        }
                    }
                    let rho2 = ((u as f64 - cx).powi(2) + (v as f64 - cy).powi(2)) / half_diagonal2;
                    let shade = 1.0 - p.vignetting * rho2.min(1.0);
                    sum.map(|s| {
                        let x = p.gain * s / (n * n) as f64 * shade + p.offset;
                        255.0 * (x.max(0.0) / 255.0).powf(p.gamma)
                    })
                })
                .collect()
        })
        .collect();
    for (v, row) in rows.into_iter().enumerate() {
        for (u, rgb) in row.into_iter().enumerate() {
            if world.colour {
                for c in 0..3 {
                    planes[c][v * w + u] = rgb[c] as f32;
                }
            } else {
                planes[0][v * w + u] = (LUMA[0] * rgb[0] + LUMA[1] * rgb[1] + LUMA[2] * rgb[2]) as f32;
            }
        }
    }
    if world.blur_sigma > 0.0 {
        for p in &mut planes {
            let img: ImageBuffer<Luma<f32>, Vec<f32>> =
                ImageBuffer::from_raw(view.size.0, view.size.1, std::mem::take(p)).expect("w x h plane");
            *p = imageproc::filter::gaussian_blur_f32(&img, world.blur_sigma as f32).into_raw();
        }
    }
    let mut bytes = vec![0u8; w * h * channels];
    for (i, b) in bytes.iter_mut().enumerate() {
        let mut x = f64::from(planes[i % channels][i / channels]);
        let e = normal(noise);
        if world.noise_sigma > 0.0 {
            x += world.noise_sigma * e;
        }
        *b = x.round().clamp(0.0, 255.0) as u8;
    }
    if world.colour {
        DynamicImage::ImageRgb8(RgbImage::from_raw(view.size.0, view.size.1, bytes).expect("w x h x 3"))
    } else {
        DynamicImage::ImageLuma8(GrayImage::from_raw(view.size.0, view.size.1, bytes).expect("w x h"))
    }
}

/// Renders a world: both views (area-integrated radiance through each camera's photometry,
/// the blur, the noise, 8 bits) and the exact truth of both.
///
/// Refused before any image is made when a field is out of range ([`StereoWorld::validate`]),
/// and after the truth when a pixel sees no surface or a true disparity leaves
/// `(0, disparities)` — naming the pixel.
pub fn render_world(world: &StereoWorld) -> Result<WorldViews, SyntheticError> {
    world.validate()?;
    let surfaces = world.prepare()?;
    let (w, h) = (world.width as usize, world.height as usize);
    let k = world.intrinsics();
    let f = world.focal_px;
    let fb = f * world.baseline;
    let origins = [DVec3::ZERO, DVec3::new(world.baseline, 0.0, 0.0)];
    let ray = |x: f64, y: f64| DVec3::new((x - k.cx) / f, (y - k.cy) / f, 1.0);

    // the truth first: a world that does not fit is refused before the images are made
    let mut truth: Vec<(Vec<f32>, Vec<bool>)> = Vec::with_capacity(2);
    for view in 0..2 {
        let (o, other) = (origins[view], origins[1 - view]);
        let rows: Vec<Result<Vec<(f32, bool)>, SyntheticError>> = (0..h)
            .into_par_iter()
            .map(|v| {
                (0..w)
                    .map(|u| {
                        let r = ray(u as f64, v as f64);
                        let Some((t, _)) = nearest(&surfaces, o, r) else {
                            return Err(SyntheticError::config(
                                "surfaces",
                                format!(
                                    "the {} camera's pixel ({u}, {v}) sees no surface: add a backdrop",
                                    ["left", "right"][view]
                                ),
                            ));
                        };
                        let d = fb / t;
                        if !(d > 0.0 && d < world.disparities as f64) {
                            return Err(SyntheticError::config(
                                "disparities",
                                format!(
                                    "the true disparity {d:.2} px at the {} camera's pixel ({u}, {v}) lies outside \
                                     (0, {})",
                                    ["left", "right"][view],
                                    world.disparities
                                ),
                            ));
                        }
                        let p = o + t * r;
                        // the other view's column of the point
                        let u_other = if view == 0 { u as f64 - d } else { u as f64 + d };
                        let outside = u_other < -0.5 || u_other > w as f64 - 0.5;
                        Ok((d as f32, outside || blocked(&surfaces, other, p)))
                    })
                    .collect()
            })
            .collect();
        let mut disparity = Vec::with_capacity(w * h);
        let mut occluded = Vec::with_capacity(w * h);
        for row in rows {
            for (d, o) in row? {
                disparity.push(d);
                occluded.push(o);
            }
        }
        truth.push((disparity, occluded));
    }

    let mut noise = rng(world.seed ^ 0x0051_7e7e_0415);
    let mut images = Vec::with_capacity(2);
    for (view, photometry) in [world.left, world.right].into_iter().enumerate() {
        let o = origins[view];
        let view = View { size: (world.width, world.height), centre: (k.cx, k.cy), photometry };
        images.push(shade(world, &surfaces, &view, |x, y| Some((o, ray(x, y))), &mut noise));
    }

    let camera = Camera::new(k, Distortion::default(), world.width, world.height)
        .map_err(SyntheticError::model("rectified camera"))?;
    let rig =
        StereoRig::new(camera, camera, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-world.baseline, 0.0, 0.0)))
            .map_err(SyntheticError::model("rectified rig"))?;
    let (right_truth, left_truth) = (truth.pop().expect("two views"), truth.pop().expect("two views"));
    let right = images.pop().expect("two views");
    let left = images.pop().expect("two views");
    Ok(WorldViews {
        left,
        right,
        disparity: DisparityMap::from_data(w, h, left_truth.0).map_err(SyntheticError::model("disparity"))?,
        disparity_right: DisparityMap::from_data(w, h, right_truth.0).map_err(SyntheticError::model("disparity"))?,
        occluded: left_truth.1,
        occluded_right: right_truth.1,
        rig,
    })
}

impl StereoWorld {
    /// The same world with every length times `factor` (positions, sizes, depths, texture
    /// scales, the baseline): its images and disparities are unchanged. For a world in metres
    /// seen by a rig in millimetres, `1000`.
    pub fn scaled(&self, factor: f64) -> Self {
        let v = |a: Vec3| a.map(|x| x * factor);
        let mut w = self.clone();
        w.baseline *= factor;
        for s in &mut w.surfaces {
            s.texture.scale *= factor;
            s.shape = match s.shape.clone() {
                Shape::Plane { centre, normal, half_size } => {
                    Shape::Plane { centre: v(centre), normal, half_size: half_size.map(|h| h.map(|x| x * factor)) }
                }
                Shape::Sphere { centre, radius } => Shape::Sphere { centre: v(centre), radius: radius * factor },
                Shape::Cylinder { centre, axis, radius, half_length } => Shape::Cylinder {
                    centre: v(centre),
                    axis,
                    radius: radius * factor,
                    half_length: half_length * factor,
                },
                Shape::HeightField { depth, amplitude, scale, bounds } => Shape::HeightField {
                    depth: depth * factor,
                    amplitude: amplitude * factor,
                    scale: scale * factor,
                    bounds: bounds.map(|b| b.map(|x| x * factor)),
                },
            };
        }
        w
    }
}

/// Renders a world through a calibrated rig instead of its own rectified pair: each camera of
/// `rig` (any lens, with its distortion; the right one at `rig.right_from_left`) sees the
/// world's surfaces, which are given in the left camera's frame in the rig's length unit (see
/// [`StereoWorld::scaled`]). The world's photometry, blur, noise and supersampling apply; its
/// own size, focal length and baseline do not. Pixels the lens cannot invert stay black.
pub fn render_world_through(
    world: &StereoWorld,
    rig: &StereoRig,
) -> Result<(DynamicImage, DynamicImage), SyntheticError> {
    world.validate()?;
    let surfaces = world.prepare()?;
    let left_from_right = rig.right_from_left.inverse();
    let rotation = left_from_right.rotation_matrix();
    let centre = left_from_right.translation;
    let mut noise = rng(world.seed ^ 0x0051_7e7e_0415);
    let mut out = Vec::with_capacity(2);
    for (k, (camera, photometry)) in [(&rig.left, world.left), (&rig.right, world.right)].into_iter().enumerate() {
        let view = View {
            size: (camera.width, camera.height),
            centre: (camera.intrinsics.cx, camera.intrinsics.cy),
            photometry,
        };
        let ray = |x: f64, y: f64| {
            let r = camera.unproject(glam::DVec2::new(x, y)).ok()?;
            Some(if k == 0 { (DVec3::ZERO, r) } else { (centre, rotation * r) })
        };
        out.push(shade(world, &surfaces, &view, ray, &mut noise));
    }
    let right = out.pop().expect("two views");
    Ok((out.pop().expect("two views"), right))
}

/// A rectified pair in the left camera's frame, as a rectification gives it: the rectified
/// images' size, their projection matrices `P1`, `P2` (in the rectified left frame), the
/// rotation `R1` (`rectified left from left camera`) and the right camera's centre in the left
/// camera's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectifiedPair {
    /// Rectified image width, pixels.
    pub width: u32,
    /// Rectified image height, pixels.
    pub height: u32,
    /// `P1 = [K1 | 0]`.
    pub p1: [[f64; 4]; 3],
    /// `P2 = [K2 | K2·t]`.
    pub p2: [[f64; 4]; 3],
    /// `R1`: rectified left from left camera.
    pub r1: glam::DMat3,
    /// The right camera's centre in the left camera's frame.
    pub right_centre: DVec3,
}

/// The exact truth of a world seen by a rectified pair ([`RectifiedPair`], e.g. the
/// rectification of the rig of [`render_world_through`]): at every rectified left pixel centre,
/// the disparity `u_left − u_right` of the surface point it sees (projected through `P2`), and
/// whether the right camera does not see that point (hidden, or outside the rectified right
/// image). `NaN` where the pixel sees no surface. The disparity range is not checked.
pub fn world_truth_rectified(
    world: &StereoWorld,
    pair: &RectifiedPair,
) -> Result<(DisparityMap, Vec<bool>), SyntheticError> {
    world.validate()?;
    let surfaces = world.prepare()?;
    let (w, h) = (pair.width as usize, pair.height as usize);
    let k1 = glam::DMat3::from_cols(
        DVec3::new(pair.p1[0][0], pair.p1[1][0], pair.p1[2][0]),
        DVec3::new(pair.p1[0][1], pair.p1[1][1], pair.p1[2][1]),
        DVec3::new(pair.p1[0][2], pair.p1[1][2], pair.p1[2][2]),
    );
    if k1.determinant().abs() < 1e-12 || pair.p1.iter().any(|r| r[3] != 0.0) {
        return Err(SyntheticError::config("p1", "must be [K | 0] with an invertible K"));
    }
    let (k1_inv, r1t) = (k1.inverse(), pair.r1.transpose());
    let p2 = pair.p2;
    let project2 = |q: DVec3| {
        let row = |i: usize| p2[i][0] * q.x + p2[i][1] * q.y + p2[i][2] * q.z + p2[i][3];
        row(0) / row(2)
    };
    let rows: Vec<Vec<(f32, bool)>> = (0..h)
        .into_par_iter()
        .map(|v| {
            (0..w)
                .map(|u| {
                    let r = r1t * (k1_inv * DVec3::new(u as f64, v as f64, 1.0));
                    let Some((t, _)) = nearest(&surfaces, DVec3::ZERO, r) else { return (f32::NAN, true) };
                    let p = t * r;
                    let u_right = project2(pair.r1 * p);
                    let d = u as f64 - u_right;
                    let outside = !(-0.5..=w as f64 - 0.5).contains(&u_right);
                    (d as f32, outside || blocked_from(&surfaces, pair.right_centre, p))
                })
                .collect()
        })
        .collect();
    let (disparity, occluded): (Vec<f32>, Vec<bool>) = rows.into_iter().flatten().unzip();
    Ok((DisparityMap::from_data(w, h, disparity).map_err(SyntheticError::model("disparity"))?, occluded))
}

/// Whether the segment from `o` to `p` is blocked short of `p` (any direction).
fn blocked_from(surfaces: &[(Prepared, Texture, u64)], o: DVec3, p: DVec3) -> bool {
    let r = p - o;
    surfaces.iter().any(|(s, _, _)| s.hit(o, r).is_some_and(|t| t < 1.0 - SHADOW_TOLERANCE))
}

/// The kinds of object a [`WorldDistribution`] draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ObjectKind {
    /// A rectangle at a random slant (up to 60°).
    Plane,
    /// A sphere.
    Sphere,
    /// A vertical post, 0.5 to 6 pixels wide.
    Post,
    /// A wire across the view at a random angle, 0.5 to 3 pixels wide.
    Wire,
    /// A relief (height field) over a rectangle.
    Relief,
}

/// A distribution of worlds (a RON description): [`WorldDistribution::draw`] turns a seed into a
/// [`StereoWorld`] — a textured backdrop and objects at random depths, slants, sizes and
/// textures, cameras whose photometry differs at random. Ranges are `[low, high]`, drawn
/// uniformly (depths uniformly in disparity).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WorldDistribution {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels.
    pub focal_px: f64,
    /// Baseline, scene units.
    pub baseline: f64,
    /// Disparities searched; every depth drawn lies inside.
    pub disparities: usize,
    /// Depth of the backdrop.
    pub backdrop_depth: [f64; 2],
    /// Number of objects.
    pub objects: [usize; 2],
    /// Depth of the objects.
    pub depth: [f64; 2],
    /// Kinds of object drawn (equally likely).
    pub kinds: Vec<ObjectKind>,
    /// Texture patterns drawn (equally likely).
    pub patterns: Vec<Pattern>,
    /// Texture contrast, grey levels.
    pub contrast: [f64; 2],
    /// The right camera's gain (the left's is 1).
    pub right_gain: [f64; 2],
    /// The right camera's offset, grey levels.
    pub right_offset: [f64; 2],
    /// The right camera's gamma.
    pub right_gamma: [f64; 2],
    /// Vignetting of each camera.
    pub vignetting: [f64; 2],
    /// Sensor noise, grey levels.
    pub noise_sigma: [f64; 2],
    /// Blur, pixels.
    pub blur_sigma: [f64; 2],
    /// Colour worlds.
    pub colour: bool,
}

impl Default for WorldDistribution {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            focal_px: 300.0,
            baseline: 0.1,
            disparities: 48,
            backdrop_depth: [4.0, 8.0],
            objects: [3, 9],
            depth: [1.0, 4.0],
            kinds: vec![ObjectKind::Plane, ObjectKind::Sphere, ObjectKind::Post, ObjectKind::Wire, ObjectKind::Relief],
            patterns: vec![Pattern::Pink, Pattern::Pink, Pattern::Pink, Pattern::Checker, Pattern::Uniform],
            contrast: [20.0, 70.0],
            right_gain: [0.9, 1.1],
            right_offset: [-8.0, 8.0],
            right_gamma: [0.9, 1.1],
            vignetting: [0.0, 0.3],
            noise_sigma: [0.5, 3.0],
            blur_sigma: [0.0, 0.8],
            colour: false,
        }
    }
}

impl WorldDistribution {
    /// Checks every range (`low ≤ high`, finite, in the field's domain) and that every depth
    /// drawn has a disparity inside the range searched.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        let range = |field: &'static str, r: [f64; 2], lo: f64, hi: f64| {
            if r.iter().all(|v| v.is_finite()) && lo <= r[0] && r[0] <= r[1] && r[1] <= hi {
                Ok(())
            } else {
                Err(SyntheticError::config(field, format!("must be [low, high] within [{lo}, {hi}], got {r:?}")))
            }
        };
        range("backdrop_depth", self.backdrop_depth, 1e-6, f64::MAX)?;
        range("depth", self.depth, 1e-6, f64::MAX)?;
        range("contrast", self.contrast, 0.0, 255.0)?;
        range("right_gain", self.right_gain, 1e-3, 100.0)?;
        range("right_offset", self.right_offset, -255.0, 255.0)?;
        range("right_gamma", self.right_gamma, 1e-3, 100.0)?;
        range("vignetting", self.vignetting, 0.0, 0.99)?;
        range("noise_sigma", self.noise_sigma, 0.0, 255.0)?;
        range("blur_sigma", self.blur_sigma, 0.0, 50.0)?;
        if self.objects[0] > self.objects[1] || self.objects[1] > 1000 {
            return Err(SyntheticError::config(
                "objects",
                format!("must be [low, high] within 0..=1000, got {:?}", self.objects),
            ));
        }
        if self.kinds.is_empty() && self.objects[1] > 0 {
            return Err(SyntheticError::config("kinds", "lists no kind of object"));
        }
        if self.patterns.is_empty() {
            return Err(SyntheticError::config("patterns", "lists no pattern"));
        }
        let nearest = self.depth[0].min(self.backdrop_depth[0]);
        let largest = self.focal_px * self.baseline / nearest;
        if largest >= self.disparities as f64 {
            return Err(SyntheticError::config(
                "depth",
                format!(
                    "the nearest depth {nearest} has the disparity {largest:.1} px, beyond the {} searched",
                    self.disparities
                ),
            ));
        }
        // the rest of the camera through a world with a backdrop only
        self.world(Vec::new(), 0).validate()
    }

    fn world(&self, surfaces: Vec<Surface>, seed: u64) -> StereoWorld {
        StereoWorld {
            width: self.width,
            height: self.height,
            focal_px: self.focal_px,
            baseline: self.baseline,
            disparities: self.disparities,
            surfaces: if surfaces.is_empty() {
                vec![Surface {
                    shape: Shape::Plane {
                        centre: [0.0, 0.0, self.backdrop_depth[0]],
                        normal: [0.0, 0.0, -1.0],
                        half_size: None,
                    },
                    texture: Texture::default(),
                }]
            } else {
                surfaces
            },
            left: Photometry::default(),
            right: Photometry::default(),
            noise_sigma: 0.0,
            blur_sigma: 0.0,
            colour: self.colour,
            samples_per_axis: default_samples(),
            seed,
        }
    }

    /// The world of `seed` (checked: every draw is a valid world).
    pub fn draw(&self, seed: u64) -> Result<StereoWorld, SyntheticError> {
        self.validate()?;
        let mut r = rng(seed ^ 0x0d15_7e1b);
        let mut uniform = |[lo, hi]: [f64; 2]| if hi > lo { lo + (hi - lo) * r.random::<f64>() } else { lo };
        let f = self.focal_px;
        let fb = f * self.baseline;
        // depths uniform in disparity
        let depth_in = |u: f64, [near, far]: [f64; 2]| fb / (fb / far + u * (fb / near - fb / far));
        let half_w = (f64::from(self.width) * 0.5) / f;
        let half_h = (f64::from(self.height) * 0.5) / f;
        let pick = |n: usize, u: f64| ((u * n as f64) as usize).min(n.saturating_sub(1));
        let backdrop_z = depth_in(uniform([0.0, 1.0]), self.backdrop_depth);
        let texture = |z: f64, uniform: &mut dyn FnMut([f64; 2]) -> f64| {
            let pattern = self.patterns[pick(self.patterns.len(), uniform([0.0, 1.0]))];
            let tint =
                if self.colour { [uniform([0.6, 1.3]), uniform([0.6, 1.3]), uniform([0.6, 1.3])] } else { [1.0; 3] };
            Texture {
                pattern,
                mean: uniform([70.0, 180.0]),
                contrast: uniform(self.contrast),
                // the finest detail 1 to 3 pixels at its depth; repeated patterns coarser
                scale: z / f * if pattern == Pattern::Pink { uniform([1.0, 3.0]) } else { uniform([4.0, 12.0]) },
                tint,
                chroma: if self.colour { uniform([0.0, 1.0]) } else { 0.0 },
            }
        };
        let mut surfaces = vec![Surface {
            shape: Shape::Plane { centre: [0.0, 0.0, backdrop_z], normal: [0.0, 0.0, -1.0], half_size: None },
            texture: texture(backdrop_z, &mut uniform),
        }];
        let count = self.objects[0] + pick(self.objects[1] - self.objects[0] + 1, uniform([0.0, 1.0]));
        for _ in 0..count {
            let kind = self.kinds[pick(self.kinds.len(), uniform([0.0, 1.0]))];
            let z = depth_in(uniform([0.0, 1.0]), [self.depth[0], self.depth[1].min(backdrop_z * 0.9)]);
            let (x, y) = (uniform([-half_w, half_w]) * z, uniform([-half_h, half_h]) * z);
            let size = uniform([0.1, 0.3]) * z;
            let shape = match kind {
                ObjectKind::Plane => {
                    let (tilt, azimuth) = (uniform([0.0, 60.0]).to_radians(), uniform([0.0, std::f64::consts::TAU]));
                    let n = [tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), -tilt.cos()];
                    Shape::Plane { centre: [x, y, z], normal: n, half_size: Some([size, size * uniform([0.5, 1.5])]) }
                }
                ObjectKind::Sphere => {
                    // a sphere entirely in front of its centre's depth range
                    let radius = (0.5 * size).min(0.5 * z);
                    Shape::Sphere { centre: [x, y, z], radius }
                }
                ObjectKind::Post => Shape::Cylinder {
                    centre: [x, 0.0, z],
                    axis: [0.0, 1.0, 0.0],
                    radius: uniform([0.25, 3.0]) * z / f,
                    half_length: 2.0 * half_h * z,
                },
                ObjectKind::Wire => {
                    let a = uniform([-0.5, 0.5]);
                    Shape::Cylinder {
                        centre: [0.0, y, z],
                        axis: [a.cos(), a.sin(), 0.0],
                        radius: uniform([0.25, 1.5]) * z / f,
                        half_length: 2.0 * half_w * z,
                    }
                }
                ObjectKind::Relief => Shape::HeightField {
                    depth: z,
                    amplitude: 0.05 * z,
                    scale: 0.5 * z,
                    bounds: Some([x - size, x + size, y - size, y + size]),
                },
            };
            surfaces.push(Surface { shape, texture: texture(z, &mut uniform) });
        }
        let mut world = self.world(surfaces, seed);
        let vignetting = uniform(self.vignetting);
        world.left = Photometry { vignetting, ..Photometry::default() };
        world.right = Photometry {
            gain: uniform(self.right_gain),
            offset: uniform(self.right_offset),
            gamma: uniform(self.right_gamma),
            vignetting: uniform(self.vignetting),
        };
        world.noise_sigma = uniform(self.noise_sigma);
        world.blur_sigma = uniform(self.blur_sigma);
        world.validate()?;
        Ok(world)
    }
}
