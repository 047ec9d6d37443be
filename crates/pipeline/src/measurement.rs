//! Measurement inputs: the pixel pairs a user gives as text (`measure --points`). Blob targets
//! found in the images are matched by [`crate::match_blobs`]; the triangulation is
//! [`crate::measure`].

use glam::DVec2;

use crate::{PipelineError, Result};

fn refuse(message: String) -> PipelineError {
    PipelineError::Input(message)
}

/// Parses `"a,b,...;a,b,...;"` into rows of numbers.
fn parse_rows(text: &str, what: &str) -> Result<Vec<Vec<f64>>> {
    let rows: Vec<Vec<f64>> = text
        .split(';')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .enumerate()
        .map(|(i, row)| {
            row.split(',')
                .map(|t| {
                    let v: f64 =
                        t.trim().parse().map_err(|_| refuse(format!("{what}: point {i}: {t:?} is not a number")))?;
                    if !v.is_finite() {
                        return Err(refuse(format!("{what}: point {i}: {t:?} is not finite")));
                    }
                    Ok(v)
                })
                .collect::<Result<Vec<f64>>>()
        })
        .collect::<Result<_>>()?;
    if rows.is_empty() {
        return Err(refuse(format!("{what}: no points given")));
    }
    Ok(rows)
}

/// Left/right pixel pairs from `points`: `"ul,vl,ur,vr;ul,vl,ur,vr;..."`, or left pixels
/// `"u,v;u,v;..."` with the right ones in `right_points` (the forms of `measure --points` and
/// `--right-points`). Refuses a value that is not a finite number, a point with the wrong
/// number of values, different counts, and an empty list, naming the point.
pub fn parse_pixel_pairs(points: &str, right_points: Option<&str>) -> Result<Vec<(DVec2, DVec2)>> {
    let rows = parse_rows(points, "--points")?;
    match right_points {
        None => rows
            .iter()
            .enumerate()
            .map(|(i, r)| match r.as_slice() {
                [ul, vl, ur, vr] => Ok((DVec2::new(*ul, *vl), DVec2::new(*ur, *vr))),
                [_, _] => {
                    Err(refuse(format!("--points: point {i} has 2 values; give `ul,vl,ur,vr` or add --right-points")))
                }
                _ => Err(refuse(format!("--points: point {i} has {} values, expected 4 (`ul,vl,ur,vr`)", r.len()))),
            })
            .collect(),
        Some(rp) => {
            let right = parse_rows(rp, "--right-points")?;
            if right.len() != rows.len() {
                return Err(refuse(format!("--points has {} points but --right-points {}", rows.len(), right.len())));
            }
            rows.iter()
                .zip(&right)
                .enumerate()
                .map(|(i, (l, r))| {
                    if l.len() != 2 {
                        return Err(refuse(format!("--points: point {i} has {} values, expected `u,v`", l.len())));
                    }
                    if r.len() != 2 {
                        return Err(refuse(format!(
                            "--right-points: point {i} has {} values, expected `u,v`",
                            r.len()
                        )));
                    }
                    Ok((DVec2::new(l[0], l[1]), DVec2::new(r[0], r[1])))
                })
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use parallax_camera_model::StereoRig;
    use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3};
    use parallax_triangulation::{Method, TriangulationConfig, measure_stereo};

    fn rig() -> StereoRig {
        let cam = Camera::new(Intrinsics::new(800.0, 800.0, 640.0, 480.0), Distortion::default(), 1280, 960).unwrap();
        StereoRig::new(cam, cam, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-100.0, 0.0, 0.0))).unwrap()
    }

    #[test]
    fn parses_both_point_forms_and_rejects_bad_ones() {
        let a = parse_pixel_pairs("1,2,3,4; 5,6,7,8;", None).unwrap();
        assert_eq!(a, vec![(DVec2::new(1.0, 2.0), DVec2::new(3.0, 4.0)), (DVec2::new(5.0, 6.0), DVec2::new(7.0, 8.0))]);
        let b = parse_pixel_pairs("1,2;5,6", Some("3,4;7,8")).unwrap();
        assert_eq!(a, b);
        assert!(parse_pixel_pairs("1,2", None).unwrap_err().to_string().contains("--right-points"));
        assert!(parse_pixel_pairs("1,2;3,4", Some("5,6")).is_err());
        assert!(parse_pixel_pairs("1,x,3,4", None).is_err());
        assert!(parse_pixel_pairs("1,NaN,3,4", None).is_err());
        assert!(parse_pixel_pairs("", None).is_err());
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
        let pairs = crate::match_blobs(&rig, &left, &right, false, 2.0).unwrap();
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
        assert!(crate::match_blobs(&rig, &left, &blank, false, 2.0).is_err());
    }

    /// Real data: the project's stereo calibration of `../shared/data/opencv-stereo-chessboard`
    /// (9x6 corners, 30 mm), then every pair's adjacent-corner distances by the optimal method.
    /// The bar: RMS of |distance − 30 mm| ≤ 0.25 mm (OpenCV: 0.47 mm default, 0.24 mm tuned).
    #[test]
    fn real_stereo_chessboard_adjacent_corner_distances() {
        let dir =
            std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/opencv-stereo-chessboard"));
        if !dir.exists() {
            println!("skipped: ../shared not found");
            return;
        }
        let board = parallax_camera_model::Chessboard::new(9, 6, 30.0).unwrap();
        let cfg = parallax_corner_detection::ChessboardConfig::default();
        let (mut left, mut right) = (Vec::new(), Vec::new());
        for k in 1..=14 {
            let l = crate::io::load_gray(&dir.join(format!("left{k:02}.jpg"))).unwrap();
            let r = crate::io::load_gray(&dir.join(format!("right{k:02}.jpg"))).unwrap();
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
