//! `cargo xtask calibrate --camera GLOB --camera GLOB …`: a rig of any number of cameras.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use parallax_camera_model::{LensModel, TargetDescription};
use parallax_composition::io::OutputSet;
use parallax_composition::records::RigOutput;
use parallax_composition::session::{self, ImageView};
use parallax_composition::summary;
use parallax_interop::{Format, RigFile};
use parallax_planar_calibration::{CalibrationConfig, RigConfig};

use super::{Args, check_model_fits, config, print_written, refuse_foreign_flags_of, refuse_report_folder};

/// Each camera's lens: `--lens` once for all, or once per camera.
fn lenses(args: &Args, n: usize) -> anyhow::Result<Vec<LensModel>> {
    let parse = |l: &String| l.parse::<LensModel>().map_err(|e| anyhow::anyhow!("--lens {l}: {e}"));
    match args.lens.len() {
        1 => Ok(vec![parse(&args.lens[0])?; n]),
        k if k == n => args.lens.iter().map(parse).collect(),
        k => anyhow::bail!("--lens is given {k} times for {n} cameras: give it once for all, or once per camera"),
    }
}

/// The frame name of a view: its image's file name.
fn frame_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Refuses inputs that cannot make a rig, naming the cameras and files: the same file under
/// two cameras, two files of one camera with one name, and file names no other camera has
/// (frames that match nothing).
fn check_frames(inputs: &[String], files: &[Vec<PathBuf>]) -> anyhow::Result<()> {
    let mut owner: BTreeMap<PathBuf, usize> = BTreeMap::new();
    for (c, list) in files.iter().enumerate() {
        let mut names = BTreeSet::new();
        for p in list {
            let canonical = p.canonicalize().unwrap_or_else(|_| p.clone());
            if let Some(&other) = owner.get(&canonical).filter(|&&o| o != c) {
                anyhow::bail!(
                    "{} is an input of camera {other} ({}) and of camera {c} ({}): each camera needs its own images",
                    p.display(),
                    inputs[other],
                    inputs[c]
                );
            }
            owner.insert(canonical, c);
            anyhow::ensure!(
                names.insert(frame_name(p)),
                "camera {c} ({}) has two files named {}: frames are matched by file name",
                inputs[c],
                frame_name(p)
            );
        }
    }
    let mut count: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (c, list) in files.iter().enumerate() {
        for p in list {
            count.entry(frame_name(p)).or_default().push(c);
        }
    }
    let lonely: Vec<String> = count
        .iter()
        .filter(|(_, cams)| cams.len() == 1)
        .map(|(name, cams)| format!("{name} (camera {})", cams[0]))
        .collect();
    anyhow::ensure!(
        lonely.is_empty(),
        "{} file name(s) match no other camera's file names, so they are no frame of the rig: {}{}; frames are \
         matched by file name across the cameras (rename or remove them)",
        lonely.len(),
        lonely.iter().take(10).cloned().collect::<Vec<_>>().join(", "),
        if lonely.len() > 10 { ", …" } else { "" }
    );
    Ok(())
}

pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    let from_images = !args.cameras.is_empty();
    let inputs: Vec<String> = if from_images {
        args.cameras.clone()
    } else {
        args.camera_corners.iter().map(|p| p.display().to_string()).collect()
    };
    let n = inputs.len();
    anyhow::ensure!(n >= 2, "a rig needs at least two cameras: repeat --camera (or --camera-corners) once per camera");
    anyhow::ensure!(
        args.right.is_none() && args.right_corners.is_none(),
        "--right / --right-corners are for a stereo pair; a rig takes --camera once per camera"
    );
    let configs: Vec<CalibrationConfig> =
        lenses(args, n)?.into_iter().map(|lens| CalibrationConfig { lens, ..config(args) }).collect();
    for (c, cfg) in configs.iter().enumerate() {
        refuse_foreign_flags_of(cfg).map_err(|e| anyhow::anyhow!("camera {c}: {e}"))?;
    }
    let target = crate::util::target(&args.board, args.square)?;
    anyhow::ensure!(
        args.report.is_none() || matches!(target, TargetDescription::Chessboard(_)),
        "--report draws chessboard sessions only (the target is {target})"
    );
    let format = args.out.as_deref().map(|o| crate::files::output_format(o, args.format.as_deref())).transpose()?;
    if let Some(f) = format {
        anyhow::ensure!(
            f != Format::Ros,
            "ROS camera_info holds one camera and no extrinsics: write a rig as kalibr, opencv (.yml/.xml), ron or json"
        );
        crate::files::refuse_unit_for_metres(f, &target)?;
        for c in &configs {
            check_model_fits(f, c)?;
        }
    }
    // Every camera's files, before any detection.
    let files: Vec<Vec<PathBuf>> = if from_images {
        inputs.iter().map(|g| parallax_composition::io::expand_glob(g)).collect::<Result<_, _>>()?
    } else {
        Vec::new()
    };
    let mut all_inputs: Vec<PathBuf> = files.iter().flatten().cloned().collect();
    all_inputs.extend(args.camera_corners.iter().cloned());
    if let Some(out) = &args.out {
        parallax_composition::io::refuse_overwriting_inputs(std::slice::from_ref(out), &all_inputs)?;
    }
    if let Some(dir) = &args.report {
        refuse_report_folder(dir, &all_inputs)?;
    }
    let outputs: Vec<(&str, &std::path::Path, bool)> = (args.report.iter().map(|d| ("--report", d.as_path(), true)))
        .chain(args.out.iter().map(|p| ("--out", p.as_path(), false)))
        .collect();
    parallax_composition::io::refuse_colliding_outputs(&outputs)?;
    let t0 = Instant::now();
    let views: Vec<Vec<ImageView>> = if from_images {
        check_frames(&inputs, &files)?;
        let detector = args.detector.config(Default::default());
        files
            .iter()
            .enumerate()
            .map(|(c, paths)| {
                println!("camera {c}: searching {} images ({})", paths.len(), inputs[c]);
                let progress = crate::progress::Progress::new("calibrate", paths.len() as u64, "images searched")?;
                let v = session::detect_files_with_progress(paths, &target, &detector, &|| progress.inc())?;
                progress.finish();
                Ok(v)
            })
            .collect::<anyhow::Result<_>>()?
    } else {
        let v: Vec<Vec<ImageView>> =
            args.camera_corners.iter().map(|f| session::read_corners_file(f, &target)).collect::<Result<_, _>>()?;
        let listed: Vec<Vec<PathBuf>> = v.iter().map(|c| c.iter().map(|v| v.image.clone()).collect()).collect();
        check_frames(&inputs, &listed)?;
        v
    };
    // Frames: the union of the file names, in natural order (`frame2` before `frame10`).
    let mut sorted: Vec<PathBuf> = views.iter().flatten().map(|v| PathBuf::from(frame_name(&v.image))).collect();
    parallax_composition::io::natural_sort(&mut sorted);
    sorted.dedup();
    let names: Vec<String> = sorted.iter().map(|p| p.display().to_string()).collect();
    let index: Vec<BTreeMap<String, &ImageView>> =
        views.iter().map(|c| c.iter().map(|v| (frame_name(&v.image), v)).collect()).collect();
    let mut sizes = Vec::with_capacity(n);
    for (c, cam) in views.iter().enumerate() {
        let found: Vec<&ImageView> = cam.iter().filter(|v| v.found()).collect();
        anyhow::ensure!(
            !found.is_empty(),
            "camera {c} ({}): the target was found in none of its {} image(s); a rig needs every camera to see it",
            inputs[c],
            cam.len()
        );
        sizes.push(session::common_size(&found)?);
        println!("camera {c}: target found in {}/{} images ({})", found.len(), cam.len(), inputs[c]);
    }
    let frames: Vec<Vec<Option<&ImageView>>> =
        names.iter().map(|name| (0..n).map(|c| index[c].get(name).copied().filter(|v| v.found())).collect()).collect();
    // Frames no camera found the target in carry nothing: left out (and said).
    let (kept, dropped): (Vec<usize>, Vec<usize>) =
        (0..names.len()).partition(|&f| frames[f].iter().any(Option::is_some));
    if !dropped.is_empty() {
        println!("{} frame(s) with the target found by no camera left out", dropped.len());
    }
    let frames: Vec<Vec<Option<&ImageView>>> = kept.iter().map(|&f| frames[f].clone()).collect();
    let names: Vec<String> = kept.iter().map(|&f| names[f].clone()).collect();
    let cfg = RigConfig { cameras: configs, fix_intrinsics: args.fix_intrinsics, ..RigConfig::default() };
    let t1 = Instant::now();
    let r = session::calibrate_rig_views(&target, &frames, &sizes, &cfg)?;
    println!(
        "rig of {n} cameras calibrated from {} frames in {:.1} ms ({} iterations; detection {:.0} ms)",
        names.len(),
        t1.elapsed().as_secs_f64() * 1e3,
        r.iterations,
        (t1 - t0).as_secs_f64() * 1e3
    );
    for (c, cam) in r.cameras.iter().enumerate() {
        println!("{}", summary::camera(&format!("camera {c}"), cam, &r.std_devs[c]));
    }
    println!("{}", summary::visibility(&names, &r));
    for w in &r.warnings {
        println!("warning: {w}");
    }
    let mut out_files = OutputSet::new();
    let mut written = Vec::new();
    if let (Some(out), Some(f)) = (&args.out, format) {
        match f {
            Format::Ron | Format::Json => {
                let record =
                    RigOutput { frames: names.clone(), camera_inputs: inputs.clone(), board: &target, result: &r };
                out_files.add(out, parallax_interop::native_string(&record, f)?)?;
                written.push(out.clone());
            }
            _ => {
                let file = RigFile {
                    cameras: &r.cameras,
                    cam_from_cam0: &r.cam_from_cam0,
                    shared_frames: &r.shared_frames,
                    rms_px: r.rms_px,
                };
                for (path, text) in parallax_interop::render_rig(&file, f, out)? {
                    out_files.add(&path, text)?;
                    written.push(path);
                }
            }
        }
    }
    let mut report = None;
    if let (Some(dir), TargetDescription::Chessboard(board)) = (&args.report, &target) {
        let t = Instant::now();
        let grids: Vec<Vec<Option<parallax_camera_model::CornerGrid>>> =
            frames.iter().map(|f| f.iter().map(|v| v.and_then(|v| v.grid.clone())).collect()).collect();
        let inputs = parallax_composition::plots::rig::RigInputs {
            board,
            grids: &grids,
            frame_names: &names,
            result: &r,
            config: &cfg,
        };
        parallax_composition::plots::rig::add_rig_report(&mut out_files, dir, &inputs)?;
        report = Some((dir.as_path(), t.elapsed().as_secs_f64() * 1e3));
    }
    out_files.commit()?;
    print_written(&written, format, report);
    println!("{}", summary::rig_keys(&r));
    if n == 2 {
        // the stereo keys, as a two-camera `--images/--right` calibration prints them
        let rig = r.stereo(0, 1)?;
        println!("{}", summary::camera_keys("left_", r.camera_rms_px[0], &rig.left));
        println!("{}", summary::camera_keys("right_", r.camera_rms_px[1], &rig.right));
        println!("stereo_rms_px: {:.6}", r.rms_px);
        println!("baseline: {:.6}", rig.baseline());
        println!("rotation_deg: {:.6}", rig.right_from_left.angle().to_degrees());
    }
    Ok(ExitCode::SUCCESS)
}
