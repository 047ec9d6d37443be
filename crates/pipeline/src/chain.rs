//! The whole chain, once: detect → calibrate → rectify → match → triangulate → hand-eye →
//! measure → robot frame. The synthetic run (`crate::scene`) and the real run (`crate::real`)
//! both build a [`ChainInput`] and call [`run_chain`]; truth scoring and self-consistency checks
//! are layers on top of the [`ChainOutput`].
//!
//! The lens of each camera is [`ChainInput::stereo`]'s (`left.lens`, `right.lens`). A rig with
//! a wide lens is rectified to a pinhole pair (`cv::fisheye::stereoRectify`), and triangulation,
//! measurement and the board poses of hand-eye work on corners moved onto the rectified pair
//! ([`RectifiedRig::pinhole`]).
//!
//! A stage that fails does not stop the chain: its output is a [`StageFailure`] and every stage
//! that does not depend on it still runs.

use std::fmt;

use glam::{DVec2, DVec3};
use parallax_camera_model::{Chessboard, CornerGrid, DisparityMap, Isometry3};
use parallax_hand_eye::{HandEyeConfig, HandEyeSolution, Method, Setup};
use parallax_planar_calibration::{StereoCalibrationResult, StereoConfig};
use parallax_stereo_rectify::RectifyConfig;
use parallax_triangulation::{CornerDistance, Measurement, PointCloud, TriangulationConfig};

use crate::stages::{self, RectifiedRig, StereoViews};

/// Why a stage has no result.
#[derive(Debug, Clone, PartialEq)]
pub enum StageFailure {
    /// The stage ran and failed (the message says why).
    Failed(String),
    /// The stage could not run because a stage it needs failed.
    Skipped {
        /// The stage it needs.
        needs: &'static str,
    },
    /// The inputs did not ask for this stage (e.g. no robot poses: no hand-eye).
    NotRequested,
}

impl fmt::Display for StageFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Failed(m) => write!(f, "failed: {m}"),
            Self::Skipped { needs } => write!(f, "not run: needs {needs}, which failed"),
            Self::NotRequested => write!(f, "not requested"),
        }
    }
}

/// A stage's result, or why there is none.
pub type StageResult<T> = std::result::Result<T, StageFailure>;

fn failed<T>(e: impl fmt::Display) -> StageResult<T> {
    Err(StageFailure::Failed(e.to_string()))
}

fn need<'a, T>(r: &'a StageResult<T>, stage: &'static str) -> StageResult<&'a T> {
    r.as_ref().map_err(|e| match e {
        StageFailure::NotRequested => StageFailure::NotRequested,
        _ => StageFailure::Skipped { needs: stage },
    })
}

/// The pair that is block-matched.
#[derive(Debug, Clone)]
pub enum MatchPair {
    /// Already rectified (e.g. a rendered scene or a Middlebury pair): matched as given.
    Rectified(image::GrayImage, image::GrayImage),
    /// Raw images of the calibrated rig: rectified with the calibration first.
    Raw(image::GrayImage, image::GrayImage),
}

/// One robot station: the robot pose (when known) and the images of the board.
#[derive(Debug, Clone)]
pub struct Station {
    /// `base_from_gripper` at this station, when robot poses are given.
    pub robot: Option<Isometry3>,
    /// Left camera image (the hand-eye camera).
    pub left: image::GrayImage,
    /// Right camera image, when the station is also a stereo measurement.
    pub right: Option<image::GrayImage>,
}

/// Everything the chain needs.
#[derive(Debug, Clone)]
pub struct ChainInput {
    /// The calibration board (its square size is the length unit of every result).
    pub board: Chessboard,
    /// The stereo calibration session: left and right image per view.
    pub calibration: Vec<[image::GrayImage; 2]>,
    /// The pair to block-match; `None`: the first calibration view with the board in both
    /// images, rectified.
    pub match_pair: Option<MatchPair>,
    /// Robot stations for hand-eye and the measurement of the board corners.
    pub stations: Vec<Station>,
    /// Eye-in-hand or eye-to-hand.
    pub setup: Setup,
    /// Chessboard detector settings.
    pub detector: parallax_corner_detection::ChessboardConfig,
    /// Stereo calibration settings (the lens of each camera in `left.lens`, `right.lens`).
    pub stereo: StereoConfig,
    /// Plausibility limits of the stereo calibration.
    pub stereo_checks: stages::StereoChecks,
    /// Rectification settings (`alpha` for Brown–Conrady rigs, `balance` and `fov_scale` for
    /// rigs with a wide lens).
    pub rectify: RectifyConfig,
    /// Block-matching settings.
    pub matcher: parallax_block_matching::MatcherConfig,
    /// Hand-eye settings (the refined method is used).
    pub hand_eye: HandEyeConfig,
}

impl ChainInput {
    /// Inputs with default settings for every stage.
    pub fn new(board: Chessboard, calibration: Vec<[image::GrayImage; 2]>) -> Self {
        Self {
            board,
            calibration,
            match_pair: None,
            stations: Vec::new(),
            setup: Setup::EyeInHand,
            detector: Default::default(),
            stereo: Default::default(),
            stereo_checks: Default::default(),
            rectify: Default::default(),
            matcher: Default::default(),
            hand_eye: Default::default(),
        }
    }
}

/// The block-matching result.
#[derive(Debug, Clone)]
pub struct MatchedPair {
    /// The disparity map.
    pub disparity: DisparityMap,
    /// The rectified left and right images that were matched.
    pub left: image::GrayImage,
    /// See `left`.
    pub right: image::GrayImage,
    /// True when the chain rectified the pair itself ([`MatchPair::Raw`] or the default pair).
    pub rectified_here: bool,
    /// Time of the matching alone, seconds.
    pub seconds: f64,
}

/// Hand-eye inputs and result.
#[derive(Debug, Clone)]
pub struct HandEyeRun {
    /// Indices of the stations used (left board found and a robot pose).
    pub stations: Vec<usize>,
    /// The solution (refined method).
    pub solution: HandEyeSolution,
}

/// The board-corner measurement at one station.
#[derive(Debug, Clone)]
pub struct StationMeasurement {
    /// Index of the station (the first whose board both cameras saw).
    pub station: usize,
    /// The measured board corners, `(col, row)`.
    pub targets: Vec<(usize, usize)>,
    /// Triangulated points (camera frame), distances and σ.
    pub measurement: Measurement,
}

/// Everything the chain produced, stage by stage.
#[derive(Debug, Clone)]
pub struct ChainOutput {
    /// Board detections of the calibration session, `[left, right]` per view.
    pub detections: Vec<[Option<CornerGrid>; 2]>,
    /// The views with the board in both images.
    pub views: StereoViews,
    /// Stereo calibration.
    pub calibration: StageResult<StereoCalibrationResult>,
    /// Rectification and corner `|Δv|` (with the rectified pinhole rig for a wide lens).
    pub rectified: StageResult<RectifiedRig>,
    /// The first kept calibration view, rectified (for reports).
    pub rectified_view: StageResult<(image::GrayImage, image::GrayImage)>,
    /// Block matching.
    pub matched: StageResult<MatchedPair>,
    /// Point cloud of the disparity map.
    pub cloud: StageResult<PointCloud>,
    /// Distances between adjacent corners of every stereo view.
    pub adjacent: StageResult<Vec<CornerDistance>>,
    /// Board detections at the stations, `[left, right]`.
    pub station_detections: Vec<[Option<CornerGrid>; 2]>,
    /// `camera_from_board` at each station by PnP with the calibrated left camera.
    pub station_poses: StageResult<Vec<Option<Isometry3>>>,
    /// Hand-eye.
    pub hand_eye: StageResult<HandEyeRun>,
    /// The board corners measured at a station.
    pub measurement: StageResult<StationMeasurement>,
    /// The measured board corners in the robot base frame.
    pub robot_frame: StageResult<Vec<DVec3>>,
}

/// The four outer corners of the board, the points the chain measures.
pub fn measurement_targets(board: &Chessboard) -> Vec<(usize, usize)> {
    vec![(0, 0), (board.cols - 1, 0), (board.cols - 1, board.rows - 1), (0, board.rows - 1)]
}

fn progress(step: usize, what: &str) {
    eprintln!("[{step}/8] {what}…");
}

fn detect_pairs<'a>(
    pairs: impl Iterator<Item = (&'a image::GrayImage, Option<&'a image::GrayImage>)>,
    input: &ChainInput,
) -> crate::Result<Vec<[Option<CornerGrid>; 2]>> {
    use rayon::prelude::*;
    let pairs: Vec<_> = pairs.collect();
    let find = |img: &image::GrayImage| {
        parallax_corner_detection::find_chessboard(img, input.board.cols, input.board.rows, &input.detector)
    };
    // The images are borrowed, never copied: each pair is detected where it lies.
    pairs.par_iter().map(|(l, r)| Ok([find(l)?, r.map(find).transpose()?.flatten()])).collect()
}

/// Runs every stage. Only a detector error (an unusable image) is returned as an error; every
/// later failure is recorded in the output and the stages that do not depend on it still run.
pub fn run_chain(input: &ChainInput) -> crate::Result<ChainOutput> {
    let board = &input.board;
    progress(1, "detecting the calibration board");
    let detections = detect_pairs(input.calibration.iter().map(|[l, r]| (l, Some(r))), input)?;
    let views = StereoViews::from_detections(&detections);

    progress(2, "calibrating both cameras and the rig");
    let calibration = match input.calibration.first().map(|[l, r]| (l.dimensions(), r.dimensions())) {
        None => failed("no calibration images"),
        Some((ls, rs)) => {
            stages::calibrate_stereo(board, &views, ls, rs, &input.stereo, &input.stereo_checks).or_else(failed)
        }
    };
    let calib = need(&calibration, "calibration");

    progress(3, "rectifying");
    let rectified = calib.clone().and_then(|c| stages::rectify(&c.rig, &views, &input.rectify).or_else(failed));
    let rectify_pair = |l: &image::GrayImage, r: &image::GrayImage| {
        let c = calib.clone()?;
        let rect = need(&rectified, "rectification")?;
        stages::rectify_images(&c.rig, &rect.rectification, l, r).or_else(failed)
    };
    let rectified_view = need(&rectified, "rectification").and_then(|_| {
        let i = *views.index.first().ok_or(StageFailure::Skipped { needs: "corners" })?;
        let [l, rr] = &input.calibration[i];
        rectify_pair(l, rr)
    });

    progress(4, "block matching");
    let to_match: StageResult<(image::GrayImage, image::GrayImage, bool)> = match &input.match_pair {
        Some(MatchPair::Rectified(l, r)) => Ok((l.clone(), r.clone(), false)),
        Some(MatchPair::Raw(l, r)) => rectify_pair(l, r).map(|(l, r)| (l, r, true)),
        None => need(&rectified_view, "rectification").map(|(l, r)| (l.clone(), r.clone(), true)),
    };
    let matched = to_match.and_then(|(left, right, rectified_here)| {
        let t = std::time::Instant::now();
        let disparity = stages::match_pair(&left, &right, &input.matcher).or_else(failed)?;
        Ok(MatchedPair { disparity, left, right, rectified_here, seconds: t.elapsed().as_secs_f64() })
    });

    progress(5, "triangulating");
    let cloud = need(&matched, "disparity").and_then(|m| {
        let rect = need(&rectified, "rectification")?;
        stages::point_cloud(&m.disparity, rect.rectification.q, Some(&m.left)).or_else(failed)
    });
    let adjacent = calib.clone().and_then(|c| {
        let cfg = TriangulationConfig { pixel_sigma: c.sigma_px, ..Default::default() };
        let rect = if c.rig.has_wide_lens() { Some(need(&rectified, "rectification")?) } else { None };
        stages::adjacent_distances(&c.rig, rect, &views, &cfg).or_else(failed)
    });

    progress(6, "hand-eye");
    let station_detections = detect_pairs(input.stations.iter().map(|s| (&s.left, s.right.as_ref())), input)?;
    let station_left: Vec<Option<CornerGrid>> = station_detections.iter().map(|d| d[0].clone()).collect();
    let station_poses = calib.clone().and_then(|c| {
        // (a wide lens's poses come from its rectified view: they need the rectification)
        let rect = if c.rig.has_wide_lens() { Some(need(&rectified, "rectification")?) } else { None };
        stages::board_poses(&c.rig.left, rect, board, &station_left).or_else(failed)
    });
    let hand_eye = if input.stations.iter().all(|s| s.robot.is_none()) {
        Err(StageFailure::NotRequested)
    } else {
        need(&station_poses, "calibration").and_then(|poses| {
            let used: Vec<usize> = (0..input.stations.len())
                .filter(|&i| poses[i].is_some() && input.stations[i].robot.is_some())
                .collect();
            let robot: Vec<Isometry3> = used.iter().filter_map(|&i| input.stations[i].robot).collect();
            let camera: Vec<Isometry3> = used.iter().filter_map(|&i| poses[i]).collect();
            stages::hand_eye(&robot, &camera, Method::Refined, &input.hand_eye)
                .map(|solution| HandEyeRun { stations: used, solution })
                .or_else(failed)
        })
    };

    progress(7, "measuring the board corners at a station");
    let measurement = if input.stations.iter().all(|s| s.right.is_none()) {
        Err(StageFailure::NotRequested)
    } else {
        calib.clone().and_then(|c| {
            let station = station_detections
                .iter()
                .position(|d| d[0].is_some() && d[1].is_some())
                .ok_or_else(|| StageFailure::Failed("no station with the board found in both cameras".into()))?;
            let [Some(gl), Some(gr)] = &station_detections[station] else {
                return failed("unreachable: the station was chosen with both grids");
            };
            let targets = measurement_targets(board);
            let pairs: Vec<(DVec2, DVec2)> = targets.iter().map(|&(c, r)| (gl.at(c, r), gr.at(c, r))).collect();
            let cfg = TriangulationConfig { pixel_sigma: c.sigma_px, ..Default::default() };
            let rect = if c.rig.has_wide_lens() { Some(need(&rectified, "rectification")?) } else { None };
            let measurement = stages::measure(&c.rig, rect, &pairs, &cfg).or_else(failed)?;
            Ok(StationMeasurement { station, targets, measurement })
        })
    };

    progress(8, "expressing the measured corners in the robot base frame");
    let robot_frame = need(&hand_eye, "hand-eye").and_then(|he| {
        let m = need(&measurement, "measurement")?;
        let robot = input.stations[m.station]
            .robot
            .ok_or_else(|| StageFailure::Failed("the measurement station has no robot pose".into()))?;
        let points: Vec<DVec3> = m.measurement.points.iter().map(|p| p.point).collect();
        Ok(stages::to_robot_frame(he.solution.setup, &he.solution.transform, &robot, &points))
    });

    Ok(ChainOutput {
        detections,
        views,
        calibration,
        rectified,
        rectified_view,
        matched,
        cloud,
        adjacent,
        station_detections,
        station_poses,
        hand_eye,
        measurement,
        robot_frame,
    })
}
