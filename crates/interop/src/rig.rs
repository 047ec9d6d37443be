//! Two cameras of a rig file as a stereo calibration (`rectify --pair I,J`): a Kalibr camchain
//! of any number of cameras (`T_cn_cnm1` chained), OpenCV FileStorage in
//! `calibrateMultiview`'s terms (`nb_cameras`, `camera_matrix_I`, `R_I`, `T_I`, …, as
//! [`crate::render_rig`] writes), or a rig record (`result.cameras`, `result.cam_from_cam0`).
//! The pair becomes the stereo form of the same format and is read as any stereo file is, with
//! the same checks.

use glam::{DMat3, DVec3};
use parallax_camera_model::Isometry3;
use serde_json::{Map, Value, json};

use crate::error::content;
use crate::interpret::{mat3_of, matrix};
use crate::{Calibration, Result, interpret, mat3, rows3};

fn isometry(r: DMat3, t: DVec3, what: &str) -> Result<Isometry3> {
    Isometry3::from_rotation_translation(r, t).map_err(|e| content(what, format!("a rig extrinsic: {e}")))
}

fn index_check(n: usize, (i, j): (usize, usize), what: &str) -> Result<()> {
    if i >= n || j >= n || i == j {
        return Err(content(
            what,
            format!("--pair {i},{j}: the rig has {n} cameras (0..{}); give two different indices", n.saturating_sub(1)),
        ));
    }
    Ok(())
}

/// Kalibr: `camK_from_cam0` by chaining `T_cn_cnm1`; the pair as `cam0`, `cam1`.
fn kalibr_pair(o: &Map<String, Value>, (i, j): (usize, usize), what: &str) -> Result<Value> {
    let n = (0..).take_while(|k| o.contains_key(&format!("cam{k}"))).count();
    index_check(n, (i, j), what)?;
    let mut from0 = vec![Isometry3::IDENTITY];
    for k in 1..n {
        let cam = o[&format!("cam{k}")].as_object().ok_or_else(|| content(what, format!("cam{k} is not a map")))?;
        let key = format!("cam{k}.T_cn_cnm1");
        let (r, c, d) =
            matrix(cam.get("T_cn_cnm1").ok_or_else(|| content(what, format!("{key} is missing")))?, &key, what)?;
        if (r, c) != (4, 4) || d[12..] != [0.0, 0.0, 0.0, 1.0] {
            return Err(content(what, format!("{key} is not a 4x4 rigid transform")));
        }
        let rot = mat3(&[[d[0], d[1], d[2]], [d[4], d[5], d[6]], [d[8], d[9], d[10]]]);
        let step = isometry(rot, DVec3::new(d[3], d[7], d[11]), what)?;
        from0.push(step * from0[k - 1]);
    }
    let j_from_i = from0[j] * from0[i].inverse();
    let mut left = o[&format!("cam{i}")].as_object().cloned().unwrap_or_default();
    left.remove("T_cn_cnm1");
    let mut right = o[&format!("cam{j}")].as_object().cloned().unwrap_or_default();
    let (r, t) = (j_from_i.rotation_matrix(), j_from_i.translation);
    let m = rows3(&r);
    right.insert(
        "T_cn_cnm1".into(),
        json!([
            [m[0][0], m[0][1], m[0][2], t.x],
            [m[1][0], m[1][1], m[1][2], t.y],
            [m[2][0], m[2][1], m[2][2], t.z],
            [0.0, 0.0, 0.0, 1.0]
        ]),
    );
    Ok(json!({ "cam0": left, "cam1": right }))
}

/// OpenCV multiview: the pair as `stereo_calib.cpp`'s keys (`M1 D1 M2 D2 R T`, sizes,
/// `fisheye_model` when both are Kannala–Brandt).
fn opencv_pair(o: &Map<String, Value>, (i, j): (usize, usize), what: &str) -> Result<Value> {
    let n =
        o.get("nb_cameras").and_then(Value::as_u64).ok_or_else(|| content(what, "nb_cameras is not a count"))? as usize;
    index_check(n, (i, j), what)?;
    let get = |key: String| o.get(&key).cloned().ok_or_else(|| content(what, format!("{key} is missing")));
    let pose = |k: usize| -> Result<Isometry3> {
        let r = mat3_of(&get(format!("R_{k}"))?, &format!("R_{k}"), what)?;
        let (_, _, t) = matrix(&get(format!("T_{k}"))?, &format!("T_{k}"), what)?;
        if t.len() != 3 {
            return Err(content(what, format!("T_{k} has {} values, not 3", t.len())));
        }
        isometry(r, DVec3::new(t[0], t[1], t[2]), what)
    };
    let j_from_i = pose(j)? * pose(i)?.inverse();
    let fisheye = |k: usize| o.get(&format!("fisheye_model_{k}")).and_then(Value::as_i64) == Some(1);
    if fisheye(i) != fisheye(j) {
        return Err(content(
            what,
            format!("cameras {i} and {j} are of different lens families: OpenCV's stereo keys mark both with one"),
        ));
    }
    let r = rows3(&j_from_i.rotation_matrix());
    let t = j_from_i.translation;
    let mut out = json!({
        "image_width": get(format!("image_width_{i}"))?,
        "image_height": get(format!("image_height_{i}"))?,
        "M1": get(format!("camera_matrix_{i}"))?,
        "D1": get(format!("distortion_coefficients_{i}"))?,
        "M2": get(format!("camera_matrix_{j}"))?,
        "D2": get(format!("distortion_coefficients_{j}"))?,
        "R": { "rows": 3, "cols": 3, "data": r.concat() },
        "T": { "rows": 3, "cols": 1, "data": [t.x, t.y, t.z] },
    });
    let size = |k: usize| (o.get(&format!("image_width_{k}")).cloned(), o.get(&format!("image_height_{k}")).cloned());
    if size(i) != size(j) {
        out["right_image_width"] = get(format!("image_width_{j}"))?;
        out["right_image_height"] = get(format!("image_height_{j}"))?;
    }
    if fisheye(i) {
        out["fisheye_model"] = json!(1);
    }
    Ok(out)
}

/// A rig record: the pair as the native stereo shape (`left`, `right`, `right_from_left`).
fn record_pair(result: &Map<String, Value>, (i, j): (usize, usize), what: &str) -> Result<Value> {
    let cameras =
        result.get("cameras").and_then(Value::as_array).ok_or_else(|| content(what, "result.cameras is missing"))?;
    let extr = result
        .get("cam_from_cam0")
        .and_then(Value::as_array)
        .ok_or_else(|| content(what, "result.cam_from_cam0 is missing"))?;
    if extr.len() != cameras.len() {
        return Err(content(what, "result.cameras and result.cam_from_cam0 differ in length"));
    }
    index_check(cameras.len(), (i, j), what)?;
    let pose = |k: usize| -> Result<Isometry3> {
        serde_json::from_value(extr[k].clone()).map_err(|e| content(what, format!("result.cam_from_cam0[{k}]: {e}")))
    };
    let j_from_i = pose(j)? * pose(i)?.inverse();
    Ok(json!({
        "left": cameras[i],
        "right": cameras[j],
        "right_from_left": serde_json::to_value(j_from_i).map_err(|e| content(what, e.to_string()))?,
    }))
}

/// Whether `v` holds a rig of more than two cameras (or any rig file of the forms above).
pub fn is_rig(v: &Value) -> bool {
    let Value::Object(o) = v else { return false };
    o.contains_key("nb_cameras")
        || o.contains_key("cam2")
        || o.get("result").and_then(Value::as_object).is_some_and(|r| r.contains_key("cam_from_cam0"))
}

/// Cameras `i` (left) and `j` (right) of the rig in `v` as a stereo calibration.
pub fn rig_pair(v: &Value, pair: (usize, usize), what: &str) -> Result<Calibration> {
    let Value::Object(o) = v else { return Err(content(what, "not a key-value map")) };
    let stereo = if o.contains_key("nb_cameras") {
        opencv_pair(o, pair, what)?
    } else if o.contains_key("cam0") {
        kalibr_pair(o, pair, what)?
    } else if let Some(result) = o.get("result").and_then(Value::as_object).filter(|r| r.contains_key("cam_from_cam0"))
    {
        record_pair(result, pair, what)?
    } else {
        return Err(content(
            what,
            "--pair reads a rig file (a Kalibr camchain, OpenCV FileStorage with nb_cameras, or a rig record of \
             `calibrate --camera`)",
        ));
    };
    interpret(&stereo, &format!("{what} (cameras {} and {})", pair.0, pair.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Format, RigFile, render_rig};
    use parallax_camera_model::{Camera, Distortion, Intrinsics, KannalaBrandt, Lens};

    /// A rig of four cameras written by `render_rig` (Kalibr: `T_cn_cnm1` chained; OpenCV:
    /// `R_I`, `T_I`) reads back as any pair: `camJ_from_camI` equals the truth's.
    #[test]
    fn every_pair_of_a_written_rig_reads_back() {
        let pinhole = |fx: f64| {
            Camera::new(Intrinsics::new(fx, fx, 320.0, 240.0), Distortion::new(-0.1, 0.01, 0.0, 0.0, 0.0), 640, 480)
                .unwrap()
        };
        let kb = Camera::new(
            Intrinsics::new(300.0, 300.0, 320.0, 240.0),
            Lens::KannalaBrandt(KannalaBrandt::new(0.01, 0.0, 0.0, 0.0).unwrap()),
            640,
            480,
        )
        .unwrap();
        let from0 = [
            Isometry3::IDENTITY,
            Isometry3::from_rvec_tvec(DVec3::new(0.01, 0.02, 0.0), DVec3::new(-0.1, 0.0, 0.0)),
            Isometry3::from_rvec_tvec(DVec3::new(0.0, -0.7, 0.05), DVec3::new(-0.2, 0.01, 0.05)),
            Isometry3::from_rvec_tvec(DVec3::new(0.03, 0.01, 0.02), DVec3::new(0.0, -0.15, 0.0)),
        ];
        let shared = vec![vec![1; 4]; 4];
        for (format, cameras) in [
            (Format::Kalibr, vec![pinhole(500.0), pinhole(510.0), kb, pinhole(520.0)]),
            (Format::OpenCvYaml, vec![pinhole(500.0), pinhole(510.0), pinhole(490.0), pinhole(520.0)]),
        ] {
            // Kalibr's radtan has no k3: these cameras have none.
            let file = RigFile { cameras: &cameras, cam_from_cam0: &from0, shared_frames: &shared, rms_px: 0.1 };
            let (_, text) = render_rig(&file, format, std::path::Path::new("rig.yaml")).unwrap().remove(0);
            let (_, v) = crate::detect(&text, "rig").unwrap();
            for (i, j) in [(0, 1), (1, 3), (3, 0), (2, 1)] {
                let mixed = cameras[i].lens_model().is_wide() != cameras[j].lens_model().is_wide();
                let c = match rig_pair(&v, (i, j), "rig") {
                    Err(e) if mixed => {
                        assert!(e.to_string().contains("famil"), "{e}");
                        continue;
                    }
                    other => other.unwrap(),
                };
                let Calibration::Stereo(s) = c else { panic!("not a stereo calibration") };
                let want = from0[j] * from0[i].inverse();
                let (angle, dist) = s.rig.right_from_left.distance(&want);
                assert!(angle < 1e-12 && dist < 1e-12, "{format:?} {i},{j}: {angle} {dist}");
                assert_eq!(s.rig.left, cameras[i]);
                assert_eq!(s.rig.right, cameras[j]);
            }
            assert!(rig_pair(&v, (0, 4), "rig").unwrap_err().to_string().contains("4 cameras"));
        }
    }
}
