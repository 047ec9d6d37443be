//! Scene files are refused at reading when a run would need more memory than the budget,
//! with the estimate and the budget in the message (a 40000x30000 stereo scene used to abort
//! on a 9.6 GB allocation half-way through the run).

use parallax_synthetic::SceneDescription;

#[test]
fn the_builtin_scenes_fit_the_budget_with_the_stated_estimate() {
    let s = SceneDescription::builtin();
    // Independent count for the built-in scene: 640x480 everywhere; views kept at 1 byte per
    // pixel plus the larger working set (rendering, 37 B/px, or the stereo scene, 33 B/px).
    let px = 640u64 * 480;
    assert_eq!((s.camera.width, s.camera.height, s.stereo_scene.width, s.stereo_scene.height), (640, 480, 640, 480));
    let views = s.views.views as u64 + 2 * s.stereo_views.views as u64 + s.trajectory.stations as u64;
    assert_eq!(s.estimated_bytes(), views * px + 37 * px);
    for scene in
        [SceneDescription::builtin(), SceneDescription::builtin_hard(), SceneDescription::builtin_eye_to_hand()]
    {
        assert!(scene.estimated_bytes() < SceneDescription::MEMORY_BUDGET / 50, "{}", scene.estimated_bytes());
        scene.validate().unwrap();
    }
}

#[test]
fn a_huge_stereo_scene_is_refused_when_read_naming_the_bytes_and_the_cap() {
    let mut s = SceneDescription::builtin();
    s.stereo_scene.width = 40000;
    s.stereo_scene.height = 30000;
    let text = s.to_ron();
    let err = SceneDescription::from_ron(&text).unwrap_err().to_string();
    let expected = s.estimated_bytes();
    // 1.2e9 pixels at 33 bytes each dominate: ≈ 39.6 GB.
    assert!(expected > 39_600_000_000 && expected < 39_700_000_000, "{expected}");
    assert!(err.contains(&expected.to_string()), "{err}");
    assert!(err.contains(&SceneDescription::MEMORY_BUDGET.to_string()), "{err}");
    assert!(err.contains("stereo_scene 40000x30000"), "{err}");
}

#[test]
fn many_views_or_huge_cameras_are_refused_and_a_large_legitimate_scene_is_not() {
    let mut s = SceneDescription::builtin();
    s.views.views = 1_000_000_000;
    assert!(s.validate().unwrap_err().to_string().contains("budget"));
    let mut s = SceneDescription::builtin();
    s.camera.width = u32::MAX;
    s.camera.height = u32::MAX;
    s.camera.intrinsics.cx = 2e9;
    s.camera.intrinsics.cy = 2e9;
    // Saturating arithmetic: no overflow panic, a refusal.
    assert!(s.estimated_bytes() > SceneDescription::MEMORY_BUDGET);
    assert!(s.validate().is_err());
    // A 4000x3000 stereo scene (≈ 0.4 GB) stays allowed.
    let mut s = SceneDescription::builtin();
    s.stereo_scene.width = 4000;
    s.stereo_scene.height = 3000;
    s.validate().unwrap();
    let kept = (s.views.views as u64 + 2 * s.stereo_views.views as u64 + s.trajectory.stations as u64) * 640 * 480;
    assert_eq!(s.estimated_bytes(), kept + 33 * 4000 * 3000);
}
