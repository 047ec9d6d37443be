//! Wide-angle rectification against OpenCV 5.0.0's `cv2.fisheye` (the script and provenance
//! note are in `tests/reference/opencv_fisheye_rectify.py`) and against the geometry itself:
//! shared rows, triangulation through `Q` and through the wide views.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Intrinsics, Isometry3, KannalaBrandt, Lens, StereoRig};
use parallax_stereo_rectify::{
    RectifyConfig, RectifyError, WideProjection, WideView, estimate_new_camera_matrix_for_undistort_rectify,
    init_undistort_rectify_map, rectify_points, rectify_points_wide, rectifying_rotations, stereo_rectify,
    wide_rectify,
};

type NewK = (f64, f64, [u32; 2], [[f64; 3]; 3]);
type Stereo = (bool, f64, f64, [[f64; 3]; 3], [[f64; 3]; 3], [[f64; 4]; 3], [[f64; 4]; 3], [[f64; 4]; 4]);
type MapAt = ([u32; 2], [f64; 2]);

fn reference() -> (Vec<NewK>, Vec<Stereo>, Vec<MapAt>) {
    let (a, b, c): ([NewK; 4], [Stereo; 2], [MapAt; 5]) = include!("reference/opencv_fisheye_rectify.in");
    (a.to_vec(), b.to_vec(), c.to_vec())
}

fn camera(fx: f64, fy: f64, cx: f64, cy: f64, k: [f64; 4]) -> Camera {
    Camera::new(
        Intrinsics::new(fx, fy, cx, cy),
        Lens::KannalaBrandt(KannalaBrandt::new(k[0], k[1], k[2], k[3]).unwrap()),
        1024,
        768,
    )
    .unwrap()
}

fn rig() -> StereoRig {
    StereoRig::new(
        camera(330.0, 328.0, 515.0, 380.0, [0.03, -0.01, 0.002, -0.0003]),
        camera(335.0, 334.0, 508.0, 388.0, [0.025, -0.008, 0.0015, -0.0002]),
        Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.03, 0.02), DVec3::new(-60.0, 1.5, 0.8)),
    )
    .unwrap()
}

fn mat3(rows: [[f64; 3]; 3]) -> DMat3 {
    DMat3::from_cols_array_2d(&rows).transpose()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * (1.0 + b.abs())
}

/// `estimate_new_camera_matrix_for_undistort_rectify` matches OpenCV to 1e-9 relative for every
/// balance, fov_scale and new size of the reference.
#[test]
fn new_camera_matrix_matches_opencv() {
    let (cases, _, _) = reference();
    let cam = rig().left;
    for (balance, fov_scale, ns, expected) in cases {
        let cfg =
            RectifyConfig { balance, fov_scale, new_size: (ns[0] > 0).then_some((ns[0], ns[1])), ..Default::default() };
        let k = estimate_new_camera_matrix_for_undistort_rectify(&cam, DMat3::IDENTITY, &cfg).unwrap();
        let e = mat3(expected);
        for c in 0..3 {
            for r in 0..3 {
                assert!(close(k.col(c)[r], e.col(c)[r], 1e-9), "balance {balance}: {k} vs {e}");
            }
        }
    }
}

/// `stereo_rectify` on a Kannala–Brandt rig matches `cv2.fisheye.stereoRectify`: R1, R2 to 1e-12, P1, P2, Q to
/// 1e-9 relative; and the map of the left camera matches `cv2.fisheye.initUndistortRectifyMap`
/// to 1e-3 px (OpenCV's and our maps are f32).
#[test]
fn stereo_rectify_and_map_match_opencv() {
    let (_, stereo, maps) = reference();
    let rig = rig();
    for (zd, balance, fov_scale, r1, r2, p1, p2, q) in stereo {
        let cfg =
            RectifyConfig { balance, fov_scale, new_size: Some((1024, 768)), zero_disparity: zd, ..Default::default() };
        let rect = stereo_rectify(&rig, &cfg).unwrap();
        for (got, exp) in [(rect.r1, mat3(r1)), (rect.r2, mat3(r2))] {
            assert!((got - exp).abs().to_cols_array().iter().all(|d| *d < 1e-12), "{got} vs {exp}");
        }
        for (got, exp) in [(rect.p1.rows, p1), (rect.p2.rows, p2)] {
            for r in 0..3 {
                for c in 0..4 {
                    assert!(close(got[r][c], exp[r][c], 1e-9), "P[{r}][{c}] {} vs {}", got[r][c], exp[r][c]);
                }
            }
        }
        for r in 0..4 {
            for c in 0..4 {
                assert!(close(rect.q[r][c], q[r][c], 1e-9), "Q[{r}][{c}] {} vs {}", rect.q[r][c], q[r][c]);
            }
        }
        if zd && balance == 0.0 {
            let map = init_undistort_rectify_map(&rig.left, rect.r1, rect.left_camera_matrix(), 1024, 768).unwrap();
            for ([u, v], [mx, my]) in &maps {
                let (x, y) = map.source(*u, *v).unwrap();
                assert!(
                    (f64::from(x) - mx).abs() < 1e-3 && (f64::from(y) - my).abs() < 1e-3,
                    "({u},{v}): {x},{y} vs {mx},{my}"
                );
            }
            // The valid-pixel rectangle has a source for every pixel inside the image.
            let roi = rect.roi1;
            assert!(roi.area() > 0);
            for (u, v) in [(roi.x, roi.y), (roi.x + roi.width - 1, roi.y + roi.height - 1)] {
                let (x, y) = map.source(u, v).unwrap();
                assert!(rig.left.contains(DVec2::new(f64::from(x), f64::from(y))), "roi corner ({u},{v}) -> ({x},{y})");
            }
        }
    }
}

/// A scene point seen by both cameras lands on the same rectified row (pinhole output and both
/// wide views) and is recovered from its disparity: through `Q` for the pinhole, through
/// [`WideView::reproject`] for the wide views, including points beside the rig (beyond 90°).
#[test]
fn rows_align_and_disparity_triangulates() {
    let rig = rig();
    let rect = stereo_rectify(&rig, &RectifyConfig { balance: 0.5, ..Default::default() }).unwrap();
    let (r1, r2, t) = rectifying_rotations(&rig.right_from_left).unwrap();
    assert!(r1 == rect.r1 && r2 == rect.r2);
    let k1 = rect.left_camera_matrix();
    let k2 = rect.right_camera_matrix();
    for x in [DVec3::new(40.0, -30.0, 500.0), DVec3::new(-300.0, 120.0, 400.0), DVec3::new(10.0, 5.0, 2000.0)] {
        let pl = rig.left.project(x).unwrap();
        let pr = rig.right.project(rig.right_from_left.transform_point(x)).unwrap();
        let to_rect = |cam: &Camera, r: DMat3, k: DMat3, p: DVec2| {
            let q = k * (r * cam.unproject(p).unwrap());
            DVec2::new(q.x / q.z, q.y / q.z)
        };
        let (l, r) = (to_rect(&rig.left, r1, k1, pl), to_rect(&rig.right, r2, k2, pr));
        assert!((l.y - r.y).abs() < 1e-9, "rows {} vs {}", l.y, r.y);
        let p = rect.reproject(l, l.x - r.x).unwrap();
        assert!((p - r1 * x).length() < 1e-9 * x.length(), "{p} vs {}", r1 * x);
        let lp = rectify_points(&rig.left, r1, &rect.p1, &[pl]).unwrap()[0];
        let rp = rectify_points(&rig.right, r2, &rect.p2, &[pr]).unwrap()[0];
        assert!((lp - l).length() < 1e-9 && (rp - r).length() < 1e-9);
    }
    for projection in [WideProjection::Equirectangular, WideProjection::Cylindrical] {
        let view = WideView::with_field_of_view(projection, 160.0, 200.0, 1024, 768).unwrap();
        // Beside the rig too: 100° from the left camera's axis, below it.
        for x in [DVec3::new(40.0, -30.0, 500.0), DVec3::new(-100.0, 400.0, -70.0), DVec3::new(30.0, 5.0, 3000.0)] {
            let xl = r1 * x;
            let xr = r2 * rig.right_from_left.transform_point(x);
            let (l, r) = (view.pixel(xl).unwrap(), view.pixel(xr).unwrap());
            assert!((l.y - r.y).abs() < 1e-9, "{projection:?}: rows {} vs {}", l.y, r.y);
            let pl = rig.left.project(x).unwrap();
            let pr = rig.right.project(rig.right_from_left.transform_point(x)).unwrap();
            let lp = rectify_points_wide(&rig.left, r1, &view, &[pl]).unwrap()[0];
            let rp = rectify_points_wide(&rig.right, r2, &view, &[pr]).unwrap()[0];
            assert!((lp - l).length() < 1e-9 && (rp - r).length() < 1e-9, "{lp} {l} {rp} {r}");
            let p = view.reproject(l, l.x - r.x, t.x.abs()).unwrap();
            assert!((p - xl).length() < 1e-9 * x.length(), "{projection:?}: {p} vs {xl}");
            let back = view.pixel(view.ray(l)).unwrap();
            assert!((back - l).length() < 1e-9);
        }
    }
}

/// A 190° lens: the pinhole target is refused (its edge midpoints lie beyond 90°), the wide
/// view keeps them, and its map finds a source for rays behind the image plane.
#[test]
fn wide_views_hold_what_a_pinhole_cannot() {
    let wide = camera(290.0, 290.0, 511.5, 383.5, [0.021, -0.0043, 0.0011, -0.00017]);
    let err = estimate_new_camera_matrix_for_undistort_rectify(&wide, DMat3::IDENTITY, &RectifyConfig::default())
        .unwrap_err();
    assert!(matches!(err, RectifyError::Degenerate(ref m) if m.contains("WideView")), "{err}");
    let rig = StereoRig::new(wide, wide, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-80.0, 0.0, 0.0))).unwrap();
    let view = WideView::with_field_of_view(WideProjection::Equirectangular, 180.0, 180.0, 721, 721).unwrap();
    let w = wide_rectify(&rig, &view).unwrap();
    assert!((w.baseline - 80.0).abs() < 1e-12);
    // Output column 10 looks ~87.5° to the left of the normal to the baseline: a ray with z ≈ 0.04.
    let (x, y) = w.left_map.source(10, 360).unwrap();
    assert!(x.is_finite() && y.is_finite());
    let ray = w.view.ray(DVec2::new(10.0, 360.0));
    let expected = wide.project(w.r1.transpose() * ray).unwrap();
    assert!((f64::from(x) - expected.x).abs() < 1e-3 && (f64::from(y) - expected.y).abs() < 1e-3);
    // Rows 0 and 720 look straight up and down (ψ = ∓90°): still inside the 190° lens.
    assert!(w.left_map.source(360, 0).unwrap().0.is_finite());
    // Swapped cameras and bad configurations are errors.
    let swapped =
        StereoRig::new(wide, wide, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(80.0, 0.0, 0.0))).unwrap();
    assert!(matches!(wide_rectify(&swapped, &view), Err(RectifyError::Config(_))));
    assert!(WideView::with_field_of_view(WideProjection::Cylindrical, 185.0, 90.0, 100, 100).is_err());
    assert!(WideView::new(WideProjection::Equirectangular, -1.0, 0.0, 0.0, 10, 10).is_err());
    let bad = RectifyConfig { balance: 1.5, ..Default::default() };
    assert!(matches!(stereo_rectify(&rig, &bad), Err(RectifyError::Config(_))));
    // A pixel no ray maps to is named in the error.
    let far = DVec2::new(5000.0, 5000.0);
    let err = rectify_points_wide(&wide, w.r1, &view, &[DVec2::new(500.0, 300.0), far]).unwrap_err();
    assert!(matches!(err, RectifyError::Point { index: 1, .. }), "{err}");
    let zero = StereoRig::new(wide, wide, Isometry3::IDENTITY).unwrap();
    assert!(matches!(wide_rectify(&zero, &view), Err(RectifyError::ZeroBaseline(_))));
}

/// One `Rectifier` for any lens: on a Kannala–Brandt rig its maps are the ones of
/// `init_undistort_rectify_map` (checked against OpenCV's fisheye map above), and an option of
/// the other lens family is refused naming it, for both families.
#[test]
fn one_rectifier_for_every_lens() {
    let rig = rig();
    let config = RectifyConfig { balance: 0.3, ..Default::default() };
    let rectifier = parallax_stereo_rectify::Rectifier::new(&rig, &config).unwrap();
    let rect = *rectifier.rectification();
    assert_eq!(rect, stereo_rectify(&rig, &config).unwrap());
    let expected = init_undistort_rectify_map(&rig.right, rect.r2, rect.right_camera_matrix(), 1024, 768).unwrap();
    let got = rectifier.right_map();
    let mut sources = 0;
    for (v, u) in (0..768).step_by(7).flat_map(|v| (0..1024).step_by(5).map(move |u| (v, u))) {
        let (a, b) = (got.source(u, v), expected.source(u, v));
        assert_eq!(a, b, "({u}, {v})");
        sources += usize::from(a.is_some());
    }
    assert!(sources > 10_000, "{sources} pixels with a source");
    let alpha = RectifyConfig { alpha: Some(0.0), ..Default::default() };
    let e = stereo_rectify(&rig, &alpha).unwrap_err().to_string();
    assert!(e.contains("alpha") && e.contains("kannala-brandt") && e.contains("balance"), "{e}");
    let pinhole = |c: &Camera| Camera::new(c.intrinsics, parallax_camera_model::Distortion::default(), 1024, 768);
    let bc = StereoRig::new(pinhole(&rig.left).unwrap(), pinhole(&rig.right).unwrap(), rig.right_from_left).unwrap();
    let e = stereo_rectify(&bc, &config).unwrap_err().to_string();
    assert!(e.contains("balance") && e.contains("Brown–Conrady"), "{e}");
    assert!(stereo_rectify(&bc, &alpha).is_ok());
}
