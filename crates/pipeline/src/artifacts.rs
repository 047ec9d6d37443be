//! The files a chain run leaves for the user: results in RON (the records of `parallax_interop`:
//! every matrix row-major, rotations also as matrices, readable by every command), overlays, the
//! rectified pair, the disparity map, the point cloud. The report lists the images with captions.

use std::path::Path;

use crate::Result;
use crate::chain::{ChainInput, ChainOutput};
use crate::io::OutputSet;

/// Two images side by side with horizontal lines every 40 px, so alignment can be judged by eye.
pub fn side_by_side(l: &image::GrayImage, r: &image::GrayImage) -> image::RgbImage {
    let (w, h) = (l.width() + r.width(), l.height().max(r.height()));
    let mut img = image::RgbImage::new(w, h);
    for (x, y, p) in l.enumerate_pixels() {
        img.put_pixel(x, y, image::Rgb([p[0]; 3]));
    }
    for (x, y, p) in r.enumerate_pixels() {
        img.put_pixel(x + l.width(), y, image::Rgb([p[0]; 3]));
    }
    for y in (20..h).step_by(40) {
        for x in 0..w {
            img.put_pixel(x, y, image::Rgb([0, 200, 0]));
        }
    }
    img
}

/// Adds every result the chain produced, as files in `dir`, to `set`; returns the images, as
/// `(file name, caption)` for the report.
pub fn add_artifacts(
    set: &mut OutputSet,
    dir: &Path,
    input: &ChainInput,
    out: &ChainOutput,
) -> Result<Vec<(String, String)>> {
    let mut images = Vec::new();
    if let Some(&i) = out.views.index.first() {
        let grid = out.detections[i][0].as_ref().expect("kept views have both grids");
        let name = format!("corners-left-{i}.png");
        set.add_png(dir.join(&name), &parallax_corner_detection::draw_chessboard(&input.calibration[i][0], grid))?;
        images.push((name, format!("detected corners, left view {i}")));
    }
    if let Ok(c) = &out.calibration {
        let rectified = out.rectified.as_ref().ok().map(|r| &r.rectification);
        let calibration = parallax_interop::StereoCalibration {
            rig: c.rig,
            rectification: rectified.map(parallax_interop::RectificationMatrices::from),
            rms_px: Some(c.rms_px),
            per_view_rms_px: c.per_view_rms_px.clone(),
        };
        set.add_ron(dir.join("calibration.ron"), &parallax_interop::StereoRecord::of(&calibration))?;
        if let Some(r) = rectified {
            set.add_ron(dir.join("rectification.ron"), &parallax_interop::RectifiedRecord::of(&calibration, r))?;
        }
    }
    if let Ok((l, r)) = &out.rectified_view {
        set.add_png(dir.join("rectified-pair.png"), &side_by_side(l, r))?;
        let i = out.views.index.first().copied().unwrap_or(0);
        images.push(("rectified-pair.png".into(), format!("rectified calibration view {i} (lines every 40 px)")));
    }
    if let Ok(m) = &out.matched {
        if m.rectified_here {
            set.add_png(dir.join("rectified-left.png"), &m.left)?;
            set.add_png(dir.join("rectified-right.png"), &m.right)?;
        } else {
            set.add_png(dir.join("left-scene.png"), &m.left)?;
            images.push(("left-scene.png".into(), "matched pair, left (as given, already rectified)".into()));
        }
        set.add(dir.join("disparity.pfm"), parallax_block_matching::to_pfm(&m.disparity))?;
        set.add_png(dir.join("disparity.png"), &parallax_block_matching::false_colour(&m.disparity, None))?;
        images.push(("disparity.png".into(), "disparity (false colour, black = invalid)".into()));
    }
    if let Ok(cloud) = &out.cloud {
        let bytes = parallax_triangulation::ply_bytes(cloud, parallax_triangulation::PlyFormat::BinaryLittleEndian)?;
        set.add(dir.join("cloud.ply"), bytes)?;
    }
    if let Ok(he) = &out.hand_eye {
        let s = &he.solution;
        let result = parallax_interop::HandEyeCalibration {
            setup: s.setup,
            transform: s.transform,
            method: Some(s.method.to_string()),
        };
        #[derive(serde::Serialize)]
        struct HandEyeArtifact<'a> {
            result: parallax_interop::HandEyeRecord,
            solution: &'a parallax_hand_eye::HandEyeSolution,
        }
        set.add_ron(
            dir.join("handeye.ron"),
            &HandEyeArtifact { result: parallax_interop::HandEyeRecord::of(&result), solution: s },
        )?;
    }
    if let Ok(m) = &out.measurement {
        set.add_ron(dir.join("measurement.ron"), &m.measurement)?;
    }
    Ok(images)
}

/// The pictures of every stage the chain ran: both cameras' calibration, the rectified first
/// view, the disparity map (depth bar when the chain rectified the pair itself; error image
/// with `truth`), and hand-eye. `view_names` names every calibration pair of the session
/// (`None`: "view i"); `unit` is the length unit. A picture that cannot be drawn never fails the
/// run: its section says why instead.
pub fn pictures(
    input: &ChainInput,
    out: &ChainOutput,
    view_names: Option<&[String]>,
    truth: Option<crate::plots::disparity::DisparityTruth<'_>>,
    unit: &str,
) -> Vec<crate::plots::Section> {
    use crate::plots::{self, Section};
    let name = |i: usize| view_names.and_then(|n| n.get(i).cloned()).unwrap_or_else(|| format!("view {i}"));
    let mut sections = Vec::new();
    let mut push = |title: &str, r: Result<Vec<Section>>| match r {
        Ok(s) => sections.extend(s),
        Err(e) => sections.push(Section {
            title: title.into(),
            warnings: vec![format!("pictures not drawn: {e}")],
            ..Section::default()
        }),
    };
    if let Ok(c) = &out.calibration {
        let names: Vec<String> = out.views.index.iter().map(|&i| name(i)).collect();
        push(
            "calibration",
            plots::calibration::stereo(&input.board, &out.views.left, &out.views.right, &names, c, &input.stereo)
                .map(|[l, r]| vec![l.0, r.0]),
        );
        if let (Ok(rect), Ok((li, ri))) = (&out.rectified, &out.rectified_view) {
            let grids = out.views.left.first().zip(out.views.right.first());
            let view = out.views.index.first().map_or_else(String::new, |&i| name(i));
            push(
                "rectification",
                plots::rectification::section(&c.rig, &rect.rectification, li, ri, grids, &view, &rect.abs_dv)
                    .map(|s| vec![s]),
            );
        }
    }
    if let Ok(m) = &out.matched {
        let q = if m.rectified_here { out.rectified.as_ref().ok().map(|r| r.rectification.q) } else { None };
        push("disparity", plots::disparity::section(&m.disparity, q.as_ref(), truth).map(|s| vec![s.0]));
    }
    if let (Ok(he), Ok(poses)) = (&out.hand_eye, &out.station_poses) {
        let robot: Vec<_> = he.stations.iter().filter_map(|&i| input.stations[i].robot).collect();
        let camera: Vec<_> = he.stations.iter().filter_map(|&i| poses[i]).collect();
        let names: Vec<String> = he.stations.iter().map(|&i| format!("station {i}")).collect();
        push(
            "hand-eye",
            plots::handeye::section(&he.solution, &robot, &camera, &input.hand_eye, &names, unit).map(|s| vec![s]),
        );
    }
    sections
}
