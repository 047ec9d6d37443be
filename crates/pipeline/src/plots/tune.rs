//! The picture of a parameter search: every configuration's bad-2 against its time, the Pareto
//! front joined, the chosen configuration and the defaults marked; and the table of scores.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{DrawResult, FONT, Plot, Section, Table, render};
use crate::Result;
use crate::tune::Score;

struct Front<'a> {
    scores: &'a [Score],
    pareto: &'a [bool],
    best: usize,
    defaults: usize,
}

impl Plot for Front<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let max_ms = self.scores.iter().map(|s| s.ms).fold(0.0, f64::max).max(1e-3) * 1.1;
        let max_bad = self.scores.iter().map(|s| s.bad2).fold(0.0, f64::max).max(1e-3) * 1.1;
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .caption("bad-2 (missing = bad) against time", (FONT, 16))
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0.0..max_ms, 0.0..max_bad)?;
        chart.configure_mesh().x_desc("ms per scene").y_desc("bad-2 %").label_style((FONT, 12)).draw()?;
        let mut front: Vec<(f64, f64)> =
            self.scores.iter().zip(self.pareto).filter(|(_, p)| **p).map(|(s, _)| (s.ms, s.bad2)).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart.draw_series(std::iter::once(PathElement::new(front, RED.stroke_width(1))))?;
        for (i, (s, p)) in self.scores.iter().zip(self.pareto).enumerate() {
            let colour = if *p { RED } else { RGBColor(100, 100, 100) };
            chart.draw_series(std::iter::once(Circle::new((s.ms, s.bad2), 3, colour.filled())))?;
            let label = if i == self.best {
                Some(format!("{i} chosen"))
            } else if i < self.defaults {
                Some(format!("{i} default"))
            } else {
                None
            };
            if let Some(l) = label {
                chart.draw_series(std::iter::once(Text::new(l, (s.ms, s.bad2), (FONT, 12))))?;
            }
        }
        Ok(())
    }
}

/// The section of a search: the table of every configuration and the picture. The first
/// `defaults` configurations are the defaults.
pub fn section(
    names: &[String],
    scores: &[Score],
    pareto: &[bool],
    best: usize,
    defaults: usize,
    scenes: &[String],
) -> Result<Section> {
    let mut s = Section { title: "matcher parameter search".into(), ..Section::default() };
    s.notes.push(format!("scenes ({}): {}", scenes.len(), scenes.join(", ")));
    s.notes.push(format!(
        "chosen: configuration {best}, {} — bad-2 {:.2} %, {:.1} ms per scene",
        names[best], scores[best].bad2, scores[best].ms
    ));
    s.tables.push(Table {
        caption: "every configuration (means over the scenes; bad-2 with missing = bad)".into(),
        header: ["config", "settings", "bad-2 %", "bad-2 overlap %", "density %", "ms", "pareto"]
            .map(String::from)
            .to_vec(),
        rows: scores
            .iter()
            .zip(pareto)
            .enumerate()
            .map(|(i, (sc, p))| {
                vec![
                    i.to_string(),
                    names[i].clone(),
                    format!("{:.2}", sc.bad2),
                    format!("{:.2}", sc.bad2_overlap),
                    format!("{:.1}", sc.density),
                    format!("{:.1}", sc.ms),
                    if *p { "yes" } else { "no" }.into(),
                ]
            })
            .collect(),
    });
    s.figures.push(render(
        "tune-pareto",
        format!("bad-2 against time of {} configurations; red: the Pareto front", scores.len()),
        (720, 480),
        true,
        &Front { scores, pareto, best, defaults },
    )?);
    Ok(s)
}
