//! The README is executable: its stage chain (the `sh` block after the `readme-chain` marker)
//! is run line by line with the built binary, in a temporary folder, on the committed fixtures —
//! once as written (`calib.ron`) and once with `calib.yml` (OpenCV FileStorage) in its place —
//! and each stage's `key: value` lines are checked against the fixtures' truth.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::Temp;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the workspace").to_path_buf()
}

/// A fresh temporary folder for one test (removed when it passes).
fn temp(name: &str) -> Temp {
    Temp::new("readme", name)
}

/// The commands of the README's chain block, continuation lines joined.
fn readme_chain() -> Vec<String> {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let start = text.find("<!-- readme-chain").expect("README.md has the readme-chain marker");
    let block = &text[start..];
    let open = block.find("```sh\n").expect("an sh block after the marker") + 6;
    let close = block[open..].find("```").expect("the block is closed") + open;
    let mut commands = Vec::new();
    let mut current = String::new();
    for line in block[open..close].lines() {
        let line = line.trim();
        match line.strip_suffix('\\') {
            Some(part) => current.push_str(part),
            None => {
                current.push_str(line);
                if !current.trim().is_empty() {
                    commands.push(std::mem::take(&mut current));
                }
            }
        }
    }
    commands
}

/// Words of a command line as a POSIX shell splits them (single and double quotes).
fn split(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word: Option<String> = None;
    let mut quote: Option<char> = None;
    for c in line.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.get_or_insert_with(String::new).push(c),
            (None, '\'' | '"') => {
                quote = Some(c);
                word.get_or_insert_with(String::new);
            }
            (None, c) if c.is_whitespace() => words.extend(word.take()),
            (None, c) => word.get_or_insert_with(String::new).push(c),
        }
    }
    assert!(quote.is_none(), "unbalanced quote in {line:?}");
    words.extend(word);
    words
}

/// Runs `cargo xtask ARGS` (the built binary) in `dir`; fixture paths point to the workspace's.
/// Returns stdout; panics with both streams when the command fails.
fn run(dir: &Path, line: &str) -> String {
    let words = split(line);
    assert_eq!(&words[..2], ["cargo", "xtask"], "{line}");
    let fixtures = root().join("fixtures");
    let args: Vec<String> = words[2..]
        .iter()
        .map(|w| match w.strip_prefix("fixtures/") {
            Some(rest) => fixtures.join(rest).display().to_string(),
            None => w.clone(),
        })
        .collect();
    let out = Command::new(env!("CARGO_BIN_EXE_xtask")).args(&args).current_dir(dir).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "`{line}` failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// The trailing `key: value` lines of a command's output (every command ends with them), and a
/// check that none of them is Rust debug formatting.
fn keys(stdout: &str) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    for line in stdout.lines().rev() {
        let Some((k, v)) = line.split_once(": ") else { break };
        if k.is_empty() || !k.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_') {
            break;
        }
        assert!(!v.contains('{') && !v.contains("Some("), "debug formatting in {line:?}");
        map.insert(k.to_string(), v.trim().to_string());
    }
    assert!(!map.is_empty(), "no key: value lines at the end of:\n{stdout}");
    map
}

fn number(keys: &BTreeMap<String, String>, k: &str) -> f64 {
    keys.get(k).unwrap_or_else(|| panic!("no `{k}` in {keys:?}")).parse().unwrap()
}

#[derive(serde::Deserialize)]
struct Truth {
    gripper_from_camera: parallax_camera_model::Isometry3,
}
#[derive(serde::Deserialize)]
struct Trajectory {
    truth: Truth,
}
#[derive(serde::Deserialize)]
struct TrajectoryFile {
    trajectory: Trajectory,
}

/// Runs the chain with `calib` as the calibration file name; returns hand-eye's `result_tf`.
fn chain(name: &str, calib: &str) -> Vec<f64> {
    let dir = temp(name);
    let lines: Vec<String> = readme_chain().iter().map(|l| l.replace("calib.ron", calib)).collect();
    let stage = |word: &str| -> Vec<&String> { lines.iter().filter(|l| split(l)[2] == word).collect() };
    assert_eq!(lines.len(), 7, "{lines:#?}");

    for line in stage("corners") {
        let k = keys(&run(&dir, line));
        assert_eq!(k["found"], "5/5", "{line}");
    }
    // Truth of the fixtures: the rig of `fixtures/stereo/truth.ron` has |T| = 60.0021 mm.
    let k = keys(&run(&dir, stage("calibrate")[0]));
    assert!(number(&k, "stereo_rms_px") < 0.05, "{k:?}");
    assert!((number(&k, "baseline") - 60.0021).abs() < 0.2, "{k:?}");
    assert!(dir.join(calib).is_file());
    if calib.ends_with(".yml") {
        let text = std::fs::read_to_string(dir.join(calib)).unwrap();
        assert!(text.starts_with("%YAML:1.0\n---\n") && text.contains("M1: !!opencv-matrix"), "{text}");
    }

    let k = keys(&run(&dir, stage("rectify")[0]));
    assert!((number(&k, "rectified_baseline").abs() - 60.0021).abs() < 0.2, "{k:?}");
    assert_eq!(k["vertical"], "false");
    assert!(number(&k, "roi_left_width") > 0.0);

    let k = keys(&run(&dir, stage("disparity")[0]));
    // The boards stand 450–700 mm away in the truth of the fixtures; the median valid depth of
    // the first pair falls in the board's range or the background behind it.
    let median = number(&k, "depth_median");
    assert!(number(&k, "points") > 10_000.0 && (300.0..5000.0).contains(&median), "{k:?}");
    assert!(dir.join("out/points.ply").is_file());

    let k = keys(&run(&dir, stage("measure")[0]));
    // Outer corners 0, 8 and 45 of the 9x6 board of 25 mm squares: 200, 125 and √(200²+125²).
    for (key, truth) in [("distance_0_1", 200.0), ("distance_0_2", 125.0), ("distance_1_2", 235.8495)] {
        let d = number(&k, key);
        assert!((d - truth).abs() < 0.5, "{key}: {d} vs {truth}");
    }
    assert_eq!(k["flagged"], "0");

    let out = run(&dir, stage("handeye")[0]);
    let k = keys(&out);
    assert_eq!(k["result"], "refined");
    assert!(
        out.lines()
            .any(|l| l.starts_with("method: refined tx: ") && l.contains(" qw: ") && l.ends_with("converged: true"))
    );
    let tf: Vec<f64> = k["result_tf"].split(' ').map(|v| v.parse().unwrap()).collect();
    let truth: TrajectoryFile =
        parallax_composition::io::read_ron(&root().join("fixtures/handeye/eye-in-hand.ron")).unwrap();
    let x = parallax_camera_model::Isometry3::new(
        glam::DQuat::from_xyzw(tf[3], tf[4], tf[5], tf[6]),
        glam::DVec3::new(tf[0], tf[1], tf[2]),
    )
    .unwrap();
    let (rot, trans) = x.distance(&truth.trajectory.truth.gripper_from_camera);
    println!("{calib}: hand-eye error {:.4}° {trans:.3} mm", rot.to_degrees());
    // Six stations with 0.1° / 1 mm robot noise: the refinement reports σ ≈ 0.15° and ≈ 3 mm
    // per axis; the bounds are about 3σ.
    assert!(rot.to_degrees() < 0.5 && trans < 15.0, "{}° {trans} mm", rot.to_degrees());
    let _ = std::fs::remove_dir_all(&dir);
    tf
}

#[test]
fn the_readme_chain_runs_with_ron_and_with_opencv_yaml() {
    let ron = chain("ron", "calib.ron");
    let yml = chain("yml", "calib.yml");
    // The OpenCV file holds the same numbers (17 significant digits), so the chain gives the
    // same hand-eye result either way.
    for (a, b) in ron.iter().zip(&yml) {
        assert!((a - b).abs() < 1e-9, "{ron:?} vs {yml:?}");
    }
}

#[test]
fn unknown_output_extensions_are_refused_and_handeye_takes_out_and_output() {
    let dir = temp("refuse");
    let bin = env!("CARGO_BIN_EXE_xtask");
    let stereo = root().join("fixtures/stereo");
    let out = Command::new(bin)
        .args(["calibrate", "--images"])
        .arg(stereo.join("left_0[01].png"))
        .args(["--board", "9x6", "--square", "25", "--out", "x.txt"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "--out x.txt was accepted");
    for f in [".txt", "ron", "json", "opencv", "ros", "kalibr"] {
        assert!(err.contains(f), "{f} missing from: {err}");
    }
    assert!(!dir.join("x.txt").exists());
    // handeye: --out and the old --output both write.
    let robot = root().join("fixtures/handeye/robot_poses.ron");
    let calib = root().join("crates/interop/tests/data/cv2_mono.xml");
    for (flag, file) in [("--out", "he.json"), ("--output", "he.ron")] {
        let out = Command::new(bin)
            .arg("handeye")
            .arg("--robot")
            .arg(&robot)
            .arg("--images")
            .arg(root().join("fixtures/handeye/station_*.png"))
            .args(["--board", "9x6", "--square", "25", "--method", "park", "--intrinsics"])
            .arg(&calib)
            .args([flag, file])
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let (c, _) = parallax_interop::read(&[dir.join(file)]).unwrap();
        assert!(matches!(c, parallax_interop::Calibration::HandEye(_)), "{file}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn corners_reads_bmp_tiff_and_webp() {
    let dir = temp("formats");
    let img = image::open(root().join("fixtures/stereo/left_00.png")).unwrap();
    for ext in ["bmp", "tiff", "webp"] {
        img.save(dir.join(format!("view.{ext}"))).unwrap();
        let k = keys(&run(&dir, &format!("cargo xtask corners --images '*.{ext}' --board 9x6")));
        assert_eq!(k["found"], "1/1", "{ext}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
