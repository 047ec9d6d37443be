//! The evaluation keys of `disparity` through the built binary, against figures this test
//! computes itself from the map the run wrote and the ground truth: `bad2` and `density` over
//! every pixel with known truth, `bad2_overlap` and `density_overlap` over those in the columns
//! where OpenCV's matchers also answer (`x ≥ min_disparity + disparities`).

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::Temp;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the workspace").to_path_buf()
}

/// `(bad-2 with missing = bad, density)` in percent over the pixels of known truth in columns
/// `x ≥ first`, counted here pixel by pixel.
fn bad2_and_density(map: &[f32], truth: &[f32], width: usize, first: usize) -> (f64, f64) {
    let (mut n, mut bad, mut returned) = (0usize, 0usize, 0usize);
    for (i, (&d, &t)) in map.iter().zip(truth).enumerate() {
        if i % width < first || t.is_nan() {
            continue;
        }
        n += 1;
        if d.is_nan() {
            bad += 1;
        } else {
            returned += 1;
            if (d - t).abs() > 2.0 {
                bad += 1;
            }
        }
    }
    (100.0 * bad as f64 / n as f64, 100.0 * returned as f64 / n as f64)
}

fn key<'a>(stdout: &'a str, name: &str) -> &'a str {
    let prefix = format!("{name}: ");
    stdout.lines().find_map(|l| l.strip_prefix(&prefix)).unwrap_or_else(|| panic!("no {name}:\n{stdout}"))
}

#[test]
fn the_overlap_keys_are_the_figures_of_the_written_map_over_the_columns_opencv_answers() {
    let dir = Temp::new("keys", "overlap");
    let easy = root().join("fixtures/stereo-scene-easy");
    let gt = easy.join("disparity.pfm");
    let truth = parallax_block_matching::from_pfm(&std::fs::read(&gt).unwrap(), "truth").unwrap();
    let (left, right) = (easy.join("left.png"), easy.join("right.png"));
    for (method, min, n) in [("bm", 0i32, 40i32), ("sgm", 0, 48), ("bm", 4, 36)] {
        let out = dir.join(format!("{method}{min}"));
        let args = [
            "disparity",
            "--left",
            left.to_str().unwrap(),
            "--right",
            right.to_str().unwrap(),
            "--gt",
            gt.to_str().unwrap(),
            "--method",
            method,
            "--min-disparity",
            &min.to_string(),
            "--disparities",
            &n.to_string(),
            "--runs",
            "1",
            "--out",
            out.to_str().unwrap(),
        ];
        let r = Command::new(env!("CARGO_BIN_EXE_xtask")).args(args).current_dir(root()).output().unwrap();
        let stdout = String::from_utf8_lossy(&r.stdout);
        assert!(r.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&r.stderr));
        let map = parallax_block_matching::from_pfm(&std::fs::read(out.join("disparity.pfm")).unwrap(), "map").unwrap();
        let w = map.width();
        let (bad2, density) = bad2_and_density(map.data(), truth.data(), w, 0);
        let first = (min + n) as usize;
        let (bad2_o, density_o) = bad2_and_density(map.data(), truth.data(), w, first);
        let case = format!("{method} [{min}, {}):\n{stdout}", min + n);
        assert_eq!(key(&stdout, "bad2"), format!("{bad2:.2}"), "{case}");
        assert_eq!(key(&stdout, "density"), format!("{density:.2}"), "{case}");
        assert_eq!(key(&stdout, "bad2_overlap"), format!("{bad2_o:.2}"), "{case}");
        assert_eq!(key(&stdout, "density_overlap"), format!("{density_o:.2}"), "{case}");
        // the left band changes the figures: the test tells the two scopes apart
        assert_ne!(format!("{density:.2}"), format!("{density_o:.2}"), "{case}");
        // pixels left of min_disparity have no candidate: their share of the image is printed
        let no_candidate = 100.0 * (min as usize * map.height()) as f64 / (w * map.height()) as f64;
        assert_eq!(key(&stdout, "rejected_no_candidate"), format!("{no_candidate:.2}"), "{case}");
    }
}
