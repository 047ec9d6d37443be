//! Rectified stereo pairs of a piecewise-planar scene with exact disparity.

use glam::DVec3;
use image::GrayImage;
use parallax_camera_model::{Camera, DisparityMap, Distortion, Intrinsics, Isometry3, StereoRig};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::error::{non_negative, positive};
use crate::noise::{normal, rng};

/// A rectified stereo scene: image size, disparity range, photometric differences and noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StereoSceneConfig {
    /// Image width, pixels (at least 32). Default 640.
    pub width: u32,
    /// Image height, pixels (at least 32). Default 480.
    pub height: u32,
    /// Upper bound of the true disparities, pixels: every true disparity lies in
    /// `[0.15, 0.9] · max_disparity` (so a matcher searching `0..max_disparity` covers them).
    /// Must be below `width / 2`. Default 64.
    pub max_disparity: f64,
    /// Standard deviation of the Gaussian noise added to both images (independently), grey
    /// levels. Default 0.
    pub noise_sigma: f64,
    /// Gain of the right image (`right = gain · radiance + offset`, before noise). Default 1.
    pub right_gain: f64,
    /// Offset of the right image, grey levels. Default 0.
    pub right_offset: f64,
    /// Seed of the textures and the noise. Default 0.
    pub seed: u64,
    /// Supersampling: `n x n` point samples per pixel (area integration). Default 4.
    pub samples_per_axis: u32,
    /// Focal length of the rectified cameras, pixels (only used by [`StereoScene::rig`] and
    /// [`StereoScene::point`]). Default 700.
    pub focal_px: f64,
    /// Baseline of the rectified rig in the scene's length unit (same use). Default 60
    /// (millimetres).
    pub baseline: f64,
}

impl Default for StereoSceneConfig {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            max_disparity: 64.0,
            noise_sigma: 0.0,
            right_gain: 1.0,
            right_offset: 0.0,
            seed: 0,
            samples_per_axis: 4,
            focal_px: 700.0,
            baseline: 60.0,
        }
    }
}

impl StereoSceneConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        if self.width < 32 || self.height < 32 {
            return Err(SyntheticError::config(
                "width",
                format!("image must be at least 32x32, got {}x{}", self.width, self.height),
            ));
        }
        positive("max_disparity", self.max_disparity)?;
        if self.max_disparity >= f64::from(self.width) / 2.0 {
            return Err(SyntheticError::config(
                "max_disparity",
                format!("{} must be below half the width ({})", self.max_disparity, self.width),
            ));
        }
        non_negative("noise_sigma", self.noise_sigma)?;
        positive("right_gain", self.right_gain)?;
        if !self.right_offset.is_finite() {
            return Err(SyntheticError::config("right_offset", "must be finite"));
        }
        if !(1..=16).contains(&self.samples_per_axis) {
            return Err(SyntheticError::config(
                "samples_per_axis",
                format!("must be in 1..=16, got {}", self.samples_per_axis),
            ));
        }
        positive("focal_px", self.focal_px)?;
        positive("baseline", self.baseline)?;
        Ok(())
    }
}

/// A rendered rectified pair and its ground truth (all masks row-major, `width · height`).
#[derive(Debug, Clone, PartialEq)]
pub struct StereoScene {
    /// Left rectified image.
    pub left: GrayImage,
    /// Right rectified image.
    pub right: GrayImage,
    /// True left disparity `d = u_left − u_right` at every pixel centre (every pixel valid;
    /// occluded pixels hold the disparity of the surface seen in the left image).
    pub disparity: DisparityMap,
    /// True where the left pixel's surface point is not visible in the right image (hidden by
    /// a nearer surface, or outside the right image).
    pub occluded: Vec<bool>,
    /// True on the low-texture patch (nearly uniform: block matching is ambiguous there).
    pub low_texture: Vec<bool>,
    /// True on pixels of fronto-parallel planes (constant disparity).
    pub fronto_parallel: Vec<bool>,
    /// The rectified rig the disparities belong to: identical pinhole cameras (`focal_px`,
    /// principal point at the image centre, no distortion), `right_from_left = (−baseline, 0, 0)`.
    pub rig: StereoRig,
}

impl StereoScene {
    /// The true 3D point (left camera frame) of pixel `(u, v)`: `Z = f · B / d`,
    /// `X = (u − cx) Z / f`, `Y = (v − cy) Z / f`; `None` out of bounds.
    pub fn point(&self, u: usize, v: usize) -> Option<DVec3> {
        let d = f64::from(self.disparity.get(u, v)?);
        let k = self.rig.left.intrinsics;
        let z = k.fx * self.rig.baseline() / d;
        Some(DVec3::new((u as f64 - k.cx) * z / k.fx, (v as f64 - k.cy) * z / k.fy, z))
    }
}

/// Where a surface lies in the left image.
#[derive(Debug, Clone, Copy)]
enum Region {
    All,
    Rect { x0: f64, x1: f64, y0: f64, y1: f64 },
    Disc { cx: f64, cy: f64, r: f64 },
}

impl Region {
    #[inline]
    fn contains(&self, u: f64, v: f64) -> bool {
        match *self {
            Region::All => true,
            Region::Rect { x0, x1, y0, y1 } => u >= x0 && u < x1 && v >= y0 && v < y1,
            Region::Disc { cx, cy, r } => (u - cx).powi(2) + (v - cy).powi(2) < r * r,
        }
    }
}

/// A planar surface patch: its region in the left image, its disparity `d = a + b u + c v`
/// (affine: exact for a plane in a rectified pair) and its texture, a function of the surface
/// point (parametrised by its left-image position), so both views see the same texture.
#[derive(Debug, Clone, Copy)]
struct Layer {
    region: Region,
    a: f64,
    b: f64,
    c: f64,
    texture_seed: u64,
    mean: f64,
    contrast: f64,
    low_texture: bool,
}

impl Layer {
    #[inline]
    fn disparity(&self, u: f64, v: f64) -> f64 {
        self.a + self.b * u + self.c * v
    }

    /// The left-image column of the surface point seen at right-image `(u_r, v)`.
    #[inline]
    fn left_u(&self, u_r: f64, v: f64) -> f64 {
        (u_r + self.a + self.c * v) / (1.0 - self.b)
    }

    fn fronto_parallel(&self) -> bool {
        self.b == 0.0 && self.c == 0.0
    }

    /// Band-limited value-noise texture: octaves of 24, 9 and 4 pixel periods.
    #[inline]
    fn texture(&self, u: f64, v: f64) -> f64 {
        let o1 = value_noise(u / 24.0, v / 24.0, self.texture_seed);
        let o2 = value_noise(u / 9.0, v / 9.0, self.texture_seed ^ 0x9e37_79b9);
        let o3 = value_noise(u / 4.0, v / 4.0, self.texture_seed ^ 0x85eb_ca6b);
        self.mean + self.contrast * (60.0 * (o1 - 0.5) + 55.0 * (o2 - 0.5) + 50.0 * (o3 - 0.5))
    }
}

pub(crate) fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

#[inline]
fn lattice(i: i64, j: i64, seed: u64) -> f64 {
    let h = splitmix(seed ^ splitmix((i as u64).wrapping_mul(0x1000_0000_01b3) ^ (j as u64).rotate_left(32)));
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Value noise in `[0, 1]` with a C² (quintic) interpolation between lattice values.
#[inline]
pub(crate) fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (i, j) = (fx as i64, fy as i64);
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (tx, ty) = (fade(x - fx), fade(y - fy));
    let a = lattice(i, j, seed) + tx * (lattice(i + 1, j, seed) - lattice(i, j, seed));
    let b = lattice(i, j + 1, seed) + tx * (lattice(i + 1, j + 1, seed) - lattice(i, j + 1, seed));
    a + ty * (b - a)
}

/// The fixed scene layout, scaled to the image size and disparity range.
fn layers(cfg: &StereoSceneConfig) -> Vec<Layer> {
    let (w, h, m) = (f64::from(cfg.width), f64::from(cfg.height), cfg.max_disparity);
    let seed = splitmix(cfg.seed);
    let layer = |k: u64, region, a, b, c, mean, contrast, low| Layer {
        region,
        a,
        b,
        c,
        texture_seed: splitmix(seed ^ k),
        mean,
        contrast,
        low_texture: low,
    };
    vec![
        // Far fronto-parallel background wall.
        layer(1, Region::All, 0.15 * m, 0.0, 0.0, 120.0, 1.0, false),
        // Slanted ground-like plane at the bottom left: disparity grows downwards and rightwards.
        layer(
            2,
            Region::Rect { x0: -1e9, x1: 0.55 * w, y0: 0.62 * h, y1: 1e9 },
            0.25 * m - 0.35 * m * 0.62 / 0.38,
            0.1 * m / w,
            0.35 * m / (0.38 * h),
            135.0,
            1.0,
            false,
        ),
        // Low-texture fronto-parallel panel (top left).
        layer(
            3,
            Region::Rect { x0: 0.08 * w, x1: 0.3 * w, y0: 0.08 * h, y1: 0.3 * h },
            0.3 * m,
            0.0,
            0.0,
            170.0,
            0.02,
            true,
        ),
        // A fronto-parallel disc in mid depth.
        layer(4, Region::Disc { cx: 0.38 * w, cy: 0.42 * h, r: 0.13 * h }, 0.6 * m, 0.0, 0.0, 110.0, 1.0, false),
        // A near fronto-parallel box: a large step discontinuity and wide occlusions.
        layer(
            5,
            Region::Rect { x0: 0.58 * w, x1: 0.82 * w, y0: 0.3 * h, y1: 0.72 * h },
            0.9 * m,
            0.0,
            0.0,
            140.0,
            1.0,
            false,
        ),
        // A small slanted panel (rotated about a vertical axis) in front of the wall.
        layer(
            6,
            Region::Rect { x0: 0.66 * w, x1: 0.9 * w, y0: 0.78 * h, y1: 0.95 * h },
            0.2 * m,
            0.25 * m / w,
            0.0,
            125.0,
            1.0,
            false,
        ),
    ]
}

/// Front-most layer at left-image position `(u, v)`.
#[inline]
fn front_left(layers: &[Layer], u: f64, v: f64) -> usize {
    let mut best = 0;
    let mut best_d = f64::NEG_INFINITY;
    for (k, l) in layers.iter().enumerate() {
        if l.region.contains(u, v) {
            let d = l.disparity(u, v);
            if d > best_d {
                best_d = d;
                best = k;
            }
        }
    }
    best
}

/// Front-most layer at right-image position `(u_r, v)` and the left column of its point.
#[inline]
fn front_right(layers: &[Layer], u_r: f64, v: f64) -> (usize, f64) {
    let mut best = (0, layers[0].left_u(u_r, v));
    let mut best_d = f64::NEG_INFINITY;
    for (k, l) in layers.iter().enumerate() {
        let u = l.left_u(u_r, v);
        if l.region.contains(u, v) {
            let d = u - u_r;
            if d > best_d {
                best_d = d;
                best = (k, u);
            }
        }
    }
    best
}

/// Renders the rectified pair and its truth.
///
/// The scene is a set of planar patches defined in the left image (a fronto-parallel
/// background wall, a slanted ground-like plane, a slanted panel, a fronto-parallel disc, a
/// near box making a step discontinuity with wide occlusions, and a nearly uniform low-texture
/// panel), each with an affine disparity and a value-noise texture attached to the surface.
/// The left image shows the front-most patch at each sample; the right image is ray-cast: each
/// right sample `u_r` is traced to every patch (`u_l − d(u_l, v) = u_r`) and takes the nearest
/// hit (largest disparity). Both images are area-integrated with `n x n` samples per pixel,
/// the right one is scaled by `right_gain` and shifted by `right_offset`, then Gaussian noise
/// is added and the values rounded to 8 bits.
pub fn render_stereo_scene(cfg: &StereoSceneConfig) -> Result<StereoScene, SyntheticError> {
    cfg.validate()?;
    let (w, h) = (cfg.width as usize, cfg.height as usize);
    let layers = layers(cfg);
    let n = cfg.samples_per_axis as usize;
    let offsets: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64 - 0.5).collect();
    let render = |right: bool| -> Vec<f64> {
        let mut out = vec![0.0; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
            for (u, px) in row.iter_mut().enumerate() {
                let mut sum = 0.0;
                for &oy in &offsets {
                    let y = v as f64 + oy;
                    for &ox in &offsets {
                        let x = u as f64 + ox;
                        sum += if right {
                            let (k, ul) = front_right(&layers, x, y);
                            layers[k].texture(ul, y)
                        } else {
                            layers[front_left(&layers, x, y)].texture(x, y)
                        };
                    }
                }
                *px = sum / (n * n) as f64;
            }
        });
        out
    };
    let left_radiance = render(false);
    let right_radiance = render(true);

    let mut disparity = vec![0f32; w * h];
    let mut occluded = vec![false; w * h];
    let mut low_texture = vec![false; w * h];
    let mut fronto_parallel = vec![false; w * h];
    for v in 0..h {
        for u in 0..w {
            let (x, y) = (u as f64, v as f64);
            let k = front_left(&layers, x, y);
            let d = layers[k].disparity(x, y);
            let i = v * w + u;
            disparity[i] = d as f32;
            let u_r = x - d;
            occluded[i] = u_r < -0.5 || front_right(&layers, u_r, y).0 != k;
            low_texture[i] = layers[k].low_texture;
            fronto_parallel[i] = layers[k].fronto_parallel();
        }
    }

    let mut rng = rng(cfg.seed ^ 0x05ee_d0f5_e7e0);
    let mut quantise = |values: &[f64], gain: f64, offset: f64| -> GrayImage {
        let bytes = values
            .iter()
            .map(|&x| {
                let mut y = gain * x + offset;
                if cfg.noise_sigma > 0.0 {
                    y += cfg.noise_sigma * normal(&mut rng);
                }
                y.round().clamp(0.0, 255.0) as u8
            })
            .collect();
        GrayImage::from_raw(cfg.width, cfg.height, bytes).expect("buffer of width x height")
    };
    let left = quantise(&left_radiance, 1.0, 0.0);
    let right = quantise(&right_radiance, cfg.right_gain, cfg.right_offset);

    let intrinsics = Intrinsics::new(cfg.focal_px, cfg.focal_px, (w as f64 - 1.0) * 0.5, (h as f64 - 1.0) * 0.5);
    let camera = Camera::new(intrinsics, Distortion::default(), cfg.width, cfg.height)
        .map_err(SyntheticError::model("rectified camera"))?;
    let rig =
        StereoRig::new(camera, camera, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-cfg.baseline, 0.0, 0.0)))
            .map_err(SyntheticError::model("rectified rig"))?;
    let disparity = DisparityMap::from_data(w, h, disparity).map_err(SyntheticError::model("disparity"))?;
    Ok(StereoScene { left, right, disparity, occluded, low_texture, fronto_parallel, rig })
}
