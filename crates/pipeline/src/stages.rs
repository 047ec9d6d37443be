//! One function per stage: plain inputs in, typed results out. The chain ([`crate::run_chain`]),
//! the CLI commands and users' own programs all call these.

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, CameraModel, Chessboard, CornerGrid, DisparityMap, Isometry3, StereoRig};
use parallax_hand_eye::{HandEyeConfig, HandEyeSolution, Method, Setup};
use parallax_planar_calibration::{CalibrationConfig, CalibrationResult, StereoCalibrationResult, StereoConfig};
use parallax_stereo_rectify::{Rectification, RectifyConfig};
use parallax_triangulation::{CornerDistance, Measurement, PointCloud, TriangulationConfig};
use rayon::prelude::*;

use crate::{PipelineError, Result};

/// Detects `board` in every image (in parallel); `None` where the board is not found.
pub fn detect_boards(
    images: &[image::GrayImage],
    board: &Chessboard,
    config: &parallax_corner_detection::ChessboardConfig,
) -> Result<Vec<Option<CornerGrid>>> {
    images
        .par_iter()
        .map(|img| Ok(parallax_corner_detection::find_chessboard(img, board.cols, board.rows, config)?))
        .collect()
}

/// The views of a stereo session with the board found in both images: their indices and the
/// left and right grids, in order.
#[derive(Debug, Clone, Default)]
pub struct StereoViews {
    /// Index of each kept view in the session.
    pub index: Vec<usize>,
    /// Left grids of the kept views.
    pub left: Vec<CornerGrid>,
    /// Right grids of the kept views.
    pub right: Vec<CornerGrid>,
}

impl StereoViews {
    /// Keeps the views whose board was found in both images.
    pub fn from_detections(detections: &[[Option<CornerGrid>; 2]]) -> Self {
        let mut out = Self::default();
        for (i, [l, r]) in detections.iter().enumerate() {
            if let (Some(l), Some(r)) = (l, r) {
                out.index.push(i);
                out.left.push(l.clone());
                out.right.push(r.clone());
            }
        }
        out
    }

    /// Number of kept views.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// True when no view has the board in both images.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }
}

/// Mono calibration from the grids of one camera (images of `size`).
pub fn calibrate_mono(
    board: &Chessboard,
    grids: &[CornerGrid],
    size: (u32, u32),
    config: &CalibrationConfig,
) -> Result<CalibrationResult> {
    Ok(parallax_planar_calibration::calibrate_chessboard(board, grids, size.0, size.1, config)?)
}

/// Plausibility limits of a stereo calibration: what a correct session never gives and the
/// common mistakes always do. A result outside them is refused with a hint, before anything is
/// written.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct StereoChecks {
    /// Largest stereo RMS reprojection error, pixels. Detected corners are good to a few tenths
    /// of a pixel; pairs in the wrong order give tens of pixels.
    pub max_rms_px: f64,
    /// Accept a rig whose right camera sits to the left of the left camera (the images are
    /// swapped, unless the cameras were named that way on purpose).
    pub allow_swapped: bool,
}

impl Default for StereoChecks {
    fn default() -> Self {
        Self { max_rms_px: 2.0, allow_swapped: false }
    }
}

/// Refuses a stereo calibration that fails [`StereoChecks`], naming the likely mistake.
pub fn check_stereo(result: &StereoCalibrationResult, checks: &StereoChecks) -> Result<()> {
    if result.rms_px.is_nan() || result.rms_px > checks.max_rms_px {
        return Err(PipelineError::Input(format!(
            "stereo RMS reprojection error {:.2} px is far above the corner noise (limit {} px): are the left and \
             right images paired in the same order, and is the board size right?",
            result.rms_px, checks.max_rms_px
        )));
    }
    let t = result.rig.right_from_left.translation;
    // OpenCV's convention: the right camera is at +x of the left one, so `right_from_left`
    // translates by −baseline along x. A horizontal rig with t.x > 0 has its images swapped.
    if !checks.allow_swapped && t.x > 0.0 && t.x.abs() > t.y.abs().max(t.z.abs()) {
        return Err(PipelineError::Input(format!(
            "the right camera is to the left of the left camera (right_from_left t = [{:.3}, {:.3}, {:.3}], t.x should \
             be negative): the left and right images are probably swapped; swap them (or allow a swapped rig on \
             purpose: `allow_swapped`, `--allow-swapped` in the CLI)",
            t.x, t.y, t.z
        )));
    }
    Ok(())
}

/// Stereo calibration from the views with the board in both images, refused when it fails
/// the plausibility `checks` ([`check_stereo`]).
pub fn calibrate_stereo(
    board: &Chessboard,
    views: &StereoViews,
    left_size: (u32, u32),
    right_size: (u32, u32),
    config: &StereoConfig,
    checks: &StereoChecks,
) -> Result<StereoCalibrationResult> {
    let result = parallax_planar_calibration::calibrate_stereo_chessboard(
        board,
        &views.left,
        &views.right,
        left_size,
        right_size,
        config,
    )?;
    check_stereo(&result, checks)?;
    Ok(result)
}

/// A rectified rig and how well the detected corners line up after rectification.
///
/// For a rig with a wide lens (Kannala–Brandt, double sphere) it also holds the rectified pair
/// as a distortion-free pinhole rig ([`rectified_pinhole_rig`]): triangulation, measurement and
/// the board poses of such a rig work on corners moved onto the rectified pair
/// ([`adjacent_distances`], [`measure`], [`board_poses`]), and their points are turned back into
/// the left camera frame by `R1ᵀ`.
#[derive(Debug, Clone)]
pub struct RectifiedRig {
    /// `R1, R2, P1, P2, Q` and the valid regions.
    pub rectification: Rectification,
    /// `|v_left − v_right|` of every corner of the stereo views after rectification, pixels.
    pub abs_dv: Vec<f64>,
    /// The rectified pair as a pinhole rig, for a rig with a wide lens (`None` otherwise).
    pub pinhole: Option<StereoRig>,
}

impl RectifiedRig {
    /// Mean `|Δv|` of the corners (NaN without corners).
    pub fn mean_abs_dv(&self) -> f64 {
        crate::stats::mean(&self.abs_dv)
    }

    /// Pixels of the left camera in the rectified left image.
    pub fn rectify_left<C: CameraModel>(&self, camera: &C, pixels: &[DVec2]) -> Result<Vec<DVec2>> {
        let r = &self.rectification;
        Ok(parallax_stereo_rectify::rectify_points(camera, r.r1, &r.p1, pixels)?)
    }

    /// Pixels of the right camera in the rectified right image.
    pub fn rectify_right<C: CameraModel>(&self, camera: &C, pixels: &[DVec2]) -> Result<Vec<DVec2>> {
        let r = &self.rectification;
        Ok(parallax_stereo_rectify::rectify_points(camera, r.r2, &r.p2, pixels)?)
    }

    /// `left camera_from_rectified left`: the rotation `R1ᵀ`.
    pub fn left_from_rectified(&self) -> Result<Isometry3> {
        Ok(Isometry3::from_rotation_translation(self.rectification.r1.transpose(), DVec3::ZERO)?)
    }
}

/// `|v_left − v_right|` of every corner of matched left/right grids after rectification
/// (point-level: undistort, rotate, project; no image resampling), in pixels.
pub fn rectified_abs_dv(
    rig: &StereoRig,
    rect: &Rectification,
    left: &[CornerGrid],
    right: &[CornerGrid],
) -> Result<Vec<f64>> {
    let mut dv = Vec::new();
    for (l, r) in left.iter().zip(right) {
        let lp = parallax_stereo_rectify::rectify_points(&rig.left, rect.r1, &rect.p1, &l.corners)?;
        let rp = parallax_stereo_rectify::rectify_points(&rig.right, rect.r2, &rect.p2, &r.corners)?;
        dv.extend(lp.iter().zip(&rp).map(|(a, b)| (a.y - b.y).abs()));
    }
    Ok(dv)
}

/// Smallest share of each rectified image that must be valid (inside the source image): below
/// it the maps have collapsed (an absurd distortion, or a calibration from mismatched pairs).
pub const MIN_VALID_RECTIFIED_FRACTION: f64 = 0.05;

/// Refuses a rectification whose valid region is empty or under
/// [`MIN_VALID_RECTIFIED_FRACTION`] of either image (the images would be mostly black), naming the
/// region and its share.
pub fn refuse_collapsed(rectification: &Rectification) -> Result<()> {
    let area = f64::from(rectification.width) * f64::from(rectification.height);
    for (side, roi) in [("left", rectification.roi1), ("right", rectification.roi2)] {
        let valid = f64::from(roi.width) * f64::from(roi.height);
        if valid < MIN_VALID_RECTIFIED_FRACTION * area {
            return Err(PipelineError::Input(format!(
                "the rectified {side} image has a valid region of {}x{} px ({:.1} % of the image): the calibration \
                 is implausible (check the distortion coefficients and that the calibration pairs were in order)",
                roi.width,
                roi.height,
                100.0 * valid / area.max(1.0)
            )));
        }
    }
    Ok(())
}

/// Rectifies the rig (Bouguet; OpenCV's `fisheye::stereoRectify` rule to a pinhole pair for a
/// wide lens) and measures the corners' `|Δv|` after rectification. Refuses a collapsed
/// rectification ([`refuse_collapsed`]).
pub fn rectify(rig: &StereoRig, views: &StereoViews, config: &RectifyConfig) -> Result<RectifiedRig> {
    let rectification = parallax_stereo_rectify::stereo_rectify(rig, config)?;
    refuse_collapsed(&rectification)?;
    let abs_dv = rectified_abs_dv(rig, &rectification, &views.left, &views.right)?;
    let wide = rig.has_wide_lens();
    let pinhole = wide.then(|| rectified_pinhole_rig(&rectification)).transpose()?;
    Ok(RectifiedRig { rectification, abs_dv, pinhole })
}

/// Resamples a stereo pair into the rectified geometry (bilinear, black outside the image).
pub fn rectify_images(
    rig: &StereoRig,
    rectification: &Rectification,
    left: &image::GrayImage,
    right: &image::GrayImage,
) -> Result<(image::GrayImage, image::GrayImage)> {
    let rectifier = parallax_stereo_rectify::Rectifier::from_rectification(rig, *rectification)?;
    Ok(rectifier.rectify_pair(left, right, parallax_stereo_rectify::Border::Constant(image::Luma([0u8])))?)
}

/// Dense disparity of a rectified pair.
pub fn match_pair(
    left: &image::GrayImage,
    right: &image::GrayImage,
    config: &parallax_block_matching::MatcherConfig,
) -> Result<DisparityMap> {
    let mut matcher = parallax_block_matching::BlockMatcher::new(config.clone())?;
    Ok(matcher.compute(left, right)?)
}

/// The point cloud of a disparity map through a rectification's `Q` (grey colours from the
/// rectified left image when given).
pub fn point_cloud(disparity: &DisparityMap, q: [[f64; 4]; 4], left: Option<&image::GrayImage>) -> Result<PointCloud> {
    let q = parallax_triangulation::ReprojectionMatrix::new(q)?;
    Ok(parallax_triangulation::disparity_to_point_cloud(
        disparity,
        &q,
        &parallax_triangulation::CloudConfig::default(),
        left.map(|l| parallax_triangulation::PixelColors::Grey(l.as_raw())),
    )?)
}

/// Distances between horizontally and vertically adjacent corners of every stereo view,
/// triangulated with the rig (their true value is the square size); with a wide-lens rig's
/// rectification on its rectified pinhole pair (distances do not depend on the frame).
pub fn adjacent_distances(
    rig: &StereoRig,
    rect: Option<&RectifiedRig>,
    views: &StereoViews,
    config: &TriangulationConfig,
) -> Result<Vec<CornerDistance>> {
    let mut out = Vec::new();
    for (l, r) in views.left.iter().zip(&views.right) {
        out.extend(match rect.and_then(|r| Some((r, r.pinhole.as_ref()?))) {
            None => parallax_triangulation::adjacent_corner_distances(rig, l, r, config)?,
            Some((rect, pinhole)) => {
                let (lr, rr) = rectified_grids(rig, rect, l, r)?;
                parallax_triangulation::adjacent_corner_distances(pinhole, &lr, &rr, config)?
            }
        });
    }
    Ok(out)
}

/// Triangulates matched pixel pairs and measures every distance between them, with σ. With a
/// wide-lens rig's rectification the pairs are triangulated on its rectified pinhole pair and
/// the points returned in the left camera frame (`R1ᵀ ·` rectified); a point's per-axis σ
/// belongs to the rectified frame and is dropped (`None`) after the rotation; the distances and
/// their σ do not depend on the frame.
pub fn measure(
    rig: &StereoRig,
    rect: Option<&RectifiedRig>,
    pairs: &[(DVec2, DVec2)],
    config: &TriangulationConfig,
) -> Result<Measurement> {
    let Some((rect, pinhole)) = rect.and_then(|r| Some((r, r.pinhole.as_ref()?))) else {
        return Ok(parallax_triangulation::measure_stereo(rig, pairs, config)?);
    };
    let (l, r): (Vec<DVec2>, Vec<DVec2>) = pairs.iter().copied().unzip();
    let (lr, rr) = (rect.rectify_left(&rig.left, &l)?, rect.rectify_right(&rig.right, &r)?);
    let rect_pairs: Vec<(DVec2, DVec2)> = lr.into_iter().zip(rr).collect();
    let mut m = parallax_triangulation::measure_stereo(pinhole, &rect_pairs, config)?;
    let left_from_rect = rect.left_from_rectified()?;
    for (p, (a, b)) in m.points.iter_mut().zip(pairs) {
        p.point = left_from_rect.transform_point(p.point);
        p.std_dev = None;
        (p.left, p.right) = (*a, *b);
    }
    Ok(m)
}

/// `camera_from_board` of every found grid by planar PnP with a calibrated camera (`None`
/// where the board was not found). With a wide-lens rig's rectification (`camera` its left
/// camera) the PnP runs on the corners moved onto the rectified left view, and the pose is
/// rotated back by `R1ᵀ`.
pub fn board_poses(
    camera: &Camera,
    rect: Option<&RectifiedRig>,
    board: &Chessboard,
    grids: &[Option<CornerGrid>],
) -> Result<Vec<Option<Isometry3>>> {
    let wide = rect.and_then(|r| Some((r, r.pinhole.as_ref()?)));
    grids
        .iter()
        .map(|g| {
            let Some(g) = g else { return Ok(None) };
            Ok(Some(match wide {
                None => parallax_planar_calibration::solve_pnp_planar(camera, board, &g.corners)?.0,
                Some((rect, pinhole)) => {
                    let corners = rect.rectify_left(camera, &g.corners)?;
                    let (rect_from_board, _) =
                        parallax_planar_calibration::solve_pnp_planar(&pinhole.left, board, &corners)?;
                    rect.left_from_rectified()? * rect_from_board
                }
            }))
        })
        .collect()
}

/// Hand-eye calibration (`AX = XB`) of paired robot and camera poses.
pub fn hand_eye(
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    method: Method,
    config: &HandEyeConfig,
) -> Result<HandEyeSolution> {
    if base_from_gripper.len() != camera_from_board.len() {
        return Err(PipelineError::Input(format!(
            "hand-eye: {} robot poses for {} camera poses",
            base_from_gripper.len(),
            camera_from_board.len()
        )));
    }
    Ok(parallax_hand_eye::calibrate(base_from_gripper, camera_from_board, method, config)?)
}

/// Points measured in the camera frame, expressed in the robot base frame: through the
/// gripper pose for eye-in-hand (`x` = `gripper_from_camera`), directly for eye-to-hand
/// (`x` = `base_from_camera`).
pub fn to_robot_frame(setup: Setup, x: &Isometry3, base_from_gripper: &Isometry3, points: &[DVec3]) -> Vec<DVec3> {
    match setup {
        Setup::EyeInHand => parallax_hand_eye::points_to_base(base_from_gripper, x, points),
        Setup::EyeToHand => points.iter().map(|p| x.transform_point(*p)).collect(),
    }
}

/// Blob targets of both images matched by epipolar distance (undistorted pixels, rig's `F`):
/// every left blob must have exactly one right blob within `max_epipolar_px` of its epipolar
/// line on the positive-disparity side, and the match must be mutual; anything else is an
/// error that asks for the points to be given.
pub fn match_blobs(
    rig: &StereoRig,
    left: &image::GrayImage,
    right: &image::GrayImage,
    bright: bool,
    max_epipolar_px: f64,
) -> Result<Vec<(DVec2, DVec2)>> {
    use parallax_corner_detection::{BlobConfig, BlobPolarity, detect_blobs};
    use parallax_triangulation::Method;
    let refuse = |m: String| Err(PipelineError::Input(m));
    let cfg = BlobConfig {
        polarity: if bright { BlobPolarity::Bright } else { BlobPolarity::Dark },
        ..BlobConfig::default()
    };
    let bl = detect_blobs(left, &cfg)?.blobs;
    let br = detect_blobs(right, &cfg)?.blobs;
    if bl.is_empty() {
        return refuse("no blob target found in the left image".into());
    }
    if bl.len() != br.len() {
        return refuse(format!(
            "{} blobs in the left image but {} in the right one: give the points",
            bl.len(),
            br.len()
        ));
    }
    let ul: Vec<DVec2> = bl.iter().map(|b| rig.left.undistort_pixel(b.centroid)).collect::<Result<_, _>>()?;
    let ur: Vec<DVec2> = br.iter().map(|b| rig.right.undistort_pixel(b.centroid)).collect::<Result<_, _>>()?;
    let f = rig.fundamental();
    let views = parallax_triangulation::stereo_views(rig);
    let cfg = TriangulationConfig { method: Method::Midpoint, covariance: false, ..Default::default() };
    // candidates[i] = right blobs compatible with left blob i.
    let candidates: Vec<Vec<usize>> = ul
        .iter()
        .zip(&bl)
        .map(|(l, lb)| {
            let line = f * l.extend(1.0);
            let norm = line.truncate().length();
            (0..ur.len())
                .filter(|&j| {
                    let d = line.dot(ur[j].extend(1.0)).abs() / norm;
                    d <= max_epipolar_px
                        && parallax_triangulation::triangulate(&views, &[lb.centroid, br[j].centroid], &cfg)
                            .is_ok_and(|p| !p.behind_camera)
                })
                .collect()
        })
        .collect();
    let mut pairs = Vec::with_capacity(bl.len());
    for (i, c) in candidates.iter().enumerate() {
        let (l, r) = (bl[i].centroid, c.first().map(|&j| br[j].centroid).unwrap_or_default());
        if c.len() != 1 {
            return refuse(format!(
                "left blob {i} at ({:.1}, {:.1}) has {} right candidates within {max_epipolar_px} px of its epipolar line: \
                 give the points",
                l.x,
                l.y,
                c.len()
            ));
        }
        let others = candidates.iter().filter(|o| o.contains(&c[0])).count();
        if others != 1 {
            return refuse(format!(
                "right blob at ({:.1}, {:.1}) matches {others} left blobs: give the points",
                r.x, r.y
            ));
        }
        pairs.push((l, r));
    }
    Ok(pairs)
}

/// Finds any kind of target in one image: a whole chessboard or circle grid, the visible part of
/// a ChArUco board or an AprilGrid, or a single marker. `None` where nothing of it is found.
pub fn detect_target(
    img: &image::GrayImage,
    target: &parallax_camera_model::TargetDescription,
) -> Result<Option<parallax_camera_model::TargetObservation>> {
    Ok(search_target(img, target)?.observation)
}

/// What [`search_target`] saw in one image.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetSearch {
    /// The target's points (at least 4), or `None`.
    pub observation: Option<parallax_camera_model::TargetObservation>,
    /// Marker targets (ChArUco, AprilGrid, single marker): the markers decoded and confirmed.
    pub markers: Option<usize>,
    /// When nothing was found: what was seen and why it was not enough, as a hint.
    pub why: Option<String>,
    /// The image corners of the markers decoded (marker targets), found or not.
    pub outlines: Vec<[glam::DVec2; 4]>,
}

/// [`detect_target`] with what the detector saw: the markers decoded and, when the target is not
/// found, why (`TargetSearch::why`). A chessboard's reason needs its candidates, which
/// `session::search_corners` adds; here a chessboard not found gets a generic reason.
pub fn search_target(
    img: &image::GrayImage,
    target: &parallax_camera_model::TargetDescription,
) -> Result<TargetSearch> {
    use parallax_camera_model::{TargetDescription as T, TargetObservation};
    use parallax_corner_detection as cd;
    // too few points to use (a pose or a calibration needs 4), with the markers that were decoded
    // (`kind` ids, ascending)
    let few_from = |n: usize, kind: &str, decoded: &mut dyn Iterator<Item = u32>| {
        let mut v: Vec<u32> = decoded.collect();
        v.sort_unstable();
        let ids = v.iter().map(u32::to_string).collect::<Vec<_>>().join(", ");
        format!(
            "{n} corners found from the {kind} decoded ({ids}), 4 are needed: is most of the target hidden, out of \
             focus or too small?"
        )
    };
    let mut outlines = Vec::new();
    let (observation, markers, why) = match target {
        T::Chessboard(b) => {
            let grid = cd::find_chessboard(img, b.cols, b.rows, &Default::default())?;
            let why = grid.is_none().then(|| format!("no {}x{} grid of inner corners found", b.cols, b.rows));
            let obs = grid
                .map(|g| TargetObservation::whole(g.corners))
                .transpose()
                .map_err(|e| PipelineError::Input(e.to_string()))?;
            (obs, None, why)
        }
        T::Charuco(b) => {
            let d = cd::detect_charuco(img, b, &Default::default())?;
            outlines = d.markers.iter().map(|m| m.corners).collect();
            let n = d.observation.ids().len();
            let why = if !d.misplaced.is_empty() {
                Some(format!(
                    "markers {:?} sit where the board as described has other markers or none: check the layout \
                     (`:legacy` for boards made before OpenCV 4.6), the square counts and the dictionary",
                    d.misplaced
                ))
            } else if d.markers.is_empty() {
                Some(format!(
                    "no marker of {} decoded: check the dictionary; the board must be in focus",
                    b.dictionary().name()
                ))
            } else {
                (n < 4).then(|| few_from(n, "markers", &mut d.markers.iter().map(|m| m.id)))
            };
            (Some(d.observation), Some(d.markers.len()), why)
        }
        T::CircleGrid(g) => {
            let d = cd::detect_circle_grid(img, g, &Default::default())?;
            let why = d.is_none().then(|| {
                format!(
                    "no {target} recognised: check the size (circles per row and column) and symmetric or asymmetric"
                )
            });
            (d.map(|d| d.observation), None, why)
        }
        T::AprilGrid(g) => {
            let d = cd::detect_aprilgrid(img, g, &Default::default())?;
            outlines = d.tags.iter().map(|m| m.corners).collect();
            let n = d.observation.ids().len();
            let why = if d.tags.is_empty() {
                Some(
                    "no tag36h11 tag of the grid decoded: the grid must be in focus with its border visible"
                        .to_string(),
                )
            } else {
                (n < 4).then(|| few_from(n, "tags", &mut d.tags.iter().map(|m| m.id)))
            };
            (Some(d.observation), Some(d.tags.len()), why)
        }
        T::Marker(m) => {
            let o = cd::detect_single_marker(img, m, &Default::default())?;
            let why = o.is_none().then(|| format!("{target} not decoded: check its id and dictionary"));
            let markers = usize::from(o.is_some());
            (o, Some(markers), why)
        }
    };
    let observation = observation.filter(|o| o.ids().len() >= 4);
    // (every arm gives its reason when it finds fewer than 4 points)
    let why = if observation.is_some() { None } else { why };
    Ok(TargetSearch { observation, markers, why, outlines })
}

/// `camera_from_target` of one observation by planar PnP with a calibrated camera, and the RMS
/// reprojection error in pixels.
pub fn target_pose(
    camera: &Camera,
    target: &parallax_camera_model::TargetDescription,
    observation: &parallax_camera_model::TargetObservation,
) -> Result<(Isometry3, f64)> {
    let object = parallax_planar_calibration::object_points_for(target, observation, 0)?;
    Ok(parallax_planar_calibration::solve_pnp_planar_points(camera, &object, observation.points())?)
}

/// The pinhole rig of a rectified pair: `K` = the left block of `P1` and `P2`, no distortion,
/// `right_from_left` = the baseline `(Tx, 0, 0)`, `Tx = P2[0][3] / P2[0][0]`; its frame is the
/// rectified left frame, `R1 · left camera frame`.
pub fn rectified_pinhole_rig(rect: &Rectification) -> Result<StereoRig> {
    let camera = |p: &parallax_camera_model::ProjectionMatrix| -> Result<Camera> {
        Ok(Camera::new(
            parallax_camera_model::Intrinsics::from_matrix(p.left_block())?,
            parallax_camera_model::Distortion::default(),
            rect.width,
            rect.height,
        )?)
    };
    if rect.vertical {
        return Err(PipelineError::Input("a vertical rectification has no horizontal pinhole rig".into()));
    }
    let tx = rect.p2.rows[0][3] / rect.p2.rows[0][0];
    let right_from_left = Isometry3::from_rotation_translation(glam::DMat3::IDENTITY, DVec3::new(tx, 0.0, 0.0))?;
    Ok(StereoRig::new(camera(&rect.p1)?, camera(&rect.p2)?, right_from_left)?)
}

/// Grids of both cameras moved onto the rectified pair (same corner order).
pub fn rectified_grids(
    rig: &StereoRig,
    rect: &RectifiedRig,
    left: &CornerGrid,
    right: &CornerGrid,
) -> Result<(CornerGrid, CornerGrid)> {
    Ok((
        CornerGrid::new(left.cols, left.rows, rect.rectify_left(&rig.left, &left.corners)?)?,
        CornerGrid::new(right.cols, right.rows, rect.rectify_right(&rig.right, &right.corners)?)?,
    ))
}
