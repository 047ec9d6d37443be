//! ViSP's file formats: camera intrinsics XML (`vpXmlParserCamera`) and pose YAML
//! (`vpPoseVector` 6x1: `cPo`, `ePc`, `rPe`; `vpHomogeneousMatrix` 4x4: `eMc`).
//!
//! Parsed by hand: the formats are a few tags and numbers each, and an XML or YAML crate would
//! be the largest dependency of the crate.
//!
//! **Distortion.** ViSP's `perspectiveProjWithDistortion` holds two one-term radial models of
//! the same lens (see `vpMeterPixelConversion` / `vpPixelMeterConversion`):
//!
//! * `kud`, undistorted → distorted, used to project: with normalised coordinates
//!   `x = X/Z`, `y = Y/Z` and `r² = x² + y²`, `u = u0 + px·x·(1 + kud·r²)`,
//!   `v = v0 + py·y·(1 + kud·r²)`. This is OpenCV's Brown–Conrady model with `fx = px`,
//!   `fy = py`, `cx = u0`, `cy = v0`, `k1 = kud` and every other coefficient 0 — exactly.
//! * `kdu`, distorted → undistorted, used to back-project: with `x_d = (u − u0)/px`,
//!   `y_d = (v − v0)/py` (pixel offsets normalised by px and py) and `r_d² = x_d² + y_d²`,
//!   `x = x_d·(1 + kdu·r_d²)`. Its inverse is not a polynomial in `r²`, so it has no exact
//!   Brown–Conrady form; ViSP fits `kud` and `kdu` separately, so they agree only approximately.
//!
//! The conversion therefore takes `kud` (exact) and reports how far `kdu` is from the exact
//! inverse of `kud` at the image corners ([`VispCamera::kdu_gap_px`]); a file with only `kdu`
//! and the Kannala–Brandt model are refused with the reason.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3};
use serde::{Deserialize, Serialize};

use crate::{HandEyeError, Result};

fn parse_err(what: &str, message: String) -> HandEyeError {
    HandEyeError::Parse { what: what.to_string(), message }
}

/// ViSP's projection models (`vpCameraParameters::vpCameraParametersProjType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum VispProjection {
    /// `perspectiveProjWithoutDistortion`: pinhole.
    WithoutDistortion,
    /// `perspectiveProjWithDistortion`: pinhole with the one-term radial `kud` / `kdu` models.
    WithDistortion,
    /// `ProjWithKannalaBrandtDistortion`: fisheye (no counterpart here: refused on conversion).
    KannalaBrandt,
}

impl VispProjection {
    /// ViSP's name of the model (the `<type>` element).
    pub fn visp_name(self) -> &'static str {
        match self {
            VispProjection::WithoutDistortion => "perspectiveProjWithoutDistortion",
            VispProjection::WithDistortion => "perspectiveProjWithDistortion",
            VispProjection::KannalaBrandt => "ProjWithKannalaBrandtDistortion",
        }
    }

    fn from_visp_name(s: &str) -> Option<Self> {
        [VispProjection::WithoutDistortion, VispProjection::WithDistortion, VispProjection::KannalaBrandt]
            .into_iter()
            .find(|p| p.visp_name().eq_ignore_ascii_case(s.trim()))
    }
}

/// One camera model of a ViSP XML file, as written there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VispCamera {
    /// `<name>` of the `<camera>`.
    pub name: Option<String>,
    /// `<image_width>`, `<image_height>` (the image size of the calibration), when given.
    pub image_size: Option<(u32, u32)>,
    /// The projection model.
    pub projection: VispProjection,
    /// Focal lengths in pixels (`px`, `py`) and principal point (`u0`, `v0`).
    pub px: f64,
    /// See `px`.
    pub py: f64,
    /// See `px`.
    pub u0: f64,
    /// See `px`.
    pub v0: f64,
    /// Undistorted → distorted radial coefficient (0 when absent).
    pub kud: f64,
    /// Distorted → undistorted radial coefficient (0 when absent).
    pub kdu: f64,
}

fn strip_comments(xml: &str) -> String {
    let mut out = String::with_capacity(xml.len());
    let mut rest = xml;
    while let Some(start) = rest.find("<!--") {
        out.push_str(&rest[..start]);
        match rest[start..].find("-->") {
            Some(end) => rest = &rest[start + end + 3..],
            None => return out,
        }
    }
    out.push_str(rest);
    out
}

/// Every `<tag>…</tag>` block (non-nested) of `xml`.
fn blocks<'a>(xml: &'a str, tag: &str) -> Vec<&'a str> {
    let (open, close) = (format!("<{tag}>"), format!("</{tag}>"));
    let mut out = Vec::new();
    let mut rest = xml;
    while let Some(s) = rest.find(&open) {
        let body = &rest[s + open.len()..];
        match body.find(&close) {
            Some(e) => {
                out.push(&body[..e]);
                rest = &body[e + close.len()..];
            }
            None => break,
        }
    }
    out
}

fn text<'a>(xml: &'a str, tag: &str) -> Option<&'a str> {
    blocks(xml, tag).into_iter().next().map(str::trim)
}

fn number(xml: &str, tag: &str, what: &str) -> Result<Option<f64>> {
    match text(xml, tag) {
        None => Ok(None),
        Some(t) => {
            let v: f64 = t.parse().map_err(|_| parse_err(what, format!("<{tag}> is not a number: {t:?}")))?;
            if !v.is_finite() {
                return Err(parse_err(what, format!("<{tag}> is not finite")));
            }
            Ok(Some(v))
        }
    }
}

/// Parses a ViSP camera XML (`vpXmlParserCamera`) and picks one model: the `<camera>` named
/// `name` (any, if there is only one), and the model of type `projection` — by default
/// `perspectiveProjWithDistortion` when the camera has it (what ViSP's hand-eye tools read),
/// else its only model. Ambiguities are errors listing what exists.
pub fn parse_camera_xml(
    xml: &str,
    what: &str,
    name: Option<&str>,
    projection: Option<VispProjection>,
) -> Result<VispCamera> {
    let xml = strip_comments(xml);
    let cams = blocks(&xml, "camera");
    if cams.is_empty() {
        return Err(parse_err(what, "no <camera> element (is this a ViSP camera XML?)".into()));
    }
    let names: Vec<String> = cams.iter().map(|c| text(c, "name").unwrap_or("(unnamed)").to_string()).collect();
    let picked: Vec<&str> =
        cams.iter().zip(&names).filter(|(_, n)| name.is_none_or(|want| want == n.as_str())).map(|(c, _)| *c).collect();
    let cam = match picked.as_slice() {
        [one] => *one,
        [] => {
            return Err(parse_err(
                what,
                format!("no camera named {:?}; the file holds {}", name.unwrap_or(""), names.join(", ")),
            ));
        }
        _ => return Err(parse_err(what, format!("several cameras ({}): name the one to use", names.join(", ")))),
    };
    let mut models = Vec::new();
    for m in blocks(cam, "model") {
        let ty = text(m, "type").ok_or_else(|| parse_err(what, "a <model> has no <type>".into()))?;
        let p = VispProjection::from_visp_name(ty)
            .ok_or_else(|| parse_err(what, format!("unknown ViSP projection type {ty:?}")))?;
        models.push((p, m));
    }
    let available: Vec<&str> = models.iter().map(|(p, _)| p.visp_name()).collect();
    let model = match projection {
        Some(want) => models.iter().find(|(p, _)| *p == want).ok_or_else(|| {
            parse_err(what, format!("no {} model; the camera has {}", want.visp_name(), available.join(", ")))
        })?,
        None => match models.iter().find(|(p, _)| *p == VispProjection::WithDistortion) {
            Some(m) => m,
            None if models.len() == 1 => &models[0],
            None if models.is_empty() => return Err(parse_err(what, "the camera has no <model>".into())),
            None => {
                return Err(parse_err(what, format!("several models ({}): choose one", available.join(", "))));
            }
        },
    };
    let (projection, m) = *model;
    let need = |tag: &str| -> Result<f64> {
        number(m, tag, what)?.ok_or_else(|| parse_err(what, format!("{}: no <{tag}>", projection.visp_name())))
    };
    let (px, py, u0, v0) = (need("px")?, need("py")?, need("u0")?, need("v0")?);
    let (kud, kdu) = match projection {
        VispProjection::WithDistortion => (need("kud")?, need("kdu")?),
        _ => (0.0, 0.0),
    };
    let size = match (number(cam, "image_width", what)?, number(cam, "image_height", what)?) {
        (Some(w), Some(h)) if w >= 1.0 && h >= 1.0 && w.fract() == 0.0 && h.fract() == 0.0 => {
            Some((w as u32, h as u32))
        }
        (None, None) => None,
        _ => return Err(parse_err(what, "image_width / image_height must both be positive integers".into())),
    };
    if !(px > 0.0 && py > 0.0) {
        return Err(parse_err(what, format!("px and py must be positive, got {px} and {py}")));
    }
    Ok(VispCamera {
        name: text(cam, "name").map(str::to_string),
        image_size: size,
        projection,
        px,
        py,
        u0,
        v0,
        kud,
        kdu,
    })
}

impl VispCamera {
    /// The intrinsics and distortion in OpenCV's convention (see the module docs): exact for
    /// both perspective models; refused for Kannala–Brandt and for a `kdu` without `kud`.
    pub fn to_opencv(&self) -> Result<(Intrinsics, Distortion)> {
        let intr = Intrinsics::new(self.px, self.py, self.u0, self.v0);
        let dist = match self.projection {
            VispProjection::WithoutDistortion => Distortion::default(),
            VispProjection::WithDistortion => {
                if self.kud == 0.0 && self.kdu != 0.0 {
                    return Err(HandEyeError::InvalidConfig(format!(
                        "ViSP camera {:?}: only kdu = {} (distorted → undistorted) is given; its inverse is not a \
                         polynomial, so it has no exact Brown–Conrady form — calibrate kud as well (ViSP's \
                         projection uses kud)",
                        self.name.as_deref().unwrap_or(""),
                        self.kdu
                    )));
                }
                Distortion::new(self.kud, 0.0, 0.0, 0.0, 0.0)
            }
            VispProjection::KannalaBrandt => {
                return Err(HandEyeError::InvalidConfig(format!(
                    "ViSP camera {:?} uses the Kannala–Brandt fisheye model, which has no counterpart in the \
                     Brown–Conrady model used here: calibrate a perspective model instead",
                    self.name.as_deref().unwrap_or("")
                )));
            }
        };
        Ok((intr, dist))
    }

    /// A [`Camera`] for images of `width` x `height`; refused when the XML gives another image
    /// size (intrinsics are in the pixels of the calibration images).
    pub fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        if let Some((w, h)) = self.image_size
            && (w, h) != (width, height)
        {
            return Err(HandEyeError::InvalidConfig(format!(
                "the ViSP intrinsics are for {w}x{h} images but the images are {width}x{height}: scale the \
                 intrinsics or use the calibration's image size"
            )));
        }
        let (intr, dist) = self.to_opencv()?;
        Camera::new(intr, dist, width, height).map_err(|e| HandEyeError::InvalidConfig(e.to_string()))
    }

    /// Largest pixel distance, over the four corners of a `width` x `height` image, between
    /// ViSP's `kdu` back-projection and the exact inverse of the `kud` model (0 without
    /// distortion): how much ViSP's two fits disagree.
    pub fn kdu_gap_px(&self, width: u32, height: u32) -> f64 {
        if self.projection != VispProjection::WithDistortion {
            return 0.0;
        }
        let mut worst = 0.0f64;
        for (u, v) in [
            (0.0, 0.0),
            (width as f64 - 1.0, 0.0),
            (0.0, height as f64 - 1.0),
            (width as f64 - 1.0, height as f64 - 1.0),
        ] {
            let d = DVec2::new((u - self.u0) / self.px, (v - self.v0) / self.py);
            let by_kdu = d * (1.0 + self.kdu * d.length_squared());
            // Exact inverse of d = x (1 + kud |x|²): fixed point from x = d.
            let mut x = d;
            for _ in 0..100 {
                x = d / (1.0 + self.kud * x.length_squared());
            }
            let gap = (by_kdu - x) * DVec2::new(self.px, self.py);
            worst = worst.max(gap.length());
        }
        worst
    }
}

/// Parses a ViSP YAML array (`rows: R`, `cols: C`, `data:` then `- [a, b, …]` rows or one inline
/// list) into its numbers, row-major.
fn parse_array(text: &str, what: &str) -> Result<(usize, usize, Vec<f64>)> {
    let dim = |key: &str| -> Result<Option<usize>> {
        match text.lines().find_map(|l| l.trim().strip_prefix(key)) {
            None => Ok(None),
            Some(v) => v
                .trim()
                .parse()
                .map(Some)
                .map_err(|_| parse_err(what, format!("`{key}` is not a count: {:?}", v.trim()))),
        }
    };
    let (rows, cols) = (dim("rows:")?, dim("cols:")?);
    let start = text.find("data:").ok_or_else(|| parse_err(what, "no `data:` entry".into()))?;
    let mut nums = Vec::new();
    for tok in text[start + 5..].split(|c: char| c.is_whitespace() || c == ',') {
        let tok = tok.trim_matches(|c: char| c == '[' || c == ']' || c == ',');
        if tok.is_empty() || tok == "-" {
            continue;
        }
        match tok.parse::<f64>() {
            Ok(v) => nums.push(v),
            Err(_) => break, // the next YAML key ends the list
        }
    }
    if nums.iter().any(|v| !v.is_finite()) {
        return Err(parse_err(what, "non-finite number in `data:`".into()));
    }
    let (rows, cols) = match (rows, cols) {
        (Some(r), Some(c)) => (r, c),
        _ if nums.len() == 6 => (6, 1),
        _ if nums.len() == 16 => (4, 4),
        _ => return Err(parse_err(what, format!("`data:` holds {} numbers and no rows/cols", nums.len()))),
    };
    if rows.checked_mul(cols) != Some(nums.len()) {
        return Err(parse_err(what, format!("`data:` holds {} numbers, expected {rows}x{cols}", nums.len())));
    }
    Ok((rows, cols, nums))
}

/// Reads a ViSP pose file: a `vpPoseVector` (6x1 `[tx, ty, tz, θux, θuy, θuz]`, axis × angle in
/// radians — `cPo`, `ePc`, `rPe` files) or a `vpHomogeneousMatrix` (4x4, row-major — `eMc`).
/// The 4x4 form must be a rigid transform (rotation orthonormal to 1e-6, last row `0 0 0 1`).
pub fn parse_pose_yaml(text: &str, what: &str) -> Result<Isometry3> {
    let (rows, cols, v) = parse_array(text, what)?;
    match (rows, cols) {
        (6, 1) | (1, 6) => {
            let (t, r) = (DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]));
            // θu is an angle in radians times a unit axis: beyond 2π it is a mistake (and a huge
            // component like 1e308 would make the rotation NaN).
            if r.abs().max_element() > std::f64::consts::TAU || r.length() > std::f64::consts::TAU {
                return Err(parse_err(
                    what,
                    format!("rotation θu = {r:?} is longer than 2π: not an axis × angle in radians"),
                ));
            }
            if t.abs().max_element() > crate::io::MAX_TRANSLATION {
                return Err(parse_err(
                    what,
                    format!("translation {t:?} is beyond ±{:e}: not a length", crate::io::MAX_TRANSLATION),
                ));
            }
            Isometry3::try_from_rvec_tvec(r, t).map_err(|e| parse_err(what, e.to_string()))
        }
        (4, 4) => {
            let last = [v[12], v[13], v[14], v[15]];
            if last != [0.0, 0.0, 0.0, 1.0] {
                return Err(parse_err(what, format!("last row of the 4x4 matrix is {last:?}, not [0, 0, 0, 1]")));
            }
            let r = DMat3::from_cols(
                DVec3::new(v[0], v[4], v[8]),
                DVec3::new(v[1], v[5], v[9]),
                DVec3::new(v[2], v[6], v[10]),
            );
            let t = DVec3::new(v[3], v[7], v[11]);
            if t.abs().max_element() > crate::io::MAX_TRANSLATION {
                return Err(parse_err(
                    what,
                    format!("translation {t:?} is beyond ±{:e}: not a length", crate::io::MAX_TRANSLATION),
                ));
            }
            Isometry3::from_rotation_translation(r, t).map_err(|e| parse_err(what, format!("4x4 matrix: {e}")))
        }
        (r, c) => Err(parse_err(what, format!("a {r}x{c} array is neither a 6x1 pose vector nor a 4x4 matrix"))),
    }
}

/// `vpPoseVector::saveYAML`'s layout (6x1: translation then θu in radians), full precision —
/// what ViSP writes as `ePc.yaml` and reads back with `vpPoseVector::loadYAML`.
pub fn pose_vector_yaml(t: &Isometry3) -> String {
    let r = t.rvec();
    let v = [t.translation.x, t.translation.y, t.translation.z, r.x, r.y, r.z];
    let mut s = String::from("rows: 6\ncols: 1\ndata:\n");
    for x in v {
        s.push_str(&format!("  - [{x:?}]\n"));
    }
    s
}

/// `vpHomogeneousMatrix` as `vpArray2D::saveYAML` writes it (4x4, row-major) — `eMc.yaml`.
pub fn homogeneous_matrix_yaml(t: &Isometry3) -> String {
    let m = t.rotation_matrix();
    let p = t.translation;
    let mut s = String::from("rows: 4\ncols: 4\ndata:\n");
    for r in 0..3 {
        s.push_str(&format!("  - [{:?}, {:?}, {:?}, {:?}]\n", m.col(0)[r], m.col(1)[r], m.col(2)[r], p[r]));
    }
    s.push_str("  - [0.0, 0.0, 0.0, 1.0]\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO_MODELS: &str = r#"<?xml version="1.0"?>
<root>
  <camera>
    <!--Name of the camera-->
    <name>Camera</name>
    <image_width>640</image_width>
    <image_height>480</image_height>
    <model>
      <type>perspectiveProjWithoutDistortion</type>
      <px>600.5</px> <py>601.25</py> <u0>320.0</u0> <v0>240.5</v0>
    </model>
    <model>
      <!--Projection model type-->
      <type>perspectiveProjWithDistortion</type>
      <px>605.0</px> <py>604.0</py> <u0>321.5</u0> <v0>239.0</v0>
      <kud>0.2</kud>
      <kdu>-0.19</kdu>
    </model>
  </camera>
</root>"#;

    #[test]
    fn kud_is_opencv_k1_exactly() {
        let cam = parse_camera_xml(TWO_MODELS, "cam.xml", None, None).unwrap();
        assert_eq!(cam.projection, VispProjection::WithDistortion);
        assert_eq!((cam.kud, cam.kdu, cam.image_size), (0.2, -0.19, Some((640, 480))));
        let c = cam.camera(640, 480).unwrap();
        // ViSP's vpMeterPixelConversion::convertPointWithDistortion, written out independently.
        for p in [DVec3::new(0.1, -0.05, 0.5), DVec3::new(-0.2, 0.15, 0.45), DVec3::new(0.0, 0.0, 1.0)] {
            let (x, y) = (p.x / p.z, p.y / p.z);
            let k = 1.0 + 0.2 * (x * x + y * y);
            let visp = DVec2::new(321.5 + 605.0 * x * k, 239.0 + 604.0 * y * k);
            let ours = c.project(p).unwrap();
            assert!((ours - visp).length() < 1e-12, "{ours} vs {visp}");
        }
        // The same camera with the distortion given explicitly (as a RON camera would).
        let explicit = Camera::new(
            Intrinsics::new(605.0, 604.0, 321.5, 239.0),
            Distortion::new(0.2, 0.0, 0.0, 0.0, 0.0),
            640,
            480,
        )
        .unwrap();
        assert_eq!(c, explicit);
        // kdu ≈ −kud to first order; the fits differ at the corners by this much.
        let gap = cam.kdu_gap_px(640, 480);
        assert!(gap > 0.1 && gap < 20.0, "{gap}");
        // The undistorted model on request.
        let plain = parse_camera_xml(TWO_MODELS, "cam.xml", None, Some(VispProjection::WithoutDistortion)).unwrap();
        assert_eq!(plain.camera(640, 480).unwrap().distortion().copied().unwrap(), Distortion::default());
        assert_eq!(plain.px, 600.5);
    }

    #[test]
    fn ambiguities_and_unsupported_models_are_refused() {
        let e = parse_camera_xml(TWO_MODELS, "cam.xml", Some("Other"), None).unwrap_err();
        assert!(e.to_string().contains("no camera named \"Other\"") && e.to_string().contains("Camera"), "{e}");
        let cam = parse_camera_xml(TWO_MODELS, "cam.xml", None, None).unwrap();
        let e = cam.camera(1280, 960).unwrap_err();
        assert!(e.to_string().contains("640x480") && e.to_string().contains("1280x960"), "{e}");
        let kdu_only = VispCamera { kud: 0.0, ..cam.clone() };
        assert!(kdu_only.to_opencv().unwrap_err().to_string().contains("only kdu"));
        let kb = "<camera><model><type>ProjWithKannalaBrandtDistortion</type><px>1</px><py>1</py><u0>0</u0><v0>0</v0></model></camera>";
        let kb = parse_camera_xml(kb, "kb.xml", None, None).unwrap();
        assert!(kb.to_opencv().unwrap_err().to_string().contains("Kannala–Brandt"));
        let missing = "<camera><model><type>perspectiveProjWithDistortion</type><px>1</px><py>1</py><u0>0</u0><v0>0</v0></model></camera>";
        assert!(parse_camera_xml(missing, "m.xml", None, None).unwrap_err().to_string().contains("no <kud>"));
        assert!(parse_camera_xml("<root/>", "x.xml", None, None).is_err());
    }

    #[test]
    fn pose_yaml_round_trips_in_both_layouts() {
        let t = Isometry3::from_rvec_tvec(
            DVec3::new(0.0017835, 0.0091737, 1.5817824),
            DVec3::new(0.0577152, -0.0339249, -0.0422769),
        );
        let v = pose_vector_yaml(&t);
        assert!(v.starts_with("rows: 6\ncols: 1\ndata:\n  - [0.0577152]\n"), "{v}");
        let back = parse_pose_yaml(&v, "ePc.yaml").unwrap();
        assert!(back.distance(&t).0 < 1e-15 && back.distance(&t).1 < 1e-17);
        let m = homogeneous_matrix_yaml(&t);
        assert!(m.starts_with("rows: 4\ncols: 4\ndata:\n  - ["), "{m}");
        let back = parse_pose_yaml(&m, "eMc.yaml").unwrap();
        assert!(back.distance(&t).0 < 1e-12 && back.distance(&t).1 < 1e-17);
        // The matrix rows are R's rows: row 0 · e_x = R[0][0].
        let first: Vec<f64> = m
            .lines()
            .nth(3)
            .unwrap()
            .trim_start_matches("  - [")
            .trim_end_matches(']')
            .split(", ")
            .map(|s| s.parse().unwrap())
            .collect();
        assert_eq!(first[0], t.rotation_matrix().col(0)[0]);
        assert_eq!(first[1], t.rotation_matrix().col(1)[0]);
        assert_eq!(first[3], t.translation.x);
        let bad = "rows: 4\ncols: 4\ndata:\n  - [2, 0, 0, 0]\n  - [0, 1, 0, 0]\n  - [0, 0, 1, 0]\n  - [0, 0, 0, 1]\n";
        assert!(parse_pose_yaml(bad, "bad.yaml").is_err());
        assert!(
            parse_pose_yaml("rows: 3\ncols: 1\ndata: [1, 2, 3]\n", "v3.yaml").unwrap_err().to_string().contains("3x1")
        );
    }
}
