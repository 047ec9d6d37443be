//! The parsers of external input, each behind one function that takes raw bytes and panics
//! only when a property fails: the `fuzz/` targets (`cargo +nightly fuzz run <target>`) call
//! them with generated inputs, and `tests/fuzz_corpus.rs` replays every file of
//! `fuzz/corpus/<target>/` through the same function on the stable toolchain.
//!
//! Each function checks that the parser never panics (any input, valid or not, must give a
//! value or an error) and, where cheap, a round trip: what was parsed, written by the project's
//! own writer and parsed again, is the same value (exactly, or to the stated tolerance where
//! the writer goes through another parametrisation of a rotation).
//!
//! | function | parser |
//! |---|---|
//! | [`pfm`] | `parallax_block_matching::from_pfm` (disparity maps) |
//! | [`pose_text`] | `parallax_hand_eye::io::parse_pose_file` (axis-angle and roll-pitch-yaw lines, RON lists, ViSP YAML) |
//! | [`visp_pose`] | `parallax_hand_eye::visp::parse_pose_yaml` (ViSP `vpPoseVector` / `vpHomogeneousMatrix` YAML) |
//! | [`visp_camera`] | `parallax_hand_eye::visp::parse_camera_xml` (ViSP camera XML) |
//! | [`calibration`] | `parallax_interop::parse` (RON, JSON, OpenCV YAML / XML, ROS, Kalibr, hand-eye records) and `parse_rig_pair` (Kalibr camchains of any size, OpenCV multiview, rig records) |
//! | [`scene`] | `parallax_synthetic::SceneDescription::from_ron` (scene files) |
//! | [`chessboard_image`] | [`crate::io::decode_image`] into `parallax_corner_detection::find_chessboard` |
//! | [`point_list`] | [`crate::measurement::parse_pixel_pairs`] (`measure --points` / `--right-points`) |
//! | [`corners_file`] | [`crate::session::CornersFile`] (`corners --out`, `calibrate --corners`) and its views |
//! | [`target_file`] | `parallax_interop::parse_target` (`--board` target files: Kalibr YAML, records, description lines) |

use std::path::Path;

use parallax_camera_model::Isometry3;
use parallax_hand_eye::io::{PoseFileFormat, RotationFormat};

/// Largest side of a decoded image handed to the chessboard detector by [`chessboard_image`]
/// (larger images are decoded but not searched, to keep a fuzz iteration short).
pub const MAX_FUZZ_IMAGE_SIDE: u32 = 1024;

/// Names of the fuzz targets, one per function of this module (and one corpus folder each).
pub const TARGETS: [&str; 10] = [
    "pfm",
    "pose_text",
    "visp_pose",
    "visp_camera",
    "calibration",
    "scene",
    "chessboard_image",
    "point_list",
    "corners_file",
    "target_file",
];

/// Runs the check of target `name` on `data`; `false` when no target has that name.
pub fn run(name: &str, data: &[u8]) -> bool {
    match name {
        "pfm" => pfm(data),
        "pose_text" => pose_text(data),
        "visp_pose" => visp_pose(data),
        "visp_camera" => visp_camera(data),
        "calibration" => calibration(data),
        "scene" => scene(data),
        "chessboard_image" => chessboard_image(data),
        "point_list" => point_list(data),
        "corners_file" => corners_file(data),
        "target_file" => target_file(data),
        _ => return false,
    }
    true
}

/// The same rotation (quaternions equal up to sign, to `tol` in the components) and
/// translation (to `tol` relative to its size).
fn assert_close(a: &Isometry3, b: &Isometry3, tol: f64, what: &str) {
    let (qa, qb) = (a.rotation(), b.rotation());
    let dq = (qa - qb).length().min((qa + qb).length());
    assert!(dq <= tol, "{what}: rotation {qa:?} came back as {qb:?}");
    let scale = a.translation.length().max(1.0);
    assert!(
        (a.translation - b.translation).length() <= tol * scale,
        "{what}: translation {:?} came back as {:?}",
        a.translation,
        b.translation
    );
}

/// Every pose a parser returns is finite with a unit quaternion.
fn assert_valid(p: &Isometry3, what: &str) {
    assert!(p.is_finite(), "{what}: a parser returned a non-finite pose {p:?}");
    assert!((p.rotation().length() - 1.0).abs() < 1e-9, "{what}: non-unit quaternion {:?}", p.rotation());
}

/// Axis-angle text lines of `poses` (the `rvec` in radians), full precision.
fn axis_angle_lines(poses: &[Isometry3]) -> String {
    poses
        .iter()
        .map(|p| {
            let (t, r) = (p.translation, p.rvec());
            format!("{:?} {:?} {:?} {:?} {:?} {:?}\n", t.x, t.y, t.z, r.x, r.y, r.z)
        })
        .collect()
}

/// PFM disparity maps: decode; a decoded map written with `to_pfm` decodes to the same map
/// (every valid value bit for bit, the same invalid pixels).
pub fn pfm(data: &[u8]) {
    let Ok(map) = parallax_block_matching::from_pfm(data, "fuzz.pfm") else { return };
    let back = parallax_block_matching::from_pfm(&parallax_block_matching::to_pfm(&map), "written.pfm")
        .expect("a written PFM decodes");
    assert_eq!((back.width(), back.height()), (map.width(), map.height()));
    for (a, b) in map.data().iter().zip(back.data()) {
        assert!(a.to_bits() == b.to_bits() || (!a.is_finite() && !b.is_finite()), "{a} came back as {b}");
    }
}

/// Pose files: the first byte picks the format (RON list, ViSP YAML, axis-angle lines,
/// roll-pitch-yaw lines), the rest is the text. Every pose returned is finite and unit; the
/// poses written as axis-angle lines (and as RON) parse back to the same poses.
pub fn pose_text(data: &[u8]) {
    let Some((&selector, rest)) = data.split_first() else { return };
    let Ok(text) = std::str::from_utf8(rest) else { return };
    let format =
        [PoseFileFormat::Ron, PoseFileFormat::Visp, PoseFileFormat::AxisAngle, PoseFileFormat::RollPitchYawDeg]
            [usize::from(selector % 4)];
    let Ok(poses) = parallax_hand_eye::io::parse_pose_file(text, format, "fuzz") else { return };
    assert!(!poses.is_empty(), "{format:?}: Ok with no pose");
    for p in &poses {
        assert_valid(p, "pose_text");
    }
    let lines = axis_angle_lines(&poses);
    let back = parallax_hand_eye::io::parse_pose_lines(&lines, RotationFormat::AxisAngle, "written")
        .unwrap_or_else(|e| panic!("{format:?}: written axis-angle lines do not parse: {e}\n{lines}"));
    assert_eq!(back.len(), poses.len());
    for (a, b) in poses.iter().zip(&back) {
        assert_close(a, b, 1e-9, "axis-angle lines");
    }
    let ron_text = ron::to_string(&poses).expect("poses serialise");
    let back = parallax_hand_eye::io::parse_pose_ron(&ron_text, "written.ron")
        .unwrap_or_else(|e| panic!("{format:?}: written RON does not parse: {e}\n{ron_text}"));
    assert_eq!(back, poses, "RON round trip");
}

/// ViSP pose YAML (6x1 pose vector or 4x4 matrix): the pose is finite and unit, and reads back
/// from both of ViSP's layouts as written by the project.
pub fn visp_pose(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(pose) = parallax_hand_eye::visp::parse_pose_yaml(text, "fuzz.yaml") else { return };
    assert_valid(&pose, "visp_pose");
    for written in
        [parallax_hand_eye::visp::pose_vector_yaml(&pose), parallax_hand_eye::visp::homogeneous_matrix_yaml(&pose)]
    {
        let back = parallax_hand_eye::visp::parse_pose_yaml(&written, "written.yaml")
            .unwrap_or_else(|e| panic!("written ViSP YAML does not parse: {e}\n{written}"));
        assert_close(&pose, &back, 1e-9, "ViSP YAML");
    }
}

/// ViSP camera XML: parsing, the conversion to OpenCV's model and the camera at the file's
/// image size (or 640x480) never panic; an accepted camera has positive finite focal lengths.
pub fn visp_camera(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(cam) = parallax_hand_eye::visp::parse_camera_xml(text, "fuzz.xml", None, None) else { return };
    let (w, h) = cam.image_size.unwrap_or((640, 480));
    if let Ok((intrinsics, _)) = cam.to_opencv() {
        assert!(intrinsics.fx > 0.0 && intrinsics.fy > 0.0, "accepted focal lengths {intrinsics:?}");
    }
    if let Ok(camera) = cam.camera(w, h) {
        assert!(camera.validate().is_ok(), "camera() returned an invalid camera {camera:?}");
    }
    let _ = cam.kdu_gap_px(w.min(4096), h.min(4096));
}

/// Calibration files of every format (detected from the content): a calibration read from
/// any of them, written as RON, JSON, OpenCV YAML and OpenCV XML, reads back as the same
/// calibration — cameras exactly, rotations to 1e-12 (OpenCV files hold them as matrices),
/// the same hand-eye setup.
pub fn calibration(data: &[u8]) {
    use parallax_interop::{Calibration, Format};
    let Ok(text) = std::str::from_utf8(data) else { return };
    // a calibration file, else cameras 2 and 0 of a rig file (Kalibr camchain, OpenCV
    // multiview, rig record)
    let calib = match parallax_interop::parse(text, "fuzz") {
        Ok((calib, _)) => calib,
        Err(_) => match parallax_interop::parse_rig_pair(text, (2, 0), "fuzz") {
            Ok(calib) => calib,
            Err(_) => return,
        },
    };
    for format in [Format::Ron, Format::Json, Format::OpenCvYaml, Format::OpenCvXml] {
        // Writing may refuse (e.g. a value a format cannot hold); it must not panic.
        let Ok(files) = parallax_interop::render(&calib, format, Path::new("written.yml")) else { continue };
        let (back, detected) = parallax_interop::parse(&files[0].1, "written")
            .unwrap_or_else(|e| panic!("{format:?}: a written calibration does not parse: {e}\n{}", files[0].1));
        assert_eq!(detected, format);
        let what = format!("{format:?} round trip");
        match (&calib, &back) {
            (Calibration::Mono(a), Calibration::Mono(b)) => assert_eq!(a.camera, b.camera, "{what}"),
            (Calibration::Stereo(a), Calibration::Stereo(b)) => {
                assert_eq!((&a.rig.left, &a.rig.right), (&b.rig.left, &b.rig.right), "{what}");
                assert_close(&a.rig.right_from_left, &b.rig.right_from_left, 1e-12, &what);
            }
            (Calibration::HandEye(a), Calibration::HandEye(b)) => {
                assert_eq!(a.setup, b.setup, "{what}");
                assert_close(&a.transform, &b.transform, 1e-12, &what);
            }
            _ => panic!("{what}: read back as another kind of calibration: {calib:?} → {back:?}"),
        }
    }
}

/// Scene files: a scene that parses and validates, written with `to_ron`, reads back equal.
pub fn scene(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(scene) = parallax_synthetic::SceneDescription::from_ron(text) else { return };
    let written = scene.to_ron();
    let back = parallax_synthetic::SceneDescription::from_ron(&written)
        .unwrap_or_else(|e| panic!("a written scene does not parse: {e}\n{written}"));
    assert_eq!(back, scene, "scene round trip");
}

/// Images: decoding with [`crate::io::decode_image`]'s checks, then the chessboard detector
/// (9x6 and 4x3 boards) on images up to [`MAX_FUZZ_IMAGE_SIDE`]; a board found has every
/// corner finite and inside the image.
pub fn chessboard_image(data: &[u8]) {
    let Ok(img) = crate::io::decode_image(data, Path::new("fuzz.img")) else { return };
    if img.width() > MAX_FUZZ_IMAGE_SIDE || img.height() > MAX_FUZZ_IMAGE_SIDE {
        return;
    }
    let gray = img.into_luma8();
    let cfg = parallax_corner_detection::ChessboardConfig::default();
    for (cols, rows) in [(9, 6), (4, 3)] {
        let Ok(Some(grid)) = parallax_corner_detection::find_chessboard(&gray, cols, rows, &cfg) else { continue };
        assert_eq!(grid.corners.len(), cols * rows);
        for c in &grid.corners {
            assert!(
                c.is_finite()
                    && c.x >= -0.5
                    && c.y >= -0.5
                    && c.x <= f64::from(gray.width()) - 0.5
                    && c.y <= f64::from(gray.height()) - 0.5,
                "corner {c} outside the {}x{} image",
                gray.width(),
                gray.height()
            );
        }
    }
}

/// `measure`'s point lists: the text up to the first `|` is `--points`, the rest (when there is
/// a `|`) `--right-points`. Every pair returned is finite, and the pairs written back in the
/// four-value form (shortest round-trip decimals) parse to the same values exactly.
pub fn point_list(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let (points, right) = match text.split_once('|') {
        Some((l, r)) => (l, Some(r)),
        None => (text, None),
    };
    let Ok(pairs) = crate::measurement::parse_pixel_pairs(points, right) else { return };
    assert!(!pairs.is_empty(), "point list: parsed to no pairs without an error");
    for (l, r) in &pairs {
        assert!(l.is_finite() && r.is_finite(), "point list: non-finite pair {l:?} {r:?}");
    }
    let written: Vec<String> = pairs.iter().map(|(l, r)| format!("{:?},{:?},{:?},{:?}", l.x, l.y, r.x, r.y)).collect();
    let back = crate::measurement::parse_pixel_pairs(&written.join(";"), None)
        .unwrap_or_else(|e| panic!("point list: written pairs do not parse: {e}"));
    assert_eq!(back, pairs, "point list round trip");
}

/// Corners files (RON or JSON): a file that parses is written back as RON and parses to the
/// same value, and its views for a 9x6 chessboard and a ChArUco board are given or refused
/// without a panic; every view given has finite points and grids of `cols x rows` corners.
pub fn corners_file(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let parsed = ron::from_str::<crate::session::CornersFile>(text)
        .or_else(|_| serde_json::from_str::<crate::session::CornersFile>(text));
    let Ok(file) = parsed else { return };
    let written = ron::to_string(&file).expect("a corners file serialises");
    let back: crate::session::CornersFile =
        ron::from_str(&written).unwrap_or_else(|e| panic!("a written corners file does not parse: {e}\n{written}"));
    assert_eq!(back, file, "corners file round trip");
    for target in ["chessboard:9x6:1", "chessboard:4x3:1", "charuco:5x7:40:30:DICT_4X4_50"] {
        let target: parallax_camera_model::TargetDescription = target.parse().expect("a valid description");
        let Ok(views) = file.clone().views(Path::new("fuzz.ron"), &target) else { continue };
        for v in &views {
            if let Some(g) = &v.grid {
                assert!(g.corners.iter().all(|c| c.is_finite()), "corners file: non-finite corner");
                assert_eq!(g.corners.len(), g.cols * g.rows, "corners file: a grid of the wrong length was accepted");
            }
        }
    }
}

/// Target files: a target that parses is written as RON and parses to the same target, and
/// its point count is the number of points it numbers.
pub fn target_file(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(target) = parallax_interop::parse_target(text, "fuzz") else { return };
    let written = ron::to_string(&target).expect("a target serialises");
    let back = parallax_interop::parse_target(&written, "fuzz.ron")
        .unwrap_or_else(|e| panic!("a written target does not parse: {e}\n{written}"));
    assert_eq!(back, target, "target round trip");
    let n = target.point_count();
    assert!(n > 0 && target.point(n as u32 - 1).is_some() && target.point(n as u32).is_none(), "point count {n}");
}
