//! The lens models of one camera type: OpenCV agreement, closed-form special cases, analytic
//! Jacobians against central differences, round trips over the valid field of view, refusals,
//! and the two file forms of a camera.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::{DVec2, DVec3};
use parallax_camera_model::{
    Camera, CameraModel, CameraModelError, Distortion, DoubleSphere, Intrinsics, Isometry3, KannalaBrandt, Lens,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(Config { cases, ..Config::default() }, TestRng::from_seed(RngAlgorithm::ChaCha, &[21; 32]))
}

fn kb(k: [f64; 4]) -> Lens {
    Lens::KannalaBrandt(KannalaBrandt::new(k[0], k[1], k[2], k[3]).unwrap())
}

fn ds(xi: f64, alpha: f64) -> Lens {
    Lens::DoubleSphere(DoubleSphere::new(xi, alpha).unwrap())
}

/// A 1024x768 camera whose horizontal field of view is about 190°.
fn kb_camera() -> Camera {
    Camera::new(
        Intrinsics { fx: 290.0, fy: 289.0, cx: 511.5, cy: 383.25, skew: 0.0 },
        kb([0.021, -0.0043, 0.0011, -0.00017]),
        1024,
        768,
    )
    .unwrap()
}

fn ds_camera() -> Camera {
    Camera::new(Intrinsics { fx: 350.0, fy: 348.0, cx: 511.5, cy: 383.25, skew: 0.0 }, ds(-0.18, 0.59), 1024, 768)
        .unwrap()
}

fn direction(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// `cv2.fisheye.projectPoints` and `cv2.fisheye.undistortPoints` (OpenCV 5.0.0; the script and
/// its provenance note are in `tests/reference/opencv_fisheye.py`) on points in front of the
/// camera: projection within 1e-9 px, undistortion within 1e-9 relative.
#[test]
fn agrees_with_opencv_fisheye() {
    let (projected, undistorted): ([[f64; 2]; 6], [[f64; 2]; 6]) = include!("reference/opencv_fisheye.in");
    let k = glam::DMat3::from_cols(
        DVec3::new(310.0, 0.0, 0.0),
        DVec3::new(0.0, 309.0, 0.0),
        DVec3::new(512.5, 383.25, 1.0),
    );
    let camera = Camera::from_opencv_kannala_brandt(k, &[0.021, -0.0043, 0.0011, -0.00017], 1024, 768).unwrap();
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.25, -0.35, 0.1), DVec3::new(-40.0, -30.0, 120.0));
    let obj = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(150.0, 0.0, 0.0),
        DVec3::new(0.0, 120.0, 0.0),
        DVec3::new(150.0, 120.0, 0.0),
        DVec3::new(-300.0, 60.0, 0.0),
        DVec3::new(260.0, -200.0, 0.0),
    ];
    for (x, e) in obj.iter().zip(projected) {
        assert!(pose.transform_point(*x).z > 0.0, "OpenCV's projection needs z > 0");
        let p = camera.project_from(&pose, *x).unwrap();
        assert!((p - DVec2::from_array(e)).length() < 1e-9, "{p} vs {e:?}");
    }
    let pixels = [
        DVec2::new(512.5, 383.25),
        DVec2::new(700.0, 383.25),
        DVec2::new(250.0, 150.0),
        DVec2::new(850.0, 650.0),
        DVec2::new(30.0, 383.0),
        DVec2::new(512.0, 10.0),
    ];
    for (p, e) in pixels.iter().zip(undistorted) {
        let ray = camera.unproject(*p).unwrap();
        let n = DVec2::new(ray.x / ray.z, ray.y / ray.z);
        let e = DVec2::from_array(e);
        assert!((n - e).length() <= 1e-9 * (1.0 + e.length()), "{n} vs {e}");
    }
}

/// Kannala–Brandt with zero coefficients is the equidistant projection `r = f θ`, also behind
/// the camera; double sphere reduces to the pinhole (`α = 0, ξ = 0`), the stereographic
/// projection with focal 2f (`ξ = 0, α = ½`: `r = 2f tan(θ/2)`) and the unified model with
/// `ξ = 1` (`α = 0`: `r = f tan(θ/2)`).
#[test]
fn special_cases_match_closed_forms() {
    let k = Intrinsics::new(250.0, 250.0, 400.0, 300.0);
    let cam = |lens| Camera::new(k, lens, 800, 600).unwrap();
    for &(theta, phi) in &[(0.3, 0.4), (1.2, -2.0), (1.7, 2.5), (2.9, 1.0)] {
        let d = direction(theta, phi) * 3.7;
        let p = cam(kb([0.0; 4])).project(d).unwrap();
        let expected = DVec2::new(400.0 + 250.0 * theta * phi.cos(), 300.0 + 250.0 * theta * phi.sin());
        assert!((p - expected).length() < 1e-10, "equidistant {p} vs {expected}");
        if theta < FRAC_PI_2 {
            let p = cam(ds(0.0, 0.0)).project(d).unwrap();
            let e = DVec2::new(400.0 + 250.0 * d.x / d.z, 300.0 + 250.0 * d.y / d.z);
            assert!((p - e).length() < 1e-9, "pinhole {p} vs {e}");
        }
        if theta < 2.3 {
            let r = 2.0 * 250.0 * (theta / 2.0).tan();
            let p = cam(ds(0.0, 0.5)).project(d).unwrap();
            let e = DVec2::new(400.0 + r * phi.cos(), 300.0 + r * phi.sin());
            assert!((p - e).length() < 1e-9, "stereographic {p} vs {e}");
            let p = cam(ds(1.0, 0.0)).project(d).unwrap();
            let e = DVec2::new(400.0 + 0.5 * r * phi.cos(), 300.0 + 0.5 * r * phi.sin());
            assert!((p - e).length() < 1e-9, "unified ξ = 1 {p} vs {e}");
        }
    }
}

/// Central differences (step 1e-6 relative) of every Jacobian, for both models, at points in
/// front of, beside and behind the image plane: agreement to 1e-6 (relative to the entry, plus
/// 1e-6 absolute).
#[test]
fn jacobians_match_central_differences() {
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.3, -0.2, 0.15), DVec3::new(0.1, -0.05, 0.2));
    let inv = pose.inverse();
    for camera in [
        kb_camera(),
        ds_camera(),
        kb_camera().with_intrinsics(Intrinsics { skew: 0.8, ..kb_camera().intrinsics() }).unwrap(),
    ] {
        let max = camera.max_field_angle();
        for &(theta, phi) in &[(0.0, 0.0), (1e-9, 0.3), (0.4, 1.0), (1.4, -2.2), (FRAC_PI_2, 0.7), (0.97 * max, 2.9)] {
            let point_object = inv.transform_point(direction(theta, phi) * 2.5);
            let j = camera.project_with_jacobians(&pose, point_object).unwrap();
            assert!((j.pixel - camera.project_from(&pose, point_object).unwrap()).length() < 1e-12);
            let check = |analytic: f64, fd: f64, what: &str| {
                assert!(
                    (analytic - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{what} at θ = {theta}: analytic {analytic}, numeric {fd}"
                );
            };
            let h = 1e-6;
            for c in 0..3 {
                let mut e = DVec3::ZERO;
                e[c] = h;
                let fd = (camera.project_from(&pose, point_object + e).unwrap()
                    - camera.project_from(&pose, point_object - e).unwrap())
                    / (2.0 * h);
                check(j.d_point[0][c], fd.x, "d_point");
                check(j.d_point[1][c], fd.y, "d_point");
            }
            for c in 0..6 {
                let mut d = [0.0; 6];
                d[c] = h;
                let plus = camera.project_from(&pose.retract(&d), point_object).unwrap();
                d[c] = -h;
                let minus = camera.project_from(&pose.retract(&d), point_object).unwrap();
                let fd = (plus - minus) / (2.0 * h);
                check(j.d_pose[0][c], fd.x, "d_pose");
                check(j.d_pose[1][c], fd.y, "d_pose");
            }
            let k0 = camera.intrinsics();
            for c in 0..5 {
                let shift = |s: f64| {
                    let mut k = [k0.fx, k0.fy, k0.cx, k0.cy, k0.skew];
                    k[c] += s;
                    let k = Intrinsics { fx: k[0], fy: k[1], cx: k[2], cy: k[3], skew: k[4] };
                    camera.with_intrinsics(k).unwrap().project_from(&pose, point_object).unwrap()
                };
                let hh = 1e-4;
                let fd = (shift(hh) - shift(-hh)) / (2.0 * hh);
                check(j.d_intrinsics[0][c], fd.x, "d_intrinsics");
                check(j.d_intrinsics[1][c], fd.y, "d_intrinsics");
            }
            let lens = camera.lens();
            let p0 = lens.parameters();
            for c in 0..lens.num_parameters() {
                let shift = |s: f64| {
                    let mut p = p0.clone();
                    p[c] += s;
                    camera
                        .with_lens(lens.with_parameters(&p).unwrap())
                        .unwrap()
                        .project_from(&pose, point_object)
                        .unwrap()
                };
                let fd = (shift(h) - shift(-h)) / (2.0 * h);
                check(j.d_distortion[0][c], fd.x, "d_lens");
                check(j.d_distortion[1][c], fd.y, "d_lens");
            }
            for c in lens.num_parameters()..8 {
                assert_eq!(j.d_distortion[0][c], 0.0);
                assert_eq!(j.d_distortion[1][c], 0.0);
            }
        }
    }
}

/// project ∘ unproject returns every pixel within 1e-9 px over the whole valid field of view
/// (θ up to 0.999 θ_max, any azimuth), and unproject ∘ project returns the direction within
/// 1e-9 rad up to 0.99 θ_max, for random Kannala–Brandt lenses (fields of view 150°–250°) and
/// random double sphere lenses (ξ ∈ [−0.4, 0.4], α ∈ [0.3, 0.75]).
#[test]
fn round_trips_over_the_valid_field_of_view() {
    let strategy = (
        (200.0..500.0f64, -0.05..0.05f64, -0.02..0.02f64, -0.005..0.005f64, -0.001..0.001f64),
        (-0.4..0.4f64, 0.3..0.75f64),
        0.0..1.0f64,
        -PI..PI,
    );
    runner(2000)
        .run(&strategy, |((f, k1, k2, k3, k4), (xi, alpha), s, phi)| {
            let k = Intrinsics { fx: f, fy: 0.998 * f, cx: 640.0, cy: 480.0, skew: 0.0 };
            for lens in [kb([k1, k2, k3, k4]), ds(xi, alpha)] {
                let camera = Camera::new(k, lens, 1280, 960).unwrap();
                let max = camera.max_field_angle();
                let d = direction(0.999 * max * s, phi);
                let pixel = camera.project(d).unwrap();
                let back = camera.project(camera.unproject(pixel).unwrap()).unwrap();
                prop_assert!((back - pixel).length() < 1e-9, "{lens:?}: {pixel} -> {back}");
                let d = direction(0.99 * max * s, phi);
                let ray = camera.unproject(camera.project(d).unwrap()).unwrap();
                prop_assert!((ray - d).length() < 1e-9, "{lens:?}: direction error {}", (ray - d).length());
                prop_assert!((ray.length() - 1.0).abs() < 1e-12);
            }
            Ok(())
        })
        .unwrap();
}

/// The valid region: Kannala–Brandt's `θ_max` is where `dθ_d/dθ` vanishes (checked by a
/// numeric derivative on each side), π when the polynomial never folds; points at or beyond it
/// and pixels beyond `θ_d(θ_max)` are refused; double sphere refuses `z ≤ −w2‖p‖` and pixels
/// beyond `r² = 1/(2α − 1)`.
#[test]
fn valid_regions_and_refusals() {
    let folding = KannalaBrandt::new(-0.05, 0.0, 0.0, 0.0).unwrap();
    // dθ_d/dθ = 1 − 0.15 θ² = 0 at θ = √(1/0.15).
    let t = (1.0f64 / 0.15).sqrt().min(PI);
    assert!((folding.max_theta() - t).abs() < 1e-12, "{} vs {t}", folding.max_theta());
    let cam =
        Camera::new(Intrinsics::new(300.0, 300.0, 500.0, 500.0), Lens::KannalaBrandt(folding), 1000, 1000).unwrap();
    assert!(matches!(cam.project(direction(t + 1e-6, 0.2)), Err(CameraModelError::OutsideValidRegion { .. })));
    assert!(cam.project(direction(t - 1e-3, 0.2)).is_ok());
    let limit = folding.distort_theta(t);
    let beyond = DVec2::new(500.0 + 300.0 * (limit + 1e-6), 500.0);
    assert!(
        matches!(cam.unproject(beyond), Err(CameraModelError::OutsideValidRegion { .. })),
        "{:?}",
        cam.unproject(beyond)
    );
    assert_eq!(KannalaBrandt::new(0.02, 0.0, 0.0, 0.0).unwrap().max_theta(), PI);
    // Straight behind a Kannala–Brandt camera there is no direction: refused.
    assert!(kb_camera().project(DVec3::new(0.0, 0.0, -1.0)).is_err());
    assert!(kb_camera().project(DVec3::ZERO).is_err());
    assert!(matches!(kb_camera().project(DVec3::new(f64::NAN, 0.0, 1.0)), Err(CameraModelError::NonFinite { .. })));
    // Double sphere: the boundary angle acos(−w2).
    let m = DoubleSphere::new(-0.18, 0.59).unwrap();
    let a: f64 = 0.59;
    let w1 = (1.0 - a) / a;
    let w2 = (w1 - 0.18) / (2.0 * w1 * -0.18 + 0.18 * 0.18 + 1.0f64).sqrt();
    assert!((m.max_theta() - (-w2).acos()).abs() < 1e-15);
    let c = ds_camera();
    assert!(c.project(direction(m.max_theta() + 1e-6, 1.0)).is_err());
    assert!(c.project(direction(m.max_theta() - 1e-3, 1.0)).is_ok());
    let r_max = (1.0 / (2.0 * a - 1.0)).sqrt();
    let beyond = c.intrinsics().to_pixel(DVec2::new(r_max * 1.001, 0.0));
    assert!(matches!(c.unproject(beyond), Err(CameraModelError::OutsideValidRegion { .. })));
    // Parameters out of their domain.
    assert!(matches!(DoubleSphere::new(1.2, 0.5), Err(CameraModelError::InvalidLens(_))));
    assert!(matches!(DoubleSphere::new(0.0, -0.1), Err(CameraModelError::InvalidLens(_))));
    assert!(matches!(KannalaBrandt::new(f64::INFINITY, 0.0, 0.0, 0.0), Err(CameraModelError::InvalidLens(_))));
    assert!(matches!(KannalaBrandt::from_opencv(&[0.1, 0.2, 0.3]), Err(CameraModelError::SizeMismatch(_))));
    assert!(Camera::new(Intrinsics::new(-1.0, 1.0, 0.0, 0.0), kb([0.0; 4]), 10, 10).is_err());
    assert!(Camera::new(Intrinsics::new(1.0, 1.0, 0.0, 0.0), kb([0.0; 4]), 0, 10).is_err());
}

/// A 190° lens images a point 95° off axis (behind the image plane) inside the image, and
/// its pixel unprojects to a ray with `z < 0`.
#[test]
fn images_points_behind_the_image_plane() {
    let camera = kb_camera();
    assert!(camera.max_field_angle() > 100f64.to_radians());
    let d = direction(95f64.to_radians(), 0.0);
    let p = camera.project(d).unwrap();
    assert!(camera.contains(p), "{p}");
    let ray = camera.unproject(p).unwrap();
    assert!(ray.z < 0.0 && (ray - d).length() < 1e-12);
}

/// Serialisation round trip, and deserialisation refuses out-of-domain parameters.
#[test]
fn serde_round_trip_and_refusal() {
    for camera in [kb_camera(), ds_camera()] {
        let text = ron::to_string(&camera).unwrap();
        let back: Camera = ron::from_str(&text).unwrap();
        assert_eq!(back, camera);
    }
    let text = ron::to_string(&ds_camera()).unwrap().replace("alpha:0.59", "alpha:1.5");
    assert!(text.contains("alpha:1.5"), "{text}");
    assert!(ron::from_str::<Camera>(&text).is_err());
}

/// The trait: the pinhole `Camera` behaves through `CameraModel` exactly as through its own
/// methods, and a generic function works for both camera types.
#[test]
fn pinhole_camera_through_the_trait() {
    fn project_generic<C: CameraModel>(c: &C, p: DVec3) -> DVec2 {
        c.project(p).unwrap()
    }
    let camera = Camera::new(
        Intrinsics::new(500.0, 501.0, 320.0, 240.0),
        Distortion::new(-0.2, 0.05, 0.001, -0.001, 0.0),
        640,
        480,
    )
    .unwrap();
    let p = DVec3::new(0.1, -0.2, 1.3);
    assert_eq!(project_generic(&camera, p), camera.project(p).unwrap());
    let px = DVec2::new(100.0, 400.0);
    assert_eq!(CameraModel::unproject_ray(&camera, px).unwrap(), camera.unproject(px).unwrap());
    assert!(!CameraModel::is_valid_direction(&camera, DVec3::new(0.0, 1.0, 0.0)));
    assert!(CameraModel::is_valid_direction(&kb_camera(), DVec3::new(0.0, 1.0, 0.0)));
    assert_eq!(CameraModel::num_lens_parameters(&camera), 8);
    assert_eq!(CameraModel::num_lens_parameters(&ds_camera()), 2);
}

/// A Brown–Conrady camera is written as before lenses were a choice (`distortion: (…)`, the
/// form every existing file holds: the text below is a pinhole camera as the release before
/// wrote it), a wide one with `lens: KannalaBrandt(…)` / `DoubleSphere(…)` (the form wide
/// cameras were written in); both read back to the same camera, and a camera with both or
/// neither is refused.
#[test]
fn files_keep_their_forms() {
    let pinhole = Camera::new(
        Intrinsics::new(800.0, 801.0, 320.5, 240.25),
        Distortion::new(-0.25, 0.125, 0.001, -0.002, 0.0625),
        640,
        480,
    )
    .unwrap();
    let old = "(intrinsics:(fx:800.0,fy:801.0,cx:320.5,cy:240.25,skew:0.0),distortion:(k1:-0.25,k2:0.125,p1:0.001,\
               p2:-0.002,k3:0.0625,k4:0.0,k5:0.0,k6:0.0),width:640,height:480)";
    assert_eq!(ron::to_string(&pinhole).unwrap(), old);
    assert_eq!(ron::from_str::<Camera>(old).unwrap(), pinhole);
    let wide_old = "(intrinsics:(fx:290.0,fy:289.0,cx:511.5,cy:383.25,skew:0.0),lens:KannalaBrandt((k1:0.021,\
                    k2:-0.0043,k3:0.0011,k4:-0.00017)),width:1024,height:768)";
    let wide = kb_camera();
    assert_eq!(ron::to_string(&wide).unwrap(), wide_old);
    assert_eq!(ron::from_str::<Camera>(wide_old).unwrap(), wide);
    let ds = ds_camera();
    assert_eq!(ron::from_str::<Camera>(&ron::to_string(&ds).unwrap()).unwrap(), ds);
    // A Brown–Conrady lens written in the `lens` form is read too.
    let as_lens = old.replace("distortion:(", "lens:BrownConrady((").replace(",width", "),width");
    assert_eq!(ron::from_str::<Camera>(&as_lens).unwrap(), pinhole);
    let both = old.replace(",width", ",lens:KannalaBrandt((k1:0.0,k2:0.0,k3:0.0,k4:0.0)),width");
    assert!(ron::from_str::<Camera>(&both).unwrap_err().to_string().contains("once"));
    let neither = "(intrinsics:(fx:800.0,fy:801.0,cx:320.5,cy:240.25,skew:0.0),width:640,height:480)";
    assert!(ron::from_str::<Camera>(neither).unwrap_err().to_string().contains("`lens`"));
    // Read cameras are checked: a zero focal length is refused.
    assert!(ron::from_str::<Camera>(&old.replace("fx:800.0", "fx:0.0")).is_err());
}
