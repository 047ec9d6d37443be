//! Calibration target descriptions beyond the plain chessboard: ChArUco boards (OpenCV's
//! `CharucoBoard` layout and predefined marker dictionaries), circle grids (OpenCV's
//! `findCirclesGrid` layouts), a [`TargetDescription`] that parses the command line's
//! `--board` forms, and [`TargetObservation`], the identified points of one view.
//!
//! Every target has a planar frame with `z = 0` on the target and numbered points; a view sees
//! any subset of them, identified by number.

use std::fmt;
use std::str::FromStr;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::Chessboard;
use crate::marker_dictionaries::PREDEFINED;

/// Errors of the target descriptions; each names the input and the accepted forms.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetError {
    /// A target description string does not parse.
    #[error("cannot read target {input:?}: {reason}; accepted forms: {}", ACCEPTED_FORMS)]
    Parse {
        /// The text given.
        input: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A target's parameters are unusable.
    #[error("invalid {target}: {reason}")]
    Invalid {
        /// Which kind of target.
        target: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The marker dictionary name is unknown.
    #[error("unknown marker dictionary {name:?}; known: {known}", known = dictionary_names().collect::<Vec<_>>().join(", "))]
    UnknownDictionary {
        /// The name given.
        name: String,
    },
    /// An observation's ids and points disagree, repeat or are not finite.
    #[error("invalid target observation: {0}")]
    InvalidObservation(String),
}

/// The `--board` forms [`TargetDescription::from_str`] accepts (for error messages and help).
pub const ACCEPTED_FORMS: &str = "chessboard:COLSxROWS[:SQUARE] (inner corners, e.g. chessboard:9x6:25), \
     charuco:SQUARESXxSQUARESY:SQUARE:MARKER:DICT[:legacy] (squares, e.g. charuco:7x5:40:30:DICT_5X5_100), \
     circles:COLSxROWS:SPACING[:DIAMETER] (symmetric grid, e.g. circles:4x11:20:10), \
     acircles:COLSxROWS:SPACING[:DIAMETER] (asymmetric grid as OpenCV's patternSize, e.g. acircles:4x11:20:10), \
     aprilgrid:TAGCOLSxTAGROWS:TAGSIZE:SPACINGRATIO (Kalibr, e.g. aprilgrid:6x6:88:0.3), \
     marker:DICT:ID:SIZE (one marker, e.g. marker:DICT_APRILTAG_36h11:0:80)";

/// Names of the predefined dictionaries, as OpenCV spells them.
pub fn dictionary_names() -> impl Iterator<Item = &'static str> {
    PREDEFINED.iter().map(|d| d.0)
}

/// One of OpenCV's predefined ArUco / AprilTag marker dictionaries (`cv2.aruco`), with its
/// bit tables (exported once from OpenCV, see `marker_dictionaries.rs`) and its
/// `maxCorrectionBits`. Serialised as its OpenCV name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct MarkerDictionary {
    index: usize,
}

impl MarkerDictionary {
    /// The predefined dictionary called `name`: OpenCV's name (`DICT_6X6_250`,
    /// `DICT_ARUCO_ORIGINAL`, `DICT_APRILTAG_36h11`, …), case-insensitive, `DICT_` optional.
    pub fn predefined(name: &str) -> Result<Self, TargetError> {
        let norm = |s: &str| s.trim().to_ascii_uppercase().trim_start_matches("DICT_").to_string();
        let want = norm(name);
        PREDEFINED
            .iter()
            .position(|d| norm(d.0) == want)
            .map(|index| Self { index })
            .ok_or_else(|| TargetError::UnknownDictionary { name: name.to_string() })
    }

    /// OpenCV's name of the dictionary.
    pub fn name(&self) -> &'static str {
        PREDEFINED[self.index].0
    }

    /// Data bits per side (the black border of one bit around them is not counted).
    pub fn marker_size(&self) -> usize {
        PREDEFINED[self.index].3
    }

    /// Number of markers.
    pub fn len(&self) -> usize {
        PREDEFINED[self.index].2
    }

    /// Always false (every predefined dictionary has markers).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// OpenCV's `maxCorrectionBits`: how many wrong bits a detector may correct.
    pub fn max_correction_bits(&self) -> u32 {
        PREDEFINED[self.index].4
    }

    /// The code of marker `id`: its data bits row-major from the top-left, the first bit most
    /// significant, 1 = white (as `getBitsFromByteList` for rotation 0). `None` past the end.
    pub fn code(&self, id: u32) -> Option<u64> {
        let (_, table, n, _, _) = PREDEFINED[self.index];
        (id < n as u32).then(|| table[id as usize])
    }

    /// True when data bit `(row, col)` of marker `id` is white. Panics past the end.
    pub fn bit(&self, id: u32, row: usize, col: usize) -> bool {
        let n = self.marker_size();
        let code = self.code(id).expect("marker id in the dictionary");
        (code >> (n * n - 1 - (row * n + col))) & 1 == 1
    }
}

impl TryFrom<String> for MarkerDictionary {
    type Error = TargetError;
    fn try_from(s: String) -> Result<Self, TargetError> {
        Self::predefined(&s)
    }
}

impl From<MarkerDictionary> for String {
    fn from(d: MarkerDictionary) -> String {
        d.name().to_string()
    }
}

/// A ChArUco board laid out as OpenCV's `cv::aruco::CharucoBoard` (OpenCV ≥ 4.6): a
/// chessboard of `squares_x x squares_y` squares whose square `(0, 0)` (top-left) is black,
/// with a marker centred in every white square, marker ids `0, 1, …` in row-major order over
/// the squares. The board frame has its origin at the board's outer top-left corner, `x` along
/// the rows, `y` down, `z = 0` on the board. The ChArUco corners are the inner chessboard
/// corners: corner `id = y·(squares_x − 1) + x` is at `((x + 1)·square, (y + 1)·square, 0)`.
/// With `legacy_pattern` (OpenCV's `setLegacyPattern(true)`, boards made before 4.6.0) and an
/// even number of rows, square `(0, 0)` is white instead.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CharucoBoardRaw")]
pub struct CharucoBoard {
    squares_x: usize,
    squares_y: usize,
    square_length: f64,
    marker_length: f64,
    dictionary: MarkerDictionary,
    legacy_pattern: bool,
}

#[derive(Deserialize)]
struct CharucoBoardRaw {
    squares_x: usize,
    squares_y: usize,
    square_length: f64,
    marker_length: f64,
    dictionary: MarkerDictionary,
    #[serde(default)]
    legacy_pattern: bool,
}

impl TryFrom<CharucoBoardRaw> for CharucoBoard {
    type Error = TargetError;
    fn try_from(r: CharucoBoardRaw) -> Result<Self, TargetError> {
        Self::new(r.squares_x, r.squares_y, r.square_length, r.marker_length, r.dictionary, r.legacy_pattern)
    }
}

impl CharucoBoard {
    /// A checked board: at least 2x2 squares (and 3 squares in all, so that it has a corner),
    /// `0 < marker_length < square_length`, finite lengths, and no more markers than the
    /// dictionary holds.
    pub fn new(
        squares_x: usize,
        squares_y: usize,
        square_length: f64,
        marker_length: f64,
        dictionary: MarkerDictionary,
        legacy_pattern: bool,
    ) -> Result<Self, TargetError> {
        let invalid = |reason: String| TargetError::Invalid { target: "ChArUco board", reason };
        if squares_x < 2 || squares_y < 2 {
            return Err(invalid(format!("needs at least 2x2 squares, got {squares_x}x{squares_y}")));
        }
        if !(square_length.is_finite() && square_length > 0.0) {
            return Err(invalid(format!("square length must be positive and finite, got {square_length}")));
        }
        if !(marker_length.is_finite() && marker_length > 0.0 && marker_length < square_length) {
            return Err(invalid(format!(
                "marker length must be positive and below the square length {square_length}, got {marker_length}"
            )));
        }
        let b = Self { squares_x, squares_y, square_length, marker_length, dictionary, legacy_pattern };
        if b.marker_count() > dictionary.len() {
            return Err(invalid(format!(
                "{squares_x}x{squares_y} squares need {} markers but {} has {}; use a larger dictionary",
                b.marker_count(),
                dictionary.name(),
                dictionary.len()
            )));
        }
        Ok(b)
    }

    /// Squares along `x` (OpenCV's `size.width`).
    pub fn squares_x(&self) -> usize {
        self.squares_x
    }
    /// Squares along `y` (OpenCV's `size.height`).
    pub fn squares_y(&self) -> usize {
        self.squares_y
    }
    /// Side of a square, in the target's length unit.
    pub fn square_length(&self) -> f64 {
        self.square_length
    }
    /// Side of a marker (its black border included), same unit.
    pub fn marker_length(&self) -> f64 {
        self.marker_length
    }
    /// The marker dictionary.
    pub fn dictionary(&self) -> MarkerDictionary {
        self.dictionary
    }
    /// OpenCV's legacy pattern flag.
    pub fn legacy_pattern(&self) -> bool {
        self.legacy_pattern
    }

    /// True when square `(x, y)` is black (no marker).
    pub fn square_is_black(&self, x: usize, y: usize) -> bool {
        if self.legacy_pattern && self.squares_y.is_multiple_of(2) { (y + 1) % 2 == x % 2 } else { y % 2 == x % 2 }
    }

    /// Number of markers (white squares).
    pub fn marker_count(&self) -> usize {
        (0..self.squares_y).map(|y| (0..self.squares_x).filter(|&x| !self.square_is_black(x, y)).count()).sum()
    }

    /// Number of ChArUco (inner chessboard) corners.
    pub fn corner_count(&self) -> usize {
        (self.squares_x - 1) * (self.squares_y - 1)
    }

    /// Square `(x, y)` holding marker `id`, or `None` when the board has no such marker.
    pub fn marker_square(&self, id: u32) -> Option<(usize, usize)> {
        let mut k = 0u32;
        for y in 0..self.squares_y {
            for x in 0..self.squares_x {
                if !self.square_is_black(x, y) {
                    if k == id {
                        return Some((x, y));
                    }
                    k += 1;
                }
            }
        }
        None
    }

    /// Marker id in square `(x, y)`, `None` for a black square or outside the board.
    pub fn marker_at(&self, x: usize, y: usize) -> Option<u32> {
        if x >= self.squares_x || y >= self.squares_y || self.square_is_black(x, y) {
            return None;
        }
        let before: usize =
            (0..y).map(|yy| (0..self.squares_x).filter(|&xx| !self.square_is_black(xx, yy)).count()).sum::<usize>()
                + (0..x).filter(|&xx| !self.square_is_black(xx, y)).count();
        Some(before as u32)
    }

    /// The four corners of marker `id` on the board (OpenCV's order: top-left, top-right,
    /// bottom-right, bottom-left as seen on the printed board).
    pub fn marker_corners(&self, id: u32) -> Option<[DVec3; 4]> {
        let (x, y) = self.marker_square(id)?;
        let d = 0.5 * (self.square_length - self.marker_length);
        let o = DVec3::new(x as f64 * self.square_length + d, y as f64 * self.square_length + d, 0.0);
        let m = self.marker_length;
        Some([o, o + DVec3::new(m, 0.0, 0.0), o + DVec3::new(m, m, 0.0), o + DVec3::new(0.0, m, 0.0)])
    }

    /// The board point of ChArUco corner `id`.
    pub fn corner_point(&self, id: u32) -> Option<DVec3> {
        let n = self.squares_x - 1;
        ((id as usize) < self.corner_count()).then(|| {
            let (x, y) = (id as usize % n, id as usize / n);
            DVec3::new((x + 1) as f64 * self.square_length, (y + 1) as f64 * self.square_length, 0.0)
        })
    }

    /// Ids of the (up to two) markers whose squares touch ChArUco corner `id`.
    pub fn markers_around_corner(&self, id: u32) -> Vec<u32> {
        let n = self.squares_x - 1;
        let (x, y) = (id as usize % n, id as usize / n);
        [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)].iter().filter_map(|&(sx, sy)| self.marker_at(sx, sy)).collect()
    }
}

/// A grid of circles as OpenCV's `findCirclesGrid` sees it (`patternSize = (cols, rows)`).
///
/// Symmetric: circle `(col, row)` at `(col·s, row·s, 0)`, id `row·cols + col`. Asymmetric
/// (OpenCV's `CALIB_CB_ASYMMETRIC_GRID`): `rows` staggered lines of `cols` circles each, circle
/// `(col, row)` at `((2·col + row mod 2)·s, row·s, 0)` (the object points of OpenCV's
/// calibration sample), so neighbouring circles in a line are `2s` apart and the lines `s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CircleGridRaw")]
pub struct CircleGrid {
    cols: usize,
    rows: usize,
    spacing: f64,
    diameter: f64,
    asymmetric: bool,
}

#[derive(Deserialize)]
struct CircleGridRaw {
    cols: usize,
    rows: usize,
    spacing: f64,
    diameter: f64,
    asymmetric: bool,
}

impl TryFrom<CircleGridRaw> for CircleGrid {
    type Error = TargetError;
    fn try_from(r: CircleGridRaw) -> Result<Self, TargetError> {
        Self::new(r.cols, r.rows, r.spacing, r.diameter, r.asymmetric)
    }
}

impl CircleGrid {
    /// A checked grid: at least 2x2 circles (3 rows for an asymmetric grid), positive finite
    /// spacing, and circles that do not touch (`diameter` below the nearest-centre distance).
    pub fn new(cols: usize, rows: usize, spacing: f64, diameter: f64, asymmetric: bool) -> Result<Self, TargetError> {
        let invalid = |reason: String| TargetError::Invalid { target: "circle grid", reason };
        if cols < 2 || rows < 2 || (asymmetric && rows < 3) {
            return Err(invalid(format!("needs at least 2x2 circles (3 rows when asymmetric), got {cols}x{rows}")));
        }
        if cols.checked_mul(rows).is_none_or(|n| n > crate::target::MAX_TARGET_POINTS) {
            return Err(invalid(format!("at most {} circles, got {cols}x{rows}", crate::target::MAX_TARGET_POINTS)));
        }
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(invalid(format!("spacing must be positive and finite, got {spacing}")));
        }
        let nearest = if asymmetric { spacing * 2f64.sqrt() } else { spacing };
        if !(diameter.is_finite() && diameter > 0.0 && diameter < nearest) {
            return Err(invalid(format!(
                "diameter must be positive and below the nearest-centre distance {nearest}, got {diameter}"
            )));
        }
        Ok(Self { cols, rows, spacing, diameter, asymmetric })
    }
    /// Circles per line (OpenCV's `patternSize.width`).
    pub fn cols(&self) -> usize {
        self.cols
    }
    /// Lines (OpenCV's `patternSize.height`).
    pub fn rows(&self) -> usize {
        self.rows
    }
    /// The grid unit `s` (see the type's docs).
    pub fn spacing(&self) -> f64 {
        self.spacing
    }
    /// Circle diameter.
    pub fn diameter(&self) -> f64 {
        self.diameter
    }
    /// Asymmetric (staggered) grid.
    pub fn asymmetric(&self) -> bool {
        self.asymmetric
    }
    /// Number of circles.
    pub fn len(&self) -> usize {
        self.cols * self.rows
    }
    /// Always false for a valid grid.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Centre of circle `id = row·cols + col`.
    pub fn point(&self, id: u32) -> Option<DVec3> {
        let (col, row) = (id as usize % self.cols, id as usize / self.cols);
        (row < self.rows).then(|| {
            let x = if self.asymmetric { (2 * col + row % 2) as f64 } else { col as f64 };
            DVec3::new(x * self.spacing, row as f64 * self.spacing, 0.0)
        })
    }
}

/// Kalibr's AprilGrid (`target_type: 'aprilgrid'`): `tag_cols x tag_rows` AprilTags of the
/// 36h11 family (OpenCV's `DICT_APRILTAG_36h11` codes) with a black border of two bits (10x10
/// bits edge to edge, `tag_size` edge to edge), `tag_spacing · tag_size` apart, and a small
/// black square of that size in the gap at every tag corner (as `kalibr_create_target_pdf`
/// draws them), so every tag corner is an X-junction.
///
/// Each tag is printed turned 180° from OpenCV's canonical `DICT_APRILTAG_36h11` marker image
/// (Kalibr draws the Kaess tag36h11 codes, which are OpenCV's turned 180°, with
/// `np.rot90(code, 2)` in `kalibr_create_target_pdf`): a decoded marker's corner 0 is the tag's
/// bottom-right on the print, 1 its bottom-left, 2 its top-left, 3 its top-right.
///
/// Numbering as Kalibr's `GridCalibrationTargetAprilgrid`: tag 0 at the bottom-left of the
/// printed target, ids along `x` then up; the target frame has its origin at tag 0's
/// bottom-left corner, `x` right and `y` **up** on the print (`z` towards the viewer); the
/// `2·tag_rows x 2·tag_cols` corners are numbered `r · 2·tag_cols + c` with corner `(c, r)` at
/// `(⌊c/2⌋·(1 + spacing)·size + (c mod 2)·size, ⌊r/2⌋·(1 + spacing)·size + (r mod 2)·size, 0)`;
/// tag `t`'s corners (bottom-left, bottom-right, top-right, top-left) are
/// `b, b + 1, b + 2·tag_cols + 1, b + 2·tag_cols` with
/// `b = ⌊t / tag_cols⌋ · 4·tag_cols + (t mod tag_cols) · 2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "AprilGridRaw")]
pub struct AprilGrid {
    tag_cols: usize,
    tag_rows: usize,
    tag_size: f64,
    tag_spacing: f64,
}

#[derive(Deserialize)]
struct AprilGridRaw {
    tag_cols: usize,
    tag_rows: usize,
    tag_size: f64,
    tag_spacing: f64,
}

impl TryFrom<AprilGridRaw> for AprilGrid {
    type Error = TargetError;
    fn try_from(r: AprilGridRaw) -> Result<Self, TargetError> {
        Self::new(r.tag_cols, r.tag_rows, r.tag_size, r.tag_spacing)
    }
}

impl AprilGrid {
    /// A checked grid: at least one tag, at most 587 (the 36h11 family), positive finite size,
    /// spacing ratio in `(0, 1]`.
    pub fn new(tag_cols: usize, tag_rows: usize, tag_size: f64, tag_spacing: f64) -> Result<Self, TargetError> {
        let invalid = |reason: String| TargetError::Invalid { target: "AprilGrid", reason };
        if tag_cols == 0 || tag_rows == 0 || tag_cols * tag_rows > 587 {
            return Err(invalid(format!("needs 1 to 587 tags (tag36h11), got {tag_cols}x{tag_rows}")));
        }
        if !(tag_size.is_finite() && tag_size > 0.0) {
            return Err(invalid(format!("tag size must be positive and finite, got {tag_size}")));
        }
        if !(tag_spacing.is_finite() && tag_spacing > 0.0 && tag_spacing <= 1.0) {
            return Err(invalid(format!("tag spacing is a ratio of the tag size in (0, 1], got {tag_spacing}")));
        }
        Ok(Self { tag_cols, tag_rows, tag_size, tag_spacing })
    }
    /// Tags along `x`.
    pub fn tag_cols(&self) -> usize {
        self.tag_cols
    }
    /// Tags along `y`.
    pub fn tag_rows(&self) -> usize {
        self.tag_rows
    }
    /// Tag size, edge to edge of the black border.
    pub fn tag_size(&self) -> f64 {
        self.tag_size
    }
    /// Gap between tags as a ratio of the tag size.
    pub fn tag_spacing(&self) -> f64 {
        self.tag_spacing
    }
    /// The tag family's dictionary (`DICT_APRILTAG_36h11`).
    pub fn dictionary(&self) -> MarkerDictionary {
        MarkerDictionary::predefined("DICT_APRILTAG_36h11").expect("predefined")
    }
    /// Number of corners (four per tag).
    pub fn corner_count(&self) -> usize {
        4 * self.tag_cols * self.tag_rows
    }
    /// Corner ids of tag `t` (bottom-left, bottom-right, top-right, top-left), `None` past the
    /// last tag.
    pub fn tag_corner_ids(&self, t: u32) -> Option<[u32; 4]> {
        let t = t as usize;
        if t >= self.tag_cols * self.tag_rows {
            return None;
        }
        let cols = 2 * self.tag_cols;
        let b = (t / self.tag_cols) * cols * 2 + (t % self.tag_cols) * 2;
        Some([b as u32, (b + 1) as u32, (b + cols + 1) as u32, (b + cols) as u32])
    }
    /// Height of the tag area (bottom of the bottom tags to the top of the top tags).
    pub fn height(&self) -> f64 {
        (self.tag_rows as f64 * (1.0 + self.tag_spacing) - self.tag_spacing) * self.tag_size
    }

    /// The target frame seen from the print frame (`x` right, `y` down, origin at the top-left
    /// corner of the top-left tag, `z` into the paper, as the chessboard and ChArUco frames):
    /// `target = (x, height − y, −z)`.
    pub fn target_from_print(&self) -> crate::Isometry3 {
        crate::Isometry3::from_quat_translation(
            glam::DQuat::from_rotation_x(std::f64::consts::PI),
            DVec3::new(0.0, self.height(), 0.0),
        )
    }

    /// The target point of corner `id`.
    pub fn point(&self, id: u32) -> Option<DVec3> {
        let cols = 2 * self.tag_cols;
        let (c, r) = (id as usize % cols, id as usize / cols);
        (r < 2 * self.tag_rows).then(|| {
            let pitch = (1.0 + self.tag_spacing) * self.tag_size;
            let f = |k: usize| (k / 2) as f64 * pitch + (k % 2) as f64 * self.tag_size;
            DVec3::new(f(c), f(r), 0.0)
        })
    }
}

/// One square marker (an AprilTag or ArUco marker of a predefined dictionary, one-bit black
/// border) used alone, e.g. as a hand-eye target. Frame as OpenCV's ArUco pose
/// (`estimatePoseSingleMarkers`, `SOLVEPNP_IPPE_SQUARE`): origin at the marker centre, `x`
/// right and `y` **up** on the print, `z` towards the viewer; points 0..3 are the marker's
/// corners top-left `(−s/2, s/2, 0)`, top-right `(s/2, s/2, 0)`, bottom-right `(s/2, −s/2, 0)`,
/// bottom-left `(−s/2, −s/2, 0)` (`s` the size of the black square, edge to edge).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SingleMarkerRaw")]
pub struct SingleMarker {
    dictionary: MarkerDictionary,
    id: u32,
    size: f64,
}

#[derive(Deserialize)]
struct SingleMarkerRaw {
    dictionary: MarkerDictionary,
    id: u32,
    size: f64,
}

impl TryFrom<SingleMarkerRaw> for SingleMarker {
    type Error = TargetError;
    fn try_from(r: SingleMarkerRaw) -> Result<Self, TargetError> {
        Self::new(r.dictionary, r.id, r.size)
    }
}

impl SingleMarker {
    /// A checked marker: an id of the dictionary and a positive finite size.
    pub fn new(dictionary: MarkerDictionary, id: u32, size: f64) -> Result<Self, TargetError> {
        let invalid = |reason: String| TargetError::Invalid { target: "marker", reason };
        if id as usize >= dictionary.len() {
            return Err(invalid(format!("{} has ids 0..{}, got {id}", dictionary.name(), dictionary.len() - 1)));
        }
        if !(size.is_finite() && size > 0.0) {
            return Err(invalid(format!("size must be positive and finite, got {size}")));
        }
        Ok(Self { dictionary, id, size })
    }
    /// The dictionary.
    pub fn dictionary(&self) -> MarkerDictionary {
        self.dictionary
    }
    /// The marker id.
    pub fn id(&self) -> u32 {
        self.id
    }
    /// Edge-to-edge size of the black square.
    pub fn size(&self) -> f64 {
        self.size
    }
    /// Corner `k` (0..3) in the marker frame.
    pub fn point(&self, k: u32) -> Option<DVec3> {
        let h = 0.5 * self.size;
        [(-h, h), (h, h), (h, -h), (-h, -h)].get(k as usize).map(|&(x, y)| DVec3::new(x, y, 0.0))
    }
}

/// Any calibration target, as the command line's `--board` describes it ([`ACCEPTED_FORMS`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum TargetDescription {
    /// A plain chessboard (OpenCV's `findChessboardCorners`), whole board per view.
    Chessboard(Chessboard),
    /// A ChArUco board; any subset of corners per view.
    Charuco(CharucoBoard),
    /// A symmetric or asymmetric circle grid (OpenCV's `findCirclesGrid`).
    CircleGrid(CircleGrid),
    /// Kalibr's AprilGrid; any subset of tags per view.
    AprilGrid(AprilGrid),
    /// One marker (its four corners), e.g. an AprilTag as a hand-eye target.
    Marker(SingleMarker),
}

impl TargetDescription {
    /// Number of numbered points (chessboard inner corners, ChArUco corners, circles).
    pub fn point_count(&self) -> usize {
        match self {
            Self::Chessboard(b) => b.len(),
            Self::Charuco(b) => b.corner_count(),
            Self::CircleGrid(g) => g.len(),
            Self::AprilGrid(g) => g.corner_count(),
            Self::Marker(_) => 4,
        }
    }

    /// The target point with number `id` (`z = 0`), `None` when there is no such point.
    pub fn point(&self, id: u32) -> Option<DVec3> {
        match self {
            Self::Chessboard(b) => {
                ((id as usize) < b.len()).then(|| b.point(id as usize % b.cols, id as usize / b.cols))
            }
            Self::Charuco(b) => b.corner_point(id),
            Self::CircleGrid(g) => g.point(id),
            Self::AprilGrid(g) => g.point(id),
            Self::Marker(m) => m.point(id),
        }
    }

    /// All points, in id order.
    pub fn points(&self) -> Vec<DVec3> {
        (0..self.point_count() as u32).map(|i| self.point(i).expect("id below point_count")).collect()
    }

    /// True when a view must show every point (chessboards and circle grids are only found
    /// whole); false when any subset is identified (ChArUco, AprilGrid).
    pub fn needs_whole_target(&self) -> bool {
        !matches!(self, Self::Charuco(_) | Self::AprilGrid(_))
    }
}

impl FromStr for TargetDescription {
    type Err = TargetError;

    /// Parses one of [`ACCEPTED_FORMS`]. Lengths may use any unit (say which in reports);
    /// a chessboard without a square size gets 1.0; a circle grid without a diameter gets half
    /// the nearest-centre distance.
    fn from_str(s: &str) -> Result<Self, TargetError> {
        let err = |reason: &str| TargetError::Parse { input: s.to_string(), reason: reason.to_string() };
        let parts: Vec<&str> = s.trim().split(':').map(str::trim).collect();
        let size = |t: &str| -> Result<(usize, usize), TargetError> {
            let (a, b) = t
                .to_ascii_lowercase()
                .split_once('x')
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .ok_or_else(|| err(&format!("{t:?} is not a size; write it as COLSxROWS, e.g. 9x6")))?;
            match (a.parse(), b.parse()) {
                (Ok(a), Ok(b)) => Ok((a, b)),
                _ => Err(err(&format!("{t:?} is not a size of two whole numbers"))),
            }
        };
        let length = |t: &str, what: &str| -> Result<f64, TargetError> {
            t.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| err(&format!("{what} {t:?} is not a positive number")))
        };
        let kind = parts[0].to_ascii_lowercase();
        let invalid = |e: TargetError| match e {
            TargetError::Invalid { reason, .. } => err(&reason),
            other => err(&other.to_string()),
        };
        match (kind.as_str(), parts.len()) {
            ("chessboard", 2 | 3) => {
                let (c, r) = size(parts[1])?;
                let sq = if parts.len() == 3 { length(parts[2], "square size")? } else { 1.0 };
                Chessboard::new(c, r, sq).map(Self::Chessboard).map_err(|e| err(&e.to_string()))
            }
            ("charuco", 5 | 6) => {
                let (sx, sy) = size(parts[1])?;
                let sq = length(parts[2], "square length")?;
                let m = length(parts[3], "marker length")?;
                let dict = MarkerDictionary::predefined(parts[4]).map_err(|e| err(&e.to_string()))?;
                let legacy = match parts.get(5).map(|t| t.to_ascii_lowercase()) {
                    None => false,
                    Some(t) if t == "legacy" => true,
                    Some(t) => return Err(err(&format!("unknown ChArUco option {t:?} (only \"legacy\")"))),
                };
                CharucoBoard::new(sx, sy, sq, m, dict, legacy).map(Self::Charuco).map_err(invalid)
            }
            ("circles" | "acircles", 3 | 4) => {
                let asym = kind == "acircles";
                let (c, r) = size(parts[1])?;
                let sp = length(parts[2], "spacing")?;
                let nearest = if asym { sp * 2f64.sqrt() } else { sp };
                let d = if parts.len() == 4 { length(parts[3], "diameter")? } else { 0.5 * nearest };
                CircleGrid::new(c, r, sp, d, asym).map(Self::CircleGrid).map_err(invalid)
            }
            ("aprilgrid", 4) => {
                let (c, r) = size(parts[1])?;
                let t = length(parts[2], "tag size")?;
                let sp = length(parts[3], "tag spacing ratio")?;
                AprilGrid::new(c, r, t, sp).map(Self::AprilGrid).map_err(invalid)
            }
            ("marker", 4) => {
                let dict = MarkerDictionary::predefined(parts[1]).map_err(|e| err(&e.to_string()))?;
                let id = parts[2]
                    .parse::<u32>()
                    .map_err(|_| err(&format!("marker id {:?} is not a whole number", parts[2])))?;
                let size = length(parts[3], "marker size")?;
                SingleMarker::new(dict, id, size).map(Self::Marker).map_err(invalid)
            }
            ("chessboard" | "charuco" | "circles" | "acircles" | "aprilgrid" | "marker", n) => {
                Err(err(&format!("{n} fields separated by ':' is the wrong number for {kind}")))
            }
            _ => Err(err(&format!("unknown target kind {:?}", parts[0]))),
        }
    }
}

impl fmt::Display for TargetDescription {
    /// The form [`FromStr`] reads back.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Chessboard(b) => write!(f, "chessboard:{}x{}:{}", b.cols, b.rows, b.square_size),
            Self::Charuco(b) => write!(
                f,
                "charuco:{}x{}:{}:{}:{}{}",
                b.squares_x,
                b.squares_y,
                b.square_length,
                b.marker_length,
                b.dictionary.name(),
                if b.legacy_pattern { ":legacy" } else { "" }
            ),
            Self::CircleGrid(g) => write!(
                f,
                "{}:{}x{}:{}:{}",
                if g.asymmetric { "acircles" } else { "circles" },
                g.cols,
                g.rows,
                g.spacing,
                g.diameter
            ),
            Self::AprilGrid(g) => write!(f, "aprilgrid:{}x{}:{}:{}", g.tag_cols, g.tag_rows, g.tag_size, g.tag_spacing),
            Self::Marker(m) => write!(f, "marker:{}:{}:{}", m.dictionary.name(), m.id, m.size),
        }
    }
}

/// The identified target points of one view: point ids (into the target's numbering) and
/// their image positions, in the same order. Checked: as many ids as points, no id twice,
/// every position finite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TargetObservationRaw")]
pub struct TargetObservation {
    ids: Vec<u32>,
    points: Vec<DVec2>,
}

#[derive(Deserialize)]
struct TargetObservationRaw {
    ids: Vec<u32>,
    points: Vec<DVec2>,
}

impl TryFrom<TargetObservationRaw> for TargetObservation {
    type Error = TargetError;
    fn try_from(r: TargetObservationRaw) -> Result<Self, TargetError> {
        Self::new(r.ids, r.points)
    }
}

impl TargetObservation {
    /// A checked observation.
    pub fn new(ids: Vec<u32>, points: Vec<DVec2>) -> Result<Self, TargetError> {
        if ids.len() != points.len() {
            return Err(TargetError::InvalidObservation(format!("{} ids but {} points", ids.len(), points.len())));
        }
        if let Some(k) = points.iter().position(|p| !p.is_finite()) {
            return Err(TargetError::InvalidObservation(format!("point {k} (id {}) is not finite", ids[k])));
        }
        let mut sorted = ids.clone();
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(TargetError::InvalidObservation(format!("id {} appears twice", w[0])));
        }
        Ok(Self { ids, points })
    }

    /// A whole chessboard / grid view: ids `0..n` in order.
    pub fn whole(points: Vec<DVec2>) -> Result<Self, TargetError> {
        Self::new((0..points.len() as u32).collect(), points)
    }

    /// Point ids.
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }
    /// Image positions, in the order of [`Self::ids`].
    pub fn points(&self) -> &[DVec2] {
        &self.points
    }
    /// Number of points.
    pub fn len(&self) -> usize {
        self.ids.len()
    }
    /// True when no point was seen.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
    /// The image position of point `id`, when seen.
    pub fn get(&self, id: u32) -> Option<DVec2> {
        self.ids.iter().position(|&i| i == id).map(|k| self.points[k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charuco_layout_is_opencvs() {
        // Figures printed by cv2.aruco.CharucoBoard((5, 4), 0.04, 0.03, DICT_4X4_50) (OpenCV 5.0):
        // ids 0..9, first corner (0.04, 0.04), marker 0 corners (0.045, 0.005) .. (0.045, 0.035).
        let d = MarkerDictionary::predefined("DICT_4X4_50").unwrap();
        let b = CharucoBoard::new(5, 4, 0.04, 0.03, d, false).unwrap();
        assert_eq!((b.marker_count(), b.corner_count()), (10, 12));
        assert_eq!(b.marker_square(0), Some((1, 0)));
        let m0 = b.marker_corners(0).unwrap();
        assert!((m0[0] - DVec3::new(0.045, 0.005, 0.0)).length() < 1e-12);
        assert!((m0[2] - DVec3::new(0.075, 0.035, 0.0)).length() < 1e-12);
        assert!((b.corner_point(4).unwrap() - DVec3::new(0.04, 0.08, 0.0)).length() < 1e-12);
        for id in 0..10 {
            let (x, y) = b.marker_square(id).unwrap();
            assert_eq!(b.marker_at(x, y), Some(id));
        }
        // First bits of DICT_4X4_50 marker 0 as getBitsFromByteList gives them: 1011 / 0101 / ...
        assert!(d.bit(0, 0, 0) && !d.bit(0, 0, 1) && d.bit(0, 0, 2) && d.bit(0, 0, 3) && !d.bit(0, 1, 0));
        assert_eq!(d.max_correction_bits(), 1);
        assert!(CharucoBoard::new(20, 20, 1.0, 0.7, d, false).is_err(), "200 markers from a 50-marker dictionary");
    }

    #[test]
    fn targets_beyond_the_point_limit_and_unchecked_records_are_refused() {
        // found by the target_file fuzz target: "acircles:40004x400000000400000:20" parsed, and its
        // point count (1.6e19) no longer fit the u32 point ids
        for s in ["acircles:40004x400000000400000:20", "chessboard:2000x1000:1", "circles:1025x1025:2:1"] {
            let err = s.parse::<TargetDescription>().unwrap_err().to_string();
            assert!(err.contains(&format!("at most {}", crate::MAX_TARGET_POINTS)), "{s}: {err}");
        }
        assert!("chessboard:1024x1024:1".parse::<TargetDescription>().is_ok());
        // a chessboard record is checked when read, as every other target is
        let err = ron::from_str::<TargetDescription>("Chessboard((cols: 0, rows: 0, square_size: -1.0))")
            .unwrap_err()
            .to_string();
        assert!(err.contains("at least 2x2"), "{err}");
        let ok: TargetDescription = ron::from_str("Chessboard((cols: 9, rows: 6, square_size: 25.0))").unwrap();
        assert_eq!(ok, "chessboard:9x6:25".parse().unwrap());
    }

    #[test]
    fn target_descriptions_parse_and_print_back() {
        for s in [
            "chessboard:9x6:25",
            "charuco:7x5:40:30:DICT_5X5_100",
            "circles:4x11:20:10",
            "acircles:4x11:20:10",
            "aprilgrid:6x6:88:0.3",
        ] {
            let t: TargetDescription = s.parse().unwrap();
            assert_eq!(t.to_string(), s);
        }
        let t: TargetDescription = "charuco:5x4:40:30:4x4_50:legacy".parse().unwrap();
        assert_eq!(t.point_count(), 12);
        let TargetDescription::Charuco(b) = t else { panic!() };
        assert!(b.legacy_pattern() && b.square_is_black(1, 0) && !b.square_is_black(0, 0));
        let a: TargetDescription = "acircles:4x11:20".parse().unwrap();
        assert!((a.point(5).unwrap() - DVec3::new(60.0, 20.0, 0.0)).length() < 1e-12);
        for bad in [
            "chessboard:9",
            "charuco:7x5:40:50:DICT_5X5_100",
            "charuco:7x5:40:30:DICT_9X9_1",
            "tiles:3x3",
            "circles:4x11:-2",
        ] {
            let e = bad.parse::<TargetDescription>().unwrap_err().to_string();
            assert!(e.contains("accepted forms") || e.contains("known"), "{bad}: {e}");
        }
    }

    #[test]
    fn aprilgrid_numbering_is_kalibrs() {
        // Kalibr's 2x2 example: tag 3's corners are 10, 11, 15, 14; corner 5 at (size, size).
        let g = AprilGrid::new(2, 2, 1.0, 0.5).unwrap();
        assert_eq!(g.tag_corner_ids(3), Some([10, 11, 15, 14]));
        assert_eq!(g.tag_corner_ids(1), Some([2, 3, 7, 6]));
        assert!((g.point(5).unwrap() - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-12);
        assert!((g.point(15).unwrap() - DVec3::new(2.5, 2.5, 0.0)).length() < 1e-12);
        assert_eq!(g.corner_count(), 16);
    }

    #[test]
    fn observations_are_checked() {
        assert!(TargetObservation::new(vec![1, 2], vec![DVec2::ZERO]).is_err());
        assert!(TargetObservation::new(vec![1, 1], vec![DVec2::ZERO, DVec2::ONE]).is_err());
        assert!(TargetObservation::new(vec![1], vec![DVec2::NAN]).is_err());
        let o = TargetObservation::new(vec![4, 2], vec![DVec2::ZERO, DVec2::ONE]).unwrap();
        assert_eq!(o.get(2), Some(DVec2::ONE));
    }
}
