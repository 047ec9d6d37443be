//! Temporary measurement: mean |dv| of corners rectified with our Bouguet + rectify_points.
use camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use glam::{DMat3, DVec2, DVec3};
use stereo_rectify::{ExtentMethod, RectifyConfig, rectify_points, stereo_rectify};

fn main() {
    let path = std::env::args().nth(1).unwrap();
    let text = std::fs::read_to_string(path).unwrap();
    let (mut cams, mut r, mut t) = (vec![], DMat3::IDENTITY, DVec3::ZERO);
    let (mut l, mut rr) = (vec![], vec![]);
    let mut p1cv = vec![];
    for line in text.lines() {
        let mut it = line.split_whitespace();
        let tag = it.next().unwrap();
        let v: Vec<f64> = it.map(|s| s.parse().unwrap()).collect();
        match tag {
            "K1" | "K2" => cams.push(
                Camera::new(Intrinsics::new(v[0], v[1], v[2], v[3]), Distortion::from_opencv(&v[4..]).unwrap(), 640, 480)
                    .unwrap(),
            ),
            "R" => r = DMat3::from_cols_array(&[v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8]]),
            "T" => t = DVec3::new(v[0], v[1], v[2]),
            "P1" => p1cv = v,
            "C" => {
                l.push(DVec2::new(v[0], v[1]));
                rr.push(DVec2::new(v[2], v[3]));
            }
            _ => {}
        }
    }
    let rig = StereoRig::new(cams[0], cams[1], Isometry3::from_rotation_translation(r, t).unwrap()).unwrap();
    for extents in [ExtentMethod::OpenCv, ExtentMethod::Exact] {
        let rect = stereo_rectify(&rig, &RectifyConfig { alpha: Some(0.0), extents, ..Default::default() }).unwrap();
        let a = rectify_points(&rig.left, rect.r1, &rect.p1, &l).unwrap();
        let b = rectify_points(&rig.right, rect.r2, &rect.p2, &rr).unwrap();
        let dv: Vec<f64> = a.iter().zip(&b).map(|(x, y)| (x.y - y.y).abs()).collect();
        let mean = dv.iter().sum::<f64>() / dv.len() as f64;
        let rms = (dv.iter().map(|d| d * d).sum::<f64>() / dv.len() as f64).sqrt();
        let max = dv.iter().copied().fold(0.0, f64::max);
        println!(
            "{extents:?}: f {:.4} (OpenCV {:.4}) c ({:.4}, {:.4}) (OpenCV {:.4}, {:.4}); {} corners mean |dv| {mean:.5} rms {rms:.5} max {max:.5}",
            rect.focal(), p1cv[0], rect.p1.rows[0][2], rect.p1.rows[1][2], p1cv[2], p1cv[6], dv.len()
        );
    }
}
