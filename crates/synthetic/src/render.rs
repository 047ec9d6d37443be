//! Rendered chessboard views with exact, area-integrated anti-aliasing.

use glam::{DMat3, DVec2, DVec3};
use image::{GrayImage, ImageBuffer, Luma};
use parallax_camera_model::{CameraModel, Chessboard, Isometry3};
use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::error::non_negative;
use crate::noise::{normal, rng, uniform};
use crate::views::project_corners;

/// Appearance of a rendered chessboard view. Intensities are 8-bit grey levels.
///
/// The default is a clean view (no blur, noise, gradient or vignetting) of a board with a
/// one-square white margin on a uniform grey background.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RenderOptions {
    /// Width of the white margin around the outer squares, in squares. Default 1.0.
    pub margin_squares: f64,
    /// Grey level of the black squares. Default 30.
    pub black: u8,
    /// Grey level of the white squares and the margin. Default 220.
    pub white: u8,
    /// Standard deviation of the Gaussian optical blur, pixels (0 = none). Default 0.
    pub blur_sigma: f64,
    /// Standard deviation of the additive Gaussian sensor noise, grey levels. Default 0.
    pub noise_sigma: f64,
    /// Fraction of pixels replaced by impulse noise (half set to 255, half to 0), in `[0, 1]`.
    /// Default 0.
    pub salt_fraction: f64,
    /// Linear illumination gradient: the brightness factor runs from `1 − g` to `1 + g`
    /// across the image along a direction drawn from `seed`. Default 0.
    pub illumination_gradient: f64,
    /// Vignetting: brightness factor `1 − vignetting · (r / r_max)²`, `r` the distance to the
    /// principal point and `r_max` that of the farthest image corner, in `[0, 1]`. Default 0.
    pub vignetting: f64,
    /// Grey level of the background around the board. Default 128.
    pub background: u8,
    /// Replace the uniform background by random clutter (rectangles, bars, a smooth shading)
    /// around the board. Default false.
    pub clutter: bool,
    /// Black squares printed as a dark frame this wide (a fraction of the square's side)
    /// around a light interior of the white squares' grey: an outlined or hollow print, whose
    /// corners are not saddles beyond the frame's width. 0 (the default) = solid squares.
    /// In `[0, 0.5)`; chessboards and ChArUco boards only.
    #[serde(skip_serializing_if = "is_zero")]
    pub square_outline: f64,
    /// A specular highlight on the print (light reflected towards the camera), added to the
    /// image before the blur; `None` (the default) for none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glare: Option<Glare>,
    /// Defocus: the image convolved with a uniform disc of this radius, pixels (after the
    /// Gaussian blur). Default 0; at most [`MAX_KERNEL_PX`].
    #[serde(skip_serializing_if = "is_zero")]
    pub defocus_radius: f64,
    /// Motion blur: the image smeared along a line of this length, pixels (after the defocus).
    /// Default 0; at most [`MAX_KERNEL_PX`].
    #[serde(skip_serializing_if = "is_zero")]
    pub motion_blur: f64,
    /// Direction of the motion blur, radians from the image's `u` axis towards `v`.
    #[serde(skip_serializing_if = "is_zero")]
    pub motion_angle: f64,
    /// Saves the final 8-bit image as a baseline JPEG of this quality (1–100) and decodes it
    /// again: a camera's or a phone's compression artefacts. `None` (the default) for none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jpeg_quality: Option<u8>,
    /// Seed of the noise, clutter and gradient direction.
    pub seed: u64,
}

/// Fields of the hard-photo effects are written only when set, so that descriptions without
/// them read as they always did.
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// A specular highlight: `strength` grey levels added at `centre` (pixels), falling off as a
/// Gaussian of standard deviation `radius` pixels (the sum clips at 255, as a sensor does).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Glare {
    /// Centre of the highlight, pixels.
    pub centre: DVec2,
    /// Standard deviation of its fall-off, pixels.
    pub radius: f64,
    /// Grey levels added at its centre.
    pub strength: f64,
}

/// Largest defocus radius and motion-blur length a render accepts, pixels.
pub const MAX_KERNEL_PX: f64 = 30.0;

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            margin_squares: 1.0,
            black: 30,
            white: 220,
            blur_sigma: 0.0,
            noise_sigma: 0.0,
            salt_fraction: 0.0,
            illumination_gradient: 0.0,
            vignetting: 0.0,
            background: 128,
            clutter: false,
            square_outline: 0.0,
            glare: None,
            defocus_radius: 0.0,
            motion_blur: 0.0,
            motion_angle: 0.0,
            jpeg_quality: None,
            seed: 0,
        }
    }
}

/// Largest optical blur a render accepts, pixels: a chessboard square of a few tens of pixels is
/// gone long before it.
pub const MAX_BLUR_SIGMA: f64 = 50.0;

impl RenderOptions {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), SyntheticError> {
        non_negative("margin_squares", self.margin_squares)?;
        non_negative("blur_sigma", self.blur_sigma)?;
        if self.blur_sigma > MAX_BLUR_SIGMA {
            return Err(SyntheticError::config(
                "blur_sigma",
                format!(
                    "{} px is above {MAX_BLUR_SIGMA} px, a blur that leaves no board to find (and takes minutes to \
                     render)",
                    self.blur_sigma
                ),
            ));
        }
        non_negative("noise_sigma", self.noise_sigma)?;
        non_negative("illumination_gradient", self.illumination_gradient)?;
        for (field, v) in [("salt_fraction", self.salt_fraction), ("vignetting", self.vignetting)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(SyntheticError::config(field, format!("must be in [0, 1], got {v}")));
            }
        }
        if !(0.0..0.5).contains(&self.square_outline) {
            return Err(SyntheticError::config(
                "square_outline",
                format!("must be in [0, 0.5) of a square (0 = solid squares), got {}", self.square_outline),
            ));
        }
        for (field, v) in [("defocus_radius", self.defocus_radius), ("motion_blur", self.motion_blur)] {
            non_negative(field, v)?;
            if v > MAX_KERNEL_PX {
                return Err(SyntheticError::config(field, format!("{v} px is above {MAX_KERNEL_PX} px")));
            }
        }
        if !self.motion_angle.is_finite() {
            return Err(SyntheticError::config("motion_angle", "must be finite"));
        }
        if let Some(g) = &self.glare
            && !(g.centre.is_finite()
                && g.radius.is_finite()
                && g.radius > 0.0
                && g.strength.is_finite()
                && g.strength >= 0.0)
        {
            return Err(SyntheticError::config("glare", "needs a finite centre, a radius > 0 and a strength >= 0"));
        }
        if self.jpeg_quality.is_some_and(|q| !(1..=100).contains(&q)) {
            return Err(SyntheticError::config("jpeg_quality", "must be in 1..=100"));
        }
        if self.illumination_gradient > 1.0 {
            return Err(SyntheticError::config("illumination_gradient", "must be at most 1 (negative brightness)"));
        }
        Ok(())
    }
}

/// A rendered view and its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedView {
    /// The 8-bit image (`camera.width() x camera.height()`).
    pub image: GrayImage,
    /// True image positions of the inner corners in OpenCV's order (row-major), projected
    /// through the camera model, distortion included. Corners may lie outside the image.
    pub corners: Vec<DVec2>,
    /// The pose the view was rendered from.
    pub camera_from_board: Isometry3,
}

/// Renders an 8-bit view of `board` seen by `camera` from `camera_from_board`.
///
/// Anti-aliasing is exact area coverage: the four corners of every pixel are unprojected
/// through the lens model ([`CameraModel::unproject_ray`]) and intersected with the board plane; on the
/// plane the pixel is the quadrilateral they span, which is clipped against the squares
/// (Sutherland–Hodgman), and each clipped piece is mapped back to the pixel through the local
/// homography of the four corners, where its area is the piece's weight. Without distortion
/// the board-to-image map is a homography, so the coverage is exact to rounding; with
/// distortion, the pixel's preimage is approximated by a straight-edged quadrilateral (error
/// of order `(1 px)² ·` curvature, far below 1e-3 px). Pixels whose corners cannot all be
/// unprojected onto the plane (horizon, invalid lens region) fall back to 16x16 point samples.
///
/// The board's square `(i, j)` (`i = −1..cols`, `j = −1..rows` in squares, the inner corner
/// `(0, 0)` at its lower-right) is black when `i + j` is even (top-left square black), then the
/// white margin, then the background. After the board, the illumination gradient and vignetting
/// multiply the image, the blur is applied (imageproc's Gaussian), then Gaussian noise, impulse
/// noise and rounding to 8 bits. The true corners are [`project_corners`].
///
/// Any [`CameraModel`] renders: the pinhole `Camera` and the wide-angle `Camera` (rays
/// behind the image plane included; pixels no ray maps to show the background).
///
/// Errors on an invalid camera, board, pose or option, or when a corner is outside the camera's
/// valid region (behind a pinhole camera).
pub fn render_chessboard<C: CameraModel + Sync>(
    camera: &C,
    board: &Chessboard,
    camera_from_board: &Isometry3,
    opts: &RenderOptions,
) -> Result<RenderedView, SyntheticError> {
    opts.validate()?;
    let corners = project_corners(camera, board, camera_from_board)?;
    let pattern = Pattern::new(board, opts);
    let image = render_pattern(camera, camera_from_board, board.square_size, &pattern, opts, &[], &|_, v| v);
    Ok(RenderedView { image, corners, camera_from_board: *camera_from_board })
}

/// Renders `pattern` (in units of `unit` on the target plane `z = 0`) through `camera` from
/// `camera_from_board`, with `opts`' background, lighting, blur, noise and quantisation, and
/// `occluders` (convex polygons in pixels, drawn over the target before the blur). `overlay`
/// changes a pixel's value given the pixel's preimage on the plane (its four corners, in
/// units, in pixel order (0,0), (1,0), (1,1), (0,1); `None` where they cannot all be
/// unprojected) — the circles of a circle grid.
pub(crate) fn render_pattern<C: CameraModel + Sync>(
    camera: &C,
    camera_from_board: &Isometry3,
    unit: f64,
    pattern: &Pattern,
    opts: &RenderOptions,
    occluders: &[crate::targets::Occluder],
    overlay: &(dyn Fn(Option<[DVec2; 4]>, f64) -> f64 + Sync),
) -> GrayImage {
    let (w, h) = (camera.width() as usize, camera.height() as usize);
    let mut rng = rng(opts.seed);
    let background = if opts.clutter {
        clutter(w, h, f64::from(opts.background), &mut rng)
    } else {
        vec![f64::from(opts.background); w * h]
    };
    let grid = CornerGrid::new(camera, camera_from_board, unit);
    let mut radiance = vec![0f32; w * h];
    radiance.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
        for (u, out) in row.iter_mut().enumerate() {
            let bg = background[v * w + u];
            let value = pixel_value(&grid, pattern, camera, camera_from_board, unit, u, v, bg);
            let quad = [grid.at(u, v), grid.at(u + 1, v), grid.at(u + 1, v + 1), grid.at(u, v + 1)];
            let quad = if let [Some(a), Some(b), Some(c), Some(d)] = quad { Some([a, b, c, d]) } else { None };
            *out = overlay(quad, value) as f32;
        }
    });
    for o in occluders {
        o.paint(&mut radiance, w, h);
    }
    apply_lighting(&mut radiance, camera, opts, &mut rng);
    if let Some(g) = &opts.glare {
        radiance.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
            for (u, out) in row.iter_mut().enumerate() {
                let d2 = (DVec2::new(u as f64, v as f64) - g.centre).length_squared();
                *out += (g.strength * (-0.5 * d2 / (g.radius * g.radius)).exp()) as f32;
            }
        });
    }
    let mut img =
        ImageBuffer::<Luma<f32>, Vec<f32>>::from_raw(w as u32, h as u32, radiance).expect("buffer of width x height");
    if opts.blur_sigma > 0.0 {
        img = imageproc::filter::gaussian_blur_f32(&img, opts.blur_sigma as f32);
    }
    let mut values = img.into_raw();
    if opts.defocus_radius > 0.0 {
        values = disc_kernel(opts.defocus_radius).apply(values, w, h);
    }
    if opts.motion_blur > 0.0 {
        values = line_kernel(opts.motion_blur, opts.motion_angle).apply(values, w, h);
    }
    let img = quantise(values, w, h, opts, &mut rng);
    match opts.jpeg_quality {
        Some(q) => jpeg_round_trip(&img, q),
        None => img,
    }
}

/// A square kernel of side `2n + 1` centred on the pixel, row-major, weights summing to 1.
struct Kernel {
    n: i64,
    weights: Vec<f32>,
}

impl Kernel {
    /// The kernel of half-side `n` whose weight at offset `(du, dv)` is `weight(du, dv)`,
    /// normalised.
    fn from_fn(n: i64, mut weight: impl FnMut(i64, i64) -> f64) -> Self {
        let mut weights: Vec<f32> =
            (-n..=n).flat_map(|dv| (-n..=n).map(move |du| (du, dv))).map(|(du, dv)| weight(du, dv) as f32).collect();
        let sum: f32 = weights.iter().sum();
        for w in &mut weights {
            *w /= sum;
        }
        Self { n, weights }
    }

    /// `values` (`w x h`) filtered with the kernel, the image's border pixels repeated
    /// outwards (imageproc's correlation).
    fn apply(&self, values: Vec<f32>, w: usize, h: usize) -> Vec<f32> {
        let side = (2 * self.n + 1) as u32;
        let img = ImageBuffer::<Luma<f32>, Vec<f32>>::from_raw(w as u32, h as u32, values).expect("w x h values");
        let kernel = imageproc::kernel::Kernel::new(&self.weights, side, side);
        imageproc::filter::filter_parallel::<_, f32, _, Luma<f32>>(&img, kernel, |v| v).into_raw()
    }
}

/// A uniform disc of radius `r` pixels, each tap weighted by the share of its pixel the disc
/// covers (16x16 samples per pixel).
fn disc_kernel(r: f64) -> Kernel {
    Kernel::from_fn(r.ceil() as i64 + 1, |du, dv| {
        let inside = (0..256)
            .filter(|s| {
                let x = du as f64 - 0.5 + ((s % 16) as f64 + 0.5) / 16.0;
                let y = dv as f64 - 0.5 + ((s / 16) as f64 + 0.5) / 16.0;
                x * x + y * y <= r * r
            })
            .count();
        inside as f64
    })
}

/// A line of `length` pixels through the origin at `angle`: 32 points per pixel of length,
/// each spread over its four nearest taps (bilinear weights).
fn line_kernel(length: f64, angle: f64) -> Kernel {
    let dir = DVec2::new(angle.cos(), angle.sin());
    let samples = ((length * 32.0).ceil() as usize).max(1);
    let n = (0.5 * length).ceil() as i64 + 1;
    let side = (2 * n + 1) as usize;
    let mut weights = vec![0.0; side * side];
    for k in 0..samples {
        let p = dir * (length * ((k as f64 + 0.5) / samples as f64 - 0.5));
        let (x0, y0) = (p.x.floor(), p.y.floor());
        let (fx, fy) = (p.x - x0, p.y - y0);
        for (dx, dy, wgt) in
            [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)]
        {
            let (u, v) = (x0 as i64 + dx + n, y0 as i64 + dy + n);
            weights[v as usize * side + u as usize] += wgt;
        }
    }
    Kernel::from_fn(n, |du, dv| weights[(dv + n) as usize * side + (du + n) as usize])
}

/// `img` saved as a baseline JPEG of `quality` and decoded again (in memory).
fn jpeg_round_trip(img: &GrayImage, quality: u8) -> GrayImage {
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality)
        .encode_image(img)
        .expect("an 8-bit grey image encodes");
    image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg).expect("our own JPEG decodes").to_luma8()
}

/// Piecewise-constant board colour on a grid of intervals (in squares).
pub(crate) struct Pattern {
    /// Interval breakpoints along board x and y, in squares.
    xs: Vec<f64>,
    ys: Vec<f64>,
    /// Colour of interval `(ix, iy)`, row-major over `xs.len() − 1` columns.
    colours: Vec<f64>,
}

impl Pattern {
    /// A pattern from increasing breakpoints and the colour at each interval's midpoint.
    pub(crate) fn from_fn(xs: Vec<f64>, ys: Vec<f64>, colour: impl Fn(f64, f64) -> f64) -> Self {
        let mut colours = Vec::with_capacity((xs.len() - 1) * (ys.len() - 1));
        for iy in 0..ys.len() - 1 {
            for ix in 0..xs.len() - 1 {
                colours.push(colour(0.5 * (xs[ix] + xs[ix + 1]), 0.5 * (ys[iy] + ys[iy + 1])));
            }
        }
        Self { xs, ys, colours }
    }

    fn new(board: &Chessboard, opts: &RenderOptions) -> Self {
        let (m, t) = (opts.margin_squares, opts.square_outline);
        let breaks = |n: usize| {
            let mut b = Vec::with_capacity(n + 4);
            if m > 0.0 {
                b.push(-1.0 - m);
            }
            b.extend((0..=n + 1).map(|k| k as f64 - 1.0));
            if t > 0.0 {
                // The inner edges of the outlined squares' frames.
                b.extend((0..=n).flat_map(|k| [k as f64 - 1.0 + t, k as f64 - t]));
                b.sort_by(f64::total_cmp);
            }
            if m > 0.0 {
                b.push(n as f64 + m);
            }
            b
        };
        let xs = breaks(board.cols);
        let ys = breaks(board.rows);
        let (black, white) = (f64::from(opts.black), f64::from(opts.white));
        let mut colours = Vec::with_capacity((xs.len() - 1) * (ys.len() - 1));
        for iy in 0..ys.len() - 1 {
            for ix in 0..xs.len() - 1 {
                let (x0, x1, y0, y1) = (xs[ix], xs[ix + 1], ys[iy], ys[iy + 1]);
                let in_squares = x0 >= -1.0 && x1 <= board.cols as f64 && y0 >= -1.0 && y1 <= board.rows as f64;
                let colour = if in_squares {
                    let (i, j) = (x0.floor() as i64, y0.floor() as i64);
                    let (fx, fy) = (0.5 * (x0 + x1) - i as f64, 0.5 * (y0 + y1) - j as f64);
                    let frame = t == 0.0 || fx.min(fy).min(1.0 - fx).min(1.0 - fy) < t;
                    if (i + j).rem_euclid(2) == 0 && frame { black } else { white }
                } else {
                    white
                };
                colours.push(colour);
            }
        }
        Self { xs, ys, colours }
    }

    /// Interval index of `x` in `breaks` (`None` outside).
    fn interval(breaks: &[f64], x: f64) -> Option<usize> {
        if !(x >= breaks[0] && x < breaks[breaks.len() - 1]) {
            return None;
        }
        Some(breaks.partition_point(|&b| b <= x) - 1)
    }

    /// Colour at a board point (squares), `None` off the board.
    fn at(&self, p: DVec2) -> Option<f64> {
        let ix = Self::interval(&self.xs, p.x)?;
        let iy = Self::interval(&self.ys, p.y)?;
        Some(self.colours[iy * (self.xs.len() - 1) + ix])
    }
}

/// Board-plane coordinates (in squares) of every pixel corner `(u − ½, v − ½)`.
struct CornerGrid {
    width: usize,
    points: Vec<Option<DVec2>>,
}

impl CornerGrid {
    fn new<C: CameraModel + Sync>(camera: &C, camera_from_board: &Isometry3, square: f64) -> Self {
        let (w, h) = (camera.width() as usize + 1, camera.height() as usize + 1);
        let plane = Plane::new(camera_from_board, square);
        let mut points = vec![None; w * h];
        points.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                *out = plane.hit(camera, DVec2::new(i as f64 - 0.5, j as f64 - 0.5));
            }
        });
        Self { width: w, points }
    }

    #[inline]
    fn at(&self, i: usize, j: usize) -> Option<DVec2> {
        self.points[j * self.width + i]
    }
}

/// The board plane in the camera frame.
struct Plane {
    board_from_camera: Isometry3,
    normal: DVec3,
    offset: f64,
    inv_square: f64,
}

impl Plane {
    fn new(camera_from_board: &Isometry3, square: f64) -> Self {
        let normal = camera_from_board.transform_vector(DVec3::Z);
        Self {
            board_from_camera: camera_from_board.inverse(),
            normal,
            offset: normal.dot(camera_from_board.translation),
            inv_square: 1.0 / square,
        }
    }

    /// Board point (in squares) seen through a pixel, `None` when the ray misses the plane.
    #[inline]
    fn hit<C: CameraModel>(&self, camera: &C, pixel: DVec2) -> Option<DVec2> {
        let ray = camera.unproject_ray(pixel).ok()?;
        let denom = self.normal.dot(ray);
        let lambda = self.offset / denom;
        if !(lambda > 0.0 && lambda.is_finite()) {
            return None;
        }
        let p = self.board_from_camera.transform_point(ray * lambda);
        let q = DVec2::new(p.x, p.y) * self.inv_square;
        q.is_finite().then_some(q)
    }
}

/// The radiance of pixel `(u, v)` before lighting, blur and noise.
fn pixel_value<C: CameraModel>(
    grid: &CornerGrid,
    pattern: &Pattern,
    camera: &C,
    camera_from_board: &Isometry3,
    square: f64,
    u: usize,
    v: usize,
    background: f64,
) -> f64 {
    let quad = [grid.at(u, v), grid.at(u + 1, v), grid.at(u + 1, v + 1), grid.at(u, v + 1)];
    if let [Some(a), Some(b), Some(c), Some(d)] = quad
        && let Some(value) = exact_coverage(pattern, [a, b, c, d], background)
    {
        return value;
    }
    point_sampled(pattern, camera, camera_from_board, square, u, v, background)
}

/// Exact coverage of the pixel whose preimage on the board is the quadrilateral `q`
/// (corners in pixel order (0,0), (1,0), (1,1), (0,1)); `None` when it is degenerate.
fn exact_coverage(pattern: &Pattern, q: [DVec2; 4], background: f64) -> Option<f64> {
    let lo = q[0].min(q[1]).min(q[2].min(q[3]));
    let hi = q[0].max(q[1]).max(q[2].max(q[3]));
    let (xs, ys) = (&pattern.xs, &pattern.ys);
    let nx = xs.len() - 1;
    // Interval ranges touched by the bounding box, clamped to the board.
    let range = |b: &[f64], lo: f64, hi: f64| -> Option<(usize, usize)> {
        if hi <= b[0] || lo >= b[b.len() - 1] {
            return None;
        }
        let first = b.partition_point(|&x| x <= lo).saturating_sub(1);
        let last = (b.partition_point(|&x| x < hi) - 1).min(b.len() - 2);
        Some((first, last))
    };
    let (Some((ix0, ix1)), Some((iy0, iy1))) = (range(xs, lo.x, hi.x), range(ys, lo.y, hi.y)) else {
        return Some(background);
    };
    let inside_board = lo.x >= xs[0] && hi.x <= xs[nx] && lo.y >= ys[0] && hi.y <= ys[ys.len() - 1];
    if ix0 == ix1 && iy0 == iy1 && inside_board {
        return Some(pattern.colours[iy0 * nx + ix0]);
    }
    // Homography from pixel-local (a, b) ∈ [0,1]² to the board, inverted to map pieces back.
    let to_pixel = square_to_quad(q)?.inverse();
    if !to_pixel.is_finite() {
        return None;
    }
    let mut covered = 0.0;
    let mut sum = 0.0;
    for iy in iy0..=iy1 {
        for ix in ix0..=ix1 {
            let piece = clip(&q, xs[ix], xs[ix + 1], ys[iy], ys[iy + 1]);
            if piece.len < 3 {
                continue;
            }
            let mut area = 0.0;
            let mut prev = map_h(&to_pixel, piece.pts[piece.len - 1])?;
            for k in 0..piece.len {
                let cur = map_h(&to_pixel, piece.pts[k])?;
                area += prev.x * cur.y - cur.x * prev.y;
                prev = cur;
            }
            let area = 0.5 * area.abs();
            covered += area;
            sum += area * pattern.colours[iy * nx + ix];
        }
    }
    let covered = covered.min(1.0);
    Some(sum + (1.0 - covered) * background)
}

#[inline]
fn map_h(h: &DMat3, p: DVec2) -> Option<DVec2> {
    let r = *h * p.extend(1.0);
    (r.z.abs() > 1e-300).then(|| DVec2::new(r.x / r.z, r.y / r.z))
}

/// Heckbert's square-to-quadrilateral homography: `(0,0), (1,0), (1,1), (0,1)` to `q[0..4]`.
fn square_to_quad(q: [DVec2; 4]) -> Option<DMat3> {
    let [p0, p1, p2, p3] = q;
    let s = p0 - p1 + p2 - p3;
    let (a, b, c, d, e, f, g, hh);
    if s.x == 0.0 && s.y == 0.0 {
        (a, b, c) = (p1.x - p0.x, p2.x - p1.x, p0.x);
        (d, e, f) = (p1.y - p0.y, p2.y - p1.y, p0.y);
        (g, hh) = (0.0, 0.0);
    } else {
        let d1 = p1 - p2;
        let d2 = p3 - p2;
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-300 {
            return None;
        }
        g = (s.x * d2.y - d2.x * s.y) / det;
        hh = (d1.x * s.y - s.x * d1.y) / det;
        (a, b, c) = (p1.x - p0.x + g * p1.x, p3.x - p0.x + hh * p3.x, p0.x);
        (d, e, f) = (p1.y - p0.y + g * p1.y, p3.y - p0.y + hh * p3.y, p0.y);
    }
    let m = DMat3::from_cols(DVec3::new(a, d, g), DVec3::new(b, e, hh), DVec3::new(c, f, 1.0));
    (m.determinant().abs() > 1e-300).then_some(m)
}

/// A small fixed-capacity polygon (a convex quad clipped by 4 half-planes has at most 8 sides).
struct Poly {
    pts: [DVec2; 12],
    len: usize,
}

/// Sutherland–Hodgman clipping of a convex quadrilateral against `[x0, x1] x [y0, y1]`.
fn clip(q: &[DVec2; 4], x0: f64, x1: f64, y0: f64, y1: f64) -> Poly {
    let mut cur = Poly { pts: [DVec2::ZERO; 12], len: 4 };
    cur.pts[..4].copy_from_slice(q);
    // Each edge: (axis, bound, keep-greater).
    for (axis, bound, greater) in [(0, x0, true), (0, x1, false), (1, y0, true), (1, y1, false)] {
        let mut out = Poly { pts: [DVec2::ZERO; 12], len: 0 };
        let inside = |p: DVec2| if greater { p[axis] >= bound } else { p[axis] <= bound };
        for k in 0..cur.len {
            let a = cur.pts[k];
            let b = cur.pts[(k + 1) % cur.len];
            let (ia, ib) = (inside(a), inside(b));
            if ia {
                out.pts[out.len] = a;
                out.len += 1;
            }
            if ia != ib {
                let t = (bound - a[axis]) / (b[axis] - a[axis]);
                let mut p = a + (b - a) * t;
                p[axis] = bound;
                out.pts[out.len] = p;
                out.len += 1;
            }
        }
        cur = out;
        if cur.len == 0 {
            break;
        }
    }
    cur
}

/// Fallback: 16x16 point samples, each unprojected through the lens model.
fn point_sampled<C: CameraModel>(
    pattern: &Pattern,
    camera: &C,
    camera_from_board: &Isometry3,
    square: f64,
    u: usize,
    v: usize,
    background: f64,
) -> f64 {
    const N: usize = 16;
    let plane = Plane::new(camera_from_board, square);
    let mut sum = 0.0;
    for j in 0..N {
        for i in 0..N {
            let px =
                DVec2::new(u as f64 - 0.5 + (i as f64 + 0.5) / N as f64, v as f64 - 0.5 + (j as f64 + 0.5) / N as f64);
            sum += plane.hit(camera, px).and_then(|p| pattern.at(p)).unwrap_or(background);
        }
    }
    sum / (N * N) as f64
}

/// Multiplies by the illumination gradient and the vignetting.
fn apply_lighting<C: CameraModel>(radiance: &mut [f32], camera: &C, opts: &RenderOptions, rng: &mut impl Rng) {
    let angle = uniform(rng, 0.0, std::f64::consts::TAU);
    if opts.illumination_gradient == 0.0 && opts.vignetting == 0.0 {
        return;
    }
    let (w, h) = (camera.width() as f64, camera.height() as f64);
    let centre = DVec2::new((w - 1.0) * 0.5, (h - 1.0) * 0.5);
    let dir = DVec2::new(angle.cos(), angle.sin());
    let half_extent = 0.5 * ((w - 1.0) * dir.x.abs() + (h - 1.0) * dir.y.abs()).max(1e-9);
    let pp = DVec2::new(camera.intrinsics().cx, camera.intrinsics().cy);
    let r_max2 =
        [DVec2::new(0.0, 0.0), DVec2::new(w - 1.0, 0.0), DVec2::new(0.0, h - 1.0), DVec2::new(w - 1.0, h - 1.0)]
            .iter()
            .map(|c| (*c - pp).length_squared())
            .fold(1e-9, f64::max);
    let width = camera.width() as usize;
    radiance.par_chunks_mut(width).enumerate().for_each(|(v, row)| {
        for (u, out) in row.iter_mut().enumerate() {
            let p = DVec2::new(u as f64, v as f64);
            let ramp = (p - centre).dot(dir) / half_extent;
            let factor = (1.0 + opts.illumination_gradient * ramp)
                * (1.0 - opts.vignetting * (p - pp).length_squared() / r_max2);
            *out = (f64::from(*out) * factor) as f32;
        }
    });
}

/// Adds Gaussian and impulse noise and rounds to 8 bits.
fn quantise(values: Vec<f32>, w: usize, h: usize, opts: &RenderOptions, rng: &mut impl Rng) -> GrayImage {
    let mut out = Vec::with_capacity(values.len());
    for &value in &values {
        let mut x = f64::from(value);
        if opts.noise_sigma > 0.0 {
            x += opts.noise_sigma * normal(rng);
        }
        if opts.salt_fraction > 0.0 && rng.random::<f64>() < opts.salt_fraction {
            x = if rng.random::<bool>() { 255.0 } else { 0.0 };
        }
        out.push(x.round().clamp(0.0, 255.0) as u8);
    }
    GrayImage::from_raw(w as u32, h as u32, out).expect("buffer of width x height")
}

/// A cluttered background: smooth shading, random rectangles (exact coverage) and bars.
fn clutter(w: usize, h: usize, level: f64, rng: &mut impl Rng) -> Vec<f64> {
    let (fw, fh) = (w as f64, h as f64);
    let (kx, ky, phase) = (uniform(rng, 1.0, 3.0) / fw, uniform(rng, 1.0, 3.0) / fh, uniform(rng, 0.0, 6.3));
    let mut img: Vec<f64> = (0..w * h)
        .map(|k| {
            let (u, v) = ((k % w) as f64, (k / w) as f64);
            level + 25.0 * (std::f64::consts::TAU * (kx * u + ky * v) + phase).sin()
        })
        .collect();
    // Axis-aligned rectangles with exact pixel coverage.
    for _ in 0..30 {
        let (rw, rh) = (uniform(rng, 0.04, 0.25) * fw, uniform(rng, 0.04, 0.25) * fh);
        let (x0, y0) = (uniform(rng, -0.1, 1.0) * fw, uniform(rng, -0.1, 1.0) * fh);
        let (x1, y1) = (x0 + rw, y0 + rh);
        let grey = uniform(rng, 0.0, 255.0);
        let u0 = (x0 - 0.5).floor().max(0.0) as usize;
        let u1 = ((x1 + 0.5).ceil().max(0.0) as usize).min(w);
        let v0 = (y0 - 0.5).floor().max(0.0) as usize;
        let v1 = ((y1 + 0.5).ceil().max(0.0) as usize).min(h);
        for v in v0..v1 {
            let cy = ((v as f64 + 0.5).min(y1) - (v as f64 - 0.5).max(y0)).max(0.0);
            for u in u0..u1 {
                let cx = ((u as f64 + 0.5).min(x1) - (u as f64 - 0.5).max(x0)).max(0.0);
                let a = cx * cy;
                let p = &mut img[v * w + u];
                *p = *p * (1.0 - a) + grey * a;
            }
        }
    }
    // Slanted bars (4x4 supersampled): edges and false corners for detectors to reject.
    for _ in 0..12 {
        let a = DVec2::new(uniform(rng, 0.0, fw), uniform(rng, 0.0, fh));
        let b = DVec2::new(uniform(rng, 0.0, fw), uniform(rng, 0.0, fh));
        let half_width = uniform(rng, 1.0, 4.0);
        let grey = uniform(rng, 0.0, 255.0);
        let (lo, hi) = (a.min(b) - half_width - 1.0, a.max(b) + half_width + 1.0);
        let ab = b - a;
        let len2 = ab.length_squared().max(1e-9);
        for v in (lo.y.max(0.0) as usize)..(hi.y.max(0.0) as usize).min(h) {
            for u in (lo.x.max(0.0) as usize)..(hi.x.max(0.0) as usize).min(w) {
                let mut hits = 0;
                for s in 0..16 {
                    let p =
                        DVec2::new(u as f64 - 0.375 + 0.25 * (s % 4) as f64, v as f64 - 0.375 + 0.25 * (s / 4) as f64);
                    let t = ((p - a).dot(ab) / len2).clamp(0.0, 1.0);
                    if (a + ab * t - p).length() <= half_width {
                        hits += 1;
                    }
                }
                let cov = f64::from(hits) / 16.0;
                let px = &mut img[v * w + u];
                *px = *px * (1.0 - cov) + grey * cov;
            }
        }
    }
    for p in &mut img {
        *p = p.clamp(0.0, 255.0);
    }
    img
}
