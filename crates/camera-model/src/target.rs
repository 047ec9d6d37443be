//! Calibration targets and detected corner grids.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Result};

/// A planar chessboard described by its *inner* corners (OpenCV's `patternSize`) and square
/// size. Its frame has the origin at the first inner corner, `x` along a row, `y` along a
/// column, `z` into the board (so `z = 0` on the board), as OpenCV's object points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ChessboardRaw")]
pub struct Chessboard {
    /// Inner corners per row (OpenCV's `patternSize.width`), at least 2.
    pub cols: usize,
    /// Inner corners per column (`patternSize.height`), at least 2.
    pub rows: usize,
    /// Side of one square, in the scene's length unit (say which in every report).
    pub square_size: f64,
}

/// Most points a target may number (ids are `u32`, and no real target comes near: a 1000 x
/// 1000 grid is 10^6); a larger description is a typo or a corrupt file.
pub const MAX_TARGET_POINTS: usize = 1 << 20;

/// A chessboard as read from a file, checked by [`Chessboard::new`] on the way in.
#[derive(Deserialize)]
struct ChessboardRaw {
    cols: usize,
    rows: usize,
    square_size: f64,
}

impl TryFrom<ChessboardRaw> for Chessboard {
    type Error = CameraModelError;
    fn try_from(r: ChessboardRaw) -> Result<Self> {
        Chessboard::new(r.cols, r.rows, r.square_size)
    }
}

impl Chessboard {
    /// A validated board: at least 2x2 and at most [`MAX_TARGET_POINTS`] inner corners, and a
    /// positive, finite square size.
    pub fn new(cols: usize, rows: usize, square_size: f64) -> Result<Self> {
        let board = Self { cols, rows, square_size };
        board.validate()?;
        Ok(board)
    }

    /// Checks the invariants of [`Self::new`].
    pub fn validate(&self) -> Result<()> {
        if self.cols < 2 || self.rows < 2 {
            return Err(CameraModelError::InvalidBoard(format!(
                "needs at least 2x2 inner corners, got {}x{}",
                self.cols, self.rows
            )));
        }
        if self.cols.checked_mul(self.rows).is_none_or(|n| n > MAX_TARGET_POINTS) {
            return Err(CameraModelError::InvalidBoard(format!(
                "at most {MAX_TARGET_POINTS} inner corners, got {}x{}",
                self.cols, self.rows
            )));
        }
        if !(self.square_size.is_finite() && self.square_size > 0.0) {
            return Err(CameraModelError::InvalidBoard(format!(
                "square size must be positive and finite, got {}",
                self.square_size
            )));
        }
        Ok(())
    }

    /// Number of inner corners.
    pub fn len(&self) -> usize {
        self.cols * self.rows
    }

    /// Always false for a valid board (kept for clippy's `len_without_is_empty`).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The 3D object point of inner corner `(col, row)`: `(col·s, row·s, 0)`.
    pub fn point(&self, col: usize, row: usize) -> DVec3 {
        DVec3::new(col as f64 * self.square_size, row as f64 * self.square_size, 0.0)
    }

    /// All inner corners in OpenCV's order (row-major: index `row · cols + col`).
    pub fn object_points(&self) -> Vec<DVec3> {
        (0..self.rows).flat_map(|r| (0..self.cols).map(move |c| self.point(c, r))).collect()
    }
}

/// Image positions of a board's inner corners, row-major in OpenCV's order
/// (`corners[row · cols + col]` matches [`Chessboard::object_points`]). Read from a file, a grid
/// is checked as by [`CornerGrid::new`] (a corners file whose grid has the wrong number of
/// corners, or a non-finite one, is refused).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CornerGridRaw")]
pub struct CornerGrid {
    /// Inner corners per row.
    pub cols: usize,
    /// Inner corners per column.
    pub rows: usize,
    /// Pixel positions, `cols · rows` of them.
    pub corners: Vec<DVec2>,
}

#[derive(Deserialize)]
struct CornerGridRaw {
    cols: usize,
    rows: usize,
    corners: Vec<DVec2>,
}

impl TryFrom<CornerGridRaw> for CornerGrid {
    type Error = CameraModelError;
    fn try_from(r: CornerGridRaw) -> Result<Self> {
        Self::new(r.cols, r.rows, r.corners)
    }
}

impl CornerGrid {
    /// A grid; errors when the number of corners is not `cols · rows` or one is not finite.
    pub fn new(cols: usize, rows: usize, corners: Vec<DVec2>) -> Result<Self> {
        if cols.checked_mul(rows) != Some(corners.len()) {
            return Err(CameraModelError::SizeMismatch(format!(
                "corner grid {cols}x{rows} needs {} corners, got {}",
                cols as u128 * rows as u128,
                corners.len()
            )));
        }
        if corners.iter().any(|c| !c.is_finite()) {
            return Err(CameraModelError::NonFinite { what: "corner position" });
        }
        Ok(Self { cols, rows, corners })
    }

    /// The corner at `(col, row)`.
    pub fn at(&self, col: usize, row: usize) -> DVec2 {
        self.corners[row * self.cols + col]
    }
}
