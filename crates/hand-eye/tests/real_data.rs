//! ViSP's Franka eye-in-hand set: its robot pose files (skipped when ../shared is absent), and
//! every method on its poses with the camera poses of `data/visp_franka.ron` (found by parallax's
//! corner detection and PnP with `cargo xtask handeye`).

use parallax_hand_eye::io::{RotationFormat, parse_visp_pose};
use parallax_hand_eye::{HandEyeConfig, HandEyeError, HandEyeWarning, Inconsistency, Method, Setup, calibrate};

#[test]
fn visp_franka_robot_poses_are_read() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/visp-franka-eye-in-hand");
    if !std::path::Path::new(dir).is_dir() {
        println!("skipped: ../shared not found ({dir})");
        return;
    }
    let mut poses = Vec::new();
    for k in 1..=8 {
        let path = format!("{dir}/franka_pose_rPe_{k}.yaml");
        let text = std::fs::read_to_string(&path).unwrap();
        poses.push(parse_visp_pose(&text, &path).unwrap());
    }
    // First file: [0.335091, -0.0321497, 0.30857, -3.01226, 0.0236777, -0.451343].
    let p = poses[0];
    assert!((p.translation - glam::DVec3::new(0.335091, -0.0321497, 0.30857)).length() < 1e-12);
    assert!((p.angle() - (3.01226f64.powi(2) + 0.0236777f64.powi(2) + 0.451343f64.powi(2)).sqrt()).abs() < 1e-9);
    // A flange 0.3–0.5 m from the base in every view.
    assert!(poses.iter().all(|p| (0.2..0.7).contains(&p.translation.length())));
}

#[derive(serde::Deserialize)]
struct Franka {
    robot: Vec<String>,
    camera: Vec<parallax_camera_model::Isometry3>,
}

fn franka() -> (Vec<parallax_camera_model::Isometry3>, Vec<parallax_camera_model::Isometry3>) {
    let f: Franka = ron::from_str(include_str!("data/visp_franka.ron")).unwrap();
    let g = parallax_hand_eye::io::parse_pose_lines(&f.robot.join("\n"), RotationFormat::AxisAngle, "robot").unwrap();
    (g, f.camera)
}

/// ViSP's published `gripper_from_camera` for this set (its tutorial): metres and θu radians.
fn visp_result() -> parallax_camera_model::Isometry3 {
    parallax_camera_model::Isometry3::from_rvec_tvec(
        glam::DVec3::new(0.001783530191, 0.009173747947, 1.581782359),
        glam::DVec3::new(0.05771519632, -0.03392488515, -0.04227690244),
    )
}

/// Every method on ViSP's Franka set (camera poses from the fixture: no ../shared needed):
/// within 0.25° / 0.7 mm of ViSP's own result, the same in millimetres as in metres (rotation
/// to 1e-9 rad, translation × 1000 to 1e-6 mm), the refinement converged, and the consistency
/// figures of a correct set — with the 13.5 % robot/camera length disagreement of this set
/// reported as a warning.
#[test]
fn visp_franka_every_method_unit_free_and_near_visp() {
    let (g, c) = franka();
    let mm = |p: &parallax_camera_model::Isometry3| p.with_translation(p.translation * 1000.0);
    let (g_mm, c_mm): (Vec<_>, Vec<_>) = (g.iter().map(mm).collect(), c.iter().map(mm).collect());
    let cfg = HandEyeConfig::default();
    let visp = visp_result();
    for m in Method::ALL {
        let a = calibrate(&g, &c, m, &cfg).unwrap_or_else(|e| panic!("{m}: {e}"));
        let b = calibrate(&g_mm, &c_mm, m, &cfg).unwrap_or_else(|e| panic!("{m} mm: {e}"));
        let (dr, dt) = a.transform.distance(&visp);
        println!("{m:11} vs ViSP {:.3}° / {:.2} mm", dr.to_degrees(), dt * 1e3);
        assert!(dr.to_degrees() < 0.25 && dt < 0.7e-3, "{m}: {}° {} mm", dr.to_degrees(), dt * 1e3);
        assert!(a.transform.distance(&b.transform).0 < 1e-9, "{m}");
        assert!((a.transform.translation * 1000.0 - b.transform.translation).length() < 1e-6, "{m}");
        if let Some(rf) = &a.refinement {
            assert!(rf.converged, "{}", rf.convergence_summary());
        }
        let k = a.consistency;
        assert!(k.angle_mismatch_deg < 0.5 && k.axis_mismatch_deg.unwrap() < 1.0, "{k:?}");
        let ratio = k.scale_ratio.unwrap();
        assert!((1.1..1.2).contains(&ratio) && k.scale_correlation.unwrap() > 0.99, "{k:?}");
        assert!(a.warnings.iter().any(|w| matches!(w, HandEyeWarning::ScaleDisagreement { .. })), "{:?}", a.warnings);
    }
}

/// The wrong inputs of the issue on real data: each refused with its kind.
#[test]
fn visp_franka_wrong_inputs_are_refused() {
    let (g, c) = franka();
    let kind = |g: &[parallax_camera_model::Isometry3], c: &[parallax_camera_model::Isometry3], cfg: &HandEyeConfig| {
        match calibrate(g, c, Method::Park, cfg) {
            Err(HandEyeError::Inconsistent { kind, .. }) => kind,
            other => panic!("expected a refusal, got {other:?}"),
        }
    };
    let d = HandEyeConfig::default();
    let c_mm: Vec<_> = c.iter().map(|p| p.with_translation(p.translation * 1e3)).collect();
    assert_eq!(kind(&g, &c_mm, &d), Inconsistency::UnitMismatch);
    let g_inv: Vec<_> = g.iter().map(|p| p.inverse()).collect();
    assert_eq!(kind(&g_inv, &c, &d), Inconsistency::InvertedPoses);
    let c_inv: Vec<_> = c.iter().map(|p| p.inverse()).collect();
    assert_eq!(kind(&g, &c_inv, &d), Inconsistency::BoardBehindCamera);
    let e2h = HandEyeConfig { setup: Setup::EyeToHand, ..Default::default() };
    assert_eq!(kind(&g, &c, &e2h), Inconsistency::InvertedPoses);
    // The robot rotations as roll-pitch-yaw radians read as axis-angle (degrees are refused by
    // the reader already).
    let rpy: Vec<_> = g
        .iter()
        .map(|p| {
            let m = p.rotation_matrix();
            let (roll, pitch, yaw) = (m.y_axis.z.atan2(m.z_axis.z), (-m.x_axis.z).asin(), m.x_axis.y.atan2(m.x_axis.x));
            parallax_camera_model::Isometry3::from_rvec_tvec(glam::DVec3::new(roll, pitch, yaw), p.translation)
        })
        .collect();
    assert_eq!(kind(&rpy, &c, &d), Inconsistency::RotationMismatch);
}

/// The stations of every subset of `n` stations, as lists of indices.
fn subsets(n: usize, min: usize) -> Vec<Vec<usize>> {
    (0u32..1 << n)
        .filter(|m| m.count_ones() as usize >= min)
        .map(|m| (0..n).filter(|i| m >> i & 1 == 1).collect())
        .collect()
}

fn pick(poses: &[parallax_camera_model::Isometry3], idx: &[usize]) -> Vec<parallax_camera_model::Isometry3> {
    idx.iter().map(|&i| poses[i]).collect()
}

/// Every subset of three or more stations of the real session is correct data: none is refused
/// (5 of the 56 three-station and 3 of the 70 four-station subsets were refused as a unit
/// mismatch, their length ratio 1.20–1.23 against the 1.2 limit, the whole set's 1.13); where the
/// ratio is beyond the limit but within its uncertainty, the solution says so with the figure.
/// The same subsets with the camera in millimetres are all refused as a unit mismatch.
#[test]
fn visp_franka_subsets_are_not_refused_for_units_the_geometry_cannot_tell() {
    let (g, c) = franka();
    let c_mm: Vec<_> = c.iter().map(|p| p.with_translation(p.translation * 1e3)).collect();
    let cfg = HandEyeConfig::default();
    let (mut uncertain, mut total, mut named) = (0, 0, 0);
    for s in subsets(8, 3) {
        let (gs, cs) = (pick(&g, &s), pick(&c, &s));
        let sol = calibrate(&gs, &cs, Method::Park, &cfg).unwrap_or_else(|e| panic!("{s:?}: {e}"));
        total += 1;
        if let Some(HandEyeWarning::ScaleUncertain { ratio, sigma, limit }) =
            sol.warnings.iter().find(|w| matches!(w, HandEyeWarning::ScaleUncertain { .. }))
        {
            uncertain += 1;
            // Beyond the limit, but not by the 3σ a refusal needs.
            let off = ratio.max(1.0 / ratio).ln();
            assert!(off > limit.ln() && off - 3.0 * sigma <= limit.ln(), "{s:?}: {ratio} ± {sigma}");
        }
        match calibrate(&gs, &pick(&c_mm, &s), Method::Park, &cfg) {
            Err(HandEyeError::Inconsistent { kind: Inconsistency::UnitMismatch, message }) => {
                named += usize::from(message.contains("1/1000"))
            }
            other => panic!("{s:?} in millimetres: expected a unit mismatch, got {other:?}"),
        }
    }
    // The factor is named when the ratio is within 15 % of 1/1000: this session's own 13 %
    // disagreement takes some subsets past that.
    println!(
        "{total} subsets of 3–8 stations solved, {uncertain} with the scale uncertain; in millimetres all refused, \
         {named} naming 1/1000"
    );
    assert!(named * 2 > total, "{named}");
    assert_eq!(total, 219);
    assert!(uncertain >= 8, "the subsets refused before carry the warning: {uncertain}");
}

/// Two stations swapped, robot or camera side, every pair of the real session: refused, naming
/// exactly those two stations (robot poses 4 and 6 in ViSP's numbering, 3 and 5 counted from 0,
/// used to give 8 of 9 methods a result 17 cm off with exit 0).
#[test]
fn visp_franka_swapped_stations_are_refused_by_number() {
    let (g, c) = franka();
    for i in 0..8 {
        for j in i + 1..8 {
            for robot_side in [true, false] {
                let (mut g2, mut c2) = (g.clone(), c.clone());
                if robot_side {
                    g2.swap(i, j);
                } else {
                    c2.swap(i, j);
                }
                let methods: &[Method] = if (i, j) == (3, 5) { &Method::ALL } else { &[Method::Park] };
                for &m in methods {
                    match calibrate(&g2, &c2, m, &HandEyeConfig::default()) {
                        Err(HandEyeError::Inconsistent { kind: Inconsistency::MismatchedStations, message }) => {
                            assert!(
                                message.starts_with("2 of 8 stations")
                                    && message.contains(&format!("stations {i} ("))
                                    && message.contains(&format!(", {j} (")),
                                "{i}↔{j} {m}: {message}"
                            );
                        }
                        other => panic!("{i}↔{j} (robot side {robot_side}) {m}: expected a refusal, got {other:?}"),
                    }
                }
            }
        }
    }
}
