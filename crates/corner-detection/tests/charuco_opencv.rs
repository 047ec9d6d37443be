//! ChArUco layouts from their owner: boards drawn by OpenCV's own `CharucoBoard.generateImage`
//! (current and legacy layouts, even and odd row counts, three dictionaries), with the truth from
//! OpenCV's `getChessboardCorners()` — `tests/data/opencv-charuco/`, made by its script (see the
//! provenance there). Every chessboard corner is found with OpenCV's id, near its true position
//! (at least as near as OpenCV's own detector on the same image), and every marker id OpenCV
//! decodes is decoded. A board described with the other layout finds no corner with a wrong id.

use std::path::PathBuf;

use glam::DVec2;
use parallax_camera_model::{CharucoBoard, MarkerDictionary};
use parallax_corner_detection::{CharucoConfig, detect_charuco};
use serde::Deserialize;

#[derive(Deserialize)]
struct Fixture {
    opencv: String,
    boards: Vec<Entry>,
}

#[derive(Deserialize)]
struct Entry {
    image: String,
    board: String,
    squares_x: usize,
    squares_y: usize,
    square_px: f64,
    marker_px: f64,
    dictionary: String,
    legacy: bool,
    truth: Vec<[f64; 2]>,
    opencv_ids: Vec<u32>,
    opencv_points: Vec<[f64; 2]>,
    opencv_markers: Vec<u32>,
}

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/opencv-charuco")
}

fn fixture() -> Fixture {
    serde_json::from_str(&std::fs::read_to_string(data().join("boards.json")).unwrap()).unwrap()
}

fn board(e: &Entry, legacy: bool) -> CharucoBoard {
    let dict = MarkerDictionary::predefined(&e.dictionary).unwrap();
    CharucoBoard::new(e.squares_x, e.squares_y, e.square_px, e.marker_px, dict, legacy).unwrap()
}

/// Corner error bound: a sharp binary render puts every corner exactly between four pixels; our
/// saddle fit lands within 0.05 px of it (OpenCV's `cornerSubPix` on the same images: up to 0.26 px).
const TOL_PX: f64 = 0.05;

#[test]
fn boards_drawn_by_opencv_are_found_with_every_id_right() {
    let f = fixture();
    assert_eq!(f.boards.len(), 4);
    for e in &f.boards {
        let img = image::open(data().join(&e.image)).unwrap().to_luma8();
        let det = detect_charuco(&img, &board(e, e.legacy), &CharucoConfig::default()).unwrap();
        let (ids, points) = (det.observation.ids(), det.observation.points());
        let n = (e.squares_x - 1) * (e.squares_y - 1);
        assert_eq!(e.truth.len(), n);
        assert_eq!(
            ids,
            (0..n as u32).collect::<Vec<_>>(),
            "{} ({}, OpenCV {}): every corner, OpenCV's ids",
            e.image,
            e.board,
            f.opencv
        );
        let mut worst = 0.0f64;
        for (&id, p) in ids.iter().zip(points) {
            let t = DVec2::from(e.truth[id as usize]);
            worst = worst.max((*p - t).length());
        }
        let opencv_worst = e
            .opencv_ids
            .iter()
            .zip(&e.opencv_points)
            .map(|(&id, &p)| (DVec2::from(p) - DVec2::from(e.truth[id as usize])).length())
            .fold(0.0, f64::max);
        println!("{}: {n} corners, worst {worst:.4} px from the truth (OpenCV {opencv_worst:.4} px)", e.image);
        assert!(worst <= TOL_PX && worst <= opencv_worst.max(TOL_PX), "{}: worst corner {worst} px", e.image);
        let mut markers: Vec<u32> = det.markers.iter().map(|m| m.id).collect();
        markers.sort_unstable();
        markers.dedup();
        assert_eq!(markers, e.opencv_markers, "{}: the markers OpenCV decodes", e.image);
    }
}

/// The two layouts differ only with an even number of rows; there, a board described with the
/// other layout gives no corner (OpenCV's `CharucoDetector` gives none either): with an odd column
/// count most markers confirm each other one square over, and only the layout check
/// (`CharucoDetection::misplaced`) tells.
#[test]
fn the_other_layout_gives_no_wrong_id() {
    for e in fixture().boards.iter().filter(|e| e.squares_y % 2 == 0) {
        let img = image::open(data().join(&e.image)).unwrap().to_luma8();
        let det = detect_charuco(&img, &board(e, !e.legacy), &CharucoConfig::default()).unwrap();
        let wrong = det
            .observation
            .ids()
            .iter()
            .zip(det.observation.points())
            .filter(|(id, p)| (**p - DVec2::from(e.truth[**id as usize])).length() > 1.0)
            .count();
        println!(
            "{} as legacy = {}: {} corners, {wrong} wrong, misplaced markers {:?}",
            e.image,
            !e.legacy,
            det.observation.ids().len(),
            det.misplaced
        );
        assert_eq!(wrong, 0, "{}: described with the other layout", e.image);
        assert!(det.observation.ids().is_empty(), "{}: described with the other layout", e.image);
        assert!(!det.misplaced.is_empty(), "{}: the layout check names the markers", e.image);
    }
}
