//! One AprilTag (tag36h11) as a hand-eye target (issue 18): 30 synthetic views (blur 0.8 px,
//! noise σ 2 grey levels, tags of 60–200 px): found in every view, the right corner order,
//! corner RMS ≤ 0.05 px against the exact projections. `MARKER_DUMP=DIR` writes the views and
//! their truth.

use glam::{DQuat, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, MarkerDictionary, SingleMarker};
use parallax_corner_detection::{MarkerConfig, detect_single_marker};
use parallax_synthetic::{RenderOptions, render_marker, rng};
use rand::Rng;

#[test]
fn single_tag_corners_are_exact() {
    let cam = Camera {
        intrinsics: Intrinsics::new(760.0, 760.0, 402.0, 297.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width: 800,
        height: 600,
    };
    let tag = SingleMarker::new(MarkerDictionary::predefined("DICT_APRILTAG_36h11").unwrap(), 42, 80.0).unwrap();
    let mut r = rng(4);
    let (mut found, mut sum, mut n, mut worst) = (0, 0.0, 0, 0.0f64);
    for k in 0..30 {
        // The marker frame's z points towards the viewer: turn it away by π about x, then tilt.
        let tilt = DQuat::from_axis_angle(
            DVec3::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0), 0.0).normalize(),
            r.random_range(0.0f64..50.0).to_radians(),
        );
        let rot =
            tilt * DQuat::from_rotation_z(r.random_range(-3.1..3.1)) * DQuat::from_rotation_x(std::f64::consts::PI);
        let t = DVec3::new(r.random_range(-120.0..120.0), r.random_range(-80.0..80.0), r.random_range(300.0..900.0));
        let pose = Isometry3::from_quat_translation(rot, t);
        let opts = RenderOptions { blur_sigma: 0.8, noise_sigma: 2.0, seed: 50 + k, ..Default::default() };
        let view = render_marker(&cam, &tag, &pose, &opts, &[], 4.0).unwrap();
        assert!(view.visible.iter().all(|&v| v), "view {k}: tag not fully in the image");
        if let Ok(dir) = std::env::var("MARKER_DUMP") {
            // Image and truth (`u v` per corner, marker order) for other detectors.
            view.image.save(format!("{dir}/tag{k:02}.png")).unwrap();
            let truth: String = view.points.iter().map(|p| format!("{} {}\n", p.unwrap().x, p.unwrap().y)).collect();
            std::fs::write(format!("{dir}/tag{k:02}.truth.txt"), truth).unwrap();
        }
        let Some(obs) = detect_single_marker(&view.image, &tag, &MarkerConfig::default()).unwrap() else {
            println!("view {k}: not found");
            continue;
        };
        found += 1;
        for (p, t) in obs.points().iter().zip(&view.points) {
            let e = (*p - t.unwrap()).length();
            worst = worst.max(e);
            sum += e * e;
            n += 1;
        }
    }
    let rms = (sum / n.max(1) as f64).sqrt();
    println!("single tag36h11: found {found}/30, corner RMS {rms:.4} px, worst {worst:.4} px");
    assert_eq!(found, 30);
    assert!(worst < 0.5, "a corner {worst} px off: wrong order or bad refinement");
    assert!(rms <= 0.05, "RMS {rms}");
}
