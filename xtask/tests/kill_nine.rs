//! Crash-consistent outputs (issue 51 item 3): `kill -9` at random moments of `disparity`, `rectify`
//! and `calibrate --out … --report …` runs (55 kills) that replace an earlier run's outputs. After each kill (and
//! the commit journal a killed run may leave finished, as the next run does first), the output
//! folder holds exactly the earlier set or exactly the new one — names and bytes — never a mix,
//! and no file of an older run beside a newer set; after a complete run no staged file or journal
//! is left. Two option sets alternate, so that consecutive sets differ in their files
//! (`confidence.pfm` only with `--confidence`) and bytes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod common;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Every file below `dir` (relative name → bytes), hidden ones included.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(dir).unwrap().display().to_string(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn visible(s: &BTreeMap<String, Vec<u8>>) -> BTreeMap<String, Vec<u8>> {
    s.iter().filter(|(k, _)| !k.split('/').any(|c| c.starts_with('.'))).map(|(k, v)| (k.clone(), v.clone())).collect()
}

/// A small deterministic generator (xorshift), so that the kill moments vary but reproduce.
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }
}

/// Runs `args(k)` into `out` to completion for k = 0, 1 (the two reference sets), then `kills`
/// times: starts run k (alternating), kills it after a random moment within 1.3 times a full
/// run's duration, finishes any journal, and checks the folder holds one whole set.
fn kill_at_random(name: &str, kills: usize, args: &dyn Fn(usize, &Path) -> Vec<String>, seed: u64) -> (usize, usize) {
    let base = common::Temp::new("kill9", name);
    let run = |k: usize, out: &Path| {
        let r = Command::new(env!("CARGO_BIN_EXE_xtask")).args(args(k, out)).current_dir(root()).output().unwrap();
        assert!(r.status.success(), "{name} run {k}: {}", String::from_utf8_lossy(&r.stderr));
    };
    // the two complete sets, and a full run's duration
    let mut sets = Vec::new();
    let mut full = Duration::ZERO;
    for k in 0..2 {
        let out = base.join(format!("ref{k}"));
        let t0 = Instant::now();
        run(k, &out);
        full = full.max(t0.elapsed());
        sets.push(visible(&snapshot(&out)));
    }
    assert_ne!(sets[0], sets[1], "{name}: the two option sets must give different outputs");
    let out = base.join("work");
    run(0, &out);
    let mut current = 0;
    let (mut old, mut new) = (0, 0);
    let mut rng = Rng(seed);
    for i in 0..kills {
        let next = 1 - current;
        let mut child = Command::new(env!("CARGO_BIN_EXE_xtask"))
            .args(args(next, &out))
            .current_dir(root())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(full.mul_f64(1.3 * rng.below(1000) as f64 / 1000.0));
        let _ = child.kill(); // SIGKILL
        child.wait().unwrap();
        // what the next run does first
        for d in [out.clone(), out.join("report")] {
            parallax_composition::io::finish_killed_commits(&d);
        }
        let now = visible(&snapshot(&out));
        if now == sets[next] {
            new += 1;
            current = next;
        } else {
            assert_eq!(now, sets[current], "{name}, kill {i}: neither the earlier set nor the new one");
            old += 1;
        }
        // a complete run now and then: it leaves no staged file or journal, whatever was killed
        if i % 5 == 4 {
            run(current, &out);
            let hidden: Vec<String> =
                snapshot(&out).into_keys().filter(|k| k.split('/').any(|c| c.starts_with('.'))).collect();
            assert!(hidden.is_empty(), "{name}: left after a complete run: {hidden:?}");
        }
    }
    (old, new)
}

#[test]
fn disparity_outputs_are_the_old_set_or_the_new_one_after_any_kill() {
    let (l, r) =
        (root().join("fixtures/stereo-scene-easy/left.png"), root().join("fixtures/stereo-scene-easy/right.png"));
    let args = |k: usize, out: &Path| -> Vec<String> {
        let mut a: Vec<String> = [
            "disparity",
            "--left",
            l.to_str().unwrap(),
            "--right",
            r.to_str().unwrap(),
            "--runs",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        if k == 1 {
            a.extend(["--confidence", "--block", "7"].map(String::from));
        }
        a
    };
    let (old, new) = kill_at_random("disparity", 25, &args, 0x9e37_79b9_7f4a_7c15);
    println!("disparity: 25 kills, {old} left the earlier set, {new} the new one, none a mix");
}

#[test]
fn calibration_and_report_are_the_old_set_or_the_new_one_after_any_kill() {
    let images = root().join("fixtures/stereo/left_*.png");
    let args = |k: usize, out: &Path| -> Vec<String> {
        let square = if k == 0 { "25" } else { "24" };
        [
            "calibrate",
            "--images",
            images.to_str().unwrap(),
            "--board",
            "9x6",
            "--square",
            square,
            "--out",
            out.join("camera.ron").to_str().unwrap(),
            "--report",
            out.join("report").to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let (old, new) = kill_at_random("calibrate", 15, &args, 0x2545_f491_4f6c_dd1d);
    println!("calibrate --report: 15 kills, {old} left the earlier set, {new} the new one, none a mix");
}

#[test]
fn rectified_images_and_maps_are_the_old_set_or_the_new_one_after_any_kill() {
    // an OpenCV stereo calibration of the fixtures' 640x480 rig (k1 = −0.1, 60 mm baseline)
    let dir = common::Temp::new("kill9", "calib");
    let calib = dir.join("calib.yml");
    std::fs::write(&calib, common::opencv_stereo_yaml("-0.1")).unwrap();
    let (l, r) = (root().join("fixtures/stereo/left_00.png"), root().join("fixtures/stereo/right_00.png"));
    let args = |k: usize, out: &Path| -> Vec<String> {
        let alpha = if k == 0 { "0" } else { "1" };
        [
            "rectify",
            "--calib",
            calib.to_str().unwrap(),
            "--left",
            l.to_str().unwrap(),
            "--right",
            r.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--alpha",
            alpha,
        ]
        .map(String::from)
        .to_vec()
    };
    let (old, new) = kill_at_random("rectify", 15, &args, 0x0123_4567_89ab_cdef);
    println!("rectify: 15 kills, {old} left the earlier set, {new} the new one, none a mix");
}
