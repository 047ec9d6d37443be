//! The rig fixtures of `tests/data/rig/` (made by OpenCV, `make_rig.py`): cameras, truth and
//! per-frame views, read into this crate's types. Shared by `tests/rig_opencv.rs` and the
//! `rig_solve` example (`#[path]`).
#![allow(dead_code)]

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, DoubleSphere, Intrinsics, Isometry3, KannalaBrandt, Lens};
use parallax_planar_calibration::{CalibrationConfig, CameraView, RigConfig};
use serde::Deserialize;

#[derive(Deserialize)]
pub struct Board {
    pub cols: usize,
    pub rows: usize,
    pub square: f64,
}

#[derive(Deserialize)]
pub struct JsonCamera {
    pub lens: String,
    pub width: u32,
    pub height: u32,
    #[serde(rename = "K")]
    pub k: [[f64; 3]; 3],
    #[serde(rename = "D")]
    pub d: Vec<f64>,
    #[serde(rename = "R")]
    pub r: [[f64; 3]; 3],
    pub t: [f64; 3],
}

#[derive(Deserialize)]
pub struct JsonFrame {
    #[serde(rename = "R")]
    pub r: [[f64; 3]; 3],
    pub t: [f64; 3],
    pub views: Vec<Option<Vec<[f64; 2]>>>,
}

#[derive(Deserialize)]
pub struct RigSet {
    pub board: Board,
    pub noise_px: f64,
    pub cameras: Vec<JsonCamera>,
    pub frames: Vec<JsonFrame>,
    #[serde(default)]
    pub opencv: serde_json::Value,
}

/// A fixture of `tests/data/rig/` by file name, or a path.
pub fn read(name: &str) -> RigSet {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/rig").join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

pub fn isometry(r: &[[f64; 3]; 3], t: &[f64; 3]) -> Isometry3 {
    // `r` is row-major: glam's column arrays, transposed
    Isometry3::from_rotation_translation(DMat3::from_cols_array_2d(r).transpose(), DVec3::from_array(*t)).unwrap()
}

impl RigSet {
    /// The true cameras.
    pub fn truth(&self) -> Vec<Camera> {
        self.cameras
            .iter()
            .map(|c| {
                let k = Intrinsics::new(c.k[0][0], c.k[1][1], c.k[0][2], c.k[1][2]);
                let lens: Lens = match c.lens.as_str() {
                    "pinhole" => Distortion::new(c.d[0], c.d[1], c.d[2], c.d[3], c.d[4]).into(),
                    "kannala-brandt" => {
                        Lens::KannalaBrandt(KannalaBrandt::new(c.d[0], c.d[1], c.d[2], c.d[3]).unwrap())
                    }
                    "double-sphere" => Lens::DoubleSphere(DoubleSphere::new(c.d[0], c.d[1]).unwrap()),
                    other => panic!("lens {other}"),
                };
                Camera::new(k, lens, c.width, c.height).unwrap()
            })
            .collect()
    }

    /// The true `camI_from_cam0`.
    pub fn extrinsics(&self) -> Vec<Isometry3> {
        self.cameras.iter().map(|c| isometry(&c.r, &c.t)).collect()
    }

    pub fn sizes(&self) -> Vec<(u32, u32)> {
        self.cameras.iter().map(|c| (c.width, c.height)).collect()
    }

    /// `frames[f][c]` for [`parallax_planar_calibration::calibrate_rig`].
    pub fn frames(&self) -> Vec<Vec<Option<CameraView>>> {
        let b = &self.board;
        let object: Vec<DVec3> = (0..b.cols * b.rows)
            .map(|k| DVec3::new((k % b.cols) as f64 * b.square, (k / b.cols) as f64 * b.square, 0.0))
            .collect();
        self.frames
            .iter()
            .map(|f| {
                f.views
                    .iter()
                    .map(|v| {
                        v.as_ref().map(|px| CameraView {
                            object: object.clone(),
                            image: px.iter().map(|p| DVec2::new(p[0], p[1])).collect(),
                        })
                    })
                    .collect()
            })
            .collect()
    }

    /// Every camera with its own lens, OpenCV's default flags otherwise.
    pub fn config(&self) -> RigConfig {
        RigConfig {
            cameras: self
                .truth()
                .iter()
                .map(|c| CalibrationConfig { lens: c.lens_model(), ..CalibrationConfig::default() })
                .collect(),
            ..RigConfig::default()
        }
    }
}
