//! `handeye --board` takes any target description; a target that is not in the images is
//! refused naming what was searched and which targets exist.

use std::path::Path;
use std::process::Command;

#[test]
fn a_target_not_in_the_images_is_named_with_the_known_targets() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let dir = std::env::temp_dir().join(format!("xtask-handeye-targets-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Intrinsics: the fixtures' true left camera, written as a RON `Camera`.
    let truth: ron::Value =
        ron::from_str(&std::fs::read_to_string(root.join("fixtures/mono/truth.ron")).unwrap()).unwrap();
    let ron::Value::Map(m) = truth else { panic!("truth.ron is a struct") };
    let camera = m.get(&ron::Value::String("camera".into())).unwrap().clone();
    let intrinsics = dir.join("camera.ron");
    std::fs::write(&intrinsics, ron::to_string(&camera).unwrap()).unwrap();
    let run = |board: &str| {
        Command::new(env!("CARGO_BIN_EXE_xtask"))
            .args(["handeye", "--robot"])
            .arg(root.join("fixtures/handeye/robot_poses.ron"))
            .arg("--images")
            .arg(root.join("fixtures/handeye/station_*.png"))
            .args(["--board", board, "--square", "25", "--intrinsics"])
            .arg(&intrinsics)
            .output()
            .unwrap()
    };
    // The stations show a 9x6 chessboard: an AprilTag is not there.
    let out = run("marker:apriltag_36h11:0:80");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("no marker") && err.contains("targets the detector knows") && err.contains("charuco"),
        "{err}"
    );
    // The same stations as a target description of the chessboard: solved.
    let ok = run("chessboard:9x6:25");
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(String::from_utf8_lossy(&ok.stdout).contains("method: refined"));
    std::fs::remove_dir_all(&dir).unwrap();
}
