//! `calibrate --camera-corners … --lens …` on rigs made by OpenCV
//! (`crates/planar-calibration/tests/data/rig/make_rig.py`: `cv2.projectPoints`,
//! `cv2.fisheye.projectPoints` and the double sphere formula in numpy; nothing of our renderer):
//! the contract lines against the truth, the JSON record, and the refusals of
//! inputs that make no rig (each before any output).

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Deserialize;

mod common;
use common::Temp;

#[derive(Deserialize)]
struct Board {
    cols: usize,
    rows: usize,
    square: f64,
}

#[derive(Deserialize)]
struct Cam {
    lens: String,
    width: u32,
    height: u32,
    #[serde(rename = "K")]
    k: [[f64; 3]; 3],
    t: [f64; 3],
}

#[derive(Deserialize)]
struct Frame {
    views: Vec<Option<Vec<[f64; 2]>>>,
}

#[derive(Deserialize)]
struct RigSet {
    board: Board,
    cameras: Vec<Cam>,
    frames: Vec<Frame>,
}

fn rig_set(name: &str) -> RigSet {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../crates/planar-calibration/tests/data/rig").join(name);
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// One corners file per camera (`corners --out`'s JSON form) in `dir`: image `frame_NNN.png`
/// for every frame, its grid where the camera saw the board.
fn corners_files(set: &RigSet, dir: &Path) -> Vec<PathBuf> {
    (0..set.cameras.len())
        .map(|c| {
            let cam = &set.cameras[c];
            let images: Vec<serde_json::Value> = set
                .frames
                .iter()
                .enumerate()
                .map(|(f, fr)| {
                    let grid = fr.views[c]
                        .as_ref()
                        .map(|v| serde_json::json!({"cols": set.board.cols, "rows": set.board.rows, "corners": v}));
                    serde_json::json!({
                        "image": format!("cam{c}/frame_{f:03}.png"),
                        "width": cam.width,
                        "height": cam.height,
                        "grid": grid,
                        "time_ms": 0.0,
                    })
                })
                .collect();
            let file = serde_json::json!({
                "cols": set.board.cols, "rows": set.board.rows, "refinement": "Saddle", "images": images,
            });
            let path = dir.join(format!("cam{c}.json"));
            std::fs::write(&path, serde_json::to_string(&file).unwrap()).unwrap();
            path
        })
        .collect()
}

fn xtask(dir: &Path, args: &[String]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask")).args(args).current_dir(dir).output().expect("running xtask");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn key(line: &str, name: &str) -> f64 {
    let mut it = line.split_whitespace();
    while let Some(tok) = it.next() {
        if tok == format!("{name}:") {
            return it.next().unwrap().parse().unwrap();
        }
    }
    panic!("no {name} in {line}")
}

fn args_for(set: &RigSet, files: &[PathBuf], rest: &[&str]) -> Vec<String> {
    let b = &set.board;
    let mut a =
        vec!["calibrate".to_string(), "--board".into(), format!("chessboard:{}x{}:{}", b.cols, b.rows, b.square)];
    for f in files {
        a.extend(["--camera-corners".to_string(), f.display().to_string()]);
    }
    for c in &set.cameras {
        let lens = if c.lens == "pinhole" { "pinhole" } else { c.lens.as_str() };
        a.extend(["--lens".to_string(), lens.to_string()]);
    }
    a.extend(rest.iter().map(|s| s.to_string()));
    a
}

/// Four cameras of three lenses, camera 3 never in a frame with camera 0: every contract line
/// against OpenCV's truth, then the JSON record and the report it wrote.
#[test]
fn four_camera_rig_made_by_opencv() {
    let set = rig_set("mixed4.json");
    let tmp = Temp::new("rig-cli", "mixed4");
    let files = corners_files(&set, tmp.as_path());
    let (ok, out, err) = xtask(tmp.as_path(), &args_for(&set, &files, &["--out", "rig.json", "--report", "report"]));
    assert!(ok, "{out}\n{err}");
    let cams: Vec<&str> = out.lines().filter(|l| l.starts_with("camera: ")).collect();
    let extr: Vec<&str> = out.lines().filter(|l| l.starts_with("extrinsic: ")).collect();
    assert_eq!((cams.len(), extr.len()), (4, 3), "{out}");
    for (c, line) in cams.iter().enumerate() {
        let truth = &set.cameras[c];
        assert!(
            line.contains(&format!("lens: {}", if truth.lens == "pinhole" { "pinhole" } else { &truth.lens })),
            "{line}"
        );
        // 1σ of fx is 0.02–0.2 % here (double sphere: its fx trades off against ξ).
        let tol = if truth.lens == "double-sphere" { 1e-2 } else { 2e-3 };
        assert!((key(line, "fx") / truth.k[0][0] - 1.0).abs() < tol, "{line} vs fx {}", truth.k[0][0]);
        assert!((key(line, "rms") - 0.2 * 2f64.sqrt()).abs() < 0.03, "{line}");
    }
    for (i, line) in extr.iter().enumerate() {
        let t = set.cameras[i + 1].t;
        let got = [key(line, "tx"), key(line, "ty"), key(line, "tz")];
        let err = ((got[0] - t[0]).powi(2) + (got[1] - t[1]).powi(2) + (got[2] - t[2]).powi(2)).sqrt();
        // sigma_t is the 1σ of the translation's norm: the norms within 5σ, the vectors within
        // 0.5 % of the norm.
        let (norm, got_norm) = (
            (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt(),
            (got[0] * got[0] + got[1] * got[1] + got[2] * got[2]).sqrt(),
        );
        assert!((got_norm - norm).abs() < 5.0 * key(line, "sigma_t") && err < 5e-3 * norm, "{line}: t {t:?}");
    }
    let rms = out.lines().find(|l| l.starts_with("rms: ")).unwrap();
    assert!((key(rms, "rms") - 0.283).abs() < 0.03, "{rms}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.as_path().join("rig.json")).unwrap()).unwrap();
    assert_eq!(record["result"]["cameras"].as_array().unwrap().len(), 4);
    assert_eq!(record["frames"].as_array().unwrap().len(), set.frames.len());
    // the report: every camera's section and the rig's (visibility, extrinsics, the picture)
    let html = std::fs::read_to_string(tmp.as_path().join("report/report.html")).unwrap();
    assert!(html.contains("rig of 4 cameras") && html.contains("calibration — camera3 camera"), "report");
    assert!(tmp.as_path().join("report/calibration-rig.png").exists());
    assert!(html.matches("<tr>").count() >= set.frames.len() + 4);
    // the visibility matrix has one row per frame
    assert!(out.contains("frame_059.png"), "{out}");
}

/// Inputs that make no rig are refused, naming the cameras or files, and write nothing.
#[test]
fn inputs_that_make_no_rig_are_refused() {
    let set = rig_set("mixed4.json");
    let tmp = Temp::new("rig-cli", "refusals");
    let files = corners_files(&set, tmp.as_path());
    let refused = |args: Vec<String>, expect: &str| {
        let (ok, out, err) = xtask(tmp.as_path(), &args);
        assert!(!ok, "accepted: {out}");
        assert!(err.contains(expect), "expected '{expect}' in:\n{err}");
        assert!(!tmp.as_path().join("r.json").exists());
    };
    // one camera twice
    refused(
        args_for(&set, &[files[0].clone(), files[0].clone(), files[2].clone(), files[3].clone()], &["--out", "r.json"]),
        "of camera 0",
    );
    // a camera not linked to camera 0: cameras 2 and 3 alone with 0 and 1 removed of shared frames
    let lone = tmp.as_path().join("lone.json");
    let text = std::fs::read_to_string(&files[3]).unwrap().replace("cam3/frame_", "cam3/other_");
    std::fs::write(&lone, text).unwrap();
    refused(
        args_for(&set, &[files[0].clone(), files[1].clone(), files[2].clone(), lone], &["--out", "r.json"]),
        "match no other camera",
    );
    // --lens count
    let mut a = args_for(&set, &files, &["--out", "r.json"]);
    a.extend(["--lens".into(), "pinhole".into()]);
    refused(a, "--lens is given 5 times for 4 cameras");
}

fn value(out: &str, name: &str) -> f64 {
    out.lines()
        .find_map(|l| l.strip_prefix(&format!("{name}: ")))
        .unwrap_or_else(|| panic!("no {name} in\n{out}"))
        .trim()
        .parse()
        .unwrap()
}

/// The rig written as OpenCV FileStorage (`calibrateMultiview`'s terms), as the JSON record and
/// as a Kalibr camchain (in metres) is read back by `rectify --pair 0,1` (cameras 2 and 3 look
/// 40° and 80° away: no pinhole rectification with camera 0): the three give the rectified
/// baseline of OpenCV's truth `|t_1|`; a rig file without `--pair` is refused with the hint.
#[test]
fn rectify_pair_reads_every_rig_file() {
    let set = rig_set("pinhole4.json");
    let tmp = Temp::new("rig-cli", "pair");
    let files = corners_files(&set, tmp.as_path());
    for out in ["rig.yml", "rig.json"] {
        let (ok, o, e) = xtask(tmp.as_path(), &args_for(&set, &files, &["--out", out]));
        assert!(ok, "{o}\n{e}");
    }
    // Kalibr: lengths in metres, no k3 in radtan
    let mut metres = rig_set("pinhole4.json");
    metres.board.square /= 1000.0;
    let (ok, o, e) =
        xtask(tmp.as_path(), &args_for(&metres, &files, &["--fix-k3", "--out", "chain.yaml", "--format", "kalibr"]));
    assert!(ok, "{o}\n{e}");
    let chain = std::fs::read_to_string(tmp.as_path().join("chain.yaml")).unwrap();
    assert_eq!(chain.matches("T_cn_cnm1").count(), 3, "{chain}");
    image::GrayImage::from_pixel(1280, 960, image::Luma([128])).save(tmp.as_path().join("l.png")).unwrap();
    image::GrayImage::from_pixel(1280, 960, image::Luma([128])).save(tmp.as_path().join("r.png")).unwrap();
    let t = set.cameras[1].t;
    let truth = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    let mut baselines = Vec::new();
    for (file, scale) in [("rig.yml", 1.0), ("rig.json", 1.0), ("chain.yaml", 1000.0)] {
        let dir = format!("out-{file}");
        let args: Vec<String> =
            ["rectify", "--calib", file, "--pair", "0,1", "--left", "l.png", "--right", "r.png", "--out", &dir]
                .iter()
                .map(|s| s.to_string())
                .collect();
        let (ok, o, e) = xtask(tmp.as_path(), &args);
        assert!(ok, "{file}: {o}\n{e}");
        let b = value(&o, "rectified_baseline").abs() * scale;
        assert!((b / truth - 1.0).abs() < 5e-3, "{file}: baseline {b} vs {truth}");
        baselines.push(b);
    }
    assert!((baselines[0] / baselines[1] - 1.0).abs() < 1e-9, "OpenCV file vs record: {baselines:?}");
    let args: Vec<String> = ["rectify", "--calib", "rig.yml", "--left", "l.png", "--right", "r.png", "--out", "x"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let (ok, _, e) = xtask(tmp.as_path(), &args);
    assert!(!ok && e.contains("--pair"), "{e}");
}

/// `--camera` globs are checked before any image is read: the same file under two cameras,
/// and file names no other camera has (listed), are refused naming the cameras and files.
#[test]
fn camera_globs_that_make_no_frames_are_refused() {
    let tmp = Temp::new("rig-cli", "globs");
    for (dir, names) in
        [("cam0", ["a.png", "b.png", "c.png"].as_slice()), ("cam1", &["a.png", "b.png", "d.png", "e.png"])]
    {
        std::fs::create_dir_all(tmp.join(dir)).unwrap();
        for n in names {
            std::fs::write(tmp.join(dir).join(n), b"not an image: never read").unwrap();
        }
    }
    let run = |globs: &[&str]| {
        let mut a: Vec<String> =
            ["calibrate", "--board", "9x6", "--square", "25", "--out", "r.json"].map(String::from).to_vec();
        for g in globs {
            a.extend(["--camera".to_string(), g.to_string()]);
        }
        let (ok, out, err) = xtask(tmp.as_path(), &a);
        assert!(!ok, "accepted: {out}");
        assert!(!tmp.join("r.json").exists());
        err
    };
    let e = run(&["cam0/*.png", "cam1/*.png"]);
    assert!(
        e.contains("3 file name(s) match no other camera")
            && e.contains("c.png (camera 0)")
            && e.contains("e.png (camera 1)"),
        "{e}"
    );
    let e = run(&["cam0/*.png", "cam0/a.png"]);
    assert!(e.contains("is an input of camera 0") && e.contains("and of camera 1"), "{e}");
    let e = run(&["cam0/*.png"]);
    assert!(e.contains("at least two cameras"), "{e}");
}

/// A camera whose images show no target, and cameras linked to camera 0 by no shared frame,
/// are refused naming them.
#[test]
fn unseeing_and_unlinked_cameras_are_refused() {
    let set = rig_set("mixed4.json");
    let tmp = Temp::new("rig-cli", "unlinked");
    let files = corners_files(&set, tmp.as_path());
    // camera 1 saw nothing
    let blind = tmp.join("blind.json");
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&files[1]).unwrap()).unwrap();
    for img in v["images"].as_array_mut().unwrap() {
        img["grid"] = serde_json::Value::Null;
    }
    std::fs::write(&blind, v.to_string()).unwrap();
    let (ok, _, e) =
        xtask(tmp.as_path(), &args_for(&set, &[files[0].clone(), blind, files[2].clone(), files[3].clone()], &[]));
    assert!(!ok && e.contains("camera 1") && e.contains("found in none of its 60 image(s)"), "{e}");
    // camera 2 loses the frames it shared with cameras 0 and 1: cameras 2 and 3 are alone
    let cut = tmp.join("cut.json");
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&files[2]).unwrap()).unwrap();
    for (f, img) in v["images"].as_array_mut().unwrap().iter_mut().enumerate() {
        if set.frames[f].views[0].is_some() || set.frames[f].views[1].is_some() {
            img["grid"] = serde_json::Value::Null;
        }
    }
    std::fs::write(&cut, v.to_string()).unwrap();
    let (ok, _, e) =
        xtask(tmp.as_path(), &args_for(&set, &[files[0].clone(), files[1].clone(), cut, files[3].clone()], &[]));
    assert!(!ok && e.contains("[2, 3]") && e.contains("share no frame"), "{e}");
}

/// The OpenCV-made stereo session of 30 views within 1° of fronto-parallel (OpenCV's
/// `stereoCalibrate`: baseline 79 times the truth, exit fine) through the command line, as a
/// stereo pair and as a two-camera rig: refused, writing nothing.
#[test]
fn near_parallel_stereo_session_is_refused() {
    let set = rig_set("parallel2.json");
    let tmp = Temp::new("rig-cli", "parallel");
    let files = corners_files(&set, tmp.as_path());
    let stereo: Vec<String> = [
        "calibrate",
        "--board",
        "chessboard:7x6:30",
        "--corners",
        "cam0.json",
        "--right-corners",
        "cam1.json",
        "--out",
        "s.yml",
    ]
    .map(String::from)
    .to_vec();
    for args in [stereo, args_for(&set, &files, &["--out", "s.yml"])] {
        let (ok, out, err) = xtask(tmp.as_path(), &args);
        assert!(!ok, "accepted: {out}");
        assert!(err.contains("tilt"), "{err}");
        assert!(!tmp.join("s.yml").exists());
    }
}

/// `--camera` globs end to end on images our renderer made: three pinhole cameras (a stereo
/// pair and one turned 30°), 15 frames; a camera that did not see a frame has a plain image of
/// that name, or no file at all (camera 2): matched by file name, the rig's contract lines
/// against the truth.
#[test]
fn camera_globs_of_rendered_images() {
    use glam::DVec3;
    use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3};
    let tmp = Temp::new("rig-cli", "rendered");
    let cam =
        Camera::new(Intrinsics::new(560.0, 560.0, 319.5, 239.5), Distortion::new(-0.12, 0.05, 0.0, 0.0, 0.0), 640, 480)
            .unwrap();
    let from0 = [
        Isometry3::IDENTITY,
        Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.02, 0.0), DVec3::new(-110.0, 0.0, 0.0)),
        Isometry3::from_rvec_tvec(DVec3::new(0.0, -30f64.to_radians(), 0.0), DVec3::new(-60.0, 0.0, -20.0)),
    ];
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let centre = DVec3::new(100.0, 62.5, 0.0);
    let tilts = [(0.4, 0.1), (-0.35, 0.2), (0.1, 0.45), (0.2, -0.4), (-0.3, -0.25), (0.45, 0.3), (-0.1, -0.45)];
    let mut seen = [[false; 3]; 15];
    for c in 0..3 {
        std::fs::create_dir_all(tmp.join(format!("cam{c}"))).unwrap();
    }
    for f in 0..15 {
        // in turn: before the pair, before camera 2, half-way between (seen by all three)
        let (a, b) = tilts[f % 7];
        let rv = DVec3::new(a, b, 0.05 * f as f64 - 0.3);
        let rot = Isometry3::from_rvec_tvec(rv, DVec3::ZERO);
        let at =
            DVec3::new(if f % 3 == 0 { -55.0 } else { 0.0 }, 10.0 * (f % 3) as f64 - 10.0, 480.0 + 15.0 * f as f64);
        let cam0_from_board = match f % 3 {
            0 => Isometry3::from_rvec_tvec(rv, at - rot.transform_vector(centre)),
            1 => from0[2].inverse() * Isometry3::from_rvec_tvec(rv, at - rot.transform_vector(centre)),
            _ => {
                let half = Isometry3::from_rvec_tvec(DVec3::new(0.0, 15f64.to_radians(), 0.0), DVec3::ZERO);
                let turned = half * Isometry3::from_rvec_tvec(rv * 0.5, DVec3::ZERO);
                let at = half.transform_vector(DVec3::new(-20.0, 0.0, 750.0));
                Isometry3::from_rotation_translation(turned.rotation_matrix(), at - turned.transform_vector(centre))
                    .unwrap()
            }
        };
        for c in 0..3 {
            let pose = from0[c] * cam0_from_board;
            let corners = parallax_synthetic::project_corners(&cam, &board, &pose);
            let inside =
                corners.is_ok_and(|k| k.iter().all(|u| u.x > 15.0 && u.y > 15.0 && u.x < 624.0 && u.y < 464.0));
            let path = tmp.join(format!("cam{c}/frame{f:02}.png"));
            if inside {
                let opts = parallax_synthetic::RenderOptions { seed: (10 * f + c) as u64, ..Default::default() };
                parallax_synthetic::render_chessboard(&cam, &board, &pose, &opts).unwrap().image.save(&path).unwrap();
                seen[f][c] = true;
            } else if c != 2 {
                image::GrayImage::from_pixel(640, 480, image::Luma([120])).save(&path).unwrap();
            }
        }
    }
    let counts: Vec<usize> = (0..3).map(|c| seen.iter().filter(|s| s[c]).count()).collect();
    assert!(counts.iter().all(|&n| n >= 5) && seen.iter().any(|s| s[1] && s[2]), "visibility {counts:?}");
    let args: Vec<String> = [
        "calibrate",
        "--board",
        "9x6",
        "--square",
        "25",
        "--camera",
        "cam0/*.png",
        "--camera",
        "cam1/*.png",
        "--camera",
        "cam2/*.png",
        "--out",
        "rig.yml",
    ]
    .map(String::from)
    .to_vec();
    let (ok, out, err) = xtask(tmp.as_path(), &args);
    assert!(ok, "{out}\n{err}");
    for c in 0..3 {
        assert!(out.contains(&format!("camera {c}: target found in {}/", counts[c])), "{out}");
        let line = out.lines().find(|l| l.starts_with(&format!("camera: {c} "))).unwrap();
        assert!((key(line, "fx") / 560.0 - 1.0).abs() < 3e-3, "{line}");
    }
    for c in 1..3 {
        let line = out.lines().find(|l| l.starts_with(&format!("extrinsic: {c} "))).unwrap();
        let t = from0[c].translation;
        let got = DVec3::new(key(line, "tx"), key(line, "ty"), key(line, "tz"));
        assert!((got - t).length() < 0.01 * t.length(), "{line} vs {t}");
        let w = DVec3::new(key(line, "rx"), key(line, "ry"), key(line, "rz"));
        assert!((w - from0[c].rvec()).length() < 2e-3, "{line}");
    }
    let yml = std::fs::read_to_string(tmp.join("rig.yml")).unwrap();
    assert!(yml.contains("nb_cameras: 3") && yml.contains("camera_matrix_2"), "{yml}");
}
