//! Files: PLY point clouds, RON and CSV measurement lists, written atomically.

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::distance::Measurement;
use crate::rectified::{PointCloud, PointColors};
use crate::{Result, TriangulationError};

/// PLY encoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum PlyFormat {
    /// Human-readable text; coordinates printed with full `f64` precision.
    Ascii,
    /// `binary_little_endian 1.0`; coordinates as `double` (8 bytes each).
    #[default]
    BinaryLittleEndian,
}

/// Encodes a point cloud as PLY: a `vertex` element with `x y z` (`double`) and, when the
/// cloud has colours, `red green blue` (`uchar`; a grey level is written to all three so every
/// viewer shows it).
pub fn ply_bytes(cloud: &PointCloud, format: PlyFormat) -> Result<Vec<u8>> {
    let n = cloud.points.len();
    let colors: Option<Vec<[u8; 3]>> = match &cloud.colors {
        PointColors::None => None,
        PointColors::Grey(g) => Some(g.iter().map(|&v| [v; 3]).collect()),
        PointColors::Rgb(c) => Some(c.clone()),
    };
    if let Some(c) = &colors
        && c.len() != n
    {
        return Err(TriangulationError::SizeMismatch(format!("{n} points but {} colours", c.len())));
    }
    if let Some(i) = cloud.points.iter().position(|p| !p.is_finite()) {
        return Err(TriangulationError::NonFinite { what: format!("point {i} of the cloud") });
    }
    let mut header = String::from("ply\n");
    header.push_str(match format {
        PlyFormat::Ascii => "format ascii 1.0\n",
        PlyFormat::BinaryLittleEndian => "format binary_little_endian 1.0\n",
    });
    header.push_str("comment written by parallax triangulation\n");
    let _ = writeln!(header, "element vertex {n}");
    header.push_str("property double x\nproperty double y\nproperty double z\n");
    if colors.is_some() {
        header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    header.push_str("end_header\n");
    let mut out = header.into_bytes();
    match format {
        PlyFormat::Ascii => {
            let mut s = String::with_capacity(n * 40);
            for (i, p) in cloud.points.iter().enumerate() {
                let _ = write!(s, "{} {} {}", p.x, p.y, p.z);
                if let Some(c) = &colors {
                    let _ = write!(s, " {} {} {}", c[i][0], c[i][1], c[i][2]);
                }
                s.push('\n');
            }
            out.extend_from_slice(s.as_bytes());
        }
        PlyFormat::BinaryLittleEndian => {
            out.reserve(n * (24 + if colors.is_some() { 3 } else { 0 }));
            for (i, p) in cloud.points.iter().enumerate() {
                for v in [p.x, p.y, p.z] {
                    out.extend_from_slice(&v.to_le_bytes());
                }
                if let Some(c) = &colors {
                    out.extend_from_slice(&c[i]);
                }
            }
        }
    }
    Ok(out)
}

/// Writes a point cloud as PLY to `path` atomically.
pub fn write_ply(path: &Path, cloud: &PointCloud, format: PlyFormat) -> Result<()> {
    write_atomic(path, &ply_bytes(cloud, format)?)
}

impl Measurement {
    /// Pretty RON of the whole measurement (settings, points, distances).
    pub fn to_ron(&self) -> Result<String> {
        ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default())
            .map_err(|e| TriangulationError::Serialization(e.to_string()))
    }

    /// CSV of the points: `index,u_left,v_left,u_right,v_right,x,y,z,sx,sy,sz,reproj_px,parallax_deg,behind_camera,low_parallax`.
    pub fn points_csv(&self) -> String {
        let mut s = String::from(
            "index,u_left,v_left,u_right,v_right,x,y,z,sx,sy,sz,reproj_px,parallax_deg,behind_camera,low_parallax\n",
        );
        for p in &self.points {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                p.index,
                p.left.x,
                p.left.y,
                p.right.x,
                p.right.y,
                p.point.x,
                p.point.y,
                p.point.z,
                p.std_dev.x,
                p.std_dev.y,
                p.std_dev.z,
                p.reprojection_error,
                p.parallax_deg,
                p.behind_camera,
                p.low_parallax
            );
        }
        s
    }

    /// CSV of the distances: `from,to,distance,std_dev`.
    pub fn distances_csv(&self) -> String {
        let mut s = String::from("from,to,distance,std_dev\n");
        for d in &self.distances {
            let _ = writeln!(s, "{},{},{},{}", d.from, d.to, d.distance, d.std_dev);
        }
        s
    }

    /// Writes the measurement to `path` atomically: RON for `*.ron`; for `*.csv` the points to
    /// `path` and the distances to `<stem>_distances.csv` beside it.
    pub fn write(&self, path: &Path) -> Result<()> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("ron") => write_atomic(path, self.to_ron()?.as_bytes()),
            Some("csv") => {
                let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("measurement");
                let dist = path.with_file_name(format!("{stem}_distances.csv"));
                write_atomic(path, self.points_csv().as_bytes())?;
                write_atomic(&dist, self.distances_csv().as_bytes())
            }
            _ => Err(TriangulationError::InvalidParameter(format!(
                "{}: measurement files must end in .ron or .csv",
                path.display()
            ))),
        }
    }
}

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename);
/// creates the parent directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |p: &Path, e: std::io::Error| TriangulationError::Io { path: p.display().to_string(), message: e.to_string() };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let name = path.file_name().ok_or_else(|| TriangulationError::Io {
        path: path.display().to_string(),
        message: "no file name".into(),
    })?;
    let tmp = dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(path, e)
    })
}
