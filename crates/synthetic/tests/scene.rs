//! Scene descriptions: RON round trips, built-in scenes and bad input.

use parallax_synthetic::*;

#[test]
fn builtin_scenes_round_trip_through_ron_and_generate() {
    for scene in
        [SceneDescription::builtin(), SceneDescription::builtin_hard(), SceneDescription::builtin_eye_to_hand()]
    {
        let text = scene.to_ron();
        let back = SceneDescription::from_ron(&text).unwrap();
        assert_eq!(back, scene, "{} does not round-trip", scene.name);
        let mono = scene.mono_poses().unwrap();
        assert_eq!(mono.len(), scene.views.views);
        let stereo = scene.stereo_poses().unwrap();
        assert_eq!(stereo.len(), scene.stereo_views.views);
        let t = hand_eye_trajectory(&scene.trajectory).unwrap();
        assert_eq!(t.eye_in_hand, scene.trajectory.eye_in_hand);
        // The trajectory's board centre is at 450..700 mm in front of the camera (before noise),
        // and the whole board (with half a square of margin) is in view of both rig cameras.
        let clean =
            hand_eye_trajectory(&TrajectoryConfig { rot_noise_rad: 0.0, trans_noise: 0.0, ..scene.trajectory.clone() })
                .unwrap();
        let s = scene.board.square_size;
        let outline: Vec<glam::DVec3> = [(-1.5, -1.5), (9.5, -1.5), (9.5, 6.5), (-1.5, 6.5)]
            .iter()
            .map(|&(x, y)| glam::DVec3::new(x * s, y * s, 0.0))
            .collect();
        for c in &clean.camera_from_board {
            let z = c.transform_point(scene.trajectory.board_centre).z;
            assert!((450.0..=700.0).contains(&z), "depth {z}");
            for (cam, pose) in [(scene.rig.left, *c), (scene.rig.right, scene.rig.right_from_left * *c)] {
                for p in &outline {
                    let px = cam.project_from(&pose, *p).unwrap();
                    assert!(cam.contains(px), "{}: board outline at {px} outside the image", scene.name);
                }
            }
        }
    }
    assert_eq!(SceneDescription::default(), SceneDescription::builtin());
}

#[test]
fn explicit_poses_replace_the_generator_and_render() {
    let mut scene = SceneDescription::builtin();
    let poses = scene.mono_poses().unwrap();
    scene.mono_poses = Some(poses[..2].to_vec());
    let back = SceneDescription::from_ron(&scene.to_ron()).unwrap();
    assert_eq!(back.mono_poses().unwrap(), poses[..2].to_vec());
    let views = back.render_mono_views().unwrap();
    assert_eq!(views.len(), 2);
    assert_eq!(views[1].camera_from_board, poses[1]);
    // Each view has its own noise: the two renders of different poses differ, and re-rendering is identical.
    assert_eq!(back.render_mono_views().unwrap()[0].image, views[0].image);
    scene.stereo_poses = Some(scene.stereo_poses().unwrap()[..1].to_vec());
    let pair = &scene.render_stereo_views().unwrap()[0];
    let right_pose = scene.rig.right_from_left * pair.0.camera_from_board;
    assert_eq!(pair.1.camera_from_board, right_pose);
    assert_eq!(pair.1.corners, project_corners(&scene.rig.right, &scene.board, &right_pose).unwrap());
}

#[test]
fn bad_scene_descriptions_are_errors() {
    assert!(matches!(SceneDescription::from_ron("not ron at all"), Err(SyntheticError::Scene(_))));
    let text = SceneDescription::builtin().to_ron();
    // A missing required section.
    let cut = text.replacen("board:", "boart:", 1);
    assert!(SceneDescription::from_ron(&cut).is_err());
    // A value out of range is caught by validation and named.
    let mut s = SceneDescription::builtin();
    s.render.blur_sigma = -1.0;
    assert!(SceneDescription::from_ron(&s.to_ron()).unwrap_err().to_string().contains("blur_sigma"));
    let mut s = SceneDescription::builtin();
    s.board.square_size = 0.0;
    assert!(SceneDescription::from_ron(&s.to_ron()).unwrap_err().to_string().contains("board"));
    let mut s = SceneDescription::builtin();
    s.mono_poses = Some(vec![]);
    assert!(s.validate().unwrap_err().to_string().contains("mono_poses"));
    let mut s = SceneDescription::builtin();
    s.tolerances.point_error = f64::NAN;
    assert!(s.validate().unwrap_err().to_string().contains("point_error"));
}

/// A scene file of the earlier form (the wide rig under `fisheye: Some((rig, views))`, beside a
/// pinhole `rig` that served no stage: `tests/data/fisheye-scene-before-lens-unification.ron`,
/// the committed `fixtures/scenes/fisheye.ron` as it was) reads as today's built-in wide scene:
/// the wide rig is the scene's rig and its generator the stereo session's, so the same views are
/// rendered; today's form round-trips.
#[test]
fn the_earlier_wide_scene_form_still_reads() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/fisheye-scene-before-lens-unification.ron");
    let old = SceneDescription::from_ron(&std::fs::read_to_string(path).unwrap()).unwrap();
    let now = SceneDescription::builtin_wide();
    assert_eq!(old, now);
    assert!(old.rig.left.lens_model().is_wide() && old.wide_views.is_some());
    assert_eq!(old.stereo_poses().unwrap(), now.stereo_poses().unwrap());
    assert_eq!(SceneDescription::from_ron(&now.to_ron()).unwrap(), now);
    assert!(now.to_ron().contains("wide_views: Some(") && !now.to_ron().contains("fisheye:"));
}
