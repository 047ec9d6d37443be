//! Real images from `../shared/data` (skipped with a message when the folder is absent):
//! the 9x6 board must be found in all 28 OpenCV stereo images and all 8 ViSP images, and the
//! order must be OpenCV's (right-handed grid, black square at the first corner's diagonal).

use std::path::{Path, PathBuf};

use parallax_corner_detection::{ChessboardConfig, find_chessboard};

fn data_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"))
}

fn images(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> =
        std::fs::read_dir(dir).map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect()).unwrap_or_default();
    v.retain(|p| {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        name.starts_with(prefix) && (name.ends_with(".jpg") || name.ends_with(".png"))
    });
    v.sort();
    v
}

#[test]
fn real_chessboards_are_all_found_in_opencv_order() {
    let root = data_dir();
    if !root.exists() {
        println!("skipped: ../shared not found ({})", root.display());
        return;
    }
    let mut paths = images(&root.join("opencv-stereo-chessboard"), "left");
    paths.extend(images(&root.join("opencv-stereo-chessboard"), "right"));
    paths.extend(images(&root.join("visp-franka-eye-in-hand"), "franka_image"));
    assert_eq!(paths.len(), 36, "expected 28 + 8 images");
    let cfg = ChessboardConfig::default();
    let mut missed = Vec::new();
    for p in &paths {
        let img = image::open(p).unwrap().into_luma8();
        match find_chessboard(&img, 9, 6, &cfg).unwrap() {
            None => missed.push(p.display().to_string()),
            Some(g) => {
                // Right-handed in the image.
                let x = g.at(8, 0) - g.at(0, 0);
                let y = g.at(0, 5) - g.at(0, 0);
                assert!(x.perp_dot(y) > 0.0, "{}: left-handed grid", p.display());
                // The square between corners (0,0) and (1,1) is black (raw pixels, independent of
                // the detector's own colour test): darker than the square between (1,0) and (2,1).
                let sample = |q: glam::DVec2| img.get_pixel(q.x.round() as u32, q.y.round() as u32)[0] as i32;
                let first = (g.at(0, 0) + g.at(1, 1)) * 0.5;
                let next = (g.at(1, 0) + g.at(2, 1)) * 0.5;
                assert!(sample(first) + 40 < sample(next), "{}: first square is not black", p.display());
            }
        }
    }
    assert!(missed.is_empty(), "board not found in {missed:?}");
}
