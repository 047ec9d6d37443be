//! `calibrate --lens kannala-brandt` from the command line against OpenCV's own
//! `cv2.fisheye.stereoCalibrate` on a wide-angle (~180°) stereo session made by OpenCV
//! (`cv2.fisheye.projectPoints` of a 9x6 board through two Kannala–Brandt cameras, σ = 0.2 px):
//! `tests/data/opencv-fisheye-stereo/` holds the corners, OpenCV's result, the script that made
//! both (`make.py`, OpenCV 5.1) and its provenance note. Nothing of parallax's renderer is
//! involved. Then `rectify` and `measure` run on the calibration file it wrote.

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
