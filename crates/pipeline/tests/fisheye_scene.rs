//! The fisheye scene (`fixtures/scenes/fisheye.ron`): a ~155°-wide Kannala–Brandt stereo rig
//! through every stage — detection on fisheye renders, fisheye stereo calibration, rectification
//! to a pinhole pair, block matching, triangulation and measurement on the rectified pair,
//! board poses by PnP, hand-eye and the robot frame — scored against the truth.

use std::path::Path;

use parallax_composition::run_scene;
use parallax_synthetic::SceneDescription;

fn scene() -> SceneDescription {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/scenes/fisheye.ron");
    SceneDescription::from_ron(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

/// Every stage runs and passes its tolerance; the report has the 17 rows of the pinhole scene.
#[test]
fn fisheye_scene_passes_every_stage() {
    let scene = scene();
    assert_eq!(scene.rig.left.lens_model(), parallax_camera_model::LensModel::KannalaBrandt);
    assert!(scene.wide_views.is_some());
    let dir = std::env::temp_dir().join(format!("parallax-fisheye-scene-{}", std::process::id()));
    let report = run_scene("fisheye", &scene, &dir, None).unwrap();
    println!("{}", report.table());
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(report.verdict(), "pipeline: PASS", "{}", report.table());
    assert_eq!(report.rows.len(), 17, "{}", report.table());
    for stage in [
        "corners",
        "calibration",
        "rectification",
        "disparity",
        "triangulation",
        "hand-eye",
        "measurement",
        "robot frame",
    ] {
        assert!(report.rows.iter().any(|r| r.stage == stage && r.value.is_finite()), "{stage}: {}", report.table());
    }
}
