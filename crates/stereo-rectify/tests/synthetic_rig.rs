//! Rectification accuracy against ground truth on synthetic rigs (true corners, true depth).

mod common;

use glam::{DVec2, DVec3};
use parallax_camera_model::StereoRig;
use parallax_stereo_rectify::{
    ExtentMethod, Rectification, Rectifier, RectifyConfig, RectifyError, init_undistort_rectify_map, rectify_points,
    stereo_rectify,
};

fn dv_stats(rig: &StereoRig, rect: &Rectification, views: &[(Vec<DVec2>, Vec<DVec2>)]) -> (f64, f64, usize) {
    let idx = usize::from(rect.vertical);
    let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0);
    for (l, r) in views {
        let rl = rectify_points(&rig.left, rect.r1, &rect.p1, l).unwrap();
        let rr = rectify_points(&rig.right, rect.r2, &rect.p2, r).unwrap();
        for (a, b) in rl.iter().zip(&rr) {
            // across the baseline: v for horizontal rigs, u for vertical ones
            let d = (a[1 - idx] - b[1 - idx]).abs();
            sum += d;
            max = max.max(d);
            n += 1;
        }
    }
    (sum / n as f64, max, n)
}

/// Issue bar: true corners of every view, rectified, agree across the baseline to ≤ 0.01 px
/// mean and ≤ 0.05 px max (distortion, vertical offset and rotation in the rig).
#[test]
fn true_corners_share_rows_after_rectification() {
    for (name, rig) in [("horizontal", common::horizontal_rig()), ("vertical", common::vertical_rig())] {
        let views = common::board_views(&rig, 20, 7);
        for extents in [ExtentMethod::OpenCv, ExtentMethod::Exact] {
            for alpha in [None, Some(0.0), Some(1.0)] {
                let cfg = RectifyConfig { alpha, extents, ..Default::default() };
                let rect = stereo_rectify(&rig, &cfg).unwrap();
                assert_eq!(rect.vertical, name == "vertical");
                let (mean, max, n) = dv_stats(&rig, &rect, &views);
                println!("{name} {extents:?} alpha {alpha:?}: {n} corners, mean |dv| {mean:.2e} px, max {max:.2e} px");
                assert!(mean <= 0.01 && max <= 0.05, "{name}: mean {mean} max {max}");
                // Exact data: the rectification is exact to numerical precision.
                assert!(max < 1e-6, "{name}: max {max}");
            }
        }
    }
}

/// The maps are the inverse of the point rectification: a rectified pixel's source position,
/// rectified again, lands back on that pixel (to the f32 storage precision of the maps).
#[test]
fn maps_invert_point_rectification() {
    let rig = common::horizontal_rig();
    let rect = stereo_rectify(&rig, &RectifyConfig { alpha: Some(0.0), ..Default::default() }).unwrap();
    let rectifier = Rectifier::from_rectification(&rig, rect).unwrap();
    for (camera, map, r, p) in
        [(&rig.left, rectifier.left_map(), rect.r1, rect.p1), (&rig.right, rectifier.right_map(), rect.r2, rect.p2)]
    {
        let mut worst = 0.0f64;
        for v in (0..480).step_by(7) {
            for u in (0..640).step_by(7) {
                let (x, y) = map.source(u, v).unwrap();
                let back = rectify_points(camera, r, &p, &[DVec2::new(x as f64, y as f64)]).unwrap()[0];
                worst = worst.max((back - DVec2::new(u as f64, v as f64)).length());
            }
        }
        println!("map round trip: worst {worst:.2e} px");
        assert!(worst < 2e-3, "worst {worst}");
    }
}

/// Q turns the disparity of a scene point back into the point (relative error ≤ 1e-9 for exact
/// input), both from exact rectified projections and through distortion + rectify_points.
#[test]
fn q_reprojects_disparity_to_true_depth() {
    for rig in [common::horizontal_rig(), common::vertical_rig()] {
        for cfg in [
            RectifyConfig { alpha: Some(0.0), ..Default::default() },
            RectifyConfig { alpha: Some(0.6), zero_disparity: false, new_size: Some((800, 500)), ..Default::default() },
        ] {
            let rect = stereo_rectify(&rig, &cfg).unwrap();
            let idx = usize::from(rect.vertical);
            let mut worst_exact = 0.0f64;
            let mut worst_chain = 0.0f64;
            for x_left in common::scene_points(200, 3) {
                let truth = rect.r1 * x_left; // the point in the rectified left frame
                // exact rectified projections
                let pl = rect.p1.project(truth).unwrap();
                let pr = rect.p2.project(truth).unwrap();
                let d = pl[idx] - pr[idx];
                let back = reproject(&rect, pl, d);
                worst_exact = worst_exact.max((back - truth).length() / truth.length());
                assert!((back.z - truth.z).abs() <= 1e-9 * truth.z);
                // through the distorted cameras
                let (Ok(a), Ok(b)) =
                    (rig.left.project(x_left), rig.right.project(rig.right_from_left.transform_point(x_left)))
                else {
                    continue;
                };
                let l = rectify_points(&rig.left, rect.r1, &rect.p1, &[a]).unwrap()[0];
                let r = rectify_points(&rig.right, rect.r2, &rect.p2, &[b]).unwrap()[0];
                // rectify_points drops P2's last column, so the disparity is plain l - r.
                let back = reproject(&rect, l, l[idx] - r[idx]);
                worst_chain = worst_chain.max((back - truth).length() / truth.length());
            }
            println!("Q: worst relative error {worst_exact:.2e} (exact), {worst_chain:.2e} (through distortion)");
            assert!(worst_exact <= 1e-9 && worst_chain <= 1e-9, "{worst_exact} {worst_chain}");
        }
    }
}

fn reproject(rect: &Rectification, pixel: DVec2, d: f64) -> DVec3 {
    rect.reproject(pixel, d).unwrap()
}

/// alpha = 0 (exact extents): every pixel inside both ROIs has its source inside the source
/// image; alpha = 1: every source pixel lands inside the rectified image.
#[test]
fn alpha_zero_is_all_valid_and_alpha_one_keeps_every_pixel() {
    for rig in [common::horizontal_rig(), common::vertical_rig()] {
        let rect0 = stereo_rectify(
            &rig,
            &RectifyConfig { alpha: Some(0.0), extents: ExtentMethod::Exact, ..Default::default() },
        )
        .unwrap();
        assert!(rect0.roi1.area() > 600 * 450 && rect0.roi2.area() > 600 * 450, "{:?} {:?}", rect0.roi1, rect0.roi2);
        let (bad, _) = invalid_in_roi(&rig, &rect0);
        assert_eq!(bad, 0, "alpha 0: {bad} invalid pixels inside the ROIs");

        let rect1 = stereo_rectify(
            &rig,
            &RectifyConfig { alpha: Some(1.0), extents: ExtentMethod::Exact, ..Default::default() },
        )
        .unwrap();
        let lost = lost_source_pixels(&rig, &rect1, 1);
        assert_eq!(lost, 0, "alpha 1: {lost} source pixels outside the rectified image");
        // alpha = 1 is tight: some source border pixel lies within a pixel of the rectified border.
        assert!(rect1.focal() < rect0.focal());
        let rect_tight = stereo_rectify(
            &rig,
            &RectifyConfig { alpha: Some(1.0), extents: ExtentMethod::Exact, new_size: None, ..Default::default() },
        )
        .unwrap();
        let mut zoomed = rect_tight;
        zoomed.p1.rows[0][0] *= 1.01;
        zoomed.p1.rows[1][1] *= 1.01;
        zoomed.p2.rows[0][0] *= 1.01;
        zoomed.p2.rows[1][1] *= 1.01;
        assert!(lost_source_pixels(&rig, &zoomed, 1) > 0, "alpha 1 is not tight");

        // OpenCV-compatible extents: report how close they come (sparse border samples).
        let rect_cv = stereo_rectify(&rig, &RectifyConfig { alpha: Some(0.0), ..Default::default() }).unwrap();
        let (bad_cv, worst_cv) = invalid_in_roi(&rig, &rect_cv);
        let rect_cv1 = stereo_rectify(&rig, &RectifyConfig { alpha: Some(1.0), ..Default::default() }).unwrap();
        println!(
            "OpenCV-compatible extents: alpha 0 leaves {bad_cv} invalid ROI pixels (worst {worst_cv:.3} px outside); \
             alpha 1 loses {} source pixels",
            lost_source_pixels(&rig, &rect_cv1, 1)
        );
    }
}

/// Count of ROI pixels whose source lies outside `[0, w-1] x [0, h-1]` (tolerance 1e-3 px for
/// the f32 maps), and the worst distance outside.
fn invalid_in_roi(rig: &StereoRig, rect: &Rectification) -> (usize, f64) {
    let (mut bad, mut worst) = (0, 0.0f64);
    for (camera, r, k, roi) in [
        (&rig.left, rect.r1, rect.left_camera_matrix(), rect.roi1),
        (&rig.right, rect.r2, rect.right_camera_matrix(), rect.roi2),
    ] {
        let map = init_undistort_rectify_map(camera, r, k, rect.width, rect.height).unwrap();
        let (w, h) = (camera.width as f32 - 1.0, camera.height as f32 - 1.0);
        for v in roi.y..roi.y + roi.height {
            for u in roi.x..roi.x + roi.width {
                let (x, y) = map.source(u, v).unwrap();
                let out = (-x).max(x - w).max(-y).max(y - h);
                if out > 1e-3 {
                    bad += 1;
                    worst = worst.max(out as f64);
                }
            }
        }
    }
    (bad, worst)
}

/// Source pixels (every `step`-th) that rectify outside `[0, W'-1] x [0, H'-1]` (tolerance 1e-6).
fn lost_source_pixels(rig: &StereoRig, rect: &Rectification, step: usize) -> usize {
    let (w, h) = (rect.width as f64 - 1.0, rect.height as f64 - 1.0);
    let mut lost = 0;
    for (camera, r, p) in [(&rig.left, rect.r1, rect.p1), (&rig.right, rect.r2, rect.p2)] {
        let pixels: Vec<DVec2> = (0..camera.height as usize)
            .step_by(step)
            .flat_map(|v| (0..camera.width as usize).step_by(step).map(move |u| DVec2::new(u as f64, v as f64)))
            .collect();
        for q in rectify_points(camera, r, &p, &pixels).unwrap() {
            if q.x < -1e-6 || q.y < -1e-6 || q.x > w + 1e-6 || q.y > h + 1e-6 {
                lost += 1;
            }
        }
    }
    lost
}

#[test]
fn bad_input_is_rejected_with_clear_errors() {
    let mut rig = common::horizontal_rig();
    let err = stereo_rectify(&rig, &RectifyConfig { alpha: Some(1.5), ..Default::default() }).unwrap_err();
    assert!(matches!(err, RectifyError::Config(_)), "{err}");
    let err = stereo_rectify(&rig, &RectifyConfig { alpha: Some(f64::NAN), ..Default::default() }).unwrap_err();
    assert!(matches!(err, RectifyError::Config(_)), "{err}");
    let err = stereo_rectify(&rig, &RectifyConfig { new_size: Some((0, 10)), ..Default::default() }).unwrap_err();
    assert!(matches!(err, RectifyError::Config(_)), "{err}");

    let mut zero = rig;
    zero.right_from_left.translation = DVec3::ZERO;
    assert!(matches!(stereo_rectify(&zero, &RectifyConfig::default()), Err(RectifyError::ZeroBaseline(_))));

    let mut other_size = rig;
    other_size.right.width = 800;
    assert!(matches!(stereo_rectify(&other_size, &RectifyConfig::default()), Err(RectifyError::SizeMismatch(_))));

    rig.left.intrinsics.fx = f64::NAN;
    let err = stereo_rectify(&rig, &RectifyConfig::default()).unwrap_err();
    assert!(err.to_string().contains("left camera"), "{err}");

    let rig = common::horizontal_rig();
    let rect = stereo_rectify(&rig, &RectifyConfig::default()).unwrap();
    let err =
        rectify_points(&rig.left, rect.r1, &rect.p1, &[DVec2::new(1.0, 2.0), DVec2::new(f64::NAN, 0.0)]).unwrap_err();
    assert!(matches!(err, RectifyError::Point { index: 1, .. }), "{err}");
    assert!(rectify_points(&rig.left, rect.r1, &rect.p1, &[]).unwrap().is_empty());
}
