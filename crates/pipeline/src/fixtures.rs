//! The committed fixtures (`fixtures/` at the workspace root): a small, fixed set of synthetic
//! scenes with ground truth (PNG images, PFM disparity, RON truth), generated deterministically
//! from the built-in scene descriptions. `cargo xtask fixtures` writes them, `--check` compares.
//!
//! Layout (lengths in millimetres, poses `a_from_b`, pixels with `(0, 0)` at the centre of the
//! top-left pixel):
//!
//! ```text
//! scenes/{easy,hard,eye-to-hand,fisheye}.ron  scene descriptions (parallax_synthetic::SceneDescription)
//! mono/view_NN.png + truth.ron           mono session (easy scene, first 6 views)
//! stereo/{left,right}_NN.png + truth.ron stereo session (easy scene, first 5 views)
//! stereo-scene-{easy,hard}/              rectified pair, disparity.pfm, masks, truth.ron
//! handeye/{eye-in-hand,eye-to-hand}.ron  robot trajectories with true hand-eye
//! handeye/station_NN.png + robot_poses.ron  the first eye-in-hand stations rendered by the
//!                                          stereo rig's left camera, and their robot poses
//!                                          (`base_from_gripper`, a RON list) — the README's
//!                                          `handeye` example
//! ```

use std::path::{Path, PathBuf};

use glam::DVec2;
use parallax_camera_model::{Camera, Chessboard, Isometry3, StereoRig};
use parallax_synthetic::{
    RenderOptions, SceneDescription, StereoScene, StereoSceneConfig, Trajectory, TrajectoryConfig, hand_eye_trajectory,
    render_stereo_scene,
};
use serde::Serialize;

use crate::io::{png_bytes, to_ron};
use crate::{PipelineError, Result};

/// What to generate (the tests use a smaller plan).
pub struct FixturePlan {
    /// Views of the mono session (the easy scene's first ones).
    pub mono_views: usize,
    /// Views of the stereo session.
    pub stereo_views: usize,
    /// Size of the two stereo scenes with true disparity.
    pub scene_width: u32,
    /// See `scene_width`.
    pub scene_height: u32,
    /// Largest disparity of the stereo scenes.
    pub scene_max_disparity: f64,
    /// Rendered eye-in-hand stations (images + robot poses).
    pub handeye_stations: usize,
}

impl Default for FixturePlan {
    fn default() -> Self {
        Self {
            mono_views: 6,
            stereo_views: 5,
            scene_width: 320,
            scene_height: 240,
            scene_max_disparity: 32.0,
            handeye_stations: 6,
        }
    }
}

/// One rendered view in a truth file.
#[derive(Serialize)]
struct ViewTruth {
    image: String,
    camera_from_board: Isometry3,
    /// True inner-corner pixels, OpenCV order.
    corners: Vec<DVec2>,
}

#[derive(Serialize)]
struct MonoTruth {
    scene: String,
    unit: String,
    camera: Camera,
    board: Chessboard,
    render: RenderOptions,
    views: Vec<ViewTruth>,
}

#[derive(Serialize)]
struct StereoViewTruth {
    left: ViewTruth,
    /// The right view; its pose is `rig.right_from_left * left.camera_from_board`.
    right: ViewTruth,
}

#[derive(Serialize)]
struct StereoTruth {
    scene: String,
    unit: String,
    rig: StereoRig,
    board: Chessboard,
    render: RenderOptions,
    views: Vec<StereoViewTruth>,
}

#[derive(Serialize)]
struct StereoSceneTruth {
    config: StereoSceneConfig,
    /// The rectified rig of the pair (identical pinhole cameras).
    rig: StereoRig,
    left: String,
    right: String,
    /// True left disparity, PFM (Middlebury's float format, rows bottom to top).
    disparity: String,
    /// 255 where the left pixel is occluded in the right image.
    occluded: String,
    /// 255 on the low-texture patch.
    low_texture: String,
    /// 255 on fronto-parallel planes.
    fronto_parallel: String,
    min_disparity: f32,
    max_disparity: f32,
    occluded_pixels: usize,
}

#[derive(Serialize)]
struct TrajectoryTruth {
    unit: String,
    config: TrajectoryConfig,
    trajectory: Trajectory,
}

/// Every fixture file of `plan`, as (path relative to the fixtures folder, bytes), sorted by
/// path. Deterministic: the same plan gives the same bytes on every machine.
pub fn fixture_files(plan: &FixturePlan) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let mut put = |rel: &str, bytes: Vec<u8>| files.push((PathBuf::from(rel), bytes));
    let easy = SceneDescription::builtin();
    let hard = SceneDescription::builtin_hard();
    let eye_to_hand = SceneDescription::builtin_eye_to_hand();
    let fisheye = SceneDescription::builtin_wide();
    for scene in [&easy, &hard, &eye_to_hand, &fisheye] {
        put(&format!("scenes/{}.ron", scene.name), scene.to_ron().as_bytes().to_vec());
    }

    // Mono session: the first views of the easy scene (same poses and seeds as the pipeline).
    let mut mono = easy.clone();
    mono.mono_poses = Some(easy.mono_poses()?.into_iter().take(plan.mono_views).collect());
    let mut views = Vec::new();
    for (i, view) in mono.render_mono_views()?.into_iter().enumerate() {
        let name = format!("view_{i:02}.png");
        put(&format!("mono/{name}"), png_bytes(&view.image)?);
        views.push(ViewTruth { image: name, camera_from_board: view.camera_from_board, corners: view.corners });
    }
    let truth = MonoTruth {
        scene: easy.name.clone(),
        unit: easy.unit.clone(),
        camera: easy.camera,
        board: easy.board,
        render: easy.render.clone(),
        views,
    };
    put("mono/truth.ron", to_ron(&truth)?.into_bytes());

    // Stereo session.
    let mut stereo = easy.clone();
    stereo.stereo_poses = Some(easy.stereo_poses()?.into_iter().take(plan.stereo_views).collect());
    let mut views = Vec::new();
    for (i, (l, r)) in stereo.render_stereo_views()?.into_iter().enumerate() {
        let (ln, rn) = (format!("left_{i:02}.png"), format!("right_{i:02}.png"));
        put(&format!("stereo/{ln}"), png_bytes(&l.image)?);
        put(&format!("stereo/{rn}"), png_bytes(&r.image)?);
        views.push(StereoViewTruth {
            left: ViewTruth { image: ln, camera_from_board: l.camera_from_board, corners: l.corners },
            right: ViewTruth { image: rn, camera_from_board: r.camera_from_board, corners: r.corners },
        });
    }
    let truth = StereoTruth {
        scene: easy.name.clone(),
        unit: easy.unit.clone(),
        rig: easy.rig,
        board: easy.board,
        render: easy.render.clone(),
        views,
    };
    put("stereo/truth.ron", to_ron(&truth)?.into_bytes());

    // Two stereo scenes with true disparity (smaller than the pipeline's, to keep fixtures small).
    for scene in [&easy, &hard] {
        let config = StereoSceneConfig {
            width: plan.scene_width,
            height: plan.scene_height,
            max_disparity: plan.scene_max_disparity,
            ..scene.stereo_scene.clone()
        };
        let s = render_stereo_scene(&config)?;
        let folder = format!("stereo-scene-{}", scene.name);
        put(&format!("{folder}/left.png"), png_bytes(&s.left)?);
        put(&format!("{folder}/right.png"), png_bytes(&s.right)?);
        put(&format!("{folder}/disparity.pfm"), parallax_block_matching::to_pfm(&s.disparity));
        put(&format!("{folder}/occluded.png"), png_bytes(&mask(&s, &s.occluded))?);
        put(&format!("{folder}/low_texture.png"), png_bytes(&mask(&s, &s.low_texture))?);
        put(&format!("{folder}/fronto_parallel.png"), png_bytes(&mask(&s, &s.fronto_parallel))?);
        let (lo, hi) = s.disparity.data().iter().fold((f32::MAX, f32::MIN), |(a, b), &d| (a.min(d), b.max(d)));
        let truth = StereoSceneTruth {
            config,
            rig: s.rig,
            left: "left.png".into(),
            right: "right.png".into(),
            disparity: "disparity.pfm".into(),
            occluded: "occluded.png".into(),
            low_texture: "low_texture.png".into(),
            fronto_parallel: "fronto_parallel.png".into(),
            min_disparity: lo,
            max_disparity: hi,
            occluded_pixels: s.occluded.iter().filter(|&&o| o).count(),
        };
        put(&format!("{folder}/truth.ron"), to_ron(&truth)?.into_bytes());
    }

    // Hand-eye trajectories.
    for (scene, name) in [(&easy, "eye-in-hand"), (&eye_to_hand, "eye-to-hand")] {
        let trajectory = hand_eye_trajectory(&scene.trajectory)?;
        let truth = TrajectoryTruth { unit: scene.unit.clone(), config: scene.trajectory.clone(), trajectory };
        if truth.trajectory.eye_in_hand {
            // Board images of the first stations, seen by the rig's left camera at the
            // trajectory's camera poses, with their robot poses.
            let n = plan.handeye_stations.min(truth.trajectory.base_from_gripper.len());
            for (i, pose) in truth.trajectory.camera_from_board.iter().take(n).enumerate() {
                let opts =
                    RenderOptions { seed: scene.render.seed.wrapping_add(7000 + i as u64), ..scene.render.clone() };
                let view = parallax_synthetic::render_chessboard(&scene.rig.left, &scene.board, pose, &opts)?;
                put(&format!("handeye/station_{i:02}.png"), png_bytes(&view.image)?);
            }
            let robot: Vec<Isometry3> = truth.trajectory.base_from_gripper.iter().take(n).copied().collect();
            put("handeye/robot_poses.ron", to_ron(&robot)?.into_bytes());
        }
        put(&format!("handeye/{name}.ron"), to_ron(&truth)?.into_bytes());
    }
    files.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(files)
}

fn mask(s: &StereoScene, m: &[bool]) -> image::GrayImage {
    let bytes = m.iter().map(|&b| if b { 255 } else { 0 }).collect();
    image::GrayImage::from_raw(s.disparity.width() as u32, s.disparity.height() as u32, bytes)
        .expect("mask of width x height")
}

/// The fixture folders (first path component) that generation owns.
fn owned_folders(files: &[(PathBuf, Vec<u8>)]) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> =
        files.iter().filter_map(|f| f.0.components().next()).map(|c| PathBuf::from(c.as_os_str())).collect();
    dirs.dedup();
    dirs
}

/// Writes every file under `dir` as one set ([`crate::io::OutputSet`]) and then removes the files of the owned
/// folders that are not generated any more (never anything outside them); returns how many were removed.
pub fn write_fixtures(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> Result<usize> {
    let mut set = crate::io::OutputSet::new();
    for (rel, bytes) in files {
        set.add(dir.join(rel), bytes)?;
    }
    set.commit()?;
    let mut removed = 0;
    for rel in list_files(dir)? {
        let owned = owned_folders(files).iter().any(|d| rel.starts_with(d));
        if owned && !files.iter().any(|f| f.0 == rel) {
            let path = dir.join(&rel);
            std::fs::remove_file(&path).map_err(|source| PipelineError::Io { what: "removing stale", path, source })?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Every regular file under `dir` (relative, sorted), skipping hidden entries (temporary files).
pub fn list_files(dir: &Path) -> Result<Vec<PathBuf>> {
    fn walk(root: &Path, sub: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
        let here = root.join(sub);
        let io = |source| PipelineError::Io { what: "reading", path: here.clone(), source };
        for entry in std::fs::read_dir(&here).map_err(io)? {
            let entry = entry.map_err(io)?;
            let name = entry.file_name();
            if name.to_string_lossy().starts_with('.') {
                continue;
            }
            let rel = sub.join(&name);
            if entry.file_type().map_err(io)?.is_dir() {
                walk(root, &rel, out)?;
            } else {
                out.push(rel);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    if dir.exists() {
        walk(dir, Path::new(""), &mut out)?;
    }
    out.sort();
    Ok(out)
}

/// Compares the folders of `dir` that generation owns with a fresh generation; `Some(description
/// of the first difference)` when stale.
pub fn check_fixtures(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> Result<Option<String>> {
    for (rel, bytes) in files {
        let committed = dir.join(rel);
        let Ok(old) = std::fs::read(&committed) else {
            return Ok(Some(format!("{} is missing", committed.display())));
        };
        if &old != bytes {
            return Ok(Some(format!("{} differs from a fresh generation", committed.display())));
        }
    }
    // only the folders generation owns: others (the zoo's hand-written worlds) are not its own
    let owned = owned_folders(files);
    for rel in list_files(dir)?.into_iter().filter(|r| owned.iter().any(|o| r.starts_with(o))) {
        if !files.iter().any(|f| f.0 == rel) {
            return Ok(Some(format!("{} is not generated any more", dir.join(rel).display())));
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plan small enough for a unit test.
    fn small_plan() -> FixturePlan {
        FixturePlan {
            mono_views: 2,
            stereo_views: 1,
            scene_width: 96,
            scene_height: 64,
            scene_max_disparity: 12.0,
            handeye_stations: 1,
        }
    }

    #[test]
    fn generation_is_deterministic_and_complete() {
        let plan = small_plan();
        let a = fixture_files(&plan).unwrap();
        let b = fixture_files(&plan).unwrap();
        assert_eq!(a, b);
        let names: Vec<String> = a.iter().map(|f| f.0.to_string_lossy().into_owned()).collect();
        assert!(a.windows(2).all(|w| w[0].0 < w[1].0), "sorted, no duplicates: {names:?}");
        assert_eq!(names.iter().filter(|n| n.starts_with("mono/view_")).count(), 2);
        assert!(
            names.iter().any(|f| f.ends_with("disparity.pfm")) && names.iter().any(|f| f.ends_with("eye-to-hand.ron"))
        );
        let hard = a.iter().find(|f| f.0.ends_with("scenes/hard.ron")).unwrap();
        let text = String::from_utf8(hard.1.clone()).unwrap();
        assert_eq!(SceneDescription::from_ron(&text).unwrap(), SceneDescription::builtin_hard());
        // The disparity file reads back as the rendered truth.
        let pfm = a.iter().find(|f| f.0.ends_with("stereo-scene-easy/disparity.pfm")).unwrap();
        let map = parallax_block_matching::from_pfm(&pfm.1, "disparity.pfm").unwrap();
        assert_eq!((map.width(), map.height()), (96, 64));
    }

    /// Writing then checking passes; an altered, a missing and an extra file are each named;
    /// regeneration removes the extra file so the check passes again.
    #[test]
    fn check_names_every_kind_of_staleness_and_regeneration_cures_it() {
        let plan = small_plan();
        let files = fixture_files(&plan).unwrap();
        let a = crate::io::test_dir("fixtures-check");
        write_fixtures(&a, &files).unwrap();
        assert_eq!(list_files(&a).unwrap(), files.iter().map(|f| f.0.clone()).collect::<Vec<_>>(), "no other file");
        assert_eq!(check_fixtures(&a, &files).unwrap(), None);
        let victim = a.join("mono/view_01.png");
        let mut bytes = std::fs::read(&victim).unwrap();
        let n = bytes.len();
        bytes[n / 2] ^= 1;
        std::fs::write(&victim, &bytes).unwrap();
        let problem = check_fixtures(&a, &files).unwrap().expect("altered file must fail the check");
        assert!(problem.contains("mono/view_01.png") && problem.contains("differs"), "{problem}");
        write_fixtures(&a, &files).unwrap();
        std::fs::remove_file(a.join("handeye/eye-in-hand.ron")).unwrap();
        assert!(check_fixtures(&a, &files).unwrap().unwrap().contains("eye-in-hand.ron"));
        write_fixtures(&a, &files).unwrap();
        std::fs::write(a.join("stereo/stale.png"), b"x").unwrap();
        assert!(check_fixtures(&a, &files).unwrap().unwrap().contains("stale.png"));
        assert_eq!(write_fixtures(&a, &files).unwrap(), 1);
        assert_eq!(check_fixtures(&a, &files).unwrap(), None);
        // a folder generation does not own (the zoo's hand-written worlds) is neither checked
        // nor touched
        std::fs::create_dir_all(a.join("zoo")).unwrap();
        std::fs::write(a.join("zoo/world.ron"), b"()").unwrap();
        assert_eq!(check_fixtures(&a, &files).unwrap(), None);
        assert_eq!(write_fixtures(&a, &files).unwrap(), 0);
        assert!(a.join("zoo/world.ron").is_file());
        std::fs::remove_dir_all(&a).unwrap();
    }
}
