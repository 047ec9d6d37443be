//! Times `detect_charuco` on the views written by `tests/charuco.rs` (`CHARUCO_DUMP=DIR`), the
//! board of that test (9x7 squares, 25 / 18 mm, DICT_4X4_50), for the side-by-side figure with
//! `scripts/charuco_vs_opencv.py` on the same files:
//! `cargo run --release -p parallax-corner-detection --example time_charuco -- DIR`.

use parallax_camera_model::{CharucoBoard, MarkerDictionary};
use parallax_corner_detection::{CharucoConfig, detect_charuco};

fn main() {
    let dir = std::env::args().nth(1).expect("usage: time_charuco DIR");
    let board =
        CharucoBoard::new(9, 7, 25.0, 18.0, MarkerDictionary::predefined("DICT_4X4_50").expect("predefined"), false)
            .expect("valid board");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .expect("readable directory")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "png"))
        .collect();
    paths.sort();
    let cfg = CharucoConfig::default();
    let mut times = Vec::new();
    let mut corners = 0;
    for p in &paths {
        let img = image::open(p).expect("PNG").into_luma8();
        let t0 = std::time::Instant::now();
        let d = detect_charuco(&img, &board, &cfg).expect("valid input");
        times.push(t0.elapsed().as_secs_f64() * 1e3);
        corners += d.observation.len();
    }
    times.sort_by(f64::total_cmp);
    println!(
        "detect_charuco: {} images, {corners} corners, median {:.2} ms per image",
        paths.len(),
        times[times.len() / 2]
    );
}
