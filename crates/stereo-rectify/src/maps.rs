//! Per-pixel lookup tables: undistort + rectify maps (as OpenCV's `initUndistortRectifyMap`),
//! undistort-only maps and homography maps.

use std::sync::Mutex;

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::Camera;
use parallax_simd::Avx2;
use rayon::prelude::*;

use crate::{RectifyError, Result};

/// A dense lookup table: the output pixel `(u, v)` takes its value from the source position
/// `(map_x[i], map_y[i])`, `i = v · width + u` (OpenCV's pair of `CV_32FC1` maps). Entries are
/// NaN where the output pixel has no source (its ray points behind the source camera).
#[derive(Debug, Clone, PartialEq)]
pub struct RemapTable {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Source column of each output pixel, row-major.
    pub map_x: Vec<f32>,
    /// Source row of each output pixel, row-major.
    pub map_y: Vec<f32>,
}

impl RemapTable {
    /// A 0x0 table (no entries), the starting point of buffers filled later.
    pub(crate) fn empty() -> Self {
        Self { width: 0, height: 0, map_x: Vec::new(), map_y: Vec::new() }
    }

    /// The source position of output pixel `(u, v)`; `None` outside the table.
    pub fn source(&self, u: u32, v: u32) -> Option<(f32, f32)> {
        if u >= self.width || v >= self.height {
            return None;
        }
        let i = v as usize * self.width as usize + u as usize;
        Some((self.map_x[i], self.map_y[i]))
    }

    /// Builds a table from a per-pixel function (row-parallel with rayon). The function gets
    /// the output pixel and returns the source position (`None`: no source, stored as NaN).
    pub fn from_fn<F>(width: u32, height: u32, f: F) -> Result<Self>
    where
        F: Fn(u32, u32) -> Option<DVec2> + Sync,
    {
        check_size(width, height)?;
        let n = width as usize * height as usize;
        let mut map_x = vec![0f32; n];
        let mut map_y = vec![0f32; n];
        map_x.par_chunks_mut(width as usize).zip(map_y.par_chunks_mut(width as usize)).enumerate().for_each(
            |(v, (mx, my))| {
                for u in 0..width {
                    let (x, y) = match f(u, v as u32) {
                        Some(p) => (p.x as f32, p.y as f32),
                        None => (f32::NAN, f32::NAN),
                    };
                    mx[u as usize] = x;
                    my[u as usize] = y;
                }
            },
        );
        Ok(Self { width, height, map_x, map_y })
    }
}

fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(RectifyError::Config(format!("map size must be non-zero, got {width}x{height}")));
    }
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(RectifyError::Config(format!("map sides must be at most {MAX_SIDE}, got {width}x{height}")));
    }
    Ok(())
}

/// The largest side of a map: columns are converted to `f64` through `i32`, which vectorises
/// (there is no vector conversion from unsigned integers before AVX-512).
const MAX_SIDE: u32 = 1 << 30;

/// The undistort + rectify map of one camera of any lens, as OpenCV's
/// `initUndistortRectifyMap(K, D, R, newK, size, CV_32FC1)` (Brown–Conrady) or
/// `fisheye::initUndistortRectifyMap` (wide lenses): output pixel `p` ← ray `(newK · R)⁻¹ p`,
/// through the lens and the camera's own intrinsics; pixels whose ray the lens does not image
/// have no source (NaN). `r` is the rectifying rotation (`R1` or `R2`; identity
/// for plain undistortion) and `new_camera_matrix` the rectified camera matrix (the left 3x3
/// block of `P1`/`P2`, see [`crate::Rectification::left_camera_matrix`]). Computed in `f64`,
/// stored as `f32` (≤ 3e-5 px rounding on a 640-px image); rows in parallel.
pub fn init_undistort_rectify_map(
    camera: &Camera,
    r: DMat3,
    new_camera_matrix: DMat3,
    width: u32,
    height: u32,
) -> Result<RemapTable> {
    let params = map_params(camera, r, new_camera_matrix, width, height)?;
    let mut map = RemapTable::empty();
    fill_map(&params, width, height, &mut map);
    Ok(map)
}

/// Writes the `width x height` map of `params` into `map`, reusing its buffers when they
/// already have that size (rows in parallel; the pages of fresh zeroed buffers are first
/// touched by the row tasks). `params` comes from [`map_params`], which did every check.
pub(crate) fn fill_map(params: &MapRow, width: u32, height: u32, map: &mut RemapTable) {
    let n = width as usize * height as usize;
    sized(&mut map.map_x, n);
    sized(&mut map.map_y, n);
    (map.width, map.height) = (width, height);
    map.map_x
        .par_chunks_mut(width as usize)
        .zip(map.map_y.par_chunks_mut(width as usize))
        .enumerate()
        .for_each(|(v, (mx, my))| params.row(v, mx, my));
}

/// Gives `v` `n` entries: a buffer of the right length is kept as it is (every entry is
/// overwritten by the caller), others are replaced by a fresh zeroed one (lazily mapped pages)
/// instead of being resized (which would write it).
fn sized<T: Copy + Default>(v: &mut Vec<T>, n: usize) {
    if v.len() != n {
        *v = vec![T::default(); n];
    }
}

/// Buffers of dropped tables ([`crate::remap::FastBilinear`]'s `Drop`), kept for the next
/// table of the same size: a rectifier built after another was dropped (a rig re-calibrated
/// in a loop, a new rectifier per session) reuses their pages instead of faulting fresh ones
/// in, which measured as more than half of [`crate::Rectifier::new`] on a 640x480 rig (2.4–2.8
/// ms against 0.85–1.2 ms for a rebuild into existing tables). At most [`SPARE_COUNT`]
/// buffers of each kind (one rectifier's two tables) and [`SPARE_BYTES`] bytes are kept; the
/// oldest go first.
pub(crate) struct Spares<T>(Mutex<Vec<Vec<T>>>);

/// Buffers kept per kind by [`Spares`].
const SPARE_COUNT: usize = 2;
/// Bytes kept per kind by [`Spares`].
const SPARE_BYTES: usize = 48 << 20;

impl<T> Spares<T> {
    const fn new() -> Self {
        Self(Mutex::new(Vec::new()))
    }

    fn list(&self) -> std::sync::MutexGuard<'_, Vec<Vec<T>>> {
        // a panic while holding the lock leaves a valid list of buffers
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Keeps `v` (unless it is empty or larger than the budget).
    pub(crate) fn give(&self, v: Vec<T>) {
        let bytes = |v: &Vec<T>| v.capacity() * size_of::<T>();
        if v.is_empty() || bytes(&v) > SPARE_BYTES {
            return;
        }
        let mut list = self.list();
        list.push(v);
        while list.len() > SPARE_COUNT || list.iter().map(bytes).sum::<usize>() > SPARE_BYTES {
            list.remove(0);
        }
    }

    /// A kept buffer of exactly `n` entries (old contents: the caller overwrites them all).
    fn take(&self, n: usize) -> Option<Vec<T>> {
        let mut list = self.list();
        let i = list.iter().rposition(|v| v.len() == n)?;
        Some(list.remove(i))
    }
}

pub(crate) static SPARE_INDEX: Spares<u32> = Spares::new();
pub(crate) static SPARE_FRAC: Spares<u16> = Spares::new();

/// [`sized`], taking a kept buffer of `n` entries from `spares` first; a buffer replaced goes
/// to `spares`.
fn sized_from<T: Copy + Default>(v: &mut Vec<T>, n: usize, spares: &Spares<T>) {
    if v.len() != n {
        let old = std::mem::replace(v, spares.take(n).unwrap_or_else(|| vec![T::default(); n]));
        spares.give(old);
    }
}

/// Gives `fast` the buffers of a `width x height` table for a `source` size (kept when they
/// have that size already, else a dropped table's buffers of that size when there are some,
/// see [`Spares`]). [`fill_fast_table`] does this itself; calling it first on the thread that
/// owns the rectifier makes fresh buffers come from that thread's malloc arena (allocated
/// inside rayon tasks they came from other threads' arenas and were returned to the OS on
/// free: measured, every build then faulted all its pages in again).
pub(crate) fn size_fast_table(width: u32, height: u32, source: (u32, u32), fast: &mut crate::remap::FastBilinear) {
    let n = width as usize * height as usize;
    sized_from(&mut fast.index, n, &SPARE_INDEX);
    sized_from(&mut fast.frac, n, &SPARE_FRAC);
    fast.border.resize_with(height as usize, Vec::new);
    (fast.width, fast.source_size) = (width, source);
}

/// The fixed-point table ([`crate::remap::FastBilinear`]) of the map of `params` for a source
/// of `source_width x source_height`, written into `fast` without storing the `f32` map: each
/// row of the map is computed into a per-task scratch row and converted while in cache, and
/// only the source positions of the border pixels (those the table cannot take) are kept. The
/// buffers are reused when they already hold `width x height` entries, so a rebuild of the
/// same size allocates nothing. This is what [`crate::Rectifier`] builds: 6 bytes per pixel
/// instead of the 14 of map + table, which measured as most of a fresh build's cost (page
/// faults). `params` comes from [`map_params`] (all checks are done there: this step cannot
/// fail, so a failed rebuild leaves the buffers untouched).
pub(crate) fn fill_fast_table(
    params: &MapRow,
    width: u32,
    height: u32,
    (sw, sh): (u32, u32),
    fast: &mut crate::remap::FastBilinear,
) {
    let w = width as usize;
    size_fast_table(width, height, (sw, sh), fast);
    // as `FastBilinear::new`: sides below 2^24 for the unsaturated conversions of the table rows
    let usable = (sw as u64) * (sh as u64) < u32::MAX as u64 && sw < 1 << 24 && sh < 1 << 24 && width > 0;
    let (last_x, last_y) = (sw as f32 - 1.0, sh as f32 - 1.0);
    fast.index
        .par_chunks_mut(w)
        .zip(fast.frac.par_chunks_mut(w))
        .zip(fast.border.par_iter_mut())
        .enumerate()
        .for_each_init(
            || (vec![0f32; w], vec![0f32; w]),
            |(mx, my), (v, ((k, f), border))| {
                params.row(v, mx, my);
                if usable {
                    crate::remap::fast_table_row(mx, my, k, f, border, sw, last_x, last_y);
                } else {
                    k.fill(u32::MAX);
                    f.fill(0);
                    border.clear();
                    border.extend(mx.iter().zip(my.iter()).map(|(&x, &y)| [x, y]));
                }
            },
        );
}

/// Checks the inputs of a map and precomputes its per-row parameters.
pub(crate) fn map_params(
    camera: &Camera,
    r: DMat3,
    new_camera_matrix: DMat3,
    width: u32,
    height: u32,
) -> Result<MapRow> {
    camera.validate().map_err(|source| RectifyError::Camera { what: "camera of the map", source })?;
    if !r.is_finite() {
        return Err(RectifyError::NonFinite("rectifying rotation"));
    }
    if !new_camera_matrix.is_finite() {
        return Err(RectifyError::NonFinite("new camera matrix"));
    }
    let m = new_camera_matrix * r;
    let det = m.determinant();
    if det.abs() < 1e-300 || !det.is_finite() {
        return Err(RectifyError::Degenerate("new camera matrix · R is singular".into()));
    }
    let ir = m.inverse();
    check_size(width, height)?;
    let k = camera.intrinsics;
    let (dist, rational, wide) = match camera.distortion() {
        Some(d) => (d.to_array(), d.is_rational(), None),
        None => ([0.0; 8], false, Some(*camera)),
    };
    let step = ir.x_axis; // d(ray)/du
    Ok(MapRow { ir, step, fx: k.fx, fy: k.fy, skew: k.skew, cx: k.cx, cy: k.cy, dist, rational, wide })
}

/// The undistort-only map of one camera (OpenCV's `initUndistortRectifyMap` with `R = I`), for
/// an output camera matrix `new_camera_matrix` (pass the camera's own `K` to keep it).
pub fn init_undistort_map(camera: &Camera, new_camera_matrix: DMat3, width: u32, height: u32) -> Result<RemapTable> {
    init_undistort_rectify_map(camera, DMat3::IDENTITY, new_camera_matrix, width, height)
}

/// The map that warps a source image by the homography `h` (output pixel `p` ← `h⁻¹ p`), e.g.
/// to apply the `H1`, `H2` of [`crate::stereo_rectify_uncalibrated`] (OpenCV's
/// `warpPerspective`).
pub fn init_homography_map(h: DMat3, width: u32, height: u32) -> Result<RemapTable> {
    if !h.is_finite() {
        return Err(RectifyError::NonFinite("homography"));
    }
    let det = h.determinant();
    if det.abs() < 1e-300 || !det.is_finite() {
        return Err(RectifyError::Degenerate("homography is singular".into()));
    }
    let ih = h.inverse();
    RemapTable::from_fn(width, height, move |u, v| {
        let q = ih * DVec3::new(u as f64, v as f64, 1.0);
        (q.z != 0.0).then(|| DVec2::new(q.x / q.z, q.y / q.z))
    })
}

/// The per-row computation of [`init_undistort_rectify_map`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MapRow {
    ir: DMat3,
    step: DVec3,
    fx: f64,
    fy: f64,
    skew: f64,
    cx: f64,
    cy: f64,
    dist: [f64; 8],
    rational: bool,
    /// A wide-angle camera: its rows go through the lens model pixel by pixel (as OpenCV's
    /// `fisheye::initUndistortRectifyMap`); `None` for Brown–Conrady (the formula below).
    wide: Option<Camera>,
}

impl MapRow {
    /// Row `v`. Written as one straight-line loop (no calls, a select for invalid pixels) so the
    /// compiler vectorises it, and run through a copy compiled for AVX2 when the CPU has it (an
    /// AVX-512 copy was removed: no machine the project is tested on can run it). Every copy
    /// runs the same operations in the same order (no fused multiply-add), so all give the same
    /// bits (`every_instruction_set_gives_the_same_row`); the formula is camera-model's
    /// `Distortion::distort`.
    fn row(&self, v: usize, mx: &mut [f32], my: &mut [f32]) {
        if let Some(camera) = &self.wide {
            let base = self.ir * DVec3::new(0.0, v as f64, 1.0);
            for (u, (ox, oy)) in mx.iter_mut().zip(my.iter_mut()).enumerate() {
                let p = camera.project(base + self.step * u as f64).ok().filter(|p| p.is_finite());
                (*ox, *oy) = p.map_or((f32::NAN, f32::NAN), |p| (p.x as f32, p.y as f32));
            }
            return;
        }
        self.row_with(Avx2::new(), v, mx, my);
    }

    /// [`Self::row`] with the copy for `isa` (`None`: the baseline; the token proves AVX2);
    /// `false` (nothing written) when this architecture has no copy for it.
    fn row_with(&self, isa: Option<Avx2>, v: usize, mx: &mut [f32], my: &mut [f32]) -> bool {
        #[inline(always)]
        fn imp(p: &MapRow, v: usize, mx: &mut [f32], my: &mut [f32]) {
            let [k1, k2, p1, p2, k3, k4, k5, k6] = p.dist;
            let base = p.ir * DVec3::new(0.0, v as f64, 1.0);
            for (u, (ox, oy)) in mx.iter_mut().zip(my.iter_mut()).enumerate() {
                // (u < MAX_SIDE < 2^31, asserted below)
                let h = base + p.step * (u as i32) as f64;
                let iw = 1.0 / h.z;
                let (x, y) = (h.x * iw, h.y * iw);
                let (x2, y2, xy) = (x * x, y * y, x * y);
                let r2 = x2 + y2;
                let mut radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                if p.rational {
                    radial /= 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
                }
                let xd = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2);
                let yd = y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy;
                let su = p.fx * xd + p.skew * yd + p.cx;
                let sv = p.fy * yd + p.cy;
                let valid = h.z > 0.0;
                *ox = if valid { su as f32 } else { f32::NAN };
                *oy = if valid { sv as f32 } else { f32::NAN };
            }
        }
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        fn avx2(p: &MapRow, v: usize, mx: &mut [f32], my: &mut [f32]) {
            imp(p, v, mx, my)
        }
        assert!(mx.len() <= MAX_SIDE as usize, "rows are checked by `check_size`");
        #[cfg(target_arch = "x86_64")]
        match isa {
            // SAFETY: the token proves AVX2.
            Some(_) => unsafe { avx2(self, v, mx, my) },
            None => imp(self, v, mx, my),
        }
        #[cfg(not(target_arch = "x86_64"))]
        match isa {
            None => imp(self, v, mx, my),
            _ => return false,
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spares keep the newest buffers within their budget and hand out only exact sizes.
    #[test]
    fn spares_keep_the_newest_buffers_of_their_budget() {
        let spares = Spares::<u32>::new();
        let (a, b, c) = (vec![1u32; 100], vec![2u32; 100], vec![3u32; 50]);
        let (pb, pc) = (b.as_ptr(), c.as_ptr());
        spares.give(a);
        spares.give(b);
        spares.give(c); // three buffers: the oldest (a) goes
        assert_eq!(spares.take(100).map(|v| v.as_ptr()), Some(pb));
        assert!(spares.take(100).is_none(), "a was dropped, b taken");
        assert!(spares.take(49).is_none() && spares.take(51).is_none(), "only exact sizes");
        assert_eq!(spares.take(50).map(|v| v.as_ptr()), Some(pc));
        spares.give(Vec::new());
        spares.give(vec![0u32; SPARE_BYTES / 4 + 1]); // over the budget alone
        assert!(spares.list().is_empty());
    }

    /// Tables built into the buffers of dropped tables (old contents of another rig) equal
    /// tables built into fresh buffers.
    #[test]
    fn a_table_in_reused_buffers_equals_a_fresh_one() {
        use parallax_camera_model::{Distortion, Intrinsics};
        let cam = |k1| {
            Camera::new(
                Intrinsics::new(536.32, 536.32, 341.84, 235.60),
                Distortion::new(k1, 0.0128, 0.00171, -0.00045, 0.1330),
                640,
                480,
            )
            .unwrap()
        };
        let k =
            DMat3::from_cols(DVec3::new(520.0, 0.0, 0.0), DVec3::new(0.0, 520.0, 0.0), DVec3::new(330.0, 245.0, 1.0));
        // a size no other test uses, so these are the buffers taken (as far as the shared
        // spares allow: the assertion holds either way)
        let (w, h) = (333, 217);
        for (k1, angle) in [(-0.27, 0.01), (-0.1, -0.2), (0.05, 0.3)] {
            let params = map_params(&cam(k1), DMat3::from_rotation_y(angle), k, w, h).unwrap();
            let mut fast = crate::remap::FastBilinear::empty();
            fill_fast_table(&params, w, h, (640, 480), &mut fast);
            let reference = init_undistort_rectify_map(&cam(k1), DMat3::from_rotation_y(angle), k, w, h).unwrap();
            assert_eq!(fast, crate::remap::FastBilinear::new(&reference, 640, 480));
        }
    }

    /// Every copy of the row formula the CPU can run gives the baseline's bits (a rational
    /// model too, and rows with pixels behind the camera).
    #[test]
    fn every_instruction_set_gives_the_same_row() {
        use parallax_camera_model::{Distortion, Intrinsics};
        let dists = [
            Distortion::new(-0.2714, 0.0128, 0.00171, -0.00045, 0.1330),
            Distortion::from_array([-0.28, 0.07, 0.001, -0.002, 0.01, 0.05, -0.01, 0.002]),
        ];
        for (i, dist) in dists.into_iter().enumerate() {
            let cam = Camera::new(Intrinsics::new(536.32, 536.32, 341.84, 235.60), dist, 640, 480).unwrap();
            // a strong rotation for the second model: part of the view is behind the camera
            let r = DMat3::from_rotation_y(if i == 0 { 0.01 } else { 1.4 }) * DMat3::from_rotation_x(-0.004);
            let k = DMat3::from_cols(
                DVec3::new(520.0, 0.0, 0.0),
                DVec3::new(0.0, 520.0, 0.0),
                DVec3::new(330.0, 245.0, 1.0),
            );
            let p = map_params(&cam, r, k, 653, 480).unwrap();
            let (mut bx, mut by) = (vec![0f32; 653], vec![0f32; 653]);
            let (mut ax, mut ay) = (vec![0f32; 653], vec![0f32; 653]);
            let mut nan = 0;
            for v in [0, 1, 240, 479] {
                // the baseline: the formula with no instruction set enabled
                p.row_with(None, v, &mut bx, &mut by);
                nan += bx.iter().filter(|x| x.is_nan()).count();
                if let Some(isa) = Avx2::new()
                    && p.row_with(Some(isa), v, &mut ax, &mut ay)
                {
                    let same = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits());
                    assert!(same(&ax, &bx) && same(&ay, &by), "{isa:?}, model {i}, row {v}");
                }
            }
            assert_eq!(nan > 0, i == 1, "the second model has pixels behind the camera");
        }
    }

    #[test]
    fn the_table_built_without_the_map_equals_the_table_of_the_map() {
        use parallax_camera_model::{Distortion, Intrinsics};
        let cam = Camera::new(
            Intrinsics::new(536.32, 536.32, 341.84, 235.60),
            Distortion::new(-0.2714, 0.0128, 0.00171, -0.00045, 0.1330),
            640,
            480,
        )
        .unwrap();
        let r = DMat3::from_rotation_y(0.01) * DMat3::from_rotation_x(-0.004);
        let k =
            DMat3::from_cols(DVec3::new(520.0, 0.0, 0.0), DVec3::new(0.0, 520.0, 0.0), DVec3::new(330.0, 245.0, 1.0));
        // the same tables reused across sizes, as a rebuild does
        let mut fast = crate::remap::FastBilinear::empty();
        for (w, h, src) in [(640, 480, (640, 480)), (700, 420, (640, 480)), (97, 61, (50, 40)), (640, 480, (640, 480))]
        {
            let params = map_params(&cam, r, k, w, h).unwrap();
            fill_fast_table(&params, w, h, src, &mut fast);
            let reference = init_undistort_rectify_map(&cam, r, k, w, h).unwrap();
            let expected = crate::remap::FastBilinear::new(&reference, src.0, src.1);
            assert_eq!(fast, expected);
            // the border lists hold exactly the map's positions of the border pixels
            let border: usize = fast.border.iter().map(Vec::len).sum();
            assert_eq!(border, fast.index.iter().filter(|&&k| k == u32::MAX).count());
            if (w, h) == (97, 61) {
                assert!(border > 0, "the small source leaves border pixels to check");
            }
        }
    }
}
