//! Calibration from identified target points: every view gives the ids it saw (any subset of
//! the target: ChArUco, AprilGrid, or a whole chessboard / circle grid) and their pixels; the
//! object points come from the target description. Stereo pairs use the points seen by both
//! cameras, matched by id.

use glam::{DVec2, DVec3};
use parallax_camera_model::{TargetDescription, TargetObservation};

use crate::{CalibrationConfig, CalibrationError, CalibrationResult, Result, StereoCalibrationResult, StereoConfig};

/// The object points of `observation` (in its order) on `target`; errors name the view and the
/// id the target does not have.
pub fn object_points_for(
    target: &TargetDescription,
    observation: &TargetObservation,
    view: usize,
) -> Result<Vec<DVec3>> {
    observation
        .ids()
        .iter()
        .map(|&id| {
            target.point(id).ok_or_else(|| {
                CalibrationError::SizeMismatch(format!(
                    "view {view}: point id {id} is not on the target {target} ({} points); check the --board description",
                    target.point_count()
                ))
            })
        })
        .collect()
}

/// The points of a stereo pair seen by both cameras, in ascending id order: object points,
/// left pixels, right pixels.
pub fn common_points(
    target: &TargetDescription,
    left: &TargetObservation,
    right: &TargetObservation,
    pair: usize,
) -> Result<(Vec<DVec3>, Vec<DVec2>, Vec<DVec2>)> {
    let mut ids: Vec<u32> = left.ids().iter().copied().filter(|&id| right.get(id).is_some()).collect();
    ids.sort_unstable();
    let obs = TargetObservation::new(ids.clone(), ids.iter().map(|&id| left.get(id).expect("seen left")).collect())
        .expect("ids from one observation are unique and finite");
    let object = object_points_for(target, &obs, pair)?;
    let r = ids.iter().map(|&id| right.get(id).expect("seen right")).collect();
    Ok((object, obs.points().to_vec(), r))
}

/// [`crate::calibrate_camera`] from identified points: view `v` contributes the target points
/// `views[v]` saw (partial views of ChArUco boards and AprilGrids, or whole chessboards and
/// circle grids as [`TargetObservation::whole`]). Partial views whose points reach the image
/// corners constrain the distortion where it is largest (see `tests/partial_views.rs`).
///
/// Errors: an id not on the target (naming the view), fewer than 4 points in a view, and
/// everything [`crate::calibrate_camera`] refuses.
pub fn calibrate_target(
    target: &TargetDescription,
    views: &[TargetObservation],
    width: u32,
    height: u32,
    config: &CalibrationConfig,
) -> Result<CalibrationResult> {
    let object = views.iter().enumerate().map(|(v, o)| object_points_for(target, o, v)).collect::<Result<Vec<_>>>()?;
    let image: Vec<Vec<DVec2>> = views.iter().map(|o| o.points().to_vec()).collect();
    crate::calibrate_camera(&object, &image, width, height, config)
}

/// [`crate::calibrate_stereo`] from identified points: pair `k` uses the points seen by both
/// `left[k]` and `right[k]` (matched by id, whatever order each camera reported them in).
///
/// Errors: different numbers of left and right views, an id not on the target, a pair with
/// fewer than 4 common points (naming the pair: drop it or move the target), and everything
/// [`crate::calibrate_stereo`] refuses.
pub fn calibrate_stereo_target(
    target: &TargetDescription,
    left: &[TargetObservation],
    right: &[TargetObservation],
    left_size: (u32, u32),
    right_size: (u32, u32),
    config: &StereoConfig,
) -> Result<StereoCalibrationResult> {
    if left.len() != right.len() {
        return Err(CalibrationError::SizeMismatch(format!("{} left views, {} right views", left.len(), right.len())));
    }
    let (mut object, mut l, mut r) = (Vec::new(), Vec::new(), Vec::new());
    for (k, (a, b)) in left.iter().zip(right).enumerate() {
        let (o, pl, pr) = common_points(target, a, b, k)?;
        if o.len() < 4 {
            return Err(CalibrationError::TooFewPoints {
                what: format!("stereo pair {k} (points seen by both cameras; drop the pair)"),
                got: o.len(),
                needed: 4,
            });
        }
        object.push(o);
        l.push(pl);
        r.push(pr);
    }
    crate::calibrate_stereo(&object, &l, &r, left_size, right_size, config)
}
