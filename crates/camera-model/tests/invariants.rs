//! Invariants held by the types themselves: no deserialised value can break them.

use glam::{DQuat, DVec3};
use parallax_camera_model::{DisparityMap, Isometry3};

#[test]
fn a_disparity_map_of_the_wrong_length_cannot_be_deserialised() {
    let ok: DisparityMap = ron::from_str("(width: 2, height: 2, data: [1.0, 2.0, 3.0, 4.0])").unwrap();
    assert_eq!((ok.width(), ok.height(), ok.data().len()), (2, 2, 4));
    let err = ron::from_str::<DisparityMap>("(width: 640, height: 480, data: [1.0, 2.0])").unwrap_err().to_string();
    assert!(err.contains("640x480") && err.contains("307200") && err.contains("got 2"), "{err}");
    // width · height overflowing usize is refused, not wrapped.
    assert!(ron::from_str::<DisparityMap>(&format!("(width: {}, height: 2, data: [])", usize::MAX)).is_err());
    // A map written and read back is the same map.
    let text = ron::to_string(&ok).unwrap();
    assert_eq!(ron::from_str::<DisparityMap>(&text).unwrap(), ok);
}

#[test]
fn a_non_unit_or_non_finite_quaternion_is_refused_and_rounding_is_renormalised() {
    let pose = |q: &str, t: &str| ron::from_str::<Isometry3>(&format!("(rotation: {q}, translation: {t})"));
    // Norm 2: a mistake, not a rotation.
    let err = pose("(0.0, 0.0, 0.0, 2.0)", "(0.0, 0.0, 0.0)").unwrap_err().to_string();
    assert!(err.contains("norm 2") && err.contains("not a rotation"), "{err}");
    assert!(pose("(0.0, 0.0, 0.0, NaN)", "(0.0, 0.0, 0.0)").is_err());
    assert!(pose("(0.0, 0.0, 0.0, 1.0)", "(1e309, 0.0, 0.0)").is_err(), "an infinite translation");
    assert!(pose("(1e308, 1e308, 0.0, 1.0)", "(0.0, 0.0, 0.0)").is_err(), "a huge quaternion");
    // Rounded to four digits (norm 1.0003): accepted, exactly unit afterwards.
    let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let rounded = |v: f64| (v * 1e4).round() / 1e4;
    let text = format!("({}, {}, {}, {})", rounded(q.x), rounded(q.y), rounded(q.z), rounded(q.w));
    let p = pose(&text, "(1.0, 2.0, 3.0)").unwrap();
    assert!((p.rotation().length() - 1.0).abs() < 1e-15);
    assert!(p.rotation().angle_between(q) < 1e-3);
    // Every pose written reads back bit for bit.
    let exact = Isometry3::from_rvec_tvec(DVec3::new(0.1, -0.2, 0.3), DVec3::new(4.0, 5.0, 6.0));
    let back: Isometry3 = ron::from_str(&ron::to_string(&exact).unwrap()).unwrap();
    assert_eq!(back, exact);
    // The checked constructor says the same as deserialisation.
    assert!(Isometry3::new(DQuat::from_xyzw(0.0, 0.0, 0.0, 2.0), DVec3::ZERO).is_err());
    assert!(Isometry3::new(DQuat::IDENTITY, DVec3::ZERO).is_ok());
}

#[test]
fn a_non_finite_translation_is_named_as_the_translation_never_as_the_quaternion() {
    for t in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let err = Isometry3::new(DQuat::IDENTITY, DVec3::new(t, 0.0, 0.0)).unwrap_err().to_string();
        assert!(err.contains("translation") && !err.contains("quaternion"), "{err}");
        let err =
            Isometry3::try_from_rvec_tvec(DVec3::new(0.1, 0.2, 0.3), DVec3::new(0.0, t, 0.0)).unwrap_err().to_string();
        assert!(err.contains("translation") && !err.contains("rotation"), "{err}");
    }
    // Deserialised: the same message.
    for text in [
        "(rotation: (0.0, 0.0, 0.0, 1.0), translation: (NaN, 0.0, 0.0))",
        "(rotation: (0.0, 0.0, 0.0, 1.0), translation: (0.0, inf, 0.0))",
    ] {
        let err = ron::from_str::<Isometry3>(text).unwrap_err().to_string();
        assert!(err.contains("translation") && !err.contains("quaternion"), "{text}: {err}");
    }
}

#[test]
fn huge_but_finite_rotation_vectors_are_refused_by_the_checked_constructor() {
    // |rvec|² overflows: the unchecked constructor would give a NaN quaternion.
    assert!(!Isometry3::from_rvec_tvec(DVec3::new(1e308, 0.0, 0.0), DVec3::ZERO).is_finite());
    for r in [DVec3::new(1e308, 0.0, 0.0), DVec3::new(1e200, 1e200, 0.0), DVec3::new(f64::NAN, 0.0, 0.0)] {
        let err = Isometry3::try_from_rvec_tvec(r, DVec3::ZERO).unwrap_err().to_string();
        assert!(err.contains("rotation vector"), "{r:?}: {err}");
    }
    // Any representable length is accepted and equals the unchecked constructor's.
    let r = DVec3::new(0.3, -2.0, 1.5);
    let t = DVec3::new(1.0, 2.0, 3.0);
    assert_eq!(Isometry3::try_from_rvec_tvec(r, t).unwrap(), Isometry3::from_rvec_tvec(r, t));
    // Huge quaternion components (norm overflowing to infinity) are refused by `new`.
    assert!(Isometry3::new(DQuat::from_xyzw(1e308, 1e308, 0.0, 0.0), DVec3::ZERO).is_err());
}

/// A corner grid read from a file is checked as `CornerGrid::new` checks it: a grid whose
/// corner count is not `cols x rows` (found by the `corners_file` fuzz target, once accepted
/// and passed on to calibration) or with a non-finite corner is refused.
#[test]
fn a_corner_grid_of_the_wrong_length_or_with_a_nan_is_refused_on_reading() {
    use parallax_camera_model::CornerGrid;
    let good =
        CornerGrid::new(2, 2, vec![glam::DVec2::ZERO, glam::DVec2::X, glam::DVec2::Y, glam::DVec2::ONE]).unwrap();
    let text = ron::to_string(&good).unwrap();
    assert_eq!(ron::from_str::<CornerGrid>(&text).unwrap(), good);
    let short = "(cols: 4, rows: 3, corners: [(1.0, 2.0)])";
    let err = ron::from_str::<CornerGrid>(short).unwrap_err().to_string();
    assert!(err.contains("needs 12 corners, got 1"), "{err}");
    let huge = "(cols: 18446744073709551615, rows: 2, corners: [])";
    assert!(ron::from_str::<CornerGrid>(huge).unwrap_err().to_string().contains("corner grid"));
    let nan = ron::from_str::<CornerGrid>("(cols: 1, rows: 1, corners: [(NaN, 0.0)])").unwrap_err().to_string();
    assert!(nan.contains("corner position"), "{nan}");
}
