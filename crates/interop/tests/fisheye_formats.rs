//! Fisheye cameras in every format: round trips of every format × lens model (mono and stereo),
//! files in each tool's own layout (`tests/data/`: OpenCV's written by `cv2.FileStorage`, ROS's
//! and Kalibr's hand-written after `camera_calibration` and Kalibr's camchain; provenance in
//! `tests/data/README.md`), the marker rules, and the refusals.

use std::path::{Path, PathBuf};

use glam::DVec3;
use parallax_camera_model::{Camera, DoubleSphere, Intrinsics, Isometry3, KannalaBrandt, Lens, StereoRig};
use parallax_interop::{
    Calibration, Format, MonoCalibration, Side, StereoCalibration, detect, parse, read, render, rig_from_ros_pair,
};
use parallax_stereo_rectify::{RectifyConfig, stereo_rectify};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

const ALL: [Format; 6] =
    [Format::OpenCvYaml, Format::OpenCvXml, Format::Json, Format::Ron, Format::Ros, Format::Kalibr];

fn kb(fx: f64, k: [f64; 4]) -> Camera {
    Camera::new(
        Intrinsics::new(fx, fx - 0.25, 319.25, 241.75),
        Lens::KannalaBrandt(KannalaBrandt::new(k[0], k[1], k[2], k[3]).unwrap()),
        640,
        480,
    )
    .unwrap()
}

fn ds(fx: f64, xi: f64, alpha: f64) -> Camera {
    Camera::new(
        Intrinsics::new(fx, fx - 0.25, 321.5, 238.25),
        Lens::DoubleSphere(DoubleSphere::new(xi, alpha).unwrap()),
        640,
        480,
    )
    .unwrap()
}

fn right_from_left() -> Isometry3 {
    Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.005), DVec3::new(-80.0, 0.5, 1.25))
}

fn mono(camera: Camera) -> Calibration {
    Calibration::Mono(MonoCalibration { camera, rms_px: Some(0.21), per_view_rms_px: vec![0.2, 0.22] })
}

fn stereo(left: Camera, right: Camera) -> Calibration {
    Calibration::Stereo(StereoCalibration {
        rig: StereoRig::new(left, right, right_from_left()).unwrap(),
        rectification: None,
        rms_px: Some(0.3),
        per_view_rms_px: vec![[0.2, 0.25], [0.3, 0.35]],
    })
}

/// `fx fy cx cy skew`, the lens parameters and the size.
fn params(c: &Camera) -> (Vec<f64>, u32, u32) {
    let k = c.intrinsics();
    let mut v = vec![k.fx, k.fy, k.cx, k.cy, k.skew];
    v.extend(c.lens().parameters());
    (v, c.width(), c.height())
}

fn max_abs(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn pose_error(a: &Isometry3, b: &Isometry3) -> f64 {
    let r = max_abs(&a.rotation_matrix().to_cols_array(), &b.rotation_matrix().to_cols_array());
    r.max((a.translation - b.translation).length() / b.translation.length())
}

/// Written and read back in `format`: the calibration it holds (ROS stereo: the two files read
/// as a pair).
fn round_trip(c: &Calibration, format: Format) -> parallax_interop::Result<(Calibration, Format)> {
    let files = render(c, format, Path::new("cam.yaml"))?;
    if files.len() == 2 {
        let (fl, vl) = detect(&files[0].1, "left").unwrap();
        let (fr, vr) = detect(&files[1].1, "right").unwrap();
        assert_eq!((fl, fr), (Format::Ros, Format::Ros));
        return Ok((rig_from_ros_pair(&vl, &vr, "pair").unwrap(), Format::Ros));
    }
    Ok(parse(&files[0].1, "cam").unwrap())
}

/// Every format × {Kannala–Brandt, double sphere} × {mono, stereo}: exact round trips (ROS's
/// rig goes through `R1 R2 P1 P2`: 1e-12), and double sphere refused by OpenCV and ROS with a
/// message naming the formats that hold it.
#[test]
fn every_format_round_trips_or_refuses_every_model() {
    let kb_l = kb(310.5, [0.021, -0.0052, 0.0011, -0.00021]);
    let kb_r = kb(309.75, [0.019, -0.0048, 0.0009, -0.00019]);
    let (ds_l, ds_r) = (ds(250.5, -0.2, 0.6), ds(249.75, -0.19, 0.61));
    for (name, c) in [
        ("KB mono", mono(kb_l)),
        ("DS mono", mono(ds_l)),
        ("KB stereo", stereo(kb_l, kb_r)),
        ("DS stereo", stereo(ds_l, ds_r)),
    ] {
        let is_ds = name.starts_with("DS");
        for format in ALL {
            let result = round_trip(&c, format);
            if is_ds && matches!(format, Format::OpenCvYaml | Format::OpenCvXml | Format::Ros) {
                let err = result.expect_err(&format!("{name} as {format:?}")).to_string();
                assert!(err.contains("double-sphere") && err.contains("kalibr") && err.contains("ron"), "{err}");
                continue;
            }
            let (back, detected) = result.unwrap_or_else(|e| panic!("{name} as {format:?}: {e}"));
            assert_eq!(detected, format, "{name}");
            assert_eq!(back.lens_model(), c.lens_model(), "{name} as {format:?}");
            match (&c, &back) {
                (Calibration::Mono(a), Calibration::Mono(b)) => {
                    // Every format holds the numbers exactly (17 significant digits).
                    assert_eq!(params(&a.camera), params(&b.camera), "{name} as {format:?}");
                    if !matches!(format, Format::Ros | Format::Kalibr) {
                        assert_eq!(a.rms_px, b.rms_px);
                        assert_eq!(a.per_view_rms_px, b.per_view_rms_px);
                    }
                }
                (Calibration::Stereo(a), Calibration::Stereo(b)) => {
                    assert_eq!(params(&a.rig.left), params(&b.rig.left), "{name} as {format:?}");
                    assert_eq!(params(&a.rig.right), params(&b.rig.right), "{name} as {format:?}");
                    let e = pose_error(&a.rig.right_from_left, &b.rig.right_from_left);
                    assert!(e < 1e-12, "{name} as {format:?}: right_from_left off by {e:e}");
                    if format == Format::Ros {
                        assert!(b.rectification.is_some(), "ROS carries R and P");
                    }
                }
                _ => panic!("{name} as {format:?}: read back as a {}", back.kind()),
            }
        }
    }
}

/// One calibration kind for every lens: a fisheye calibration hands its cameras on with their
/// lens, a pinhole file reads as a Brown–Conrady camera, and a rig of a pinhole and a wide lens
/// is refused by the formats that mark a whole rig with one family (OpenCV, ROS), naming both.
#[test]
fn fisheye_and_pinhole_are_not_confused() {
    let c = stereo(kb(310.5, [0.0; 4]), kb(310.5, [0.0; 4]));
    assert_eq!(c.camera(Side::Left, "f").unwrap(), kb(310.5, [0.0; 4]));
    assert_eq!(c.clone().into_stereo("f").unwrap().rig.right, kb(310.5, [0.0; 4]));
    let (pinhole, _) = read(&[data("cv2_mono.yml")]).unwrap();
    assert_eq!(pinhole.lens_model(), Some(parallax_camera_model::LensModel::BrownConrady));
    let plain = Camera::new(
        Intrinsics::new(600.0, 600.0, 319.5, 239.5),
        parallax_camera_model::Distortion::default(),
        640,
        480,
    )
    .unwrap();
    let mixed = stereo(plain, kb(310.5, [0.0; 4]));
    for format in [Format::OpenCvYaml, Format::Ros] {
        let err = render(&mixed, format, Path::new("x.yml")).unwrap_err().to_string();
        assert!(err.contains("brown-conrady") || err.contains("pinhole"), "{err}");
        assert!(err.contains("kannala-brandt"), "{err}");
    }
    let (back, _) = parse(&render(&mixed, Format::Json, Path::new("x.json")).unwrap()[0].1, "x.json").unwrap();
    assert_eq!(back.into_stereo("x").unwrap().rig, mixed.into_stereo("x").unwrap().rig);
}

/// `cv2.FileStorage` files in the layout of OpenCV's calibration sample with its fisheye option
/// (`fisheye_model: 1`, `D` 4x1) and a `cv::fisheye` stereo file (`D` 1x4): K and D exact; the
/// rectification cv2.fisheye.stereoRectify wrote is read, and ours reproduces it.
#[test]
fn opencv_written_fisheye_files() {
    let truth_l = Camera::new(
        Intrinsics::new(310.5, 310.25, 319.25, 241.75),
        Lens::KannalaBrandt(KannalaBrandt::new(0.021, -0.0052, 0.0011, -0.00021).unwrap()),
        640,
        480,
    )
    .unwrap();
    for name in ["cv2_fisheye_mono.yml", "cv2_fisheye_mono.xml"] {
        let (c, formats) = read(&[data(name)]).unwrap();
        assert_eq!(formats[0], if name.ends_with("xml") { Format::OpenCvXml } else { Format::OpenCvYaml });
        let Calibration::Mono(m) = c else { panic!("{name}: {}", c.kind()) };
        assert_eq!(params(&m.camera), params(&truth_l), "{name}");
        assert_eq!(m.rms_px, Some(0.2125));
    }
    let (c, _) = read(&[data("cv2_fisheye_stereo.yml")]).unwrap();
    let Calibration::Stereo(s) = c else { panic!("{}", c.kind()) };
    assert_eq!(params(&s.rig.left), params(&truth_l));
    let e = pose_error(&s.rig.right_from_left, &right_from_left());
    assert!(e < 1e-15, "R, T off by {e:e}");
    let cv = s.rectification.expect("R1 R2 P1 P2 Q");
    let ours = stereo_rectify(&s.rig, &RectifyConfig::default()).unwrap();
    let d_r = max_abs(&ours.r1.to_cols_array(), &cv.r1.to_cols_array());
    let d_p: f64 = (0..3).map(|r| max_abs(&ours.p2.rows[r], &cv.p2.rows[r])).fold(0.0, f64::max);
    println!("cv2.fisheye.stereoRectify vs ours: R1 {d_r:.3e}, P2 {d_p:.3e}");
    assert!(d_r < 1e-12, "R1 differs by {d_r:e}");
    // P2 holds f·Tx ≈ −2·10⁴: OpenCV's 10 Newton steps against our converged undistortion.
    assert!(d_p < 1e-6, "P2 differs by {d_p:e}");
}

/// No marker, 4 coefficients: OpenCV's own `k1 k2 p1 p2` (pinhole), never a guess at fisheye.
#[test]
fn four_coefficients_without_a_marker_are_pinhole() {
    let (c, _) = read(&[data("cv2_pinhole_d4.yml")]).unwrap();
    let Calibration::Mono(m) = c else { panic!("{}", c.kind()) };
    assert_eq!(m.camera.distortion().unwrap().to_array(), [-0.12, 0.05, 5e-4, -3e-4, 0.0, 0.0, 0.0, 0.0]);
    // `fisheye_model: 0` says the same; `1` with 5 coefficients is refused.
    let k = "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 300., 0., 320., 0., 300., 240., 0., 0., 1. ]\n";
    let file = |marker: &str, d: &str| {
        format!(
            "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n{marker}{k}distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: {}\n   dt: d\n   data: [ {d} ]\n",
            d.split(',').count()
        )
    };
    let (c, _) = parse(&file("fisheye_model: 0\n", "0.1, 0.01, 0.001, 0.0001"), "f0").unwrap();
    assert!(matches!(c, Calibration::Mono(_)), "{}", c.kind());
    let (c, _) = parse(&file("fisheye_model: 1\n", "0.1, 0.01, 0.001, 0.0001"), "f1").unwrap();
    let Calibration::Mono(m) = c else { panic!("{}", c.kind()) };
    assert_eq!(m.camera.lens().parameters(), vec![0.1, 0.01, 0.001, 0.0001]);
    let err = parse(&file("fisheye_model: 1\n", "0.1, 0.01, 0.001, 0.0001, 0.0"), "f5").unwrap_err().to_string();
    assert!(err.contains("exactly 4 coefficients") && err.contains("has 5"), "{err}");
    let err = parse(&file("fisheye_model: 2\n", "0.1, 0.01, 0.001, 0.0001"), "f2").unwrap_err().to_string();
    assert!(err.contains("fisheye_model: 2"), "{err}");
}

/// Two ROS camera_info files in camera_calibration's layout (`distortion_model: equidistant`):
/// a fisheye rig, R and T from the rectification and projection matrices.
#[test]
fn ros_equidistant_pair() {
    let (c, formats) = read(&[data("ros_equidistant_left.yaml"), data("ros_equidistant_right.yaml")]).unwrap();
    assert_eq!(formats, vec![Format::Ros, Format::Ros]);
    let Calibration::Stereo(s) = c else { panic!("{}", c.kind()) };
    let e = pose_error(&s.rig.right_from_left, &right_from_left());
    println!("ROS pair: right_from_left off by {e:.3e}");
    assert!(e < 1e-12, "{e:e}");
    assert_eq!(s.rig.right.lens().parameters(), vec![0.019, -0.0048, 0.0009, -0.00019]);
    // One file alone is a mono fisheye camera.
    let (c, _) = read(&[data("ros_equidistant_right.yaml")]).unwrap();
    assert!(matches!(c, Calibration::Mono(_)), "{}", c.kind());
    // A left equidistant and a right plumb_bob file are not one rig.
    let left = std::fs::read_to_string(data("ros_equidistant_left.yaml")).unwrap();
    let right = std::fs::read_to_string(data("ros_equidistant_right.yaml"))
        .unwrap()
        .replace("distortion_model: equidistant", "distortion_model: plumb_bob")
        .replace(
            "rows: 1\n  cols: 4\n  data: [0.019, -0.0048, 0.0009, -0.00019]",
            "rows: 1\n  cols: 5\n  data: [0.019, -0.0048, 0.0009, -0.00019, 0.0]",
        );
    let (_, vl) = detect(&left, "l").unwrap();
    let (_, vr) = detect(&right, "r").unwrap();
    let err = rig_from_ros_pair(&vl, &vr, "pair").unwrap_err().to_string();
    assert!(err.contains("one family"), "{err}");
}

/// Kalibr camchains (Kalibr's own layout: `cam_overlaps`, `rostopic`, `T_cn_cnm1`): pinhole-equi
/// and ds rigs; the same numbers as the OpenCV file; eucm, omni and mixed rigs refused.
#[test]
fn kalibr_camchains() {
    let (c, _) = read(&[data("kalibr_equi_stereo.yaml")]).unwrap();
    let Calibration::Stereo(k) = c else { panic!("{}", c.kind()) };
    let Calibration::Stereo(cv) = read(&[data("cv2_fisheye_stereo.yml")]).unwrap().0 else { panic!() };
    assert_eq!(params(&k.rig.left), params(&cv.rig.left));
    assert_eq!(params(&k.rig.right), params(&cv.rig.right));
    assert!(pose_error(&k.rig.right_from_left, &cv.rig.right_from_left) < 1e-15);

    let (c, _) = read(&[data("kalibr_ds_stereo.yaml")]).unwrap();
    let Calibration::Stereo(d) = c else { panic!("{}", c.kind()) };
    assert_eq!(params(&d.rig.left), params(&ds(250.5, -0.2, 0.6)));
    assert_eq!(params(&d.rig.right), params(&ds(249.75, -0.19, 0.61)));

    let text = std::fs::read_to_string(data("kalibr_ds_stereo.yaml")).unwrap();
    let eucm = text.replacen("camera_model: ds", "camera_model: eucm", 1);
    let err = parse(&eucm, "eucm").unwrap_err().to_string();
    assert!(err.contains("camera_model eucm is not supported"), "{err}");
    let bad = text.replacen("distortion_coeffs: []", "distortion_coeffs: [0.1]", 1);
    let err = parse(&bad, "ds+d").unwrap_err().to_string();
    assert!(err.contains("takes no distortion"), "{err}");
    let short = text.replacen("intrinsics: [-0.2, 0.6, 250.5,", "intrinsics: [250.5,", 1);
    let err = parse(&short, "ds4").unwrap_err().to_string();
    assert!(err.contains("[xi, alpha, fu, fv, pu, pv]"), "{err}");
    let equi = std::fs::read_to_string(data("kalibr_equi_stereo.yaml")).unwrap();
    let mixed = equi.replacen("distortion_model: equidistant", "distortion_model: radtan", 1);
    let err = parse(&mixed, "mixed").unwrap_err().to_string();
    assert!(err.contains("different families"), "{err}");
}

/// A native record edited in one place (`camera` against its `cv::fisheye` matrices, or the
/// `lens_model` name) is refused.
#[test]
fn native_records_are_checked() {
    let c = mono(kb(310.5, [0.021, -0.0052, 0.0011, -0.00021]));
    let json = &render(&c, Format::Json, Path::new("c.json")).unwrap()[0].1;
    assert!(json.contains("\"lens_model\": \"kannala_brandt\"") && json.contains("\"fisheye_model\": 1"), "{json}");
    let edited = json.replacen("0.021", "0.025", 1);
    let err = parse(&edited, "edited").unwrap_err().to_string();
    assert!(err.contains("disagree"), "{err}");
    let renamed = json.replace("\"lens_model\": \"kannala_brandt\"", "\"lens_model\": \"double_sphere\"");
    let err = parse(&renamed, "renamed").unwrap_err().to_string();
    assert!(err.contains("lens_model"), "{err}");
}

/// Pinhole files read as before the lens models: every committed pinhole file is a pinhole
/// calibration, and the OpenCV files parallax wrote are re-written byte for byte from what
/// is read (the reading is exact and the writer unchanged).
#[test]
fn pinhole_files_read_and_write_as_before() {
    for name in ["ours_mono.yml", "cv2_mono.yml", "cv2_mono.xml", "ours_mono.json"] {
        let (c, _) = read(&[data(name)]).unwrap();
        let pinhole = Some(parallax_camera_model::LensModel::BrownConrady);
        assert!(matches!(c, Calibration::Mono(_)) && c.lens_model() == pinhole, "{name}: {}", c.kind());
    }
    for name in ["ours_stereo.yml", "ours_stereo.xml", "ours_stereo.ron", "cv2_stereo.yml", "cv2_stereo.xml"] {
        let (c, _) = read(&[data(name)]).unwrap();
        assert!(matches!(c, Calibration::Stereo(_)), "{name}: {}", c.kind());
    }
    for (name, format) in [
        ("ours_mono.yml", Format::OpenCvYaml),
        ("ours_stereo.yml", Format::OpenCvYaml),
        ("ours_stereo.xml", Format::OpenCvXml),
    ] {
        let text = std::fs::read_to_string(data(name)).unwrap();
        let (c, detected) = parse(&text, name).unwrap();
        assert_eq!(detected, format);
        let again = &render(&c, format, Path::new(name)).unwrap()[0].1;
        assert_eq!(again, &text, "{name}: re-written differently");
    }
}
