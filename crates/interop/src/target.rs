//! Calibration targets from files: Kalibr's target YAML, the project's own
//! [`TargetDescription`] records (RON, JSON, YAML), or a text file holding one description line
//! (`charuco:7x5:40:30:DICT_5X5_100`, [`ACCEPTED_FORMS`]).
//!
//! Kalibr's files (`target_type: aprilgrid | checkerboard | circlegrid`, the layout of Kalibr's
//! wiki page "Calibration targets") give lengths in metres, so every result computed with such a
//! target is in metres. Kalibr's `codeOffset` (tag ids starting above 0) and asymmetric circle
//! grids (whose spacing Kalibr defines differently from OpenCV's) are refused rather than
//! guessed: describe an asymmetric grid with `acircles:` in OpenCV's convention.

use std::path::Path;

use parallax_camera_model::{ACCEPTED_FORMS, AprilGrid, Chessboard, CircleGrid, TargetDescription};
use serde_yaml_ng::Value;

use crate::error::{InteropError, Result, content};

/// Reads a target file ([`parse_target`] on its text); errors name the file.
pub fn read_target(path: &Path) -> Result<TargetDescription> {
    let text = crate::read_text_file(path).map_err(|source| InteropError::Io { path: path.to_path_buf(), source })?;
    parse_target(&text, &path.display().to_string())
}

/// Parses a target from text: one description line ([`ACCEPTED_FORMS`]), a Kalibr target YAML,
/// or a serialised [`TargetDescription`] (RON, JSON or YAML). `what` names the source in errors.
///
/// ```
/// use parallax_interop::parse_target;
/// use parallax_interop::parallax_camera_model::TargetDescription;
///
/// let kalibr = "target_type: 'aprilgrid'\ntagCols: 6\ntagRows: 6\ntagSize: 0.088\ntagSpacing: 0.3\n";
/// let grid = parse_target(kalibr, "april_6x6.yaml").unwrap();
/// assert_eq!(grid, "aprilgrid:6x6:0.088:0.3".parse::<TargetDescription>().unwrap());
/// ```
pub fn parse_target(text: &str, what: &str) -> Result<TargetDescription> {
    let trimmed = text.trim();
    crate::check_nesting(trimmed, what)?;
    if trimmed.is_empty() {
        return Err(content(what, format!("the file is empty; a target is one of: {ACCEPTED_FORMS}")));
    }
    // One description line (comments starting with `#` allowed around it).
    let lines: Vec<&str> = trimmed.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')).collect();
    if let [line] = lines.as_slice()
        && let Some(kind) = line.split(':').next()
        && ["chessboard", "charuco", "circles", "acircles", "aprilgrid", "marker"].contains(&kind.trim())
    {
        return line.parse().map_err(|e| content(what, format!("{e}")));
    }
    if let Ok(value) = serde_yaml_ng::from_str::<Value>(trimmed)
        && let Some(kind) = value.get("target_type")
    {
        return kalibr(&value, kind, what);
    }
    // The project's own records: JSON starts with `{`, RON has parentheses, else YAML.
    let record: std::result::Result<TargetDescription, String> = if trimmed.starts_with('{') {
        serde_json::from_str(trimmed).map_err(|e| e.to_string())
    } else if trimmed.contains('(') {
        ron::from_str(trimmed).map_err(|e| e.to_string())
    } else {
        serde_yaml_ng::from_str(trimmed).map_err(|e| e.to_string())
    };
    record.map_err(|e| {
        if ["Chessboard", "Charuco", "CircleGrid", "AprilGrid", "Marker"].iter().any(|k| trimmed.contains(k)) {
            // A record that names a known target kind but fails to read or to pass its checks.
            content(what, format!("not a valid target record: {e}"))
        } else {
            content(
                what,
                format!(
                    "not a target: expected a Kalibr target YAML (target_type: aprilgrid | checkerboard | \
                     circlegrid), a serialised TargetDescription (RON, JSON or YAML) or one line in the form \
                     {ACCEPTED_FORMS}"
                ),
            )
        }
    })
}

/// A Kalibr target YAML.
fn kalibr(v: &Value, kind: &Value, what: &str) -> Result<TargetDescription> {
    let count = |key: &str| -> Result<usize> {
        v.get(key)
            .and_then(Value::as_u64)
            .and_then(|n| usize::try_from(n).ok())
            .ok_or_else(|| content(what, format!("Kalibr target needs `{key}` as a whole number")))
    };
    let length = |key: &str| -> Result<f64> {
        v.get(key)
            .and_then(Value::as_f64)
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| content(what, format!("Kalibr target needs `{key}` as a positive number (metres)")))
    };
    let invalid = |e: &dyn std::fmt::Display| content(what, e.to_string());
    match kind.as_str() {
        Some("aprilgrid") => {
            match v.get("codeOffset").map(Value::as_u64) {
                None | Some(Some(0)) => {}
                Some(other) => {
                    return Err(content(
                        what,
                        format!(
                            "codeOffset {other:?}: tag ids that do not start at 0 are not supported (the AprilGrid's tags are ids 0..cols·rows)"
                        ),
                    ));
                }
            }
            let grid = AprilGrid::new(count("tagCols")?, count("tagRows")?, length("tagSize")?, length("tagSpacing")?)
                .map_err(|e| invalid(&e))?;
            Ok(TargetDescription::AprilGrid(grid))
        }
        Some("checkerboard") => {
            let (row, col) = (length("rowSpacingMeters")?, length("colSpacingMeters")?);
            if (row - col).abs() > 1e-9 * row.max(col) {
                return Err(content(
                    what,
                    format!(
                        "rowSpacingMeters {row} and colSpacingMeters {col} differ: only square cells are supported"
                    ),
                ));
            }
            let board = Chessboard::new(count("targetCols")?, count("targetRows")?, row).map_err(|e| invalid(&e))?;
            Ok(TargetDescription::Chessboard(board))
        }
        Some("circlegrid") => {
            if v.get("asymmetricGrid").and_then(Value::as_bool).unwrap_or(false) {
                return Err(content(
                    what,
                    "asymmetricGrid: true is not read from Kalibr files (its spacing convention differs from \
                     OpenCV's); describe the grid as acircles:COLSxROWS:SPACING[:DIAMETER] in OpenCV's convention",
                ));
            }
            let spacing = length("spacingMeters")?;
            // Kalibr files have no circle diameter: the description-line default (half the spacing).
            let grid = CircleGrid::new(count("targetCols")?, count("targetRows")?, spacing, 0.5 * spacing, false)
                .map_err(|e| invalid(&e))?;
            Ok(TargetDescription::CircleGrid(grid))
        }
        _ => {
            Err(content(what, format!("Kalibr target_type {kind:?} is not one of aprilgrid, checkerboard, circlegrid")))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> TargetDescription {
        s.parse().unwrap()
    }

    #[test]
    fn kalibr_targets_read_as_their_description_lines() {
        // The three templates of Kalibr's wiki page "Calibration targets", comments included.
        let april = "target_type: 'aprilgrid' #gridtype\ntagCols: 6               #number of apriltags\n\
                     tagRows: 6\ntagSize: 0.088           #size of apriltag, edge to edge [m]\ntagSpacing: 0.3\n";
        assert_eq!(parse_target(april, "a").unwrap(), parse("aprilgrid:6x6:0.088:0.3"));
        let board = "target_type: 'checkerboard' #gridtype\ntargetCols: 6\ntargetRows: 7\n\
                     rowSpacingMeters: 0.06\ncolSpacingMeters: 0.06\n";
        assert_eq!(parse_target(board, "b").unwrap(), parse("chessboard:6x7:0.06"));
        let circles =
            "target_type: 'circlegrid'\ntargetCols: 6\ntargetRows: 7\nspacingMeters: 0.02\nasymmetricGrid: False\n";
        assert_eq!(parse_target(circles, "c").unwrap(), parse("circles:6x7:0.02"));
    }

    #[test]
    fn kalibr_targets_that_would_need_a_guess_are_refused_by_name() {
        let cases = [
            (
                "target_type: 'aprilgrid'\ntagCols: 6\ntagRows: 6\ntagSize: 0.088\ntagSpacing: 0.3\ncodeOffset: 24\n",
                "codeOffset",
            ),
            (
                "target_type: 'checkerboard'\ntargetCols: 6\ntargetRows: 7\nrowSpacingMeters: 0.06\ncolSpacingMeters: 0.05\n",
                "square cells",
            ),
            (
                "target_type: 'circlegrid'\ntargetCols: 6\ntargetRows: 7\nspacingMeters: 0.02\nasymmetricGrid: True\n",
                "acircles:",
            ),
            ("target_type: 'aprilgrid'\ntagCols: 6\ntagRows: 6\ntagSize: -0.088\ntagSpacing: 0.3\n", "tagSize"),
            ("target_type: 'aprilgrid'\ntagCols: 6\ntagSize: 0.088\ntagSpacing: 0.3\n", "tagRows"),
            ("target_type: 'aprilgrid'\ntagCols: 6\ntagRows: 6\ntagSize: 0.088\ntagSpacing: 3\n", "spacing"),
            ("target_type: 'hexgrid'\n", "hexgrid"),
        ];
        for (text, needle) in cases {
            let err = parse_target(text, "target.yaml").unwrap_err().to_string();
            assert!(err.contains("target.yaml") && err.contains(needle), "{needle}: {err}");
        }
    }

    #[test]
    fn description_lines_and_serialised_records_round_trip() {
        for line in [
            "chessboard:9x6:25",
            "charuco:7x5:40:30:DICT_5X5_100",
            "acircles:4x11:20:10",
            "aprilgrid:6x6:88:0.3",
            "marker:DICT_APRILTAG_36h11:0:80",
        ] {
            let t = parse(line);
            assert_eq!(parse_target(&format!("# our rig's target\n{line}\n"), "t").unwrap(), t);
            assert_eq!(parse_target(&ron::to_string(&t).unwrap(), "t.ron").unwrap(), t);
            assert_eq!(parse_target(&serde_json::to_string(&t).unwrap(), "t.json").unwrap(), t);
            assert_eq!(parse_target(&serde_yaml_ng::to_string(&t).unwrap(), "t.yaml").unwrap(), t);
        }
        // A record whose values fail the target's own checks is refused with the reason.
        let bad = ron::to_string(&parse("aprilgrid:6x6:88:0.3")).unwrap().replace("88.0", "-88.0");
        let err = parse_target(&bad, "t.ron").unwrap_err().to_string();
        assert!(err.contains("t.ron") && err.contains("tag size"), "{err}");
        let err = parse_target("hello", "t.txt").unwrap_err().to_string();
        assert!(err.contains("t.txt") && err.contains("target_type") && err.contains("charuco:"), "{err}");
        let err = parse_target("charuco:7x5:40", "t.txt").unwrap_err().to_string();
        assert!(err.contains("t.txt") && err.contains("charuco"), "{err}");
        assert!(parse_target("", "t.txt").unwrap_err().to_string().contains("empty"));
    }
}
