//! Reads ViSP's Franka eye-in-hand robot poses (skipped when ../shared is absent).
//! The hand-eye figures on this set need corner detection and are measured with
//! `cargo xtask handeye` (see the crate docs).

use parallax_hand_eye::io::parse_visp_pose;

#[test]
fn visp_franka_robot_poses_are_read() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/visp-franka-eye-in-hand");
    if !std::path::Path::new(dir).is_dir() {
        println!("skipped: ../shared not found ({dir})");
        return;
    }
    let mut poses = Vec::new();
    for k in 1..=8 {
        let path = format!("{dir}/franka_pose_rPe_{k}.yaml");
        let text = std::fs::read_to_string(&path).unwrap();
        poses.push(parse_visp_pose(&text, &path).unwrap());
    }
    // First file: [0.335091, -0.0321497, 0.30857, -3.01226, 0.0236777, -0.451343].
    let p = poses[0];
    assert!((p.translation - glam::DVec3::new(0.335091, -0.0321497, 0.30857)).length() < 1e-12);
    assert!((p.angle() - (3.01226f64.powi(2) + 0.0236777f64.powi(2) + 0.451343f64.powi(2)).sqrt()).abs() < 1e-9);
    // A flange 0.3–0.5 m from the base in every view.
    assert!(poses.iter().all(|p| (0.2..0.7).contains(&p.translation.length())));
}
