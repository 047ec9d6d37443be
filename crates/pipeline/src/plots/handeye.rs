//! Pictures of a hand-eye calibration: per-station residuals (how far each station's fixed frame
//! `G_i X C_i` — `base_from_board` eye-in-hand — lies from their mean, rotation and translation),
//! the spread of those frames' origins, and every linear method beside the refined solution.

use parallax_camera_model::Isometry3;
use parallax_hand_eye::{HandEyeConfig, HandEyeSolution, Method};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::calibration::{Bars, bars};
use super::{DrawResult, FONT, Plot, Section, Table, render, view_colour};
use crate::Result;

/// Per-station deviation of the fixed frame from the mean: `(rotation deg, translation)`.
pub fn station_deviations(solution: &HandEyeSolution) -> Vec<(f64, f64)> {
    let q = &solution.quality;
    q.station_boards
        .iter()
        .map(|b| {
            let (r, t) = b.distance(&q.mean_board);
            (r.to_degrees(), t)
        })
        .collect()
}

/// The hand-eye section. `base_from_gripper` / `camera_from_board` are the poses the solution
/// was computed from (the linear methods are re-run on them for the table); `names` one per
/// station; `unit` the length unit.
pub fn section(
    solution: &HandEyeSolution,
    base_from_gripper: &[Isometry3],
    camera_from_board: &[Isometry3],
    config: &HandEyeConfig,
    names: &[String],
    unit: &str,
) -> Result<Section> {
    let mut s = Section { title: "hand-eye".into(), ..Section::default() };
    let dev = station_deviations(solution);
    let frame = if matches!(solution.setup, parallax_hand_eye::Setup::EyeInHand) {
        "base_from_board"
    } else {
        "gripper_from_board"
    };
    let rot: Vec<f64> = dev.iter().map(|d| d.0).collect();
    let trans: Vec<f64> = dev.iter().map(|d| d.1).collect();
    let names: Vec<String> = if names.len() == dev.len() {
        names.to_vec()
    } else {
        (0..dev.len()).map(|i| format!("station {i}")).collect()
    };
    s.notes.push(format!(
        "{} stations; {frame} spread: {:.3} deg, {:.3} {unit} (mean over stations); AX = XB residual {:.3} deg, {:.3} {unit}",
        dev.len(),
        solution.quality.board_spread_rotation_deg,
        solution.quality.board_spread_translation,
        solution.quality.mean_rotation_deg,
        solution.quality.mean_translation
    ));
    for w in &solution.warnings {
        s.warnings.push(w.to_string());
    }
    s.figures.push(render(
        "handeye-station-residuals",
        format!(
            "per station: rotation (deg) and translation ({unit}) of its {frame} from the mean over stations (a station \
             far above the others has a bad robot or board pose)"
        ),
        (900, 760),
        true,
        &StationBars { names: &names, rot: &rot, trans: &trans, unit },
    )?);
    let mean = solution.quality.mean_board;
    let offsets: Vec<glam::DVec3> =
        solution.quality.station_boards.iter().map(|b| b.translation - mean.translation).collect();
    s.figures.push(render(
        "handeye-board-spread",
        format!("spread of the {frame} origins about their mean ({unit}), x–y and x–z, one colour per station"),
        (900, 460),
        true,
        &Spread { offsets: &offsets, unit },
    )?);
    let mut table = Table {
        caption: format!("methods side by side: distance of each solution from the refined one ({unit}, deg)"),
        header: [
            "method",
            "rotation from refined (deg)",
            &format!("translation from refined ({unit})"),
            "residual (deg)",
            &format!("residual ({unit})"),
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: Vec::new(),
    };
    for m in [
        Method::Tsai,
        Method::Park,
        Method::Horaud,
        Method::Andreff,
        Method::Daniilidis,
        Method::Rodrigues,
        Method::Refined,
    ] {
        let sol = if m == solution.method {
            Ok(solution.clone())
        } else {
            parallax_hand_eye::calibrate(base_from_gripper, camera_from_board, m, config)
        };
        table.rows.push(match sol {
            Ok(x) => {
                let (r, t) = x.transform.distance(&solution.transform);
                vec![
                    format!("{m:?}"),
                    format!("{:.4}", r.to_degrees()),
                    format!("{t:.4}"),
                    format!("{:.4}", x.quality.mean_rotation_deg),
                    format!("{:.4}", x.quality.mean_translation),
                ]
            }
            Err(e) => vec![format!("{m:?}"), format!("failed: {e}"), String::new(), String::new(), String::new()],
        });
    }
    s.tables.push(table);
    Ok(s)
}

struct StationBars<'a> {
    names: &'a [String],
    rot: &'a [f64],
    trans: &'a [f64],
    unit: &'a str,
}

impl Plot for StationBars<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let (a, b) = root.split_vertically(root.dim_in_pixel().1 / 2);
        bars(
            &a,
            "rotation from the mean",
            "deg",
            &Bars { names: self.names, values: self.rot, threshold: None, flagged: &[] },
        )?;
        bars(
            &b,
            "translation from the mean",
            self.unit,
            &Bars { names: self.names, values: self.trans, threshold: None, flagged: &[] },
        )?;
        Ok(())
    }
}

struct Spread<'a> {
    offsets: &'a [glam::DVec3],
    unit: &'a str,
}

impl Plot for Spread<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let lim = self.offsets.iter().map(|o| o.abs().max_element()).fold(0.0, f64::max).max(1e-9) * 1.2;
        let halves = root.split_evenly((1, 2));
        for (k, area) in halves.iter().enumerate() {
            let (yname, pick): (&str, fn(&glam::DVec3) -> f64) = if k == 0 { ("y", |o| o.y) } else { ("z", |o| o.z) };
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .caption(format!("x–{yname}"), (FONT, 15))
                .x_label_area_size(35)
                .y_label_area_size(55)
                .build_cartesian_2d(-lim..lim, -lim..lim)?;
            chart
                .configure_mesh()
                .x_desc(format!("x ({})", self.unit))
                .y_desc(format!("{yname} ({})", self.unit))
                .label_style((FONT, 12))
                .draw()?;
            chart.draw_series(
                self.offsets.iter().enumerate().map(|(i, o)| Circle::new((o.x, pick(o)), 4, view_colour(i).filled())),
            )?;
            chart.draw_series(std::iter::once(Cross::new((0.0, 0.0), 6, BLACK.stroke_width(2))))?;
        }
        Ok(())
    }
}
