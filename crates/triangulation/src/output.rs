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

    /// CSV of the points: `index,u_left,v_left,u_right,v_right,x,y,z,sx,sy,sz,reproj_px,parallax_deg,behind_camera,low_parallax,high_reprojection`.
    pub fn points_csv(&self) -> String {
        let mut s = String::from(
            "index,u_left,v_left,u_right,v_right,x,y,z,sx,sy,sz,reproj_px,parallax_deg,behind_camera,low_parallax,high_reprojection\n",
        );
        for p in &self.points {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                p.index,
                p.left.x,
                p.left.y,
                p.right.x,
                p.right.y,
                p.point.x,
                p.point.y,
                p.point.z,
                opt(p.std_dev.map(|s| s.x)),
                opt(p.std_dev.map(|s| s.y)),
                opt(p.std_dev.map(|s| s.z)),
                p.reprojection_error,
                p.parallax_deg,
                p.behind_camera,
                p.low_parallax,
                p.high_reprojection
            );
        }
        s
    }

    /// CSV of the distances: `from,to,distance,std_dev` (an empty `std_dev` where none exists).
    pub fn distances_csv(&self) -> String {
        let mut s = String::from("from,to,distance,std_dev\n");
        for d in &self.distances {
            let _ = writeln!(s, "{},{},{},{}", d.from, d.to, d.distance, opt(d.std_dev));
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
    let io =
        |p: &Path, e: std::io::Error| TriangulationError::Io { path: p.display().to_string(), message: e.to_string() };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let name = path
        .file_name()
        .ok_or_else(|| TriangulationError::Io { path: path.display().to_string(), message: "no file name".into() })?;
    let tmp = dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(path, e)
    })
}

/// A CSV field: the value, or empty where there is none.
fn opt(v: Option<f64>) -> String {
    v.map_or_else(String::new, |v| v.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distance::{MeasuredDistance, MeasuredPoint};
    use crate::point::TriangulationConfig;
    use glam::{DVec2, DVec3};

    fn cloud(colors: PointColors) -> PointCloud {
        PointCloud {
            points: vec![DVec3::new(1.5, -2.25, 1000.125), DVec3::new(-0.1, 0.2, 3.0e-7)],
            pixels: vec![[0, 0], [1, 0]],
            colors,
            ..Default::default()
        }
    }

    fn split_header(bytes: &[u8]) -> (String, &[u8]) {
        let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        (String::from_utf8(bytes[..end].to_vec()).unwrap(), &bytes[end..])
    }

    #[test]
    fn ascii_ply_round_trips_points_and_grey() {
        let c = cloud(PointColors::Grey(vec![7, 200]));
        let bytes = ply_bytes(&c, PlyFormat::Ascii).unwrap();
        let (header, body) = split_header(&bytes);
        assert!(header.starts_with("ply\nformat ascii 1.0\n"));
        assert!(header.contains("element vertex 2\n") && header.contains("property uchar red\n"));
        let lines: Vec<&str> = std::str::from_utf8(body).unwrap().lines().collect();
        assert_eq!(lines.len(), 2);
        for (line, (p, g)) in lines.iter().zip(c.points.iter().zip([7u8, 200])) {
            let v: Vec<f64> = line.split(' ').map(|t| t.parse().unwrap()).collect();
            assert_eq!(DVec3::new(v[0], v[1], v[2]), *p, "full precision");
            assert_eq!(&v[3..], &[g as f64; 3]);
        }
    }

    #[test]
    fn binary_ply_round_trips_points_and_rgb() {
        let c = cloud(PointColors::Rgb(vec![[1, 2, 3], [250, 251, 252]]));
        let bytes = ply_bytes(&c, PlyFormat::BinaryLittleEndian).unwrap();
        let (header, body) = split_header(&bytes);
        assert!(header.contains("format binary_little_endian 1.0\n"));
        assert_eq!(body.len(), 2 * 27);
        for (k, p) in c.points.iter().enumerate() {
            let rec = &body[27 * k..27 * (k + 1)];
            let f = |i: usize| f64::from_le_bytes(rec[8 * i..8 * i + 8].try_into().unwrap());
            assert_eq!(DVec3::new(f(0), f(1), f(2)), *p);
            let PointColors::Rgb(rgb) = &c.colors else { unreachable!() };
            assert_eq!(&rec[24..27], &rgb[k]);
        }
        // No colours: 24 bytes per point and no colour properties.
        let bytes = ply_bytes(&cloud(PointColors::None), PlyFormat::BinaryLittleEndian).unwrap();
        let (header, body) = split_header(&bytes);
        assert!(!header.contains("red") && body.len() == 48);
    }

    #[test]
    fn ply_rejects_inconsistent_clouds() {
        assert!(matches!(
            ply_bytes(&cloud(PointColors::Grey(vec![1])), PlyFormat::Ascii),
            Err(TriangulationError::SizeMismatch(_))
        ));
        let mut c = cloud(PointColors::None);
        c.points[1].y = f64::NAN;
        assert!(matches!(ply_bytes(&c, PlyFormat::Ascii), Err(TriangulationError::NonFinite { .. })));
    }

    fn measurement() -> Measurement {
        let p = |i: usize, x: f64| MeasuredPoint {
            index: i,
            left: DVec2::new(100.0 + x, 50.0),
            right: DVec2::new(60.0 + x, 50.0),
            point: DVec3::new(x, 0.0, 500.0),
            std_dev: Some(DVec3::new(0.01, 0.01, 0.4)),
            reprojection_error: 0.05,
            parallax_deg: 11.4,
            behind_camera: false,
            low_parallax: false,
            high_reprojection: false,
        };
        Measurement {
            config: TriangulationConfig::default(),
            points: vec![p(0, 0.0), p(1, 30.0)],
            distances: vec![MeasuredDistance { from: 0, to: 1, distance: 30.0, std_dev: Some(0.0141) }],
        }
    }

    #[test]
    fn measurement_files_round_trip_and_are_written_atomically() {
        let m = measurement();
        let dir = std::env::temp_dir().join(format!("triangulation-out-{}", std::process::id()));
        let ron_path = dir.join("m.ron");
        m.write(&ron_path).unwrap();
        let back: Measurement = ron::from_str(&std::fs::read_to_string(&ron_path).unwrap()).unwrap();
        assert_eq!(back, m);
        let csv_path = dir.join("m.csv");
        m.write(&csv_path).unwrap();
        let pts = std::fs::read_to_string(&csv_path).unwrap();
        let lines: Vec<&str> = pts.lines().collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0].split(',').count(), lines[2].split(',').count());
        assert!(lines[2].starts_with("1,130,50,90,50,30,0,500,"));
        let d = std::fs::read_to_string(dir.join("m_distances.csv")).unwrap();
        assert_eq!(d, "from,to,distance,std_dev\n0,1,30,0.0141\n");
        assert!(m.write(&dir.join("m.txt")).is_err());
        // Only the three outputs, no temporary file left behind.
        let mut names: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        assert_eq!(names, ["m.csv", "m.ron", "m_distances.csv"]);
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(matches!(write_atomic(Path::new("/proc/no/such/dir/x.ply"), b"x"), Err(TriangulationError::Io { .. })));
    }
}
