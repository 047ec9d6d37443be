//! The command line against OpenCV's own results and files.
//!
//! - `calibrate --lens kannala-brandt` against `cv2.fisheye.stereoCalibrate` on a wide-angle
//!   (~180°) stereo session made by OpenCV (`cv2.fisheye.projectPoints` of a 9x6 board through
//!   two Kannala–Brandt cameras, σ = 0.2 px): `tests/data/opencv-fisheye-stereo/` holds the
//!   corners, OpenCV's result, the script that made both (`make.py`, OpenCV 5.1) and its
//!   provenance note. Nothing of parallax's renderer is involved. Then `rectify` and `measure`
//!   run on the calibration file it wrote.
//! - OpenCV's `stereo_calib.cpp` file pair (`intrinsics.yml`: M1 D1 M2 D2, `extrinsics.yml`: R T
//!   R1 R2 P1 P2 Q, no image size, alpha 1) through `rectify` and `disparity --calib`, against
//!   OpenCV's `initUndistortRectifyMap` + `remap` and `reprojectImageTo3D` with the stored
//!   matrices; and `F` against `cv2.stereoCalibrate`'s on the same corners of OpenCV's stereo
//!   chessboards: `tests/data/opencv-stereo-calib/` (its `make.py` and provenance note).

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::Temp;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the workspace").to_path_buf()
}

fn data() -> PathBuf {
    root().join("xtask/tests/data/opencv-fisheye-stereo")
}

fn run(dir: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask")).args(args).current_dir(dir).output().expect("running xtask");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "xtask {args:?} failed:\n{stdout}\n{stderr}");
    stdout.into_owned()
}

/// `calibrate --lens LENS` of the 9x6 board of 25 mm squares, with `rest` (corners, outputs).
fn calibrate(dir: &Path, lens: &str, rest: &[&str]) -> String {
    let args: Vec<&str> = ["calibrate", "--lens", lens, "--board", "9x6", "--square", "25"]
        .into_iter()
        .chain(rest.iter().copied())
        .collect();
    run(dir, &args)
}

/// OpenCV's results on the session (`reference.json`, written by `make.py`).
fn reference() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(data().join("reference.json")).unwrap()).unwrap()
}

/// The `key: value` of `key` in a command's output.
fn key(out: &str, key: &str) -> f64 {
    let prefix = format!("{key}: ");
    let line = out.lines().find(|l| l.starts_with(&prefix)).unwrap_or_else(|| panic!("no `{key}:` in\n{out}"));
    line[prefix.len()..].trim().parse().unwrap_or_else(|_| panic!("`{line}` is no number"))
}

/// A number of a JSON document by its path of keys and indices.
fn at<'a>(v: &'a serde_json::Value, path: &[&str]) -> &'a serde_json::Value {
    path.iter().fold(v, |v, k| match k.parse::<usize>() {
        Ok(i) => &v[i],
        Err(_) => &v[*k],
    })
}

fn num(v: &serde_json::Value, path: &[&str]) -> f64 {
    at(v, path).as_f64().unwrap_or_else(|| panic!("{path:?} is no number"))
}

/// Relative agreement `|a − b| ≤ tol · |b|` (for values of order 1 and above; the rotation's
/// entries are compared absolutely, as entries of a unit-norm matrix).
fn close(what: &str, a: f64, b: f64, tol: f64) {
    assert!((a - b).abs() <= tol * b.abs(), "{what}: parallax {a} vs OpenCV {b} (relative {:e})", (a - b) / b);
}

#[test]
fn kannala_brandt_stereo_from_the_command_line_reproduces_opencv() {
    let dir = Temp::new("opencv-fisheye", "stereo");
    let json = dir.join("calib.json");
    let (left, right) = (data().join("left.json"), data().join("right.json"));
    let out = calibrate(
        &dir,
        "kannala-brandt",
        &[
            "--corners",
            left.to_str().unwrap(),
            "--right-corners",
            right.to_str().unwrap(),
            "--out",
            json.to_str().unwrap(),
            "--report",
            "report",
        ],
    );
    // The report draws the wide lens too (residuals, coverage, the lens's displacement field).
    let html = std::fs::read_to_string(dir.join("report/report.html")).unwrap();
    assert!(html.contains("<img") && dir.join("report/calibration-left-distortion.png").is_file());
    let reference = reference();
    let cv = &reference["stereo"];
    let file: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    // `calibrate`'s record: the images, the board, the calibration (rig, lens model, pose) and σ.
    let ours = &file["calibration"];
    assert_eq!(ours["lens_model"], "kannala_brandt");
    // The printed keys.
    assert!(out.contains("left_lens: kannala-brandt") && out.contains("right_lens: kannala-brandt"), "{out}");
    close("stereo RMS", key(&out, "stereo_rms_px"), num(cv, &["rms"]), 1e-4);
    for (side, k, d) in [("left", "K1", "D1"), ("right", "K2", "D2")] {
        let cam = ["rig", side];
        let intr = |name: &str| num(ours, &[cam[0], cam[1], "intrinsics", name]);
        close(&format!("{side} fx"), intr("fx"), num(cv, &[k, "0", "0"]), 1e-4);
        close(&format!("{side} fy"), intr("fy"), num(cv, &[k, "1", "1"]), 1e-4);
        close(&format!("{side} cx"), intr("cx"), num(cv, &[k, "0", "2"]), 1e-4);
        close(&format!("{side} cy"), intr("cy"), num(cv, &[k, "1", "2"]), 1e-4);
        assert_eq!(intr("skew"), 0.0, "CALIB_FIX_SKEW");
        for (i, name) in ["k1", "k2", "k3", "k4"].iter().enumerate() {
            let v = num(ours, &[cam[0], cam[1], "lens", "KannalaBrandt", name]);
            close(&format!("{side} {name}"), v, num(cv, &[d, &i.to_string()]), 1e-4);
        }
        close(&format!("{side} fx (printed)"), key(&out, &format!("{side}_fx")), num(cv, &[k, "0", "0"]), 1e-4);
    }
    for r in 0..3 {
        let t = num(ours, &["right_from_left", "translation", &r.to_string()]);
        close(&format!("T[{r}]"), t, num(cv, &["T", &r.to_string()]), 1e-4);
        for c in 0..3 {
            let a = num(ours, &["right_from_left", "rotation_matrix", &r.to_string(), &c.to_string()]);
            let b = num(cv, &["R", &r.to_string(), &c.to_string()]);
            assert!((a - b).abs() <= 1e-4 * 1e-2, "R[{r}][{c}]: {a} vs {b}");
        }
    }

    // rectify and measure take the file as it was written.
    let black = image::GrayImage::new(1280, 960);
    for n in ["l.png", "r.png"] {
        black.save(dir.join(n)).unwrap();
    }
    // This rig images ~180°: the midpoints of the image edges lie 109° from the rectified axis,
    // which no pinhole pair can hold (OpenCV's fisheye::stereoRectify clips them and returns a
    // wrong pair). `rectify` refuses it, names the angle and writes nothing.
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["rectify", "--calib", json.to_str().unwrap(), "--left", "l.png", "--right", "r.png", "--out", "rect"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("a pinhole cannot hold it") && err.contains("109."), "{err}");
    assert!(!dir.join("rect").exists(), "nothing written");
    // With a field of view a pinhole holds (a narrower camera of the same lens), it rectifies.
    let narrow = dir.join("narrow.json");
    let mut v = ours.clone();
    for side in ["left", "right"] {
        let c = &mut v["rig"][side];
        c["width"] = 640.into();
        c["height"] = 480.into();
        let cx = c["intrinsics"]["cx"].as_f64().unwrap() - 320.0;
        let cy = c["intrinsics"]["cy"].as_f64().unwrap() - 240.0;
        c["intrinsics"]["cx"] = cx.into();
        c["intrinsics"]["cy"] = cy.into();
    }
    for k in ["opencv", "rectification"] {
        v.as_object_mut().unwrap().remove(k);
    }
    std::fs::write(&narrow, serde_json::to_string(&v).unwrap()).unwrap();
    let small = image::GrayImage::new(640, 480);
    for n in ["sl.png", "sr.png"] {
        small.save(dir.join(n)).unwrap();
    }
    let rect = run(
        &dir,
        &["rectify", "--calib", narrow.to_str().unwrap(), "--left", "sl.png", "--right", "sr.png", "--out", "rect"],
    );
    assert!(rect.contains("kannala-brandt lenses to a pinhole pair"), "{rect}");
    assert!(dir.join("rect/rectification.ron").is_file() && dir.join("rect/left_rectified.png").is_file());
    // Two horizontally adjacent corners of view 0 (25 mm apart on the board), raw pixels.
    let corners = |f: &PathBuf| -> serde_json::Value {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap();
        v["images"][0]["grid"]["corners"].clone()
    };
    let (l, r) = (corners(&left), corners(&right));
    let pair = |i: usize| format!("{},{},{},{}", l[i][0], l[i][1], r[i][0], r[i][1]);
    let points = format!("{};{}", pair(20), pair(21));
    let m = run(&dir, &["measure", "--calib", json.to_str().unwrap(), "--points", &points]);
    let d = key(&m, "distance_0_1");
    assert!((d - 25.0).abs() < 0.5, "adjacent corners measured {d} mm apart, the board's squares are 25 mm\n{m}");
}

/// Flags of one lens family are refused with the other, naming the flag and the lens, before any
/// work.
#[test]
fn flags_of_another_lens_are_refused() {
    let dir = Temp::new("opencv-fisheye", "flags");
    let left = data().join("left.json");
    for (lens, flag) in
        [("kannala-brandt", "--rational"), ("double-sphere", "--fix-k1"), ("kannala-brandt", "--fix-k5")]
    {
        let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
            .args(["calibrate", "--lens", lens, "--board", "9x6", "--square", "25", "--corners"])
            .arg(&left)
            .arg(flag)
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(flag) && err.contains(lens), "{lens} {flag}: {err}");
    }
}

/// `--lens double-sphere` on the same OpenCV-made left corners: the keys name the lens and its
/// `xi:` / `alpha:`, the fit is as good as the Kannala–Brandt one (the session was made through a
/// Kannala–Brandt lens: RMS within 5 % of OpenCV's mono RMS), and the paraxial focal length
/// `fx / (1 + ξ)`, the one a double sphere fixes near the axis, is OpenCV's `fx` to 1 %.
#[test]
fn double_sphere_from_the_command_line() {
    let dir = Temp::new("opencv-fisheye", "ds");
    let left = data().join("left.json");
    let out = calibrate(&dir, "double-sphere", &["--corners", left.to_str().unwrap()]);
    assert!(out.lines().any(|l| l == "lens: double-sphere"), "{out}");
    let reference = reference();
    let cv_rms = num(&reference, &["mono_left", "rms"]);
    let rms = key(&out, "rms_px");
    assert!(rms < 1.05 * cv_rms, "double sphere RMS {rms} against OpenCV's Kannala–Brandt {cv_rms}");
    let paraxial = key(&out, "fx") / (1.0 + key(&out, "xi"));
    let cv_fx = num(&reference, &["mono_left", "K", "0", "0"]);
    assert!((paraxial / cv_fx - 1.0).abs() < 0.01, "paraxial focal {paraxial} against OpenCV's fx {cv_fx}");
    assert!((0.0..=1.0).contains(&key(&out, "alpha")));
}

/// Mono: `calibrate --lens kannala-brandt` on the left corners reproduces `cv2.fisheye.calibrate`
/// (same flags, same points) to 1e-4 relative in K and D, and the RMS.
#[test]
fn kannala_brandt_mono_reproduces_opencv() {
    let dir = Temp::new("opencv-fisheye", "mono");
    let left = data().join("left.json");
    let json = dir.join("mono.json");
    calibrate(&dir, "kannala-brandt", &["--corners", left.to_str().unwrap(), "--out", json.to_str().unwrap()]);
    let reference = reference();
    let cv = &reference["mono_left"];
    let file: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let camera = &file["calibration"]["camera"];
    for (name, r, c) in [("fx", 0, 0), ("fy", 1, 1), ("cx", 0, 2), ("cy", 1, 2)] {
        close(name, num(camera, &["intrinsics", name]), num(cv, &["K", &r.to_string(), &c.to_string()]), 1e-4);
    }
    for (i, name) in ["k1", "k2", "k3", "k4"].iter().enumerate() {
        close(name, num(camera, &["lens", "KannalaBrandt", name]), num(cv, &["D", &i.to_string()]), 1e-4);
    }
    close("RMS", num(&file["calibration"], &["rms_px"]), num(cv, &["rms"]), 1e-4);
}

/// OpenCV's `stereo_calib.cpp` files and images (`tests/data/opencv-stereo-calib`).
fn stereo_calib_data() -> PathBuf {
    root().join("xtask/tests/data/opencv-stereo-calib")
}

fn stereo_calib_reference() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(stereo_calib_data().join("reference.json")).unwrap()).unwrap()
}

fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// (largest, mean, share above 1) of the absolute grey-level differences of two images.
fn grey_difference(a: &Path, b: &Path) -> (u8, f64, f64) {
    let (a, b) = (image::open(a).unwrap().into_luma8(), image::open(b).unwrap().into_luma8());
    assert_eq!(a.dimensions(), b.dimensions());
    let d: Vec<u8> = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| x.abs_diff(*y)).collect();
    let n = d.len() as f64;
    let mean = d.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    (*d.iter().max().unwrap(), mean, d.iter().filter(|&&v| v > 1).count() as f64 / n)
}

#[test]
fn stereo_calib_files_rectify_with_their_stored_matrices_as_opencv_does() {
    let dir = Temp::new("opencv-stereo-calib", "rectify");
    let data = stereo_calib_data();
    let (intr, extr) = (data.join("intrinsics.yml"), data.join("extrinsics.yml"));
    let (left, right) = (root().join("fixtures/stereo/left_00.png"), root().join("fixtures/stereo/right_00.png"));
    let rectify = |out: &str, extra: &[&str]| {
        let args = [
            &["rectify", "--calib", path_str(&intr), path_str(&extr)][..],
            &["--left", path_str(&left), "--right", path_str(&right), "--out", out],
            extra,
        ]
        .concat();
        Command::new(env!("CARGO_BIN_EXE_xtask")).args(&args).current_dir(&dir).output().unwrap()
    };
    let r = rectify("stored", &[]);
    let out = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{out}{}", String::from_utf8_lossy(&r.stderr));
    // both choices are said: the size from the images, the file's own matrices
    assert!(out.contains("image size: none in the file; the images' 640x480"), "{out}");
    assert!(out.contains("R1 R2 P1 P2 Q: the calibration file's"), "{out}");
    for side in ["left", "right"] {
        let ours = dir.join(format!("stored/{side}_rectified.png"));
        // against OpenCV's map sampled by exact bilinear interpolation: rounding apart, equal
        let (max, mean, _) = grey_difference(&ours, &data.join(format!("exact_{side}_rectified.png")));
        assert!(max <= 1 && mean < 0.01, "{side} vs exact bilinear on OpenCV's map: max {max}, mean {mean}");
        // against OpenCV's remap itself, whose 1/32-pixel interpolation table differs from exact
        // bilinear interpolation by up to 3 grey levels on the board's sharp edges (make.py)
        let (max, mean, above_one) = grey_difference(&ours, &data.join(format!("opencv_{side}_rectified.png")));
        assert!(mean < 0.1 && above_one < 0.01 && max <= 4, "{side} vs OpenCV remap: max {max}, mean {mean}");
    }
    // the stored P1 is the one printed (alpha 1, not rectify's default 0)
    let extr_text = std::fs::read_to_string(&extr).unwrap();
    let err = parallax_interop::read(&[&intr, &extr]).unwrap_err().to_string();
    assert!(err.contains("no image size"), "without images the pair is refused: {err}");
    let (c, _, sized) = parallax_interop::read_with_image_size(&[&intr, &extr], (640, 480)).unwrap();
    assert!(sized);
    let stereo = c.into_stereo("pair").unwrap();
    let stored = stereo.rectification.expect("extrinsics.yml holds R1 R2 P1 P2 Q");
    assert!(extr_text.contains("P1"));
    close("focal", key(&out, "focal_px"), stored.p1.rows[0][0], 1e-9);
    close("cx", key(&out, "principal_point_left_u"), stored.p1.rows[0][2], 1e-9);

    // an option of the computation is refused while the file's matrices are used …
    let r = rectify("alpha", &["--alpha", "1"]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("--recompute"), "{err}");
    assert!(!dir.join("alpha").exists(), "written before the refusal");
    // … and with --recompute, alpha 1 gives OpenCV's stereoRectify again
    let r = rectify("recomputed", &["--recompute", "--alpha", "1"]);
    let out = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success() && out.contains("R1 R2 P1 P2 Q: computed, alpha Some(1.0)"), "{out}");
    close("recomputed focal", key(&out, "focal_px"), stored.p1.rows[0][0], 1e-6);
    close("recomputed cx", key(&out, "principal_point_left_u"), stored.p1.rows[0][2], 1e-6);

    // matrices of another rig are refused when the file is read, naming the matrices
    let other = extr_text.replacen("R1: !!opencv-matrix", "R1_unused: !!opencv-matrix", 1);
    let r1 = parallax_interop::opencv::parse_yaml(&extr_text, "extr").unwrap()["R1"].clone();
    let mut doc: serde_json::Value = parallax_interop::opencv::parse_yaml(&other, "extr").unwrap();
    // R1 turned by 1° about y: the rectified frames are no longer parallel
    let data_of = |v: &serde_json::Value| -> Vec<f64> {
        v["data"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
    };
    let m = data_of(&r1);
    let (c, s) = (1f64.to_radians().cos(), 1f64.to_radians().sin());
    let turned: Vec<f64> = (0..3)
        .flat_map(|i| {
            let row = [m[3 * i], m[3 * i + 1], m[3 * i + 2]];
            [row[0] * c - row[2] * s, row[1], row[0] * s + row[2] * c]
        })
        .collect();
    doc["R1"] = serde_json::json!({"rows": 3, "cols": 3, "dt": "d", "data": turned});
    doc.as_object_mut().unwrap().remove("R1_unused");
    let bad = dir.join("bad_extrinsics.json");
    std::fs::write(&bad, doc.to_string()).unwrap();
    let r = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["rectify", "--calib", path_str(&intr), path_str(&bad), "--left", path_str(&left)])
        .args(["--right", path_str(&right), "--out", "bad"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("R2 R R1ᵀ") && err.contains("do not belong to its M1 D1 M2 D2 R T"),
        "{err}"
    );
    assert!(!dir.join("bad").exists(), "written before the refusal");
}

#[test]
fn depth_through_a_stored_q_is_opencvs_reproject_image_to_3d() {
    let data = stereo_calib_data();
    let (intr, extr) = (data.join("intrinsics.yml"), data.join("extrinsics.yml"));
    let reference = stereo_calib_reference();
    let (c, _, _) = parallax_interop::read_with_image_size(&[&intr, &extr], (640, 480)).unwrap();
    let stereo = c.into_stereo("pair").unwrap();
    // the disparity ramp make.py gave reprojectImageTo3D, in f32 as there
    let (w, h) = (640usize, 480usize);
    let ramp: Vec<f32> = (0..h)
        .flat_map(|v| (0..w).map(move |u| (8.0 + 40.0 * u as f64 / w as f64 + 10.0 * v as f64 / h as f64) as f32))
        .collect();
    let map = parallax_camera_model::DisparityMap::from_data(w, h, ramp).unwrap();
    let depth = parallax_composition::disparity::depth_from_rectification(&stereo, &map, "pair").unwrap();
    let samples = reference["stereo_calib"]["q_samples"].as_array().unwrap();
    assert!(samples.len() >= 30);
    for s in samples {
        let (u, v) = (s["u"].as_u64().unwrap() as u32, s["v"].as_u64().unwrap() as u32);
        let i = depth.cloud.pixels.iter().position(|p| *p == [u, v]).expect("a point at every sample pixel");
        let p = depth.cloud.points[i];
        for (k, ours) in [p.x, p.y, p.z].into_iter().enumerate() {
            let cv = s["xyz"][k].as_f64().unwrap();
            // OpenCV returns float32 points: 1e-6 of the point's size covers their rounding
            assert!((ours - cv).abs() <= 1e-6 * p.length(), "({u}, {v}) coordinate {k}: ours {ours}, OpenCV {cv}");
        }
    }

    // and `disparity --calib` with the pair: the depth through the stored Q, said so
    let dir = Temp::new("opencv-stereo-calib", "disparity");
    let (left, right) = (root().join("fixtures/stereo/left_00.png"), root().join("fixtures/stereo/right_00.png"));
    run(
        &dir,
        &[
            "rectify",
            "--calib",
            path_str(&intr),
            path_str(&extr),
            "--left",
            path_str(&left),
            "--right",
            path_str(&right),
            "--out",
            "rect",
        ],
    );
    let out = run(
        &dir,
        &[
            "disparity",
            "--left",
            "rect/left_rectified.png",
            "--right",
            "rect/right_rectified.png",
            "--disparities",
            "64",
            "--out",
            "disp",
            "--calib",
            path_str(&intr),
            path_str(&extr),
        ],
    );
    assert!(out.contains("points through the calibration file's Q"), "{out}");
    let pfm =
        parallax_block_matching::from_pfm(&std::fs::read(dir.join("disp/disparity.pfm")).unwrap(), "pfm").unwrap();
    let q = stereo.rectification.unwrap().q;
    let mut z: Vec<f64> = Vec::new();
    for v in 0..pfm.height() {
        for u in 0..pfm.width() {
            let Some(d) = pfm.get(u, v) else { continue };
            let x = [u as f64, v as f64, f64::from(d), 1.0];
            let row = |r: usize| (0..4).map(|c| q[r][c] * x[c]).sum::<f64>();
            let zz = row(2) / row(3);
            if zz.is_finite() && zz > 0.0 {
                z.push(zz);
            }
        }
    }
    z.sort_by(f64::total_cmp);
    close("median depth", key(&out, "depth_median"), z[z.len() / 2], 1e-5);
}

#[test]
fn f_is_opencvs_on_the_same_corners_of_the_shared_stereo_chessboards() {
    let dir = Temp::new("opencv-stereo-calib", "f");
    let data = stereo_calib_data();
    let (l, r) = (data.join("shared_left.json"), data.join("shared_right.json"));
    run(
        &dir,
        &[
            "calibrate",
            "--corners",
            path_str(&l),
            "--right-corners",
            path_str(&r),
            "--board",
            "9x6",
            "--square",
            "30",
            "--out",
            "calib.yml",
        ],
    );
    let text = std::fs::read_to_string(dir.join("calib.yml")).unwrap();
    let ours = parallax_interop::opencv::parse_yaml(&text, "calib.yml").unwrap();
    let f: Vec<f64> = ours["F"]["data"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let cv: Vec<f64> = stereo_calib_reference()["f_reference"]["F"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|row| row.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect::<Vec<_>>())
        .collect();
    assert_eq!(f[8], 1.0, "F scaled as OpenCV's, F[2][2] = 1");
    let largest = cv.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let worst = f.iter().zip(&cv).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / largest;
    assert!(worst < 1e-6, "F differs from OpenCV's by {worst:e} of its largest element\nours {f:?}\nOpenCV {cv:?}");
}
