//! The pictures of a rig calibration: every camera's section (residuals, coverage, per-view
//! errors, projection uncertainty: `calibration::camera_section` over the frames it saw, its
//! poses `camI_from_cam0 ∘ cam0_from_board`), then the rig: the frames × cameras visibility
//! matrix, the extrinsics with their 1σ, and the rig seen from above and from the side.

use glam::DVec3;
use parallax_camera_model::{Chessboard, CornerGrid, Isometry3};
use parallax_planar_calibration::{RigCalibrationResult, RigConfig};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::calibration::{CameraInputs, camera_section};
use super::{DrawResult, FONT, Plot, Section, Table, render, view_colour};
use crate::{PipelineError, Result};

/// The rig from above (`x`–`z` of camera 0's frame) and from the side (`z`–`y`): each
/// camera's centre and optical axis, in the target's unit.
struct RigViews<'a> {
    cam_from_cam0: &'a [Isometry3],
}

impl RigViews<'_> {
    /// Centre and a point one axis length along the optical axis, per camera (camera 0's frame).
    fn axes(&self) -> (Vec<(DVec3, DVec3)>, f64) {
        let centres: Vec<DVec3> = self.cam_from_cam0.iter().map(|e| e.inverse().translation).collect();
        let span = centres.iter().flat_map(|a| centres.iter().map(move |b| (*a - *b).length())).fold(0.0, f64::max);
        let len = if span > 0.0 { 0.4 * span } else { 1.0 };
        let axes = self
            .cam_from_cam0
            .iter()
            .zip(&centres)
            .map(|(e, c)| (*c, *c + e.inverse().transform_vector(DVec3::Z) * len))
            .collect();
        (axes, len)
    }
}

impl Plot for RigViews<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let (axes, len) = self.axes();
        let halves = root.split_evenly((1, 2));
        for (area, (name, pick)) in halves.iter().zip([
            ("from above (x right, z forward)", (|p: DVec3| (p.x, p.z)) as fn(DVec3) -> (f64, f64)),
            ("from the side (z forward, y down)", |p: DVec3| (p.z, p.y)),
        ]) {
            let pts: Vec<(f64, f64)> = axes.iter().flat_map(|(c, a)| [pick(*c), pick(*a)]).collect();
            let lo = pts.iter().fold((f64::INFINITY, f64::INFINITY), |m, p| (m.0.min(p.0), m.1.min(p.1)));
            let hi = pts.iter().fold((f64::NEG_INFINITY, f64::NEG_INFINITY), |m, p| (m.0.max(p.0), m.1.max(p.1)));
            let pad = 0.2 * len;
            let (w, h) = ((hi.0 - lo.0).max(1e-9), (hi.1 - lo.1).max(1e-9));
            let half = 0.5 * w.max(h) + pad;
            let (cx, cy) = (0.5 * (lo.0 + hi.0), 0.5 * (lo.1 + hi.1));
            let y_range =
                if name.starts_with("from the side") { (cy + half)..(cy - half) } else { (cy - half)..(cy + half) };
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .caption(name, (FONT, 15))
                .x_label_area_size(30)
                .y_label_area_size(50)
                .build_cartesian_2d((cx - half)..(cx + half), y_range)?;
            chart.configure_mesh().label_style((FONT, 11)).draw()?;
            for (i, (c, a)) in axes.iter().enumerate() {
                let col = view_colour(i);
                chart.draw_series(std::iter::once(PathElement::new(vec![pick(*c), pick(*a)], col.stroke_width(2))))?;
                chart.draw_series(std::iter::once(Circle::new(pick(*c), 5, col.filled())))?;
                chart.draw_series(std::iter::once(Text::new(format!("cam{i}"), pick(*c), (FONT, 13))))?;
            }
        }
        Ok(())
    }
}

/// The inputs of a rig's pictures: chessboard grids per frame and camera (`None`: not seen).
#[derive(Debug, Clone, Copy)]
pub struct RigInputs<'a> {
    /// The board.
    pub board: &'a Chessboard,
    /// `grids[f][c]`: camera `c`'s corners of frame `f`.
    pub grids: &'a [Vec<Option<CornerGrid>>],
    /// A name per frame.
    pub frame_names: &'a [String],
    /// The result.
    pub result: &'a RigCalibrationResult,
    /// The configuration it was calibrated with.
    pub config: &'a RigConfig,
}

/// The rig's sections: one per camera, then the rig (visibility, extrinsics, the picture).
pub fn rig_sections(r: &RigInputs<'_>) -> Result<Vec<Section>> {
    let res = r.result;
    let n = res.cameras.len();
    if r.grids.len() != res.cam0_from_board.len() || r.frame_names.len() != r.grids.len() {
        return Err(PipelineError::Input(format!(
            "rig pictures: {} frames of grids, {} frame poses, {} names",
            r.grids.len(),
            res.cam0_from_board.len(),
            r.frame_names.len()
        )));
    }
    let mut sections = Vec::with_capacity(n + 1);
    for c in 0..n {
        let seen: Vec<usize> = (0..r.grids.len()).filter(|&f| r.grids[f][c].is_some()).collect();
        let grids: Vec<CornerGrid> = seen.iter().map(|&f| r.grids[f][c].clone().expect("seen")).collect();
        let poses: Vec<Isometry3> = seen.iter().map(|&f| res.cam_from_cam0[c] * res.cam0_from_board[f]).collect();
        let names: Vec<String> = seen.iter().map(|&f| r.frame_names[f].clone()).collect();
        let label = format!("camera{c}");
        let (section, _) = camera_section(&CameraInputs {
            label: &label,
            camera: &res.cameras[c],
            board: r.board,
            grids: &grids,
            camera_from_board: &poses,
            view_names: &names,
            config: &r.config.cameras[c],
            other_camera: None,
        })?;
        sections.push(section);
    }
    let mut rig = Section { title: format!("rig of {n} cameras"), ..Section::default() };
    rig.notes.push(format!(
        "RMS {:.4} px over every point of every camera; extrinsics camI_from_cam0 in the target's unit; each \
         camera's projection uncertainty above is that of its own views (the rig's coupling left out)",
        res.rms_px
    ));
    rig.warnings = res.warnings.iter().map(ToString::to_string).collect();
    rig.tables.push(Table {
        caption: "extrinsics camI_from_cam0 with 1σ (σ|t| of the translation's norm, σθ of the rotation)".into(),
        header: ["camera", "tx", "ty", "tz", "rotation (°)", "σ|t|", "σθ (°)", "RMS (px)"].map(String::from).to_vec(),
        rows: (0..n)
            .map(|c| {
                let (e, s) = (&res.cam_from_cam0[c], &res.extrinsic_std_devs[c]);
                let t = e.translation;
                vec![
                    c.to_string(),
                    format!("{:.4}", t.x),
                    format!("{:.4}", t.y),
                    format!("{:.4}", t.z),
                    format!("{:.4}", e.angle().to_degrees()),
                    format!("{:.4}", s.baseline),
                    format!("{:.4}", s.angle_rad.to_degrees()),
                    format!("{:.4}", res.camera_rms_px[c]),
                ]
            })
            .collect(),
    });
    rig.tables.push(Table {
        caption: "visibility: frames × cameras (RMS of the view in px; · = not seen)".into(),
        header: std::iter::once("frame".to_string()).chain((0..n).map(|c| format!("cam{c}"))).collect(),
        rows: r
            .frame_names
            .iter()
            .zip(&res.per_view_rms_px)
            .map(|(name, row)| {
                std::iter::once(name.clone())
                    .chain(row.iter().map(|v| v.map_or("·".to_string(), |e| format!("{e:.3}"))))
                    .collect()
            })
            .collect(),
    });
    rig.figures.push(render(
        "calibration-rig",
        format!("the rig: camera centres and optical axes in camera 0's frame ({n} cameras)"),
        (1000, 500),
        true,
        &RigViews { cam_from_cam0: &res.cam_from_cam0 },
    )?);
    sections.push(rig);
    Ok(sections)
}

/// Stages the pictures of a rig calibration in `set` under `dir` (PNG/SVG files and a
/// self-contained `report.html`), committed with the command's other outputs.
pub fn add_rig_report(set: &mut crate::io::OutputSet, dir: &std::path::Path, inputs: &RigInputs<'_>) -> Result<()> {
    let mut pictures = super::Pictures::new("parallax calibration — rig");
    pictures.sections = rig_sections(inputs)?;
    pictures.add_to(set, dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The picture's axes: camera centres `−Rᵀt` and their optical axes.
    #[test]
    fn rig_axes_are_camera_centres_and_optical_axes() {
        let extr = [
            Isometry3::IDENTITY,
            Isometry3::from_rvec_tvec(DVec3::new(0.0, -std::f64::consts::FRAC_PI_2, 0.0), DVec3::new(-100.0, 0.0, 0.0)),
        ];
        let (axes, len) = RigViews { cam_from_cam0: &extr }.axes();
        // the two centres are 100 apart: the axes are drawn 0.4 of that long
        assert!((len - 40.0).abs() < 1e-9, "{len}");
        assert!((axes[0].0 - DVec3::ZERO).length() < 1e-12);
        assert!((axes[0].1 - DVec3::new(0.0, 0.0, len)).length() < 1e-9);
        // camera 1 = Ry(−90°) x + (−100, 0, 0): its centre −Rᵀt = (0, 0, −100) in camera 0's
        // frame, its optical axis Rᵀz = +x
        assert!((axes[1].0 - DVec3::new(0.0, 0.0, -100.0)).length() < 1e-9, "{:?}", axes[1].0);
        assert!((axes[1].1 - DVec3::new(len, 0.0, -100.0)).length() < 1e-9, "{:?}", axes[1].1);
    }
}
