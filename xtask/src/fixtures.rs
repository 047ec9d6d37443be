//! `cargo xtask fixtures [--check]`: the small, fixed set of synthetic scenes with ground truth
//! committed in `fixtures/` (PNG images, PFM disparity, RON truth), regenerated
//! deterministically from the built-in scene descriptions.
//!
//! Layout (lengths in millimetres, poses `a_from_b`, pixels with `(0, 0)` at the centre of the
//! top-left pixel):
//!
//! ```text
//! fixtures/scenes/{easy,hard,eye-to-hand}.ron     scene descriptions (parallax_synthetic::SceneDescription)
//! fixtures/mono/view_NN.png + truth.ron           mono session (easy scene, first 6 views)
//! fixtures/stereo/{left,right}_NN.png + truth.ron stereo session (easy scene, first 5 views)
//! fixtures/stereo-scene-{easy,hard}/              rectified pair, disparity.pfm, masks, truth.ron
//! fixtures/handeye/{eye-in-hand,eye-to-hand}.ron  robot trajectories with true hand-eye
//! ```

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use glam::DVec2;
use parallax_camera_model::{Camera, Chessboard, Isometry3, StereoRig};
use parallax_synthetic::{
    RenderOptions, SceneDescription, StereoScene, StereoSceneConfig, Trajectory, TrajectoryConfig, hand_eye_trajectory,
    render_stereo_scene,
};
use serde::Serialize;

use parallax_composition::io::{save_png, write_atomic, write_ron};

/// Arguments of `cargo xtask fixtures`.
#[derive(clap::Args)]
pub struct Args {
    /// Do not write: regenerate into a temporary directory and fail when a committed file
    /// differs, is missing or is not generated any more.
    #[arg(long)]
    check: bool,
    /// The fixtures directory (default: `fixtures/` at the workspace root).
    #[arg(long)]
    dir: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap_or(Path::new("."));
    let dir = args.dir.unwrap_or_else(|| workspace.join("fixtures"));
    let plan = Plan::default();
    let start = std::time::Instant::now();
    if args.check {
        match check(&dir, &plan)? {
            None => {
                println!(
                    "fixtures are up to date: {} files in {} match a fresh generation ({:.1} s)",
                    plan_file_count(&dir)?,
                    dir.display(),
                    start.elapsed().as_secs_f64()
                );
                Ok(ExitCode::SUCCESS)
            }
            Some(problem) => {
                eprintln!("fixtures are stale: {problem}\nrun `cargo xtask fixtures` and commit the result");
                Ok(ExitCode::FAILURE)
            }
        }
    } else {
        let files = generate(&dir, &plan)?;
        let bytes: u64 = files.iter().map(|f| std::fs::metadata(dir.join(f)).map(|m| m.len()).unwrap_or(0)).sum();
        println!(
            "wrote {} fixture files ({:.2} MB) to {} in {:.1} s",
            files.len(),
            bytes as f64 / 1e6,
            dir.display(),
            start.elapsed().as_secs_f64()
        );
        Ok(ExitCode::SUCCESS)
    }
}

fn plan_file_count(dir: &Path) -> anyhow::Result<usize> {
    Ok(list_files(dir)?.len())
}

/// What to generate (the tests use a smaller plan).
struct Plan {
    mono_views: usize,
    stereo_views: usize,
    scene_width: u32,
    scene_height: u32,
    scene_max_disparity: f64,
}

impl Default for Plan {
    fn default() -> Self {
        Self { mono_views: 6, stereo_views: 5, scene_width: 320, scene_height: 240, scene_max_disparity: 32.0 }
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

/// Generates every fixture into `dir`; returns the files written, relative to `dir`, sorted.
fn generate(dir: &Path, plan: &Plan) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut put = |rel: &str| -> PathBuf {
        files.push(PathBuf::from(rel));
        dir.join(rel)
    };
    let easy = SceneDescription::builtin();
    let hard = SceneDescription::builtin_hard();
    let eye_to_hand = SceneDescription::builtin_eye_to_hand();
    for scene in [&easy, &hard, &eye_to_hand] {
        write_atomic(&put(&format!("scenes/{}.ron", scene.name)), scene.to_ron().as_bytes())?;
    }

    // Mono session: the first views of the easy scene (same poses and seeds as the pipeline).
    let mut mono = easy.clone();
    mono.mono_poses = Some(easy.mono_poses()?.into_iter().take(plan.mono_views).collect());
    let mut views = Vec::new();
    for (i, view) in mono.render_mono_views()?.into_iter().enumerate() {
        let name = format!("view_{i:02}.png");
        save_png(&put(&format!("mono/{name}")), &view.image)?;
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
    write_ron(&put("mono/truth.ron"), &truth)?;

    // Stereo session.
    let mut stereo = easy.clone();
    stereo.stereo_poses = Some(easy.stereo_poses()?.into_iter().take(plan.stereo_views).collect());
    let mut views = Vec::new();
    for (i, (l, r)) in stereo.render_stereo_views()?.into_iter().enumerate() {
        let (ln, rn) = (format!("left_{i:02}.png"), format!("right_{i:02}.png"));
        save_png(&put(&format!("stereo/{ln}")), &l.image)?;
        save_png(&put(&format!("stereo/{rn}")), &r.image)?;
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
    write_ron(&put("stereo/truth.ron"), &truth)?;

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
        save_png(&put(&format!("{folder}/left.png")), &s.left)?;
        save_png(&put(&format!("{folder}/right.png")), &s.right)?;
        write_atomic(&put(&format!("{folder}/disparity.pfm")), &pfm(&s))?;
        save_png(&put(&format!("{folder}/occluded.png")), &mask(&s, &s.occluded))?;
        save_png(&put(&format!("{folder}/low_texture.png")), &mask(&s, &s.low_texture))?;
        save_png(&put(&format!("{folder}/fronto_parallel.png")), &mask(&s, &s.fronto_parallel))?;
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
        write_ron(&put(&format!("{folder}/truth.ron")), &truth)?;
    }

    // Hand-eye trajectories.
    for (scene, name) in [(&easy, "eye-in-hand"), (&eye_to_hand, "eye-to-hand")] {
        let trajectory = hand_eye_trajectory(&scene.trajectory)?;
        let truth = TrajectoryTruth { unit: scene.unit.clone(), config: scene.trajectory.clone(), trajectory };
        write_ron(&put(&format!("handeye/{name}.ron")), &truth)?;
    }
    files.sort();
    Ok(files)
}

/// Middlebury PFM: header, then little-endian `f32` rows from the bottom row up.
fn pfm(s: &StereoScene) -> Vec<u8> {
    let (w, h) = (s.disparity.width(), s.disparity.height());
    let mut out = format!("Pf\n{w} {h}\n-1.0\n").into_bytes();
    for v in (0..h).rev() {
        for d in &s.disparity.data()[v * w..(v + 1) * w] {
            out.extend_from_slice(&d.to_le_bytes());
        }
    }
    out
}

fn mask(s: &StereoScene, m: &[bool]) -> image::GrayImage {
    let bytes = m.iter().map(|&b| if b { 255 } else { 0 }).collect();
    image::GrayImage::from_raw(s.disparity.width() as u32, s.disparity.height() as u32, bytes)
        .expect("mask of width x height")
}

/// Every regular file under `dir` (relative, sorted), skipping hidden entries (temporary files).
fn list_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    fn walk(root: &Path, sub: &Path, out: &mut Vec<PathBuf>) -> anyhow::Result<()> {
        let here = root.join(sub);
        for entry in std::fs::read_dir(&here).with_context(|| format!("reading {}", here.display()))? {
            let entry = entry?;
            let name = entry.file_name();
            if name.to_string_lossy().starts_with('.') {
                continue;
            }
            let rel = sub.join(&name);
            if entry.file_type()?.is_dir() {
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

/// Regenerates into a temporary directory and compares with `dir`; `Some(description of the
/// first difference)` when stale.
fn check(dir: &Path, plan: &Plan) -> anyhow::Result<Option<String>> {
    let tmp = std::env::temp_dir().join(format!("parallax-fixtures-check-{}", std::process::id()));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).with_context(|| format!("removing {}", tmp.display()))?;
    }
    let result = (|| -> anyhow::Result<Option<String>> {
        let fresh = generate(&tmp, plan)?;
        for rel in &fresh {
            let committed = dir.join(rel);
            let Ok(old) = std::fs::read(&committed) else {
                return Ok(Some(format!("{} is missing", committed.display())));
            };
            let new = std::fs::read(tmp.join(rel)).with_context(|| format!("reading {}", tmp.join(rel).display()))?;
            if old != new {
                return Ok(Some(format!("{} differs from a fresh generation", committed.display())));
            }
        }
        for rel in list_files(dir)? {
            if !fresh.contains(&rel) {
                return Ok(Some(format!("{} is not generated any more", dir.join(rel).display())));
            }
        }
        Ok(None)
    })();
    let _ = std::fs::remove_dir_all(&tmp);
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> Plan {
        Plan { mono_views: 2, stereo_views: 1, scene_width: 96, scene_height: 64, scene_max_disparity: 12.0 }
    }

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("xtask-fixtures-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn generation_is_byte_identical_and_check_detects_changes() {
        let (a, b) = (temp("a"), temp("b"));
        let plan = small();
        let fa = generate(&a, &plan).unwrap();
        let fb = generate(&b, &plan).unwrap();
        assert_eq!(fa, fb);
        assert_eq!(list_files(&a).unwrap(), fa, "no other file is written");
        for rel in &fa {
            assert_eq!(
                std::fs::read(a.join(rel)).unwrap(),
                std::fs::read(b.join(rel)).unwrap(),
                "{} differs",
                rel.display()
            );
        }
        assert!(fa.iter().any(|f| f.ends_with("disparity.pfm")) && fa.iter().any(|f| f.ends_with("eye-to-hand.ron")));
        // The scene files parse back.
        let text = std::fs::read_to_string(a.join("scenes/hard.ron")).unwrap();
        assert_eq!(SceneDescription::from_ron(&text).unwrap(), SceneDescription::builtin_hard());

        assert_eq!(check(&a, &plan).unwrap(), None);
        // An altered PNG is named.
        let victim = a.join("mono/view_01.png");
        let mut bytes = std::fs::read(&victim).unwrap();
        let n = bytes.len();
        bytes[n / 2] ^= 1;
        std::fs::write(&victim, &bytes).unwrap();
        let problem = check(&a, &plan).unwrap().expect("altered file must fail the check");
        assert!(problem.contains("mono/view_01.png") && problem.contains("differs"), "{problem}");
        // A missing file and an extra file are named too.
        generate(&a, &plan).unwrap();
        std::fs::remove_file(a.join("handeye/eye-in-hand.ron")).unwrap();
        assert!(check(&a, &plan).unwrap().unwrap().contains("eye-in-hand.ron"));
        generate(&a, &plan).unwrap();
        std::fs::write(a.join("stereo/stale.png"), b"x").unwrap();
        assert!(check(&a, &plan).unwrap().unwrap().contains("stale.png"));
        std::fs::remove_dir_all(&a).unwrap();
        std::fs::remove_dir_all(&b).unwrap();
    }

    #[test]
    fn pfm_rows_are_bottom_up_little_endian() {
        let s =
            render_stereo_scene(&StereoSceneConfig { width: 40, height: 32, max_disparity: 8.0, ..Default::default() })
                .unwrap();
        let bytes = pfm(&s);
        let header = b"Pf\n40 32\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        assert_eq!(bytes.len(), header.len() + 40 * 32 * 4);
        // First stored value is the bottom-left pixel.
        let first = f32::from_le_bytes(bytes[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(first, s.disparity.get(0, 31).unwrap());
    }
}
