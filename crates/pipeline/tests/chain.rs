//! The chain end to end on synthetic scenes (truth known) and on the committed stereo
//! fixtures (the real-data path, scored by its self-consistency checks).

use std::path::{Path, PathBuf};

use parallax_composition::{Corruption, RealChecks, RealInputs, Report, io, run_real, run_scene};
use parallax_synthetic::SceneDescription;

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("parallax-chain-{name}-{}", std::process::id()))
}

fn run(name: &str, scene: &SceneDescription, corrupt: Option<Corruption>) -> (Report, String) {
    let dir = temp(name);
    let report = run_scene(name, scene, &dir, corrupt).unwrap();
    let md = std::fs::read_to_string(dir.join("report.md")).expect("report.md is always written");
    assert!(dir.join("report.html").is_file() && dir.join("report.ron").is_file());
    let _ = std::fs::remove_dir_all(&dir);
    (report, md)
}

fn rows_of<'a>(r: &'a Report, stage: &str) -> Vec<&'a parallax_composition::Row> {
    r.rows.iter().filter(|row| row.stage == stage).collect()
}

/// The built-in scene passes every tolerance; corrupting a stage input makes the stage that
/// consumes it (and those downstream) fail by name.
#[test]
fn builtin_scene_passes_and_corruptions_name_the_stage() {
    let (ok, _) = run("ok", &SceneDescription::builtin(), None);
    assert_eq!(ok.verdict(), "pipeline: PASS", "{}", ok.table());
    assert_eq!(ok.rows.len(), 17, "{}", ok.table());
    let (square, _) = run("square", &SceneDescription::builtin(), Some(Corruption::SquareSize));
    let failed = square.failed_stages();
    assert!(failed.contains(&"calibration".to_string()), "{failed:?}");
    assert!(failed.contains(&"measurement".to_string()), "{failed:?}");
    assert!(square.table().contains("baseline vector error"));
    let (swapped, _) = run("swap", &SceneDescription::builtin(), Some(Corruption::SwapStereo));
    assert!(swapped.failed_stages().contains(&"corners".to_string()), "{:?}", swapped.failed_stages());
    assert!(swapped.verdict().starts_with("pipeline: FAIL (corners, calibration"), "{}", swapped.verdict());
}

/// Two robot stations cannot determine `AX = XB`: hand-eye fails, the robot frame cannot run,
/// but every other stage (measurement included) runs, and the report lists every stage.
#[test]
fn a_failing_stage_does_not_stop_the_others() {
    let mut scene = SceneDescription::builtin();
    scene.trajectory.stations = 2;
    let (r, md) = run("two-stations", &scene, None);
    assert!(!r.passed());
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
        assert!(md.contains(&format!("| {stage} |")), "report.md lacks {stage}:\n{md}");
    }
    assert!(rows_of(&r, "hand-eye").iter().any(|row| !row.pass()));
    assert!(rows_of(&r, "robot frame").iter().all(|row| !row.pass()) && !rows_of(&r, "robot frame").is_empty());
    let measurement = rows_of(&r, "measurement");
    assert_eq!(measurement.len(), 2);
    assert!(measurement.iter().all(|row| row.pass()), "{}", r.table());
    assert!(r.failed_stages() == ["hand-eye", "robot frame"], "{:?}", r.failed_stages());
    assert!(r.notes.iter().any(|(s, t)| s == "robot frame" && t.contains("needs hand-eye")), "{:?}", r.notes);
}

/// A scene in metres is scored and reported in metres: the same renders, every length row in
/// `m` and 1000x smaller than in millimetres.
#[test]
fn a_scene_in_metres_reports_metres() {
    let mm = SceneDescription::builtin();
    let m = mm.in_unit(1e-3, "m");
    let (r_mm, _) = run("mm", &mm, None);
    let (r_m, md) = run("m", &m, None);
    assert_eq!(r_m.verdict(), "pipeline: PASS", "{}", r_m.table());
    assert!(!md.contains("| mm |"), "{md}");
    let mut lengths = 0;
    for (a, b) in r_mm.rows.iter().zip(&r_m.rows) {
        assert_eq!(a.figure, b.figure);
        if a.unit == "mm" {
            lengths += 1;
            assert_eq!(b.unit, "m");
            // The same computation in other units: equal to 1e-4 relative (LM stops on relative
            // criteria, so the last digits may differ) or 1e-9 m absolute.
            let expect = a.value * 1e-3;
            assert!(
                (b.value - expect).abs() <= 1e-4 * expect.abs() + 1e-9,
                "{}: {} m vs {} mm",
                a.figure,
                b.value,
                a.value
            );
        } else {
            assert_eq!(a.unit, b.unit);
        }
    }
    assert_eq!(lengths, 5);
    assert!(r_m.notes.iter().any(|(s, t)| s == "measurement" && t.ends_with(" m")), "{:?}", r_m.notes);
}

/// The committed synthetic stereo fixtures (5 pairs, 9x6 board of 25 mm) as real-run inputs.
fn fixture_inputs(robot: Option<Vec<parallax_camera_model::Isometry3>>) -> RealInputs {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/stereo");
    let calibration = (0..5)
        .map(|i| {
            let l = io::load_gray(&dir.join(format!("left_{i:02}.png"))).unwrap();
            let r = io::load_gray(&dir.join(format!("right_{i:02}.png"))).unwrap();
            ([l, r], format!("left_{i:02}.png"))
        })
        .collect();
    RealInputs {
        board: parallax_camera_model::Chessboard::new(9, 6, 25.0).unwrap(),
        unit: "mm".into(),
        calibration,
        pair: None,
        disparities: 64,
        robot,
        checks: RealChecks::default(),
    }
}

/// The real-data path on the committed synthetic stereo fixtures (5 pairs): every check runs and
/// passes, the calibration matches the fixtures' true rig, and the artifacts are written.
#[test]
fn real_mode_runs_its_checks_on_the_stereo_fixtures() {
    let inputs = fixture_inputs(None);
    let out = temp("real");
    let report = run_real(inputs, &out).unwrap();
    assert!(report.rows.len() >= 5, "{}", report.table());
    assert_eq!(report.verdict(), "pipeline: PASS", "{}\n{:?}", report.table(), report.notes);
    // The artifact is an interop record, read back by the one reader.
    let cal = parallax_interop::read_stereo(&[out.join("calibration.ron")]).unwrap();
    assert!(cal.rectification.is_some());
    let truth = SceneDescription::builtin().rig;
    // Five views only: fx within 0.5 %, baseline within 1 % of the rendered rig.
    assert!((cal.rig.left.intrinsics.fx / truth.left.intrinsics.fx - 1.0).abs() < 5e-3);
    assert!((cal.rig.baseline() / truth.baseline() - 1.0).abs() < 1e-2);
    for f in ["disparity.pfm", "cloud.ply", "report.html", "rectified-left.png", "rectified-pair.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A robot pose count that does not match the image pairs is refused before anything runs or
/// is written.
#[test]
fn real_mode_refuses_robot_poses_that_do_not_match_the_pairs() {
    let inputs = fixture_inputs(Some(vec![parallax_camera_model::Isometry3::IDENTITY; 3]));
    let out = temp("real-bad");
    let err = run_real(inputs, &out).unwrap_err().to_string();
    assert!(err.contains("3 robot poses for 5 image pairs"), "{err}");
    assert!(!out.exists(), "nothing may be written when the inputs are refused");
}
