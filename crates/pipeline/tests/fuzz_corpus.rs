//! Replays the seed corpus of every fuzz target (`fuzz/corpus/<target>/`, including the inputs
//! that once crashed a parser) through the function the target calls
//! (`parallax_composition::fuzz_checks`), on the stable toolchain: a parser that panics on any
//! of them, or a round trip that fails, fails this test, naming the file.

use std::path::{Path, PathBuf};

use parallax_composition::fuzz_checks;

fn corpus_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus")
}

#[test]
fn every_fuzz_target_has_a_seed_corpus_and_every_folder_a_target() {
    let mut folders: Vec<String> = std::fs::read_dir(corpus_root())
        .expect("fuzz/corpus exists")
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    folders.sort();
    let mut targets: Vec<String> = fuzz_checks::TARGETS.iter().map(|s| s.to_string()).collect();
    targets.sort();
    assert_eq!(folders, targets, "fuzz/corpus/ folders and fuzz_checks::TARGETS differ");
    for t in fuzz_checks::TARGETS {
        let manifest = corpus_root().join("../fuzz_targets").join(format!("{t}.rs"));
        let text = std::fs::read_to_string(&manifest).unwrap_or_else(|e| panic!("{}: {e}", manifest.display()));
        assert!(text.contains(&format!("fuzz_checks::{t}(")), "{} does not call fuzz_checks::{t}", manifest.display());
    }
}

#[test]
fn the_seed_corpus_replays_without_a_panic() {
    let mut failures = Vec::new();
    let mut count = 0;
    for target in fuzz_checks::TARGETS {
        let dir = corpus_root().join(target);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        assert!(!files.is_empty(), "{}: empty seed corpus", dir.display());
        for file in files {
            let data = std::fs::read(&file).unwrap();
            count += 1;
            let outcome = std::panic::catch_unwind(|| assert!(fuzz_checks::run(target, &data)));
            if outcome.is_err() {
                failures.push(file.display().to_string());
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {count} corpus files failed their check:\n{}",
        failures.len(),
        failures.join("\n")
    );
    println!("{count} corpus files replayed");
}

/// The seeds are not only rejected inputs: each real file of the corpus parses (so the round
/// trips above were exercised on real values).
#[test]
fn the_real_seed_files_parse() {
    let root = corpus_root();
    let text = |p: &str| std::fs::read_to_string(root.join(p)).unwrap();
    assert_eq!(
        parallax_block_matching::from_pfm(&std::fs::read(root.join("pfm/easy_crop_le.pfm")).unwrap(), "pfm")
            .unwrap()
            .width(),
        20
    );
    assert_eq!(
        parallax_block_matching::from_pfm(&std::fs::read(root.join("pfm/hard_crop_be.pfm")).unwrap(), "pfm")
            .unwrap()
            .height(),
        16
    );
    for f in ["robot_pose_0.yaml", "eMc_4x4.yaml", "inline.yaml"] {
        parallax_hand_eye::visp::parse_pose_yaml(&text(&format!("visp_pose/{f}")), f).unwrap();
    }
    // The axis-angle seed holds the fixtures' robot poses: the same poses as the RON file.
    let lines = std::fs::read(root.join("pose_text/axis_angle_robot_poses.bin")).unwrap();
    let from_lines = parallax_hand_eye::io::parse_pose_file(
        std::str::from_utf8(&lines[1..]).unwrap(),
        parallax_hand_eye::io::PoseFileFormat::AxisAngle,
        "lines",
    )
    .unwrap();
    let ron_seed = std::fs::read(root.join("pose_text/ron_robot_poses.bin")).unwrap();
    let from_ron = parallax_hand_eye::io::parse_pose_ron(std::str::from_utf8(&ron_seed[1..]).unwrap(), "ron").unwrap();
    assert_eq!(from_lines.len(), 6);
    for (a, b) in from_lines.iter().zip(&from_ron) {
        let (dr, dt) = a.distance(b);
        assert!(dr < 1e-9 && dt < 1e-9, "{a:?} vs {b:?}");
    }
    parallax_hand_eye::visp::parse_camera_xml(&text("visp_camera/fixture_camera.xml"), "xml", None, None).unwrap();
    for f in
        ["cv2_mono.yml", "cv2_stereo.xml", "ours_stereo.ron", "ours_mono.json", "ours_handeye.yml", "cv2_handeye.yml"]
    {
        parallax_interop::parse(&text(&format!("calibration/{f}")), f).unwrap();
    }
    // the nesting bombs and the repeated XML element: refused, naming why
    for (f, why) in [
        ("edge-nesting-json.json", "nested more than 128 levels"),
        ("edge-nesting-yaml.yml", "nested more than 128 levels"),
        ("edge-nesting-ron.ron", "nested more than 128 levels"),
        ("edge-nesting-xml.xml", "XML nested more than 128 levels"),
        ("edge-xml-repeated-key.xml", "<image_width> appears twice"),
    ] {
        let err = parallax_interop::parse(&text(&format!("calibration/{f}")), f).unwrap_err().to_string();
        assert!(err.contains(why), "{f}: {err}");
    }
    for f in ["easy.ron", "hard.ron", "eye-to-hand.ron"] {
        parallax_synthetic::SceneDescription::from_ron(&text(&format!("scene/{f}"))).unwrap();
    }
    let img = std::fs::read(root.join("chessboard_image/board_4x3.png")).unwrap();
    let gray = parallax_composition::io::decode_image(&img, Path::new("board_4x3.png")).unwrap().into_luma8();
    let cfg = parallax_corner_detection::ChessboardConfig::default();
    let grid =
        parallax_corner_detection::find_chessboard(&gray, 4, 3, &cfg).unwrap().expect("the drawn board is found");
    // First inner corner between the squares at 20..40 and 40..60 px: pixel 39.5 (pixel centres).
    assert!((grid.corners[0] - glam::DVec2::new(39.5, 39.5)).length() < 0.1, "{:?}", grid.corners[0]);
    let truncated = std::fs::read(root.join("chessboard_image/truncated.jpg")).unwrap();
    assert!(parallax_composition::io::decode_image(&truncated, Path::new("t.jpg")).is_err());
    // Point lists: the valid seeds parse (to the values written), the `edge-` ones are refused.
    let pairs =
        parallax_composition::measurement::parse_pixel_pairs(&text("point_list/four_values.txt"), None).unwrap();
    assert_eq!(pairs[0], (glam::DVec2::new(100.5, 200.25), glam::DVec2::new(90.5, 200.25)));
    let lr = text("point_list/left_and_right.txt");
    let (l, r) = lr.split_once('|').unwrap();
    assert_eq!(parallax_composition::measurement::parse_pixel_pairs(l, Some(r)).unwrap().len(), 2);
    for f in ["edge-nan.txt", "edge-count-mismatch.txt"] {
        let t = text(&format!("point_list/{f}"));
        let (l, r) = t.split_once('|').map_or((t.as_str(), None), |(l, r)| (l, Some(r)));
        assert!(parallax_composition::measurement::parse_pixel_pairs(l, r).is_err(), "{f}");
    }
    // Target files: every seed but the `edge-` ones reads; Kalibr's templates in metres.
    for f in std::fs::read_dir(root.join("target_file")).unwrap().flatten() {
        let name = f.file_name().to_string_lossy().into_owned();
        let parsed = parallax_interop::read_target(&f.path());
        assert_eq!(parsed.is_ok(), !name.starts_with("edge-"), "{name}: {parsed:?}");
    }
    let april = parallax_interop::read_target(&root.join("target_file/kalibr_aprilgrid.yaml")).unwrap();
    assert_eq!(april, "aprilgrid:6x6:0.088:0.3".parse().unwrap());
    // Corners files: the seed written by `corners --out` reads and gives its views.
    let file: parallax_composition::session::CornersFile = ron::from_str(&text("corners_file/mono_9x6.ron")).unwrap();
    let board = "chessboard:9x6:1".parse().unwrap();
    let views = file.views(Path::new("mono_9x6.ron"), &board).unwrap();
    assert!(views.iter().filter(|v| v.grid.is_some()).count() >= 2);
}
