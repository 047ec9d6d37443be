//! Wrong files are refused with a message that names the mistake, never read as something else.

use parallax_interop::parse;

/// OpenCV's mono keys with `body` appended (a 640x480 camera unless `body` overrides keys).
fn mono(k: &str, d: &str, extra: &str) -> String {
    format!(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {k} ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {d} ]\n{extra}"
    )
}

fn refused(text: &str, needle: &str) {
    let err = parse(text, "f.yml").unwrap_err().to_string();
    assert!(err.contains("f.yml") && err.contains(needle), "expected {needle:?} in: {err}");
}

#[test]
fn a_valid_file_is_read_and_each_mistake_is_named() {
    let k = "600., 0., 320., 0., 600., 240., 0., 0., 1.";
    let d = "-0.1, 0.05, 0., 0., 0.";
    let (c, _) = parse(&mono(k, d, ""), "f.yml").unwrap();
    let cam = c.camera(Default::default(), "f").unwrap();
    assert_eq!(
        (cam.intrinsics.fx, cam.intrinsics.cx, cam.distortion().unwrap().k1, cam.width),
        (600.0, 320.0, -0.1, 640)
    );

    refused(&mono("600., 0., 320., 0., 600., 240., 0., 0.", d, ""), "rows 3 x cols 3 = 9 but data has 8");
    refused(&mono("600., 0., 320., 0., 600., 240., 1e-3, 0., 1.", d, ""), "upper triangular");
    refused(&mono("-600., 0., 320., 0., 600., 240., 0., 0., 1.", d, ""), "f.yml");
    refused(&mono(k, "-0.1, 0.05, 0., 0., 0., 0.1", "").replace("cols: 5", "cols: 6"), "6 distortion coefficients");
    refused(&mono(k, d, "").replace("dt: d", "dt: u"), "dt: u");
    refused(&mono(k, d, "").replace("image_width: 640\n", ""), "no image size");
    refused("%YAML:1.0\n---\nfoo: 1\n", "no calibration found");
    refused("<?xml version=\"1.0\"?>\n<root><camera/></root>\n", "not an OpenCV FileStorage");
    refused("image_width: [\n", "f.yml");
}

#[test]
fn stereo_files_with_missing_or_inconsistent_parts_are_refused() {
    let m = "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 600., 0., 320., 0., 600., 240., 0., 0., 1. ]\n";
    let d = "   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n";
    let r = "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n";
    let t = "   rows: 3\n   cols: 1\n   dt: d\n   data: [ -100., 0., 0. ]\n";
    let base = format!(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nM1: !!opencv-matrix\n{m}D1: !!opencv-matrix\n{d}M2: !!opencv-matrix\n{m}D2: !!opencv-matrix\n{d}R: !!opencv-matrix\n{r}T: !!opencv-matrix\n{t}"
    );
    let s = parse(&base, "f.yml").unwrap().0.into_stereo("f").unwrap();
    assert_eq!(s.rig.baseline(), 100.0);
    // E of another rig (a vertical baseline): refused.
    let e = "E: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 0., 0., 1., 0., 0., 0., -1., 0., 0. ]\n";
    refused(&format!("{base}{e}"), "E does not agree");
    // The same E up to scale and sign is accepted ([T]x R for T = (-100, 0, 0)).
    let e_ok =
        "E: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 0., 0., 0., 0., 0., 1., 0., -1., 0. ]\n";
    assert!(parse(&format!("{base}{e_ok}"), "f.yml").is_ok());
    // Half a rectification.
    refused(&format!("{base}R1: !!opencv-matrix\n{r}"), "rectification incomplete");
    // Not a rotation.
    let bad_r = "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 2., 0., 0., 0., 1., 0., 0., 0., 1. ]\n";
    refused(&base.replace(&format!("R: !!opencv-matrix\n{r}"), &format!("R: !!opencv-matrix\n{bad_r}")), "f.yml");
    // A rotation vector is accepted for R (OpenCV allows both).
    let rvec = "   rows: 3\n   cols: 1\n   dt: d\n   data: [ 0., 0., 0. ]\n";
    let s = parse(&base.replace(&format!("R: !!opencv-matrix\n{r}"), &format!("R: !!opencv-matrix\n{rvec}")), "f.yml")
        .unwrap()
        .0
        .into_stereo("f")
        .unwrap();
    assert_eq!(s.rig.right_from_left.angle(), 0.0);
    // OpenCV's `imageSize` in whole pixels only (640.9 x 480.9 was read as 640 x 480)
    let sized = |size: &str| base.replace("image_width: 640\nimage_height: 480\n", &format!("imageSize: {size}\n"));
    let s = parse(&sized("[ 640, 480 ]"), "f.yml").unwrap().0.into_stereo("f").unwrap();
    assert_eq!((s.rig.left.width, s.rig.left.height), (640, 480));
    refused(&sized("[ 640.9, 480.9 ]"), "whole pixels");
}

/// Stored `R1 R2 P1 P2 Q` that disagree with the file's `M1 D1 M2 D2 R T` (one entry of `Q` ten
/// times too large gave depths ten times too small with exit 0; an `R1` of another rig rectified
/// to images whose rows do not correspond) are refused when read, naming the matrix.
#[test]
fn stored_rectification_matrices_that_disagree_with_the_rig_are_refused() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cv2_stereo.yml");
    let text = std::fs::read_to_string(path).unwrap();
    assert!(parse(&text, "f.yml").is_ok(), "OpenCV's own file is read");
    // Q[3][2] = -1/Tx ten times too large
    let q = text.replacen("0.016664501429767026", "0.16664501429767026", 1);
    assert_ne!(q, text);
    refused(&q, "Q is not the one of P1 and P2");
    // P2's Tx·f of another baseline, with the Q of that P2: only the rig can tell
    let p2 =
        text.replacen("0.016664501429767026", "0.015", 1).replacen("-35938.600306073946", "-39926.590412292997", 1);
    assert_eq!(p2.len(), text.len() - "0.016664501429767026".len() + "0.015".len());
    refused(&p2, "is not this rig's");
    // R1 no longer a rotation (one entry's sign flipped)
    let r1 = text.replacen("-0.0085393088651686978", "0.0085393088651686978", 1);
    assert_ne!(r1, text);
    refused(&r1, "R1 is not a rotation");
}

/// Hostile files (issue 51): nesting bombs of a megabyte are refused by one linear pass before
/// any parser runs (an XML nested 100,000 levels overflowed the stack; a YAML nested 200,000
/// levels parsed for minutes); a repeated XML element is refused, not resolved by keeping the
/// last one; a file larger than a calibration can be is refused before it is read.
#[test]
fn nesting_bombs_duplicate_keys_and_endless_files_are_refused() {
    let n = 1 << 20;
    let bombs = [
        ("json", "[".repeat(n)),
        ("yaml", format!("%YAML:1.0\n---\nM1: {}", "[".repeat(n))),
        ("ron", format!("({}", "(".repeat(n))),
        (
            "json in a string is no bomb, the rest is",
            format!("{{\"a\": \"{}\", \"b\": {}}}", "[".repeat(200), "[".repeat(n)),
        ),
    ];
    for (kind, text) in &bombs {
        let err = parse(text, "f.yml").unwrap_err().to_string();
        assert!(err.contains("nested more than 128 levels"), "{kind}: {err}");
        let err = parallax_interop::parse_target(text, "t.yaml").unwrap_err().to_string();
        assert!(err.contains("nested more than 128 levels"), "{kind} as a target: {err}");
    }
    let xml = format!(
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n{}{}</opencv_storage>\n",
        "<a>".repeat(100_000),
        "</a>".repeat(100_000)
    );
    let err = parse(&xml, "f.xml").unwrap_err().to_string();
    assert!(err.contains("XML nested more than 128 levels"), "{err}");
    // 128 levels of brackets in a string are text, not nesting
    let quoted = format!("%YAML:1.0\n---\nname: \"{}\"\n", "[".repeat(1000));
    let err = parse(&quoted, "f.yml").unwrap_err().to_string();
    assert!(err.contains("no calibration found"), "{err}");

    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cv2_mono.xml");
    let text = std::fs::read_to_string(path).unwrap();
    assert!(parse(&text, "f.xml").is_ok());
    let twice = text.replacen("<image_width>", "<image_width>2000</image_width>\n<image_width>", 1);
    let err = parse(&twice, "f.xml").unwrap_err().to_string();
    assert!(err.contains("<image_width> appears twice"), "{err}");

    // a sparse file of 65 MiB: refused by its size, unread
    let dir = std::env::temp_dir().join(format!("parallax-interop-large-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let large = dir.join("calib.yml");
    std::fs::File::create(&large).unwrap().set_len(parallax_interop::MAX_TEXT_BYTES + 1).unwrap();
    let err = parallax_interop::read(&[&large]).unwrap_err().to_string();
    assert!(err.contains("67108865 bytes, more than the 67108864 bytes"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
    // an endless device: refused once the limit has been read
    let zero = std::path::Path::new("/dev/zero");
    if zero.exists() {
        let err = parallax_interop::read(&[zero]).unwrap_err().to_string();
        assert!(err.contains("over 67108864 bytes"), "{err}");
    } else {
        println!("skipped the /dev/zero case: no /dev/zero on this system");
    }
}

/// A key given twice in a JSON or RON calibration: the readers kept the last without a word
/// (issue 51; the YAML reader refused already, the XML reader since the last round).
#[test]
fn a_key_given_twice_in_json_or_ron_is_refused_naming_it() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    for (file, key, extra) in [
        ("ours_stereo.json", "\"calibration\"", "\"calibration\": {},\n"),
        ("ours_stereo.ron", "calibration:", "calibration: (),\n"),
    ] {
        let text = std::fs::read_to_string(format!("{dir}/{file}")).unwrap();
        assert!(parse(&text, file).is_ok(), "{file}");
        let i = text.find(key).unwrap();
        let doubled = format!("{}{extra}{}", &text[..i], &text[i..]);
        let err = parse(&doubled, file).unwrap_err().to_string();
        assert!(err.contains(file) && err.contains("\"calibration\" appears twice"), "{file}: {err}");
    }
}
