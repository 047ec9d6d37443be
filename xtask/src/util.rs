//! Argument parsing shared by the xtask commands (file I/O lives in `parallax_composition::io`).

use anyhow::Context;
use parallax_camera_model::{Chessboard, TargetDescription};
use parallax_corner_detection::{ChessboardConfig, CornerRefinement};

/// Parses a board size `COLSxROWS` (inner corners, OpenCV's `patternSize`), e.g. `9x6`.
pub fn parse_board_size(s: &str) -> Result<(usize, usize), String> {
    let (c, r) = s.split_once(['x', 'X']).ok_or_else(|| format!("board {s:?} is not COLSxROWS (e.g. 9x6)"))?;
    let c: usize = c.trim().parse().map_err(|_| format!("bad column count in board {s:?}"))?;
    let r: usize = r.trim().parse().map_err(|_| format!("bad row count in board {s:?}"))?;
    if c < 2 || r < 2 {
        return Err(format!("board needs at least 2x2 inner corners, got {s:?}"));
    }
    Ok((c, r))
}

/// The board of `--board COLSxROWS --square S`, with a message naming `--square` when the size
/// is not a positive length.
pub fn board(cols: usize, rows: usize, square: f64) -> anyhow::Result<Chessboard> {
    anyhow::ensure!(
        square.is_finite() && square > 0.0,
        "--square must be a positive length (the side of one square, in the unit of every result), got {square}"
    );
    Ok(Chessboard::new(cols, rows, square)?)
}

/// The target of `--board B [--square S]`: a chessboard's `COLSxROWS` (needs `--square`), any
/// target description (`chessboard:9x6:25`, `charuco:…`, …, its lengths in it), or a target file
/// (Kalibr's target YAML, a `TargetDescription` record, a description line); an unknown form is
/// refused naming it and the accepted forms.
pub fn target(board: &str, square: Option<f64>) -> anyhow::Result<TargetDescription> {
    let path = std::path::Path::new(board);
    if path.is_file() {
        anyhow::ensure!(square.is_none(), "--square is not used with a target file ({board}): its lengths are in it");
        return Ok(parallax_interop::read_target(path)?);
    }
    match parse_board_size(board) {
        Ok((cols, rows)) => {
            let square = square.context("--square is required with a COLSxROWS board")?;
            Ok(TargetDescription::Chessboard(self::board(cols, rows, square)?))
        }
        Err(_) => {
            let t: TargetDescription = board.parse().with_context(|| format!("--board {board:?}"))?;
            // `chessboard:9x6` carries no square size (the parser gives it 1): every length of a
            // calibration would be in squares. `--square` gives it; with a description that has
            // its lengths it is a second, maybe conflicting, answer (it used to be ignored).
            let sizeless = board.split(':').count() == 2;
            match (t, square) {
                (TargetDescription::Chessboard(c), Some(s)) if sizeless => {
                    Ok(TargetDescription::Chessboard(self::board(c.cols, c.rows, s)?))
                }
                (TargetDescription::Chessboard(_), None) if sizeless => anyhow::bail!(
                    "--board {board} gives no square size: write it in ({board}:25) or pass --square (every length \
                     of the result is in its unit)"
                ),
                (_, Some(_)) => anyhow::bail!(
                    "--square is not used with --board {board}: the description carries its lengths (change them there)"
                ),
                (t, None) => Ok(t),
            }
        }
    }
}

/// The target of `corners --board B`: as [`target`], but lengths are not needed (corner
/// positions have no unit): a `COLSxROWS` board or a sizeless chessboard description gets
/// squares of 1.
pub fn target_for_corners(board: &str) -> anyhow::Result<TargetDescription> {
    if std::path::Path::new(board).is_file() {
        return target(board, None);
    }
    if let Ok((cols, rows)) = parse_board_size(board) {
        return Ok(TargetDescription::Chessboard(self::board(cols, rows, 1.0)?));
    }
    board.parse().with_context(|| format!("--board {board:?}"))
}

/// The chessboard detector's settings (`corners`, `calibrate`). Lengths are in pixels of the
/// pyramid level searched: the defaults follow the image (a 1600x1200 image is searched at
/// 800x600 first), so most rigs need none of these.
#[derive(clap::Args, Debug, Clone)]
pub struct DetectorArgs {
    /// Gaussian smoothing before the saddle response, pixels (default 1.5).
    #[arg(long, value_parser = positive)]
    detection_sigma: Option<f64>,
    /// Radius of the ring on which a corner's four sectors are checked, pixels; below half the
    /// smallest corner spacing (default 5).
    #[arg(long, value_parser = positive)]
    ring_radius: Option<f64>,
    /// Minimum dark/bright difference on the ring, grey levels (default 20).
    #[arg(long, value_parser = positive)]
    min_contrast: Option<f64>,
    /// Longer side of the coarsest pyramid level searched; 0 searches full resolution only
    /// (default 500).
    #[arg(long)]
    pyramid_side: Option<u32>,
}

impl DetectorArgs {
    /// The detector configuration: the defaults with the settings given.
    pub fn config(&self, refinement: CornerRefinement) -> ChessboardConfig {
        let d = ChessboardConfig::default();
        ChessboardConfig {
            detection_sigma: self.detection_sigma.unwrap_or(d.detection_sigma),
            ring_radius: self.ring_radius.unwrap_or(d.ring_radius),
            min_contrast: self.min_contrast.unwrap_or(d.min_contrast),
            pyramid_side: self.pyramid_side.unwrap_or(d.pyramid_side),
            refinement,
            ..d
        }
    }
}

/// A positive finite number (clap value parser).
fn positive(s: &str) -> Result<f64, String> {
    s.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0).ok_or_else(|| format!("{s:?} is not a positive number"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_sizes_parse_and_bad_ones_are_named() {
        assert_eq!(parse_board_size("9x6"), Ok((9, 6)));
        assert_eq!(parse_board_size(" 12 X 8 "), Ok((12, 8)));
        assert!(parse_board_size("9").unwrap_err().contains("COLSxROWS"));
        assert!(parse_board_size("1x6").unwrap_err().contains("at least 2x2"));
        assert!(parse_board_size("ax6").unwrap_err().contains("column"));
        assert!(board(9, 6, -30.0).unwrap_err().to_string().contains("--square"));
        assert!(board(9, 6, f64::NAN).is_err());
        assert_eq!(target("9x6", Some(25.0)).unwrap().to_string(), "chessboard:9x6:25");
        assert!(target("9x6", None).unwrap_err().to_string().contains("--square"));
        let err = format!("{:#}", target("hexagons:3x3", None).unwrap_err());
        assert!(err.contains("hexagons") && err.contains("charuco:") && err.contains("aprilgrid:"), "{err}");
    }

    #[test]
    fn detector_settings_reach_the_configuration_and_bad_ones_are_refused() {
        use clap::Parser;
        #[derive(Parser)]
        #[command(allow_negative_numbers = true)]
        struct Cli {
            #[command(flatten)]
            detector: DetectorArgs,
        }
        let cli = Cli::try_parse_from(["x", "--ring-radius", "7", "--detection-sigma", "2.5", "--pyramid-side", "0"])
            .unwrap();
        let c = cli.detector.config(CornerRefinement::SubPix);
        let d = ChessboardConfig::default();
        assert_eq!((c.ring_radius, c.detection_sigma, c.pyramid_side), (7.0, 2.5, 0));
        assert_eq!(
            (c.min_contrast, c.max_candidates, c.refinement),
            (d.min_contrast, d.max_candidates, CornerRefinement::SubPix)
        );
        for bad in [["x", "--ring-radius", "-7"], ["x", "--min-contrast", "0"], ["x", "--detection-sigma", "nan"]] {
            let err = Cli::try_parse_from(bad).err().unwrap().to_string();
            assert!(err.contains(bad[2]) && err.contains("positive"), "{err}");
        }
    }

    #[test]
    fn a_target_file_is_read_and_a_square_beside_it_refused() {
        let path = std::env::temp_dir().join(format!("xtask-util-target-{}.yaml", std::process::id()));
        std::fs::write(&path, "target_type: 'aprilgrid'\ntagCols: 6\ntagRows: 5\ntagSize: 0.04\ntagSpacing: 0.25\n")
            .unwrap();
        let file = path.to_str().unwrap();
        let t = target(file, None).unwrap();
        assert_eq!(t, "aprilgrid:6x5:0.04:0.25".parse::<TargetDescription>().unwrap());
        assert_eq!(t.point_count(), 4 * 6 * 5);
        let err = target(file, Some(25.0)).unwrap_err().to_string();
        assert!(err.contains("--square") && err.contains(file), "{err}");
        std::fs::remove_file(&path).unwrap();
    }
}
