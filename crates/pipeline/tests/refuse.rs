//! Common mistakes are refused with a hint, never answered plausibly: swapped cameras,
//! out-of-order pairs, a rig whose rectification collapses.

use std::path::Path;

use glam::DVec3;
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_composition::{ChainInput, StageFailure, StereoViews, io, run_chain};

fn pairs() -> Vec<[image::GrayImage; 2]> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/stereo");
    (0..5)
        .map(|i| {
            [
                io::load_gray(&dir.join(format!("left_{i:02}.png"))).unwrap(),
                io::load_gray(&dir.join(format!("right_{i:02}.png"))).unwrap(),
            ]
        })
        .collect()
}

fn calibration_error(calibration: Vec<[image::GrayImage; 2]>) -> String {
    let out = run_chain(&ChainInput::new(Chessboard::new(9, 6, 25.0).unwrap(), calibration)).unwrap();
    match out.calibration {
        Err(StageFailure::Failed(m)) => m,
        other => panic!("the calibration was not refused: {:?}", other.map(|c| c.rig.right_from_left.translation)),
    }
}

#[test]
fn swapped_cameras_are_refused_with_a_hint() {
    let ok = run_chain(&ChainInput::new(Chessboard::new(9, 6, 25.0).unwrap(), pairs())).unwrap();
    assert!(ok.calibration.is_ok(), "{:?}", ok.calibration.err());
    let swapped: Vec<_> = pairs().into_iter().map(|[l, r]| [r, l]).collect();
    let m = calibration_error(swapped);
    assert!(m.contains("swapped") && m.contains("t.x should be negative"), "{m}");
}

#[test]
fn out_of_order_pairs_are_refused_with_a_hint() {
    let mut p = pairs();
    let rights: Vec<_> = p.iter().map(|[_, r]| r.clone()).collect();
    for (i, pair) in p.iter_mut().enumerate() {
        pair[1] = rights[(i + 1) % rights.len()].clone();
    }
    let m = calibration_error(p);
    assert!(m.contains("same order") || m.contains("swapped"), "{m}");
}

#[test]
fn a_rectification_that_collapses_is_refused() {
    let k = Intrinsics::new(600.0, 600.0, 320.0, 240.0);
    let sane = Camera::new(k, Distortion::default(), 640, 480).unwrap();
    let t = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-60.0, 0.0, 0.0));
    let views = StereoViews::default();
    let good = parallax_composition::rectify(&StereoRig::new(sane, sane, t).unwrap(), &views, &Default::default());
    assert!(good.is_ok(), "{:?}", good.err());
    // A rig rotated 80° between the cameras keeps almost nothing of the left image in common.
    let turned = Isometry3::from_rvec_tvec(DVec3::new(0.0, 80f64.to_radians(), 0.0), DVec3::new(-60.0, 0.0, 0.0));
    match parallax_composition::rectify(&StereoRig::new(sane, sane, turned).unwrap(), &views, &Default::default()) {
        Err(e) => assert!(e.to_string().contains("valid region"), "{e}"),
        Ok(r) => panic!("rectification accepted with ROIs {:?} / {:?}", r.rectification.roi1, r.rectification.roi2),
    }
}
