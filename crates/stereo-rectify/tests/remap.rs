//! `remap` against a naive per-pixel reference (f64 arithmetic, explicit border rules), and the
//! `Rectifier` against `remap` with its own maps.

mod common;

use glam::DVec2;
use image::{ImageBuffer, Luma, LumaA, Pixel, Rgb};
use parallax_stereo_rectify::{
    Border, Image, Interpolation, Rectifier, RectifyConfig, RectifyError, RemapTable, Sample, init_undistort_map, remap,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random table: mostly inside, some positions across and far beyond the border, some NaN,
/// some exactly on integer and half-integer positions.
fn random_table(w: u32, h: u32, src_w: u32, src_h: u32, seed: u64) -> RemapTable {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = (w * h) as usize;
    let mut map_x = Vec::with_capacity(n);
    let mut map_y = Vec::with_capacity(n);
    for _ in 0..n {
        let kind = rng.random_range(0..20);
        let (x, y) = match kind {
            0 => (f32::NAN, 3.0),
            1 => (rng.random_range(-1e6..1e6), rng.random_range(-1e6..1e6)),
            2 => (rng.random_range(0..src_w) as f32, rng.random_range(0..src_h) as f32),
            3 => (rng.random_range(0..src_w) as f32 + 0.5, rng.random_range(0..src_h) as f32 + 0.5),
            _ => (rng.random_range(-2.0..src_w as f32 + 1.0), rng.random_range(-2.0..src_h as f32 + 1.0)),
        };
        map_x.push(x);
        map_y.push(y);
    }
    RemapTable { width: w, height: h, map_x, map_y }
}

/// The reference: OpenCV's rules written out per pixel in f64.
fn naive<P: Pixel>(src: &Image<P>, table: &RemapTable, interp: Interpolation, border: Border<P>) -> Vec<Vec<f64>>
where
    P::Subpixel: Sample,
{
    let (sw, sh) = (src.width() as i64, src.height() as i64);
    let c = P::CHANNEL_COUNT as usize;
    let fetch = |x: i64, y: i64, ch: usize| -> f64 {
        match border {
            _ if x >= 0 && y >= 0 && x < sw && y < sh => {
                src.get_pixel(x as u32, y as u32).channels()[ch].to_f32() as f64
            }
            Border::Replicate => {
                src.get_pixel(x.clamp(0, sw - 1) as u32, y.clamp(0, sh - 1) as u32).channels()[ch].to_f32() as f64
            }
            Border::Constant(p) => p.channels()[ch].to_f32() as f64,
        }
    };
    let mut out = Vec::new();
    for i in 0..table.map_x.len() {
        let (x, y) = (table.map_x[i] as f64, table.map_y[i] as f64);
        let mut px = vec![0.0; c];
        for ch in 0..c {
            px[ch] = if !(x.is_finite() && y.is_finite()) {
                match border {
                    Border::Constant(p) => p.channels()[ch].to_f32() as f64,
                    Border::Replicate => 0.0,
                }
            } else {
                let (x, y) = (x.clamp(-3.0, sw as f64 + 2.0), y.clamp(-3.0, sh as f64 + 2.0));
                match interp {
                    Interpolation::Nearest => fetch(x.round_ties_even() as i64, y.round_ties_even() as i64, ch),
                    Interpolation::Bilinear => {
                        let (x0, y0) = (x.floor(), y.floor());
                        let (a, b) = (x - x0, y - y0);
                        let (x0, y0) = (x0 as i64, y0 as i64);
                        (1.0 - a) * (1.0 - b) * fetch(x0, y0, ch)
                            + a * (1.0 - b) * fetch(x0 + 1, y0, ch)
                            + (1.0 - a) * b * fetch(x0, y0 + 1, ch)
                            + a * b * fetch(x0 + 1, y0 + 1, ch)
                    }
                }
            };
        }
        out.push(px);
    }
    out
}

/// Largest difference between `remap` and the reference, in grey levels.
fn worst_difference<P>(src: &Image<P>, table: &RemapTable, interp: Interpolation, border: Border<P>) -> f64
where
    P: Pixel + Send + Sync,
    P::Subpixel: Sample,
{
    let fast = remap(src, table, interp, border).unwrap();
    assert_eq!(fast.dimensions(), (table.width, table.height));
    let slow = naive(src, table, interp, border);
    let mut worst = 0.0f64;
    for (i, (px, reference)) in fast.pixels().zip(&slow).enumerate() {
        for (ch, &v) in px.channels().iter().enumerate() {
            let d = (v.to_f32() as f64 - reference[ch]).abs();
            assert!(d <= 0.51, "pixel {i} channel {ch}: {} vs reference {}", v.to_f32(), reference[ch]);
            worst = worst.max(d);
        }
    }
    worst
}

#[test]
fn remap_matches_naive_reference_for_all_pixel_types() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (sw, sh) = (37, 23);
    let gray8: Image<Luma<u8>> = ImageBuffer::from_fn(sw, sh, |_, _| Luma([rng.random()]));
    let gray16: Image<Luma<u16>> = ImageBuffer::from_fn(sw, sh, |_, _| Luma([rng.random()]));
    let rgb: Image<Rgb<u8>> = ImageBuffer::from_fn(sw, sh, |_, _| Rgb([rng.random(), rng.random(), rng.random()]));
    let table = random_table(53, 31, sw, sh, 5);
    for interp in [Interpolation::Bilinear, Interpolation::Nearest] {
        // rounding of an exact .5 can go either way between f32 and f64: ≤ 0.5 + ε everywhere,
        // and exact for nearest.
        let w8 = worst_difference(&gray8, &table, interp, Border::Constant(Luma([17]))).max(worst_difference(
            &gray8,
            &table,
            interp,
            Border::Replicate,
        ));
        let w16 = worst_difference(&gray16, &table, interp, Border::Constant(Luma([40000]))).max(worst_difference(
            &gray16,
            &table,
            interp,
            Border::Replicate,
        ));
        let wrgb = worst_difference(&rgb, &table, interp, Border::Constant(Rgb([1, 2, 3]))).max(worst_difference(
            &rgb,
            &table,
            interp,
            Border::Replicate,
        ));
        println!("{interp:?}: worst |fast - naive| u8 {w8:.3}, u16 {w16:.3}, rgb {wrgb:.3}");
        if interp == Interpolation::Nearest {
            assert_eq!(w8.max(w16).max(wrgb), 0.0);
        }
    }
}

#[test]
fn identity_map_reproduces_the_image_and_undistort_map_inverts_distortion() {
    let rig = common::horizontal_rig();
    let cam = rig.left;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let src: Image<Luma<u16>> = ImageBuffer::from_fn(64, 48, |_, _| Luma([rng.random()]));
    let identity = RemapTable::from_fn(64, 48, |u, v| Some(DVec2::new(u as f64, v as f64))).unwrap();
    for interp in [Interpolation::Bilinear, Interpolation::Nearest] {
        assert_eq!(remap(&src, &identity, interp, Border::Replicate).unwrap(), src);
    }
    // Undistort-only map: the source position of each output pixel re-undistorts to it.
    let k = cam.intrinsics.matrix();
    let map = init_undistort_map(&cam, k, cam.width, cam.height).unwrap();
    let mut worst = 0.0f64;
    for v in (0..cam.height).step_by(13) {
        for u in (0..cam.width).step_by(13) {
            let (x, y) = map.source(u, v).unwrap();
            let und = cam.undistort_pixel(DVec2::new(x as f64, y as f64)).unwrap();
            worst = worst.max((und - DVec2::new(u as f64, v as f64)).length());
        }
    }
    assert!(worst < 2e-3, "undistort map round trip {worst} px");
}

#[test]
fn rectifier_rectifies_pairs_with_its_maps() {
    let rig = common::horizontal_rig();
    let rectifier = Rectifier::new(&rig, &RectifyConfig { alpha: Some(0.0), ..Default::default() }).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let left: Image<Rgb<u8>> = ImageBuffer::from_fn(640, 480, |_, _| Rgb([rng.random(), rng.random(), rng.random()]));
    let right: Image<Rgb<u8>> = ImageBuffer::from_fn(640, 480, |u, v| Rgb([(u % 256) as u8, (v % 256) as u8, 9]));
    let (l, r) = rectifier.rectify_pair(&left, &right, Border::Constant(Rgb([0, 0, 0]))).unwrap();
    let border = Border::Constant(Rgb([0, 0, 0]));
    // The rectifier's fixed-point maps (1/256 px) stay within one grey level of the f32 path.
    for (fast, img, map) in [(&l, &left, rectifier.left_map()), (&r, &right, rectifier.right_map())] {
        let exact = remap(img, map, Interpolation::Bilinear, border).unwrap();
        let worst = fast.as_raw().iter().zip(exact.as_raw()).map(|(&a, &b)| (a as i32 - b as i32).abs()).max().unwrap();
        let differing = fast.as_raw().iter().zip(exact.as_raw()).filter(|(a, b)| a != b).count();
        println!("rectifier vs f32 remap: worst {worst} level, {differing} of {} values differ", exact.as_raw().len());
        assert!(worst <= 1, "worst {worst}");
    }
    let nearest = rectifier.clone().with_interpolation(Interpolation::Nearest);
    let (ln, _) = nearest.rectify_pair(&left, &right, border).unwrap();
    assert_eq!(ln, remap(&left, rectifier.left_map(), Interpolation::Nearest, border).unwrap());
    let small: Image<Rgb<u8>> = ImageBuffer::new(320, 240);
    let err = rectifier.rectify_pair(&small, &right, border).unwrap_err();
    assert!(matches!(err, RectifyError::SizeMismatch(ref m) if m.contains("left")), "{err}");
    let empty: Image<Luma<u8>> = ImageBuffer::new(0, 0);
    let table = RemapTable::from_fn(4, 4, |_, _| None).unwrap();
    assert!(matches!(remap(&empty, &table, Interpolation::Bilinear, Border::Replicate), Err(RectifyError::Empty(_))));
    let broken = RemapTable { width: 4, height: 4, map_x: vec![0.0; 3], map_y: vec![0.0; 16] };
    let img: Image<Luma<u8>> = ImageBuffer::new(4, 4);
    assert!(matches!(
        remap(&img, &broken, Interpolation::Bilinear, Border::Replicate),
        Err(RectifyError::SizeMismatch(_))
    ));
}

#[test]
fn vectorised_8_bit_rectification_equals_the_16_bit_scalar_path() {
    // 8-bit grey images take an AVX2 gather path (when the CPU has it); 16-bit images holding the
    // same values take the scalar fixed-point path: same integer arithmetic, so equal outputs
    let rig = common::horizontal_rig();
    let rectifier = Rectifier::new(&rig, &RectifyConfig { alpha: Some(1.0), ..Default::default() }).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let left: Image<Luma<u8>> = ImageBuffer::from_fn(640, 480, |_, _| Luma([rng.random()]));
    let right: Image<Luma<u8>> = ImageBuffer::from_fn(640, 480, |u, v| Luma([((u * 7 + v * 3) % 256) as u8]));
    let wide = |img: &Image<Luma<u8>>| -> Image<Luma<u16>> {
        ImageBuffer::from_fn(img.width(), img.height(), |u, v| Luma([img.get_pixel(u, v)[0] as u16]))
    };
    for border in [Border::Constant(Luma([17u8])), Border::Replicate] {
        let (l8, r8) = rectifier.rectify_pair(&left, &right, border).unwrap();
        let border16 = match border {
            Border::Constant(p) => Border::Constant(Luma([p[0] as u16])),
            Border::Replicate => Border::Replicate,
        };
        let (l16, r16) = rectifier.rectify_pair(&wide(&left), &wide(&right), border16).unwrap();
        for (a, b) in [(&l8, &l16), (&r8, &r16)] {
            let differing = a.as_raw().iter().zip(b.as_raw()).filter(|&(&x, &y)| x as u16 != y).count();
            assert_eq!(differing, 0, "{differing} pixels differ ({border:?})");
        }
        // the nearest-neighbour offsets precomputed by the rectifier give `remap`'s nearest
        let nearest = rectifier.clone().with_interpolation(Interpolation::Nearest);
        let (ln, rn) = nearest.rectify_pair(&left, &right, border).unwrap();
        assert_eq!(ln, remap(&left, rectifier.left_map(), Interpolation::Nearest, border).unwrap());
        assert_eq!(rn, remap(&right, rectifier.right_map(), Interpolation::Nearest, border).unwrap());
    }
}

#[test]
fn rebuilt_rectifier_equals_a_new_one() {
    // `rebuild` reuses the tables (same size) or replaces them (other size): either way the
    // result is the rectifier `new` builds for the new rig, bit for bit, interpolation kept
    let (h, v) = (common::horizontal_rig(), common::vertical_rig());
    let cfg = RectifyConfig { alpha: Some(0.0), ..Default::default() };
    let mut rectifier = Rectifier::new(&h, &cfg).unwrap().with_interpolation(Interpolation::Nearest);
    rectifier.rebuild(&v, &cfg).unwrap();
    assert_eq!(rectifier, Rectifier::new(&v, &cfg).unwrap().with_interpolation(Interpolation::Nearest));
    let smaller = RectifyConfig { alpha: Some(1.0), new_size: Some((500, 300)), ..Default::default() };
    rectifier.rebuild(&h, &smaller).unwrap();
    assert_eq!(rectifier, Rectifier::new(&h, &smaller).unwrap().with_interpolation(Interpolation::Nearest));
    // the f32 maps it had built are rebuilt in place, for the new size
    assert_eq!(rectifier.left_map().map_x.len(), 500 * 300);
    assert_eq!(rectifier.left_map(), Rectifier::new(&h, &smaller).unwrap().left_map());
    assert_eq!(rectifier.right_map(), Rectifier::new(&h, &smaller).unwrap().right_map());
    // the rebuilt rectifier resamples as the new one
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let img: Image<Luma<u8>> = ImageBuffer::from_fn(640, 480, |_, _| Luma([rng.random()]));
    let border = Border::Constant(Luma([0u8]));
    let (l, _) = rectifier.rectify_pair(&img, &img, border).unwrap();
    assert_eq!(l, remap(&img, rectifier.left_map(), Interpolation::Nearest, border).unwrap());
    // a failed rebuild leaves the rectifier as it was
    let before = rectifier.clone();
    let mut broken = *rectifier.rectification();
    broken.width = 0;
    assert!(rectifier.rebuild_from_rectification(&h, broken).is_err());
    assert_eq!(rectifier, before);
}

#[test]
fn border_pixels_of_a_wide_view_resample_as_the_f32_maps() {
    // alpha = 1 keeps every source pixel, so much of the output lies at or beyond the source's
    // edge: those pixels take the exact path from the positions the table keeps for them (the
    // f32 maps are not built for resampling). Two channels, both borders, against `remap` with
    // the f32 maps.
    let rig = common::horizontal_rig();
    let rectifier = Rectifier::new(&rig, &RectifyConfig { alpha: Some(1.0), ..Default::default() }).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let left: Image<LumaA<u8>> = ImageBuffer::from_fn(640, 480, |_, _| LumaA([rng.random(), rng.random()]));
    let right: Image<LumaA<u8>> = ImageBuffer::from_fn(640, 480, |u, v| LumaA([(u % 256) as u8, (v % 256) as u8]));
    let map = rectifier.left_map();
    let outside =
        map.map_x.iter().zip(&map.map_y).filter(|&(&x, &y)| !(x >= 0.0 && y >= 0.0 && x < 639.0 && y < 479.0)).count();
    assert!(outside > 10_000, "only {outside} border pixels: the test would not exercise the border path");
    for border in [Border::Constant(LumaA([40, 200])), Border::Replicate] {
        let (l, r) = rectifier.rectify_pair(&left, &right, border).unwrap();
        for (fast, img, map) in [(&l, &left, rectifier.left_map()), (&r, &right, rectifier.right_map())] {
            let exact = remap(img, map, Interpolation::Bilinear, border).unwrap();
            let worst =
                fast.as_raw().iter().zip(exact.as_raw()).map(|(&a, &b)| (a as i32 - b as i32).abs()).max().unwrap();
            assert!(worst <= 1, "worst {worst} grey levels ({border:?})");
        }
        let nearest = rectifier.clone().with_interpolation(Interpolation::Nearest);
        let (ln, rn) = nearest.rectify_pair(&left, &right, border).unwrap();
        assert_eq!(ln, remap(&left, rectifier.left_map(), Interpolation::Nearest, border).unwrap());
        assert_eq!(rn, remap(&right, rectifier.right_map(), Interpolation::Nearest, border).unwrap());
    }
}
