//! Files written by OpenCV itself (`tests/data/cv2_*`, see `tests/data/README.md`) read by this
//! crate, against the native files parallax wrote for the same calibration (`ours_*`).

use std::path::{Path, PathBuf};

use glam::DMat3;
use parallax_interop::{Calibration, Format, Side, StereoCalibration, parse, read, read_stereo, render};
use parallax_stereo_rectify::{ExtentMethod, RectifyConfig, init_undistort_rectify_map, stereo_rectify};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn stereo(name: &str) -> StereoCalibration {
    read_stereo(&[data(name)]).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn max_abs(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn params(s: &StereoCalibration) -> Vec<f64> {
    let mut v = Vec::new();
    for c in [s.rig.left, s.rig.right] {
        let k = c.intrinsics;
        v.extend([k.fx, k.fy, k.cx, k.cy, k.skew]);
        v.extend(c.lens.parameters());
    }
    v.extend(s.rig.right_from_left.rotation_matrix().to_cols_array());
    v.extend(s.rig.right_from_left.translation.to_array());
    v
}

/// `rectify`'s default settings (alpha 0, zero disparity, OpenCV's extents).
fn config() -> RectifyConfig {
    let c = parallax_interop::default_rectify_config();
    assert_eq!((c.alpha, c.zero_disparity, c.extents), (Some(0.0), true, ExtentMethod::OpenCv));
    c
}

#[test]
fn every_opencv_written_stereo_file_holds_our_rig() {
    let ours = stereo("ours_stereo.ron");
    let p = params(&ours);
    for name in ["cv2_stereo.yml", "cv2_stereo.xml", "ours_stereo.yml", "ours_stereo.xml", "ours_stereo.json"] {
        let s = stereo(name);
        let d = max_abs(&params(&s), &p);
        println!("{name}: max |Δ| of K, D, R, T against ours_stereo.ron = {d:.3e}");
        // Numbers are written with 17 significant digits (exact); R goes through a quaternion
        // on our side, hence not bit-exact.
        assert!(d <= 1e-12, "{name}: {d}");
        assert_eq!((s.rig.left.width, s.rig.left.height), (640, 480));
    }
    // stereo_calib.cpp's two files, read together (in either order).
    for pair in [["cv2_intrinsics.yml", "cv2_extrinsics.yml"], ["cv2_extrinsics.yml", "cv2_intrinsics.yml"]] {
        let s = read_stereo(&pair.map(data)).unwrap();
        assert!(max_abs(&params(&s), &p) <= 1e-12, "{pair:?}");
        assert!(s.rectification.is_some());
    }
    // One of them alone is not a rig: the message says what is missing.
    let err = read(&[data("cv2_extrinsics.yml")]).unwrap_err().to_string();
    assert!(err.contains("no calibration found") || err.contains("M1"), "{err}");
}

#[test]
fn opencv_rectification_matches_ours_and_drives_the_same_maps() {
    let ron = stereo("ours_stereo.ron");
    let cv = stereo("cv2_stereo.yml");
    let written = cv.rectification.expect("cv2_stereo.yml holds R1 R2 P1 P2 Q");
    // Our Bouguet rectification of the rig OpenCV wrote, against OpenCV's stereoRectify.
    let mine = stereo_rectify(&cv.rig, &config()).unwrap();
    let m3 = |m: DMat3| m.to_cols_array().to_vec();
    let flat = |r: &[[f64; 4]]| r.iter().flatten().copied().collect::<Vec<f64>>();
    let diffs = [
        ("R1", max_abs(&m3(mine.r1), &m3(written.r1))),
        ("R2", max_abs(&m3(mine.r2), &m3(written.r2))),
        ("P1", max_abs(&flat(&mine.p1.rows), &flat(&written.p1.rows))),
        ("P2", max_abs(&flat(&mine.p2.rows), &flat(&written.p2.rows))),
        ("Q", max_abs(&flat(&mine.q), &flat(&written.q))),
    ];
    for (name, d) in diffs {
        println!("stereo_rectify vs cv2.stereoRectify {name}: {d:.3e}");
        assert!(d <= 1e-9, "{name}: {d}");
    }
    // The RON route and the OpenCV-file route give the same undistort-rectify maps.
    let ron_rect = stereo_rectify(&ron.rig, &config()).unwrap();
    let mut worst: f32 = 0.0;
    for (a_cam, a_r, a_p, b_cam, b_r, b_p) in [
        (ron.rig.left, ron_rect.r1, ron_rect.p1, cv.rig.left, mine.r1, mine.p1),
        (ron.rig.right, ron_rect.r2, ron_rect.p2, cv.rig.right, mine.r2, mine.p2),
    ] {
        let a = init_undistort_rectify_map(&a_cam, a_r, a_p.left_block(), 640, 480).unwrap();
        let b = init_undistort_rectify_map(&b_cam, b_r, b_p.left_block(), 640, 480).unwrap();
        for (x, y) in a.map_x.iter().chain(&a.map_y).zip(b.map_x.iter().chain(&b.map_y)) {
            assert_eq!(x.is_nan(), y.is_nan());
            if x.is_finite() {
                worst = worst.max((x - y).abs());
            }
        }
    }
    println!("maps, RON route vs cv2 file route: max |Δ| = {worst:.3e} px");
    assert!(worst <= 1e-4, "{worst}");
}

#[test]
fn opencv_written_mono_and_hand_eye_files_are_read() {
    let (ours, _) = read(&[data("ours_mono.json")]).unwrap();
    let Calibration::Mono(ours) = ours else { panic!("ours_mono.json is a mono result") };
    for name in ["cv2_mono.yml", "cv2_mono.xml", "ours_mono.yml"] {
        let (c, formats) = read(&[data(name)]).unwrap();
        let Calibration::Mono(m) = c else { panic!("{name}: not mono") };
        assert_eq!(m.camera, ours.camera, "{name}");
        assert_eq!(m.rms_px, ours.rms_px, "{name}");
        assert_eq!(m.per_view_rms_px, ours.per_view_rms_px, "{name}");
        assert!(matches!(formats[0], Format::OpenCvYaml | Format::OpenCvXml));
    }
    let (a, _) = read(&[data("cv2_handeye.yml")]).unwrap();
    let (b, _) = read(&[data("ours_handeye.yml")]).unwrap();
    let (Calibration::HandEye(a), Calibration::HandEye(b)) = (a, b) else { panic!("hand-eye files") };
    let (dr, dt) = a.transform.distance(&b.transform);
    assert!(dr < 1e-12 && dt < 1e-12, "{dr} {dt}");
    assert_eq!(b.method.as_deref(), Some("refined"));
    // A hand-eye file is no camera: asking for one names what it holds.
    let err = Calibration::HandEye(a).camera(Side::Left, "he").unwrap_err().to_string();
    assert!(err.contains("hand-eye"), "{err}");
}

#[test]
fn ros_camera_info_parses_as_yaml_with_its_fields_and_round_trips() {
    let ours = stereo("ours_stereo.ron");
    let cal = Calibration::Stereo(ours.clone());
    let files = render(&cal, Format::Ros, Path::new("/tmp/x/rig.yaml")).unwrap();
    assert_eq!(files[0].0, Path::new("/tmp/x/rig_left.yaml"));
    assert_eq!(files[1].0, Path::new("/tmp/x/rig_right.yaml"));
    let rect = ours.rectification.unwrap();
    for ((_, text), (cam, r, p)) in
        files.iter().zip([(ours.rig.left, rect.r1, rect.p1), (ours.rig.right, rect.r2, rect.p2)])
    {
        // Plain YAML, parsed independently of this crate's reader.
        let v: serde_yaml_ng::Value = serde_yaml_ng::from_str(text).unwrap();
        assert_eq!(v["image_width"].as_u64(), Some(640));
        assert_eq!(v["image_height"].as_u64(), Some(480));
        assert!(v["camera_name"].as_str().is_some());
        assert_eq!(v["distortion_model"].as_str(), Some("plumb_bob"));
        let data =
            |k: &str| -> Vec<f64> { v[k]["data"].as_sequence().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
        assert_eq!(data("camera_matrix"), parallax_interop::rows3(&cam.intrinsics.matrix()).concat());
        assert_eq!(data("distortion_coefficients"), cam.distortion().unwrap().to_array()[..5].to_vec());
        assert_eq!(data("rectification_matrix"), parallax_interop::rows3(&r).concat());
        assert_eq!(data("projection_matrix"), p.rows.concat());
        assert_eq!(v["projection_matrix"]["rows"].as_u64(), Some(3));
        assert_eq!(v["projection_matrix"]["cols"].as_u64(), Some(4));
    }
    // The pair read back is the rig (from R1, R2, P1, P2), to rounding.
    let dir = std::env::temp_dir().join(format!("interop-ros-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let paths: Vec<PathBuf> = files
        .iter()
        .map(|(p, t)| {
            let q = dir.join(p.file_name().unwrap());
            std::fs::write(&q, t).unwrap();
            q
        })
        .collect();
    let back = read_stereo(&paths).unwrap();
    let d = max_abs(&params(&back), &params(&ours));
    println!("ROS pair → rig: max |Δ| = {d:.3e}");
    assert!(d < 1e-9, "{d}");
    // Right before left is refused with the hint.
    let err = read_stereo(&[paths[1].clone(), paths[0].clone()]).unwrap_err().to_string();
    assert!(err.contains("left camera's file first"), "{err}");
    // One camera_info alone is that camera.
    let (one, formats) = read(&[paths[0].clone()]).unwrap();
    assert_eq!(formats, [Format::Ros]);
    assert_eq!(one.camera(Side::Left, "x").unwrap(), ours.rig.left);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn kalibr_camchain_round_trips_and_refuses_what_it_cannot_hold() {
    let mut ours = stereo("ours_stereo.ron");
    // Our calibration has k3 (not in radtan): refused, with the flag to use.
    let err = render(&Calibration::Stereo(ours.clone()), Format::Kalibr, Path::new("c.yaml")).unwrap_err();
    assert!(err.to_string().contains("--fix-k3"), "{err}");
    for c in [&mut ours.rig.left, &mut ours.rig.right] {
        let d = parallax_interop::parallax_camera_model::Distortion { k3: 0.0, ..*c.distortion().unwrap() };
        c.lens = d.into();
    }
    ours.rectification = None;
    ours.rms_px = None;
    ours.per_view_rms_px.clear();
    let text = &render(&Calibration::Stereo(ours.clone()), Format::Kalibr, Path::new("c.yaml")).unwrap()[0].1;
    let v: serde_yaml_ng::Value = serde_yaml_ng::from_str(text).unwrap();
    assert_eq!(v["cam0"]["camera_model"].as_str(), Some("pinhole"));
    assert_eq!(v["cam1"]["distortion_model"].as_str(), Some("radtan"));
    assert_eq!(v["cam1"]["resolution"][0].as_u64(), Some(640));
    assert_eq!(v["cam1"]["T_cn_cnm1"][0][3].as_f64(), Some(ours.rig.right_from_left.translation.x));
    assert!(v["cam0"].get("T_cn_cnm1").is_none());
    // every key of Kalibr's own camchain layout (kalibr_equi_stereo.yaml, after the files
    // `kalibr_calibrate_cameras` writes: `cam_overlaps` and `rostopic` are read by its tools)
    let kalibr: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(&std::fs::read_to_string(data("kalibr_equi_stereo.yaml")).unwrap()).unwrap();
    let keys = |v: &serde_yaml_ng::Value| {
        v.as_mapping().unwrap().keys().map(|k| k.as_str().unwrap().to_string()).collect::<Vec<_>>()
    };
    for cam in ["cam0", "cam1"] {
        assert_eq!(keys(&v[cam]), keys(&kalibr[cam]), "{cam}");
        assert_eq!(v[cam]["rostopic"], kalibr[cam]["rostopic"], "{cam}");
        assert_eq!(v[cam]["cam_overlaps"], kalibr[cam]["cam_overlaps"], "{cam}");
    }
    let (back, format) = parse(text, "camchain").unwrap();
    assert_eq!(format, Format::Kalibr);
    let back = back.into_stereo("camchain").unwrap();
    assert!(max_abs(&params(&back), &params(&ours)) < 1e-12);
}

#[test]
fn a_native_file_edited_in_one_place_only_is_refused() {
    let text = std::fs::read_to_string(data("ours_stereo.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let fx = v["calibration"]["rig"]["left"]["intrinsics"]["fx"].as_f64().unwrap();
    v["calibration"]["rig"]["left"]["intrinsics"]["fx"] = serde_json::json!(fx + 1.0);
    let err = parse(&v.to_string(), "edited.json").unwrap_err().to_string();
    assert!(err.contains("disagree"), "{err}");
    // The rig alone (opencv block removed) is read as edited.
    v["calibration"].as_object_mut().unwrap().remove("opencv");
    let (c, _) = parse(&v.to_string(), "edited.json").unwrap();
    assert_eq!(c.camera(Side::Left, "x").unwrap().intrinsics.fx, fx + 1.0);
    // The pose in every convention beside the rig: each form edited alone is refused (an edited
    // translation there was ignored, the rig's baseline kept), the view as written is read, a
    // quaternion of the other sign is the same rotation, and without the view the rig is read.
    let pristine: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(parse(&pristine.to_string(), "as written").is_ok());
    let edits: [(&str, serde_json::Value); 5] = [
        ("translation", serde_json::json!([-50.0, 0.39223502987414594, -0.33580718322980124])),
        ("quaternion_xyzw", serde_json::json!([0.0, 0.0, 0.0, 1.0])),
        ("rotation_matrix", serde_json::json!([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])),
        ("rotation_vector_rad", serde_json::json!([0.0, 0.0, 0.0])),
        ("tf", serde_json::json!("-50 0.39 -0.33 0 0 0 1")),
    ];
    for (form, value) in edits {
        let mut e = pristine.clone();
        e["calibration"]["right_from_left"][form] = value;
        let err = parse(&e.to_string(), "pose.json").unwrap_err().to_string();
        assert!(err.contains(&format!("right_from_left.{form}")) && err.contains("one place"), "{form}: {err}");
    }
    let mut neg = pristine.clone();
    let q = neg["calibration"]["right_from_left"]["quaternion_xyzw"].clone();
    let q: Vec<f64> = q.as_array().unwrap().iter().map(|x| -x.as_f64().unwrap()).collect();
    neg["calibration"]["right_from_left"]["quaternion_xyzw"] = serde_json::json!(q);
    assert!(parse(&neg.to_string(), "negated").is_ok());
    let mut bare = pristine.clone();
    bare["calibration"].as_object_mut().unwrap().remove("right_from_left");
    assert!(parse(&bare.to_string(), "bare").is_ok());
}

#[test]
fn output_formats_follow_the_extension_and_unknown_ones_are_refused() {
    let f = |p: &str, e: Option<&str>| Format::for_output(Path::new(p), e);
    assert_eq!(f("a.ron", None).unwrap(), Format::Ron);
    assert_eq!(f("a.JSON", None).unwrap(), Format::Json);
    assert_eq!(f("a.yml", None).unwrap(), Format::OpenCvYaml);
    assert_eq!(f("a.yaml", None).unwrap(), Format::OpenCvYaml);
    assert_eq!(f("a.xml", None).unwrap(), Format::OpenCvXml);
    assert_eq!(f("a.yaml", Some("ros")).unwrap(), Format::Ros);
    assert_eq!(f("a.yaml", Some("kalibr")).unwrap(), Format::Kalibr);
    assert_eq!(f("a.xml", Some("opencv")).unwrap(), Format::OpenCvXml);
    for (p, e) in [("x.txt", None), ("x", None), ("x.yml", Some("toml"))] {
        let err = f(p, e).unwrap_err().to_string();
        assert!(
            err.contains("ron") && err.contains("json") && err.contains("opencv") && err.contains("kalibr"),
            "{err}"
        );
    }
}

#[test]
fn matrices_in_native_files_are_row_major() {
    // E = [T]x R: E[0][1] = -T.z R[0][1]... checked against an independent product from the
    // row-major R and T the file holds.
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data("ours_stereo.json")).unwrap()).unwrap();
    let o = &v["calibration"]["opencv"];
    let m = |k: &str| -> [[f64; 3]; 3] { serde_json::from_value(o[k].clone()).unwrap() };
    let (r, e) = (m("R"), m("E"));
    let t: [f64; 3] = serde_json::from_value(o["T"].clone()).unwrap();
    let tx = [[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            let expect: f64 = (0..3).map(|k| tx[i][k] * r[k][j]).sum();
            assert!((e[i][j] - expect).abs() < 1e-9, "E[{i}][{j}] {} vs {expect}", e[i][j]);
        }
    }
    // And the pose record's rotation matrix is the same R.
    let pose: [[f64; 3]; 3] =
        serde_json::from_value(v["calibration"]["right_from_left"]["rotation_matrix"].clone()).unwrap();
    assert_eq!(pose, r);
}
