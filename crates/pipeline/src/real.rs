//! The real run: the same chain on the user's images, without truth. What it can check without
//! truth it checks, each figure against a stated tolerance ([`RealChecks`]): the board geometry
//! is known, so distances between triangulated corners are scored against it.

use std::path::{Path, PathBuf};

use parallax_camera_model::{Chessboard, Isometry3};

use crate::chain::{ChainInput, ChainOutput, MatchPair, Station, run_chain};
use crate::report::Report;
use crate::{PipelineError, Result, artifacts, io, stats};

/// Tolerances of the self-consistency checks of a real run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RealChecks {
    /// Fewest stereo pairs with the board in both images.
    pub min_pairs: usize,
    /// Largest stereo RMS reprojection error, pixels (a mix-up of the image order or a wrong
    /// board gives tens of pixels; a good calibration well under 0.5).
    pub stereo_rms_px: f64,
    /// Largest mean `|v_left − v_right|` of the detected corners after rectification, pixels.
    pub rectified_dv_px: f64,
    /// Largest RMS error of the triangulated distances between adjacent corners, percent of
    /// the square size.
    pub adjacent_distance_pct: f64,
    /// Largest error of a distance between two of the board's outer corners measured at one
    /// station, percent of the true distance.
    pub corner_distance_pct: f64,
    /// Largest mean rotation residual of `AX = XB` over the station pairs, degrees.
    pub handeye_rotation_deg: f64,
    /// Largest mean translation residual of `AX = XB`, percent of the mean camera-to-board
    /// distance.
    pub handeye_translation_pct: f64,
}

impl Default for RealChecks {
    fn default() -> Self {
        Self {
            min_pairs: 3,
            stereo_rms_px: 1.0,
            rectified_dv_px: 0.5,
            adjacent_distance_pct: 2.0,
            corner_distance_pct: 1.0,
            handeye_rotation_deg: 1.0,
            handeye_translation_pct: 2.0,
        }
    }
}

/// The inputs of a real run, already loaded.
#[derive(Debug, Clone)]
pub struct RealInputs {
    /// The board (its square size is the length unit).
    pub board: Chessboard,
    /// Name of the length unit, for the report (`mm`, `m`, ...).
    pub unit: String,
    /// Calibration pairs, `[left, right]`, with their file names for notes.
    pub calibration: Vec<([image::GrayImage; 2], String)>,
    /// The pair to block-match (raw images of the rig); the first calibration pair when absent.
    pub pair: Option<[image::GrayImage; 2]>,
    /// Disparities to search.
    pub disparities: usize,
    /// Robot `base_from_gripper` poses, one per calibration pair, for hand-eye with the left camera.
    pub robot: Option<Vec<Isometry3>>,
    /// Tolerances of the checks.
    pub checks: RealChecks,
}

impl RealInputs {
    /// The inputs of a real run read from files: calibration pairs `left[k]`, `right[k]` (named
    /// by the left file's name), the pair to match when given, default checks. Refuses lists of
    /// different lengths.
    pub fn from_files(
        board: Chessboard,
        unit: &str,
        left: &[PathBuf],
        right: &[PathBuf],
        pair: Option<[&Path; 2]>,
        disparities: usize,
        robot: Option<Vec<Isometry3>>,
    ) -> Result<Self> {
        if left.len() != right.len() {
            return Err(PipelineError::Input(format!("{} left images but {} right images", left.len(), right.len())));
        }
        let pair = pair.map(|[l, r]| Ok::<_, PipelineError>([io::load_gray(l)?, io::load_gray(r)?])).transpose()?;
        let mut calibration = Vec::with_capacity(left.len());
        for (l, r) in left.iter().zip(right) {
            let name = l.file_name().map_or_else(|| l.display().to_string(), |n| n.to_string_lossy().into_owned());
            calibration.push(([io::load_gray(l)?, io::load_gray(r)?], name));
        }
        Ok(Self { board, unit: unit.to_string(), calibration, pair, disparities, robot, checks: RealChecks::default() })
    }
}

/// Runs the chain on real images, writes the artifacts and the report into `out`, and returns
/// the report with every self-consistency check that could run.
pub fn run_real(inputs: RealInputs, out: &Path) -> Result<Report> {
    if let Some(robot) = &inputs.robot
        && robot.len() != inputs.calibration.len()
    {
        return Err(PipelineError::Input(format!(
            "{} robot poses for {} image pairs: give one pose per pair, in the same order",
            robot.len(),
            inputs.calibration.len()
        )));
    }
    std::fs::create_dir_all(out).map_err(|source| PipelineError::Io {
        what: "creating directory",
        path: out.to_path_buf(),
        source,
    })?;
    let mut report = Report::new("real", &inputs.unit);
    let names: Vec<String> = inputs.calibration.iter().map(|c| c.1.clone()).collect();
    let calibration: Vec<[image::GrayImage; 2]> = inputs.calibration.into_iter().map(|c| c.0).collect();
    let mut input = ChainInput::new(inputs.board, calibration);
    input.match_pair = inputs.pair.map(|[l, r]| MatchPair::Raw(l, r));
    input.matcher.num_disparities = inputs.disparities;
    input.stations = input
        .calibration
        .iter()
        .enumerate()
        .map(|(i, [l, r])| Station {
            robot: inputs.robot.as_ref().map(|p| p[i]),
            left: l.clone(),
            right: Some(r.clone()),
        })
        .collect();
    let output = run_chain(&input)?;
    check(&mut report, &inputs.board, &inputs.checks, &names, &output);
    let mut files = crate::io::OutputSet::new();
    report.images = artifacts::add_artifacts(&mut files, out, &input, &output)?;
    report.sections = artifacts::pictures(&input, &output, Some(&names), None, &inputs.unit);
    report.add_to(&mut files, out)?;
    files.commit()?;
    Ok(report)
}

fn check(report: &mut Report, board: &Chessboard, tol: &RealChecks, names: &[String], out: &ChainOutput) {
    let unit = report.unit.clone();
    for (i, d) in out.detections.iter().enumerate() {
        if d[0].is_none() || d[1].is_none() {
            report.note("corners", format!("board not found in both images of pair {}", names[i]));
        }
    }
    report.note("corners", format!("board found in both images of {}/{} pairs", out.views.len(), out.detections.len()));
    report.at_least(
        "corners",
        "pairs with the board in both images",
        out.views.len() as f64,
        tol.min_pairs as f64,
        "pairs",
    );

    let rms_figure = "stereo RMS reprojection error";
    match &out.calibration {
        Ok(c) => {
            report.at_most("calibration", rms_figure, c.rms_px, tol.stereo_rms_px, "px");
            report.note(
                "calibration",
                format!(
                    "RMS {:.4} px (left {:.4}, right {:.4}); left fx {:.3}, right fx {:.3}; baseline {:.4} ± {:.4} {unit}",
                    c.rms_px,
                    c.left_rms_px,
                    c.right_rms_px,
                    c.rig.left.intrinsics.fx,
                    c.rig.right.intrinsics.fx,
                    c.rig.baseline(),
                    c.rig_std_devs.baseline
                ),
            );
            for w in &c.warnings {
                report.note("calibration", format!("warning: {w}"));
            }
        }
        Err(e) => {
            report.note("calibration", e.to_string());
            report.at_most("calibration", rms_figure, f64::NAN, tol.stereo_rms_px, "px");
        }
    }

    let dv_figure = "mean |Δv| of detected corners";
    match &out.rectified {
        Ok(r) => {
            report.at_most("rectification", dv_figure, r.mean_abs_dv(), tol.rectified_dv_px, "px");
            report.note("rectification", format!("{} corners, mean |Δv| {:.4} px", r.abs_dv.len(), r.mean_abs_dv()));
        }
        Err(e) => {
            report.note("rectification", e.to_string());
            report.at_most("rectification", dv_figure, f64::NAN, tol.rectified_dv_px, "px");
        }
    }

    match &out.matched {
        Ok(m) => report.note(
            "disparity",
            format!(
                "{}x{}, density {:.1} %, {:.1} ms",
                m.disparity.width(),
                m.disparity.height(),
                100.0 * m.disparity.density(),
                1e3 * m.seconds
            ),
        ),
        Err(e) => report.note("disparity", e.to_string()),
    }
    match &out.cloud {
        Ok(c) => report.note("triangulation", format!("{} points in cloud.ply", c.len())),
        Err(e) => report.note("triangulation", e.to_string()),
    }

    let adj_figure = "adjacent-corner distance RMS error";
    match &out.adjacent {
        Ok(d) => {
            let rms = parallax_triangulation::distance_rms(d, board.square_size).unwrap_or(f64::NAN);
            report.at_most(
                "measurement",
                adj_figure,
                100.0 * rms / board.square_size,
                tol.adjacent_distance_pct,
                "% sq",
            );
            report.note(
                "measurement",
                format!(
                    "adjacent corners: RMS error {rms:.4} {unit} over {} distances (square {})",
                    d.len(),
                    board.square_size
                ),
            );
        }
        Err(e) => {
            report.note("measurement", e.to_string());
            report.at_most("measurement", adj_figure, f64::NAN, tol.adjacent_distance_pct, "% sq");
        }
    }
    let corner_figure = "outer-corner distance error (worst of 6)";
    match &out.measurement {
        Ok(m) => {
            let worst = m
                .measurement
                .distances
                .iter()
                .map(|d| {
                    let (a, b) = (m.targets[d.from], m.targets[d.to]);
                    let truth = (board.point(a.0, a.1) - board.point(b.0, b.1)).length();
                    100.0 * (d.distance - truth).abs() / truth
                })
                .fold(0.0, f64::max);
            report.at_most("measurement", corner_figure, worst, tol.corner_distance_pct, "%");
            report.note("measurement", format!("outer corners measured in pair {}", names[m.station]));
        }
        Err(e) => {
            report.note("measurement", e.to_string());
            report.at_most("measurement", corner_figure, f64::NAN, tol.corner_distance_pct, "%");
        }
    }

    match &out.hand_eye {
        Err(crate::chain::StageFailure::NotRequested) => report.note("hand-eye", "not run (no robot poses given)"),
        Err(e) => {
            report.note("hand-eye", e.to_string());
            report.at_most("hand-eye", "mean rotation residual", f64::NAN, tol.handeye_rotation_deg, "deg");
            report.at_most("hand-eye", "mean translation residual", f64::NAN, tol.handeye_translation_pct, "%");
        }
        Ok(he) => {
            let q = &he.solution.quality;
            let distances: Vec<f64> = match &out.station_poses {
                Ok(p) => he.stations.iter().filter_map(|&i| p[i].map(|p| p.translation.length())).collect(),
                Err(_) => Vec::new(),
            };
            let scale = stats::mean(&distances);
            report.at_most("hand-eye", "mean rotation residual", q.mean_rotation_deg, tol.handeye_rotation_deg, "deg");
            report.at_most(
                "hand-eye",
                "mean translation residual",
                100.0 * q.mean_translation / scale,
                tol.handeye_translation_pct,
                "%",
            );
            let t = he.solution.transform.translation;
            report.note(
                "hand-eye",
                format!(
                    "{} stations; transform t ({:.4}, {:.4}, {:.4}) {unit}, rvec {:?} rad; residual {:.3} deg / {:.4} {unit}",
                    he.stations.len(),
                    t.x,
                    t.y,
                    t.z,
                    he.solution.transform.rvec().to_array(),
                    q.mean_rotation_deg,
                    q.mean_translation
                ),
            );
        }
    }
}
