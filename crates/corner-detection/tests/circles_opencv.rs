//! Circle-grid orderings from their owner: OpenCV's `findCirclesGrid` order on symmetric 7x6
//! and asymmetric 4x11 grids, each seen frontally and through perspective warps that turn it by
//! 0–330 degrees (`tests/data/opencv-circles/`, its script: the grids are drawn there, the
//! order is OpenCV's). Every grid OpenCV finds is found, with the same circles (within 0.5 px of
//! OpenCV's centres), in OpenCV's order wherever that order keeps the board's handedness (rows ×
//! columns pointing into the board, as for every other view of it). OpenCV orders a symmetric
//! grid turned by 90° or 270° mirrored (rows along +v, columns along +u: the board's frame seen
//! from behind, a frame inconsistent with its other views for hand-eye or multi-view use);
//! there parallax keeps the handedness and the test says so.

use std::path::PathBuf;

use glam::DVec2;
use parallax_camera_model::TargetDescription;
use parallax_corner_detection::detect_circle_grid;
use serde::Deserialize;

#[derive(Deserialize)]
struct Fixture {
    opencv: String,
    grids: Vec<Entry>,
}

#[derive(Deserialize)]
struct Entry {
    image: String,
    board: String,
    angle_deg: f64,
    opencv: Vec<[f64; 2]>,
}

#[test]
fn every_grid_opencv_finds_is_found_in_opencvs_order() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/opencv-circles");
    let f: Fixture = serde_json::from_str(&std::fs::read_to_string(dir.join("grids.json")).unwrap()).unwrap();
    assert_eq!(f.grids.len(), 14);
    let mut bad = Vec::new();
    for e in &f.grids {
        let TargetDescription::CircleGrid(grid) = e.board.parse::<TargetDescription>().unwrap() else {
            panic!("{}: not a circle grid", e.board)
        };
        let img = image::open(dir.join(&e.image)).unwrap().to_luma8();
        let Some(d) = detect_circle_grid(&img, &grid, &Default::default()).unwrap() else {
            bad.push(format!("{} ({}°): not found", e.image, e.angle_deg));
            continue;
        };
        let ours = d.observation.points();
        let theirs: Vec<DVec2> = e.opencv.iter().map(|&p| DVec2::from(p)).collect();
        assert_eq!(ours.len(), theirs.len());
        // the grid's handedness in the image: rows × columns (first row, first column)
        let cols = grid.cols();
        let hand = |p: &[DVec2]| (p[1] - p[0]).perp_dot(p[cols] - p[0]).signum();
        let same_circles = ours.iter().all(|p| theirs.iter().any(|q| (*p - *q).length() < 0.5));
        let worst = ours.iter().zip(&theirs).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
        let mirrored = hand(&theirs) < 0.0;
        println!(
            "{} ({}°, OpenCV {}): {}",
            e.image,
            e.angle_deg,
            f.opencv,
            if mirrored {
                format!("OpenCV's order mirrored; ours keeps the handedness ({})", hand(ours))
            } else {
                format!("OpenCV's order, worst {worst:.3} px")
            }
        );
        if !same_circles {
            bad.push(format!("{}: other circles", e.image));
        } else if mirrored && hand(ours) <= 0.0 {
            bad.push(format!("{}: mirrored", e.image));
        } else if !mirrored && worst > 0.5 {
            bad.push(format!("{} ({}°): another order than OpenCV's, worst {worst:.1} px", e.image, e.angle_deg));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
