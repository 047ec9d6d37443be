//! `cargo xtask measure`: triangulate left/right pixel pairs with a stereo calibration and print
//! the 3D points and all pairwise distances with their first-order uncertainty.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail, ensure};
use glam::DVec2;
use parallax_triangulation::{Method, TriangulationConfig, measure_stereo};

/// Triangulation method (see the `triangulation` crate).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum MethodArg {
    /// Minimise the reprojection error through the full camera model (maximum likelihood).
    Optimal,
    /// The linear least-squares form `A X = B`.
    Linear,
    /// The homogeneous DLT by SVD.
    Dlt,
    /// Midpoint of the common perpendicular.
    Midpoint,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Optimal => Method::Optimal,
            MethodArg::Linear => Method::Linear,
            MethodArg::Dlt => Method::Dlt,
            MethodArg::Midpoint => Method::Midpoint,
        }
    }
}

/// Arguments of `cargo xtask measure`.
#[derive(clap::Args)]
pub struct Args {
    /// Stereo calibration, any format (detected from the content: `calibrate` or `rectify` output,
    /// a rig, OpenCV YAML/XML, ROS camera_info left + right, Kalibr); two files are read together.
    #[arg(long, num_args = 1..=2, required = true)]
    calib: Vec<PathBuf>,
    /// Left image (optional: checks the image size against the calibration and that every
    /// point lies inside the image).
    #[arg(long)]
    left: Option<PathBuf>,
    /// Right image (optional, as `--left`).
    #[arg(long)]
    right: Option<PathBuf>,
    /// Raw (distorted) pixel pairs `"ul,vl,ur,vr;ul,vl,ur,vr;..."`, or left pixels `"u,v;u,v;..."`
    /// together with `--right-points`. Without it, dark circular targets are found in both
    /// images by the blob detector and matched along the epipolar lines.
    #[arg(long, allow_hyphen_values = true)]
    points: Option<String>,
    /// Blob mode: bright targets on a dark background instead of dark on bright.
    #[arg(long)]
    bright_blobs: bool,
    /// Blob mode: largest distance of a right blob from the epipolar line of a left blob, pixels.
    #[arg(long, default_value_t = 2.0)]
    max_epipolar_px: f64,
    /// Right pixels `"u,v;u,v;..."` matching `--points` given as left pixels.
    #[arg(long, allow_hyphen_values = true)]
    right_points: Option<String>,
    /// Triangulation method.
    #[arg(long, value_enum, default_value = "optimal")]
    method: MethodArg,
    /// Pixel noise per coordinate used for the uncertainties, pixels.
    #[arg(long, default_value_t = 0.1)]
    pixel_sigma: f64,
    /// Write the measurement to this file (`.ron`, `.json`, or `.csv` for points plus
    /// `<stem>_distances.csv`).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Parses `"a,b,...;a,b,...;"` into rows of `width` numbers each.
fn parse_rows(text: &str, what: &str) -> anyhow::Result<Vec<Vec<f64>>> {
    let rows: Vec<Vec<f64>> = text
        .split(';')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .enumerate()
        .map(|(i, row)| {
            row.split(',')
                .map(|t| {
                    let v: f64 =
                        t.trim().parse().with_context(|| format!("{what}: point {i}: {t:?} is not a number"))?;
                    ensure!(v.is_finite(), "{what}: point {i}: {t:?} is not finite");
                    Ok(v)
                })
                .collect::<anyhow::Result<Vec<f64>>>()
        })
        .collect::<anyhow::Result<_>>()?;
    ensure!(!rows.is_empty(), "{what}: no points given");
    Ok(rows)
}

/// Left/right pixel pairs from `--points` (and `--right-points`).
fn parse_pairs(points: &str, right_points: Option<&str>) -> anyhow::Result<Vec<(DVec2, DVec2)>> {
    let rows = parse_rows(points, "--points")?;
    match right_points {
        None => rows
            .iter()
            .enumerate()
            .map(|(i, r)| match r.as_slice() {
                [ul, vl, ur, vr] => Ok((DVec2::new(*ul, *vl), DVec2::new(*ur, *vr))),
                [_, _] => bail!("--points: point {i} has 2 values; give `ul,vl,ur,vr` or add --right-points"),
                _ => bail!("--points: point {i} has {} values, expected 4 (`ul,vl,ur,vr`)", r.len()),
            })
            .collect(),
        Some(rp) => {
            let right = parse_rows(rp, "--right-points")?;
            ensure!(right.len() == rows.len(), "--points has {} points but --right-points {}", rows.len(), right.len());
            rows.iter()
                .zip(&right)
                .enumerate()
                .map(|(i, (l, r))| {
                    ensure!(l.len() == 2, "--points: point {i} has {} values, expected `u,v`", l.len());
                    ensure!(r.len() == 2, "--right-points: point {i} has {} values, expected `u,v`", r.len());
                    Ok((DVec2::new(l[0], l[1]), DVec2::new(r[0], r[1])))
                })
                .collect()
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(out) = &args.out {
        let csv = out.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let native = out.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron") || e.eq_ignore_ascii_case("json"));
        ensure!(csv || native, "{}: a measurement is written as .ron, .json or .csv", out.display());
        let mut outputs = vec![out.clone()];
        if csv {
            let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            outputs.push(out.with_file_name(format!("{stem}_distances.csv")));
        }
        let inputs: Vec<&PathBuf> = args.calib.iter().chain(&args.left).chain(&args.right).collect();
        parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    }
    let rig = crate::files::read_calibration(&args.calib)?.into_stereo(&args.calib[0].display().to_string())?.rig;
    let mut images = Vec::new();
    for (side, path, cam) in [("left", &args.left, &rig.left), ("right", &args.right, &rig.right)] {
        let Some(path) = path else { continue };
        let img = parallax_composition::io::load_gray(path)?;
        ensure!(
            img.width() == cam.width && img.height() == cam.height,
            "{side} image {} is {}x{} but the calibration's {side} camera is {}x{}",
            path.display(),
            img.width(),
            img.height(),
            cam.width,
            cam.height
        );
        images.push(img);
    }
    let pairs = match (&args.points, images.as_slice()) {
        (Some(points), _) => parse_pairs(points, args.right_points.as_deref())?,
        (None, [left, right]) => {
            let pairs = parallax_composition::match_blobs(&rig, left, right, args.bright_blobs, args.max_epipolar_px)
                .context("blob targets (give --points to measure chosen pixels instead)")?;
            println!("blob targets: {} matched pairs", pairs.len());
            pairs
        }
        (None, _) => bail!("give --points, or both --left and --right images to find blob targets"),
    };
    for (i, (l, r)) in pairs.iter().enumerate() {
        ensure!(rig.left.contains(*l), "point {i}: left pixel ({}, {}) is outside the left image", l.x, l.y);
        ensure!(rig.right.contains(*r), "point {i}: right pixel ({}, {}) is outside the right image", r.x, r.y);
    }
    ensure!(args.pixel_sigma.is_finite() && args.pixel_sigma >= 0.0, "--pixel-sigma must be ≥ 0");
    let config =
        TriangulationConfig { method: args.method.into(), pixel_sigma: args.pixel_sigma, ..Default::default() };
    let m = measure_stereo(&rig, &pairs, &config)?;

    println!(
        "rig: baseline {:.4} (calibration length unit), method {:?}, pixel noise {} px per coordinate",
        rig.baseline(),
        config.method,
        config.pixel_sigma
    );
    println!("points (left camera frame; ± = 1σ from pixel noise):");
    println!(
        "{:>3}  {:>18}  {:>18}  {:>28}  {:>26}  {:>8}  {:>8}  flags",
        "#", "left px", "right px", "X, Y, Z", "σX, σY, σZ", "reproj", "parallax"
    );
    let mut flagged = 0;
    for p in &m.points {
        let mut flags = Vec::new();
        if p.behind_camera {
            flags.push("BEHIND-CAMERA");
        }
        if p.low_parallax {
            flags.push("LOW-PARALLAX");
        }
        flagged += usize::from(!flags.is_empty());
        println!(
            "{:>3}  {:>8.2},{:>8.2}  {:>8.2},{:>8.2}  {:>9.3},{:>9.3},{:>9.3}  {:>8.4},{:>8.4},{:>8.4}  {:>6.3}px  {:>7.3}°  {}",
            p.index,
            p.left.x,
            p.left.y,
            p.right.x,
            p.right.y,
            p.point.x,
            p.point.y,
            p.point.z,
            p.std_dev.map_or(f64::NAN, |s| s.x),
            p.std_dev.map_or(f64::NAN, |s| s.y),
            p.std_dev.map_or(f64::NAN, |s| s.z),
            p.reprojection_error,
            p.parallax_deg,
            flags.join(" ")
        );
    }
    if !m.distances.is_empty() {
        println!("distances:");
        for d in &m.distances {
            match d.std_dev {
                Some(s) => println!("  {:>3} – {:<3} {:>12.4} ± {s:.4}", d.from, d.to, d.distance),
                None => println!(
                    "  {:>3} – {:<3} {:>12.4} ± n/a (no covariance: a point behind a camera?)",
                    d.from, d.to, d.distance
                ),
            }
        }
    }
    if let Some(out) = &args.out {
        if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
            let text = parallax_interop::native_string(&m, parallax_interop::Format::Json)?;
            parallax_composition::io::write_atomic(out, text.as_bytes())?;
        } else {
            m.write(out).with_context(|| format!("writing {}", out.display()))?;
        }
        println!("wrote {}", out.display());
    }
    let worst = m.points.iter().map(|p| p.reprojection_error).fold(0.0, f64::max);
    println!(
        "summary: {} points, {} distances, worst RMS reprojection error {:.3} px, {} flagged",
        m.points.len(),
        m.distances.len(),
        worst,
        flagged
    );
    println!("points: {}", m.points.len());
    println!("distances: {}", m.distances.len());
    for d in &m.distances {
        println!("distance_{}_{}: {:.6}", d.from, d.to, d.distance);
    }
    println!("worst_reprojection_px: {worst:.6}");
    println!("flagged: {flagged}");
    Ok(if flagged == 0 { ExitCode::SUCCESS } else { ExitCode::from(2) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use parallax_camera_model::StereoRig;
    use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3};

    fn rig() -> StereoRig {
        let cam = Camera::new(Intrinsics::new(800.0, 800.0, 640.0, 480.0), Distortion::default(), 1280, 960).unwrap();
        StereoRig::new(cam, cam, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-100.0, 0.0, 0.0))).unwrap()
    }

    #[test]
    fn parses_both_point_forms_and_rejects_bad_ones() {
        let a = parse_pairs("1,2,3,4; 5,6,7,8;", None).unwrap();
        assert_eq!(a, vec![(DVec2::new(1.0, 2.0), DVec2::new(3.0, 4.0)), (DVec2::new(5.0, 6.0), DVec2::new(7.0, 8.0))]);
        let b = parse_pairs("1,2;5,6", Some("3,4;7,8")).unwrap();
        assert_eq!(a, b);
        assert!(parse_pairs("1,2", None).unwrap_err().to_string().contains("--right-points"));
        assert!(parse_pairs("1,2;3,4", Some("5,6")).is_err());
        assert!(parse_pairs("1,x,3,4", None).is_err());
        assert!(parse_pairs("1,NaN,3,4", None).is_err());
        assert!(parse_pairs("", None).is_err());
    }

    #[test]
    fn blob_targets_are_matched_along_epipolar_lines_and_measured() {
        let rig = rig();
        // Four targets at different heights and depths (the thesis's ranging layout).
        let targets = [
            DVec3::new(-80.0, -60.0, 700.0),
            DVec3::new(90.0, -20.0, 650.0),
            DVec3::new(60.0, 70.0, 800.0),
            DVec3::new(-50.0, 110.0, 750.0),
        ];
        let draw = |cam: &parallax_camera_model::Camera, from_left: &Isometry3| {
            let centres: Vec<DVec2> =
                targets.iter().map(|t| cam.project(from_left.transform_point(*t)).unwrap()).collect();
            // Anti-aliased dark discs of radius 6 px (4x4 supersampling) on white.
            image::GrayImage::from_fn(cam.width, cam.height, |x, y| {
                let mut cover = 0.0;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let p = DVec2::new(x as f64 - 0.375 + 0.25 * sx as f64, y as f64 - 0.375 + 0.25 * sy as f64);
                        if centres.iter().any(|c| (p - *c).length() < 6.0) {
                            cover += 1.0 / 16.0;
                        }
                    }
                }
                image::Luma([(230.0 - 200.0 * cover) as u8])
            })
        };
        let left = draw(&rig.left, &Isometry3::IDENTITY);
        let right = draw(&rig.right, &rig.right_from_left);
        let pairs = parallax_composition::match_blobs(&rig, &left, &right, false, 2.0).unwrap();
        assert_eq!(pairs.len(), 4);
        let m = measure_stereo(&rig, &pairs, &TriangulationConfig::default()).unwrap();
        for d in &m.distances {
            // Which targets: match each measured point to the nearest truth.
            let nearest =
                |p: DVec3| targets.iter().min_by(|a, b| (**a - p).length().total_cmp(&(**b - p).length())).unwrap();
            let truth = (*nearest(m.points[d.from].point) - *nearest(m.points[d.to].point)).length();
            assert!((d.distance - truth).abs() < 0.15, "{} vs {truth}", d.distance);
            println!("blob distance {:.4} vs true {truth:.4}", d.distance);
        }
        // A missing target in the right image is reported, not guessed.
        let blank = image::GrayImage::from_pixel(1280, 960, image::Luma([230]));
        assert!(parallax_composition::match_blobs(&rig, &left, &blank, false, 2.0).is_err());
    }

    /// Real data: the project's stereo calibration of `../shared/data/opencv-stereo-chessboard`
    /// (9x6 corners, 30 mm), then every pair's adjacent-corner distances by the optimal method.
    /// The bar: RMS of |distance − 30 mm| ≤ 0.25 mm (OpenCV: 0.47 mm default, 0.24 mm tuned).
    #[test]
    fn real_stereo_chessboard_adjacent_corner_distances() {
        let dir =
            std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/opencv-stereo-chessboard"));
        if !dir.exists() {
            println!("skipped: ../shared not found");
            return;
        }
        let board = parallax_camera_model::Chessboard::new(9, 6, 30.0).unwrap();
        let cfg = parallax_corner_detection::ChessboardConfig::default();
        let (mut left, mut right) = (Vec::new(), Vec::new());
        for k in 1..=14 {
            let l = parallax_composition::io::load_gray(&dir.join(format!("left{k:02}.jpg"))).unwrap();
            let r = parallax_composition::io::load_gray(&dir.join(format!("right{k:02}.jpg"))).unwrap();
            let gl = parallax_corner_detection::find_chessboard(&l, 9, 6, &cfg).unwrap();
            let gr = parallax_corner_detection::find_chessboard(&r, 9, 6, &cfg).unwrap();
            if let (Some(gl), Some(gr)) = (gl, gr) {
                left.push(gl);
                right.push(gr);
            }
        }
        let calib = parallax_planar_calibration::calibrate_stereo_chessboard(
            &board,
            &left,
            &right,
            (640, 480),
            (640, 480),
            &parallax_planar_calibration::StereoConfig::default(),
        )
        .unwrap();
        let tri = TriangulationConfig::default();
        let mut all = Vec::new();
        for (l, r) in left.iter().zip(&right) {
            all.extend(parallax_triangulation::adjacent_corner_distances(&calib.rig, l, r, &tri).unwrap());
        }
        let rms = parallax_triangulation::distance_rms(&all, 30.0).unwrap();
        let mean = all.iter().map(|d| d.distance - 30.0).sum::<f64>() / all.len() as f64;
        println!(
            "real: {} pairs, stereo RMS {:.4} px, baseline {:.3} mm, {} edges: adjacent-corner RMS {rms:.4} mm, mean {mean:+.4} mm",
            left.len(),
            calib.rms_px,
            calib.rig.baseline(),
            all.len()
        );
        assert!(rms <= 0.25, "adjacent-corner distance RMS {rms} mm");
        for method in [Method::Linear, Method::Dlt, Method::Midpoint] {
            let cfg = TriangulationConfig::with_method(method);
            let mut d = Vec::new();
            for (l, r) in left.iter().zip(&right) {
                d.extend(parallax_triangulation::adjacent_corner_distances(&calib.rig, l, r, &cfg).unwrap());
            }
            println!(
                "real, {method:?}: adjacent-corner RMS {:.4} mm",
                parallax_triangulation::distance_rms(&d, 30.0).unwrap()
            );
        }
    }
}
