//! Stereo worlds through a calibrated rig: the raw images and the truth in the rig's
//! rectification agree (the right image warped by the true disparity reproduces the left one,
//! through lens distortion and a rotated rig), and the whole chain — calibration, rectification,
//! matching, triangulation — passes on zoo worlds seen through the built-in rig.

use std::path::PathBuf;

use parallax_composition::run_scene;
use parallax_synthetic::{SceneDescription, StereoWorld, render_world_through, world_truth_rectified};

fn zoo(name: &str) -> StereoWorld {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/zoo").join(format!("{name}.ron"));
    StereoWorld::from_ron(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Linear interpolation of row `v` at column `x`.
fn sample(img: &image::GrayImage, x: f64, v: u32) -> f64 {
    let i = x.floor() as u32;
    let t = x - f64::from(i);
    let p = |i: u32| f64::from(img.get_pixel(i.min(img.width() - 1), v).0[0]);
    (1.0 - t) * p(i) + t * p(i + 1)
}

#[test]
fn raw_images_through_a_distorted_rig_rectify_onto_the_truth_of_its_rectification() {
    // the hard scene's rig: strong distortion, a rotated right camera
    let scene = SceneDescription::builtin_hard();
    let rig = scene.rig;
    let mut world = zoo("planes");
    world.noise_sigma = 0.0;
    world.samples_per_axis = 4;
    let world = world.scaled(rig.baseline() / world.baseline);
    let (left, right) = render_world_through(&world, &rig).unwrap();
    let rect = parallax_stereo_rectify::stereo_rectify(&rig, &Default::default()).unwrap();
    let rectifier = parallax_stereo_rectify::Rectifier::from_rectification(&rig, rect).unwrap();
    let (rl, rr) = rectifier
        .rectify_pair(&left.to_luma8(), &right.to_luma8(), parallax_stereo_rectify::Border::Constant(image::Luma([0])))
        .unwrap();
    let (truth, occluded) =
        world_truth_rectified(&world, &parallax_composition::scene::rectified_pair(&rig, &rect)).unwrap();
    let w = rect.width as usize;
    let (mut sum, mut count) = (0.0, 0usize);
    let mut shifted = 0.0;
    for v in 20..rect.height as usize - 20 {
        for u in 20..w - 20 {
            let i = v * w + u;
            let d = f64::from(truth.data()[i]);
            // away from depth edges, occlusions and the black border
            let smooth = (u - 2..=u + 2).all(|uu| {
                (v - 2..=v + 2)
                    .all(|vv| !occluded[vv * w + uu] && (f64::from(truth.data()[vv * w + uu]) - d).abs() < 0.5)
            });
            let x = u as f64 - d;
            let l = f64::from(rl.get_pixel(u as u32, v as u32).0[0]);
            if !smooth
                || x < 2.0
                || l == 0.0
                || sample(&rr, x.floor(), v as u32) == 0.0
                || sample(&rr, x.ceil(), v as u32) == 0.0
            {
                continue;
            }
            sum += (l - sample(&rr, x, v as u32)).abs();
            // the same with the truth one pixel off: what a wrong truth would look like
            shifted += (l - sample(&rr, x - 1.0, v as u32)).abs();
            count += 1;
        }
    }
    let (mean, off) = (sum / count as f64, shifted / count as f64);
    println!("{count} pixels: mean |left − warped right| {mean:.2} grey levels, one pixel off {off:.2}");
    // two bilinear resamplings (rectification, the warp) of texture with detail near a pixel
    assert!(count > 100_000, "{count} pixels compared");
    assert!(
        mean < 4.0 && mean < 0.4 * off,
        "mean |left − warped right| {mean:.2} grey levels (one pixel off: {off:.2})"
    );
}

#[test]
fn zoo_worlds_through_the_builtin_rig_pass_the_whole_chain() {
    for name in ["clutter", "terrain"] {
        let scene = SceneDescription { stereo_world: Some(zoo(name)), ..SceneDescription::builtin() };
        scene.validate().unwrap();
        let dir = std::env::temp_dir().join(format!("parallax-world-{name}-{}", std::process::id()));
        let report = run_scene(name, &scene, &dir, None).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(report.verdict(), "pipeline: PASS", "{name}\n{}", report.table());
        let bad2 = report.rows.iter().find(|r| r.stage == "disparity" && r.figure.starts_with("bad-2")).unwrap();
        assert!(bad2.value < bad2.tolerance, "{name}: {}", report.table());
    }
}

#[test]
fn a_scene_with_a_world_round_trips_through_ron_and_scales_with_its_unit() {
    let scene = SceneDescription { stereo_world: Some(zoo("spheres")), ..SceneDescription::builtin() };
    let back = SceneDescription::from_ron(&scene.to_ron()).unwrap();
    assert_eq!(back, scene);
    let metres = scene.in_unit(0.001, "m");
    let w = metres.stereo_world.unwrap();
    assert!((w.baseline - 0.1e-3).abs() < 1e-15, "{}", w.baseline);
    // the scene without a world writes no world (files of earlier versions stay as they were)
    assert!(!SceneDescription::builtin().to_ron().contains("stereo_world"));
}
