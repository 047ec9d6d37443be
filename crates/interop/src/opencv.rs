//! OpenCV `FileStorage`: YAML (`%YAML:1.0`, `!!opencv-matrix`) and XML (`<opencv_storage>`,
//! `type_id="opencv-matrix"`), read into a generic value tree and written as OpenCV writes them.
//!
//! OpenCV's YAML is YAML 1.0 with a `%YAML:1.0` directive (no space: not valid YAML 1.1/1.2)
//! and the local tag `!!opencv-matrix`; the reader removes both and parses the rest with
//! `serde_yaml_ng`. Matrices become `{rows, cols, dt, data}` maps, which the interpreter reads
//! like ROS `camera_info`'s `{rows, cols, data}`. The XML reader walks `quick-xml` events.
//! Both writers are hand-written: the formats are a few lines each, and OpenCV's own reader
//! insists on its header and layout. Numbers are written as C's `%.16e` (17 significant digits,
//! which round-trips every `f64` exactly; `1.0000000000000000e+00` is also a float for PyYAML).

use std::fmt::Write as _;

use quick_xml::events::Event;
use serde_json::{Map, Value};

use crate::error::{Result, syntax};

/// One entry of a FileStorage document.
#[derive(Debug, Clone, PartialEq)]
pub enum Entry {
    /// An integer.
    Int(i64),
    /// A real number.
    Real(f64),
    /// A string.
    Text(String),
    /// A matrix of doubles (`dt: d`), row-major.
    Matrix {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
        /// `rows · cols` values, row-major.
        data: Vec<f64>,
    },
}

impl Entry {
    /// A matrix from row-major rows.
    pub fn matrix<const C: usize>(rows: &[[f64; C]]) -> Self {
        Self::Matrix { rows: rows.len(), cols: C, data: rows.iter().flatten().copied().collect() }
    }

    /// A column vector (OpenCV writes vectors as `n x 1`; distortion as `1 x n` in the samples).
    pub fn row_vector(values: &[f64]) -> Self {
        Self::Matrix { rows: 1, cols: values.len(), data: values.to_vec() }
    }

    /// A column vector `n x 1`.
    pub fn col_vector(values: &[f64]) -> Self {
        Self::Matrix { rows: values.len(), cols: 1, data: values.to_vec() }
    }
}

/// C's `%.16e`: `6.0000000000000000e+02` (OpenCV's format for doubles; exact round trip).
pub fn c_exp(v: f64) -> String {
    let s = format!("{v:.16e}");
    let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = exponent.parse().unwrap_or(0);
    format!("{mantissa}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

fn check_finite(key: &str, values: &[f64]) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(crate::InteropError::Unsupported(format!("{key}: a value is not finite; refusing to write it")))
    }
}

fn quoted(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

/// The document as OpenCV's YAML.
pub fn to_yaml(entries: &[(String, Entry)]) -> Result<String> {
    let mut out = String::from("%YAML:1.0\n---\n");
    for (key, e) in entries {
        match e {
            Entry::Int(i) => writeln!(out, "{key}: {i}"),
            Entry::Real(v) => {
                check_finite(key, &[*v])?;
                writeln!(out, "{key}: {}", c_exp(*v))
            }
            Entry::Text(s) => writeln!(out, "{key}: {}", quoted(s)),
            Entry::Matrix { rows, cols, data } => {
                check_finite(key, data)?;
                let mut text = String::new();
                for (i, v) in data.iter().enumerate() {
                    if i > 0 {
                        text.push_str(if i % 4 == 0 { ",\n       " } else { ", " });
                    }
                    text.push_str(&c_exp(*v));
                }
                writeln!(out, "{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {text} ]")
            }
        }
        .expect("writing to a String cannot fail");
    }
    Ok(out)
}

/// The document as OpenCV's XML.
pub fn to_xml(entries: &[(String, Entry)]) -> Result<String> {
    let mut out = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
    for (key, e) in entries {
        match e {
            Entry::Int(i) => writeln!(out, "<{key}>{i}</{key}>"),
            Entry::Real(v) => {
                check_finite(key, &[*v])?;
                writeln!(out, "<{key}>{}</{key}>", c_exp(*v))
            }
            Entry::Text(s) => {
                let escaped =
                    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;");
                writeln!(out, "<{key}>\"{escaped}\"</{key}>")
            }
            Entry::Matrix { rows, cols, data } => {
                check_finite(key, data)?;
                let mut text = String::new();
                for (i, v) in data.iter().enumerate() {
                    text.push_str(if i % 4 == 0 { "\n    " } else { " " });
                    text.push_str(&c_exp(*v));
                }
                writeln!(
                    out,
                    "<{key} type_id=\"opencv-matrix\">\n  <rows>{rows}</rows>\n  <cols>{cols}</cols>\n  <dt>d</dt>\n  <data>{text}</data></{key}>"
                )
            }
        }
        .expect("writing to a String cannot fail");
    }
    out.push_str("</opencv_storage>\n");
    Ok(out)
}

/// True when `text` looks like OpenCV's YAML (its directive or its matrix tag).
pub fn is_opencv_yaml(text: &str) -> bool {
    text.trim_start().starts_with("%YAML") || text.contains("!!opencv-matrix")
}

/// True when `text` is an OpenCV XML storage.
pub fn is_opencv_xml(text: &str) -> bool {
    text.contains("<opencv_storage")
}

/// Any YAML (OpenCV's dialect included) as a value tree: the `%YAML:1.0` directive line is
/// dropped and every `!!opencv-…` tag removed (they carry no information the reader needs:
/// a matrix is recognised by its `rows`/`cols`/`data` keys).
pub fn parse_yaml(text: &str, what: &str) -> Result<Value> {
    let mut cleaned = String::with_capacity(text.len());
    for line in text.lines() {
        if line.trim_start().starts_with("%YAML") {
            continue;
        }
        let mut rest = line;
        while let Some(i) = rest.find("!!opencv-") {
            cleaned.push_str(&rest[..i]);
            let tail = &rest[i..];
            let end = tail.find(char::is_whitespace).unwrap_or(tail.len());
            rest = &tail[end..];
        }
        cleaned.push_str(rest);
        cleaned.push('\n');
    }
    let value: serde_yaml_ng::Value = serde_yaml_ng::from_str(&cleaned).map_err(|e| syntax(what, e))?;
    serde_json::to_value(value).map_err(|e| syntax(what, format!("not representable as a value tree: {e}")))
}

/// A scalar of XML text: an integer, a real, or a string (OpenCV quotes some strings).
fn xml_scalar(text: &str) -> Value {
    let t = text.trim();
    if let Ok(i) = t.parse::<i64>() {
        return Value::from(i);
    }
    if let Ok(v) = t.parse::<f64>() {
        return Value::from(v);
    }
    Value::from(t.strip_prefix('"').and_then(|s| s.strip_suffix('"')).unwrap_or(t).to_string())
}

/// An OpenCV XML storage as a value tree: elements with children become maps, leaves become
/// scalars, `<data>` of an `opencv-matrix` becomes an array of numbers.
pub fn parse_xml(text: &str, what: &str) -> Result<Value> {
    let mut reader = quick_xml::Reader::from_str(text);
    // Stack of open elements: (name, children, text).
    let mut stack: Vec<(String, Map<String, Value>, String)> = Vec::new();
    let mut root: Option<Value> = None;
    loop {
        match reader.read_event().map_err(|e| syntax(what, format!("XML: {e}")))? {
            Event::Start(e) => {
                if stack.len() >= crate::MAX_NESTING {
                    return Err(syntax(
                        what,
                        format!("XML nested more than {} levels deep: not a calibration", crate::MAX_NESTING),
                    ));
                }
                let name = e.name().as_ref().to_string();
                stack.push((name, Map::new(), String::new()));
            }
            Event::Empty(e) => {
                let name = e.name().as_ref().to_string();
                if let Some(parent) = stack.last_mut() {
                    insert_unique(&mut parent.1, name, Value::Null, what)?;
                }
            }
            Event::Text(t) => {
                let s = t.xml10_content();
                if let Some(top) = stack.last_mut() {
                    top.2.push_str(&s);
                }
            }
            Event::GeneralRef(r) => {
                let name = r.as_ref().to_string();
                let c = match name.as_str() {
                    "amp" => "&",
                    "lt" => "<",
                    "gt" => ">",
                    "quot" => "\"",
                    "apos" => "'",
                    other => return Err(syntax(what, format!("XML: unknown entity &{other};"))),
                };
                if let Some(top) = stack.last_mut() {
                    top.2.push_str(c);
                }
            }
            Event::End(_) => {
                let (name, children, text) = stack.pop().ok_or_else(|| syntax(what, "XML: unbalanced end tag"))?;
                let value = if !children.is_empty() {
                    Value::Object(children)
                } else if name == "data" {
                    let numbers: std::result::Result<Vec<f64>, _> =
                        text.split_whitespace().map(str::parse::<f64>).collect();
                    match numbers {
                        Ok(n) => Value::from(n),
                        Err(_) => xml_scalar(&text),
                    }
                } else {
                    xml_scalar(&text)
                };
                match stack.last_mut() {
                    Some(parent) => insert_unique(&mut parent.1, name, value, what)?,
                    None => root = Some(value),
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    match root {
        Some(Value::Object(m)) => Ok(Value::Object(m)),
        Some(_) | None => Err(syntax(what, "XML: no <opencv_storage> element with entries")),
    }
}

/// Adds an XML element to its parent's entries; a second element of the same name is refused (a
/// reader keeping either would guess which one the writer meant). OpenCV's anonymous sequence
/// items (`<_>`) are not entries of a map and keep the reader's earlier behaviour.
fn insert_unique(map: &mut Map<String, Value>, name: String, value: Value, what: &str) -> Result<()> {
    if name != "_" && map.contains_key(&name) {
        return Err(syntax(what, format!("XML: <{name}> appears twice in one element: which one is meant?")));
    }
    map.insert(name, value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c_exp_matches_printf_and_round_trips() {
        assert_eq!(c_exp(600.0), "6.0000000000000000e+02");
        assert_eq!(c_exp(-2.5e-1), "-2.5000000000000000e-01");
        assert_eq!(c_exp(-1.5e-7), "-1.4999999999999999e-07"); // printf("%.16e") says the same
        assert_eq!(c_exp(0.0), "0.0000000000000000e+00");
        for v in [0.1, 1.0 / 3.0, -123456.789e-300, f64::MAX, f64::MIN_POSITIVE, 5e-324] {
            assert_eq!(c_exp(v).parse::<f64>().unwrap(), v, "{v}");
        }
    }

    #[test]
    fn yaml_and_xml_writers_read_back() {
        let entries = vec![
            ("image_width".to_string(), Entry::Int(640)),
            ("avg_reprojection_error".to_string(), Entry::Real(0.125)),
            ("method".to_string(), Entry::Text("a \"b\" <c>".into())),
            ("camera_matrix".to_string(), Entry::matrix(&[[600.0, 0.0, 320.5], [0.0, 601.0, 240.25], [0.0, 0.0, 1.0]])),
            ("d".to_string(), Entry::row_vector(&[0.1, -0.2, 1e-3, -2e-4, 0.05])),
        ];
        for (text, tree) in [(to_yaml(&entries).unwrap(), None), (to_xml(&entries).unwrap(), Some(()))] {
            let v = if tree.is_some() { parse_xml(&text, "x").unwrap() } else { parse_yaml(&text, "y").unwrap() };
            assert_eq!(v["image_width"], 640, "{text}");
            assert_eq!(v["avg_reprojection_error"], 0.125);
            assert_eq!(v["method"], "a \"b\" <c>", "{text}");
            assert_eq!(v["camera_matrix"]["rows"], 3);
            let data: Vec<f64> = serde_json::from_value(v["camera_matrix"]["data"].clone()).unwrap();
            assert_eq!(data, [600.0, 0.0, 320.5, 0.0, 601.0, 240.25, 0.0, 0.0, 1.0]);
            let d: Vec<f64> = serde_json::from_value(v["d"]["data"].clone()).unwrap();
            assert_eq!(d, [0.1, -0.2, 1e-3, -2e-4, 0.05]);
        }
        assert!(to_yaml(&[("x".into(), Entry::Real(f64::NAN))]).is_err());
    }
}
