//! The pipeline's result table, its verdict and the Markdown / HTML / RON report.
//!
//! A [`Row`] is one figure of one stage against its tolerance; a [`Report`] collects rows, notes
//! and images in stage order. The verdict is `pipeline: PASS` only when at least one row ran and
//! every row passed (a NaN value — a stage that failed or could not run — fails).

use std::fmt::Write as _;
use std::path::Path;

use base64::Engine as _;
use serde::Serialize;

use crate::Result;

/// How a figure is compared with its tolerance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Bound {
    /// Passes when `value ≤ tolerance`.
    AtMost,
    /// Passes when `value ≥ tolerance`.
    AtLeast,
}

/// One line of the table: a stage's figure against ground truth and its tolerance.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Stage name (`corners`, `calibration`, ...).
    pub stage: String,
    /// What is measured.
    pub figure: String,
    /// The measured value.
    pub value: f64,
    /// The tolerance from the scene file.
    pub tolerance: f64,
    /// Unit of value and tolerance.
    pub unit: String,
    /// Direction of the comparison.
    pub bound: Bound,
}

impl Row {
    /// True when the value is within tolerance (a NaN value fails).
    pub fn pass(&self) -> bool {
        match self.bound {
            Bound::AtMost => self.value <= self.tolerance,
            Bound::AtLeast => self.value >= self.tolerance,
        }
    }
}

/// The collected rows plus notes and artifacts.
#[derive(Debug, Default, Serialize)]
pub struct Report {
    /// Scene name.
    pub scene: String,
    /// Length unit of the scene (every length row and note is in it).
    pub unit: String,
    /// Table rows in stage order.
    pub rows: Vec<Row>,
    /// Free-form lines per stage (results without a truth column).
    pub notes: Vec<(String, String)>,
    /// Images written to the output directory (file name, caption).
    pub images: Vec<(String, String)>,
    /// The pictures of the stages that ran (calibration, rectification, disparity, hand-eye):
    /// written as files beside the report and inline in `report.html`; not in `report.ron`.
    #[serde(skip)]
    pub sections: Vec<crate::plots::Section>,
}

impl Report {
    /// Adds a row with an upper bound.
    pub fn at_most(&mut self, stage: &str, figure: &str, value: f64, tolerance: f64, unit: &str) {
        self.rows.push(Row {
            stage: stage.into(),
            figure: figure.into(),
            value,
            tolerance,
            unit: unit.into(),
            bound: Bound::AtMost,
        });
    }

    /// Adds a row with a lower bound.
    pub fn at_least(&mut self, stage: &str, figure: &str, value: f64, tolerance: f64, unit: &str) {
        self.rows.push(Row {
            stage: stage.into(),
            figure: figure.into(),
            value,
            tolerance,
            unit: unit.into(),
            bound: Bound::AtLeast,
        });
    }

    /// A report for `scene` whose lengths are in `unit`.
    pub fn new(scene: &str, unit: &str) -> Self {
        Self { scene: scene.into(), unit: unit.into(), ..Self::default() }
    }

    /// Adds a note line for a stage.
    pub fn note(&mut self, stage: &str, text: impl Into<String>) {
        self.notes.push((stage.into(), text.into()));
    }

    /// The stages with at least one failing row, in order, without repeats.
    pub fn failed_stages(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for r in self.rows.iter().filter(|r| !r.pass()) {
            if !out.contains(&r.stage) {
                out.push(r.stage.clone());
            }
        }
        out
    }

    /// The plain-text table printed at the end of a run.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let w_stage = self.rows.iter().map(|r| r.stage.len()).max().unwrap_or(5).max(5);
        let w_fig = self.rows.iter().map(|r| r.figure.len()).max().unwrap_or(6).max(6);
        let _ = writeln!(
            s,
            "{:<w_stage$}  {:<w_fig$}  {:>12}  {:>12}  {:<6}  result",
            "stage", "figure", "value", "tolerance", "unit"
        );
        let _ = writeln!(s, "{}", "-".repeat(w_stage + w_fig + 50));
        for r in &self.rows {
            let op = if r.bound == Bound::AtMost { "≤" } else { "≥" };
            let _ = writeln!(
                s,
                "{:<w_stage$}  {:<w_fig$}  {:>12}  {op}{:>11}  {:<6}  {}",
                r.stage,
                r.figure,
                fmt_value(r.value),
                fmt_value(r.tolerance),
                r.unit,
                if r.pass() { "pass" } else { "FAIL" }
            );
        }
        s
    }

    /// The closing line of the output contract: `pipeline: PASS` or `pipeline: FAIL (<stages>)`;
    /// a report without a single row is `pipeline: FAIL (no checks ran)`, never a pass.
    pub fn verdict(&self) -> String {
        let failed = self.failed_stages();
        if self.rows.is_empty() {
            "pipeline: FAIL (no checks ran)".into()
        } else if failed.is_empty() {
            "pipeline: PASS".into()
        } else {
            format!("pipeline: FAIL ({})", failed.join(", "))
        }
    }

    /// True when the verdict is a pass.
    pub fn passed(&self) -> bool {
        !self.rows.is_empty() && self.failed_stages().is_empty()
    }

    /// A Markdown report with the table, the notes and the images inline.
    pub fn markdown(&self) -> String {
        let mut s = format!("# parallax pipeline — scene `{}`\n\n", self.scene);
        s.push_str("| stage | figure | value | tolerance | unit | result |\n|---|---|---|---|---|---|\n");
        for r in &self.rows {
            let op = if r.bound == Bound::AtMost { "≤" } else { "≥" };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {op} {} | {} | {} |",
                r.stage,
                r.figure,
                fmt_value(r.value),
                fmt_value(r.tolerance),
                r.unit,
                if r.pass() { "pass" } else { "**FAIL**" }
            );
        }
        let _ = writeln!(s, "\n**{}**\n", self.verdict());
        if !self.notes.is_empty() {
            s.push_str("## Notes\n\n");
            for (stage, text) in &self.notes {
                let _ = writeln!(s, "- **{stage}**: {text}");
            }
            s.push('\n');
        }
        if !self.images.is_empty() {
            s.push_str("## Images\n\n");
            for (file, caption) in &self.images {
                let _ = writeln!(s, "### {caption}\n\n![{caption}]({file})\n");
            }
        }
        s.push_str(&crate::plots::sections_markdown(&self.sections));
        s
    }

    /// Adds `report.md`, `report.html` (self-contained: every image inline) and `report.ron`
    /// in `dir` to `set`, and the picture files of [`Self::sections`]. The images listed in
    /// [`Self::images`] must already be in `set`.
    pub fn add_to(&self, set: &mut crate::io::OutputSet, dir: &Path) -> Result<()> {
        crate::plots::add_figures(set, dir, &self.sections)?;
        set.add(dir.join("report.md"), self.markdown())?;
        let html = self.html_with(|file| {
            let bytes = set.get(&dir.join(file)).ok_or_else(|| {
                crate::PipelineError::Input(format!("the report lists {file}, which this run does not write"))
            })?;
            Ok(format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes)))
        })?;
        set.add(dir.join("report.html"), html)?;
        set.add_ron(dir.join("report.ron"), self)
    }

    /// The HTML page with the images of [`Self::images`] referenced by file name (relative to
    /// the report) and the pictures of [`Self::sections`] inline.
    pub fn html(&self) -> String {
        self.html_with(|file| Ok(file.to_string())).unwrap_or_default()
    }

    fn html_with(&self, src: impl Fn(&str) -> Result<String>) -> Result<String> {
        let esc = |t: &str| t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        let mut s = format!(
            "{}<h1>parallax pipeline — scene <code>{}</code></h1><table><tr><th>stage</th><th>figure</th>\
             <th>value</th><th>tolerance</th><th>unit</th><th>result</th></tr>",
            crate::plots::html_head(&format!("parallax pipeline — {}", self.scene)),
            esc(&self.scene)
        );
        for r in &self.rows {
            let op = if r.bound == Bound::AtMost { "≤" } else { "≥" };
            let res = if r.pass() { "pass" } else { "FAIL" };
            let _ = write!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{op} {}</td><td>{}</td><td class=\"{res}\">{res}</td></tr>",
                esc(&r.stage),
                esc(&r.figure),
                fmt_value(r.value),
                fmt_value(r.tolerance),
                esc(&r.unit)
            );
        }
        let _ = write!(s, "</table><p><b>{}</b></p>", esc(&self.verdict()));
        if !self.notes.is_empty() {
            s.push_str("<h2>Notes</h2><ul>");
            for (stage, text) in &self.notes {
                let _ = write!(s, "<li><b>{}</b>: {}</li>", esc(stage), esc(text));
            }
            s.push_str("</ul>");
        }
        for (file, caption) in &self.images {
            let _ = write!(s, "<h3>{0}</h3><img src=\"{1}\" alt=\"{0}\">", esc(caption), esc(&src(file)?));
        }
        s.push_str(&crate::plots::sections_html(&self.sections));
        s.push_str("</body></html>\n");
        Ok(s)
    }
}

fn fmt_value(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) { format!("{v:.3e}") } else { format!("{v:.4}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdict_names_failing_stages_once_and_nan_fails() {
        let mut r = Report::new("t", "mm");
        r.at_most("calibration", "focal error", 0.05, 0.1, "%");
        r.at_most("disparity", "bad-2", 12.0, 10.0, "%");
        r.at_least("disparity", "density", 80.0, 85.0, "%");
        r.at_most("hand-eye", "rotation error", f64::NAN, 0.5, "deg");
        assert_eq!(r.failed_stages(), vec!["disparity".to_string(), "hand-eye".to_string()]);
        assert_eq!(r.verdict(), "pipeline: FAIL (disparity, hand-eye)");
        let ok = Report { scene: "t".into(), rows: vec![r.rows[0].clone()], ..Report::default() };
        assert_eq!(ok.verdict(), "pipeline: PASS");
        assert!(r.table().contains("FAIL") && r.markdown().contains("**FAIL**") && r.html().contains("class=\"FAIL\""));
        assert!(ok.passed() && !r.passed());
    }

    #[test]
    fn a_report_without_rows_never_passes() {
        let empty = Report::new("real", "mm");
        assert_eq!(empty.verdict(), "pipeline: FAIL (no checks ran)");
        assert!(!empty.passed());
    }
}
