//! Stereo scenes: the right image warped by the true disparity must reproduce the left one.

use std::time::Instant;

use parallax_synthetic::*;

/// Catmull–Rom interpolation of row `v` of `img` at column `x`.
fn sample_row(img: &image::GrayImage, x: f64, v: u32) -> f64 {
    let w = img.width() as i64;
    let p = |i: i64| f64::from(img.get_pixel(i.clamp(0, w - 1) as u32, v).0[0]);
    let i = x.floor() as i64;
    let t = x - i as f64;
    let (p0, p1, p2, p3) = (p(i - 1), p(i), p(i + 1), p(i + 2));
    p1 + 0.5 * t * (p2 - p0 + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)))
}

/// Mean |left − warped right| over non-occluded pixels away from depth edges (2 px).
fn warp_error(s: &StereoScene, gain: f64, offset: f64) -> (f64, usize) {
    let (w, h) = (s.disparity.width(), s.disparity.height());
    let mut sum = 0.0;
    let mut count = 0;
    for v in 2..h - 2 {
        for u in 2..w - 2 {
            let d = s.disparity.get(u, v).unwrap();
            let smooth = (v - 2..=v + 2).all(|vv| {
                (u - 2..=u + 2).all(|uu| !s.occluded[vv * w + uu] && (s.disparity.get(uu, vv).unwrap() - d).abs() < 1.5)
            });
            let x = u as f64 - f64::from(d);
            if !smooth || x < 2.0 {
                continue;
            }
            let r = (sample_row(&s.right, x, v as u32) - offset) / gain;
            sum += (f64::from(s.left.get_pixel(u as u32, v as u32).0[0]) - r).abs();
            count += 1;
        }
    }
    (sum / count as f64, count)
}

#[test]
fn warping_right_by_true_disparity_reproduces_left() {
    let t = Instant::now();
    let s = render_stereo_scene(&StereoSceneConfig::default()).unwrap();
    println!("render_stereo_scene 640x480, 4x4 samples: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
    let (mad, n) = warp_error(&s, 1.0, 0.0);
    println!("noise-free warp mean abs diff {mad:.3} grey over {n} pixels");
    assert!(n > 200_000, "too few pixels compared: {n}");
    // Below the noise level of a typical camera (σ = 1 grey level).
    assert!(mad < 1.0, "mean abs diff {mad}");
    // Texture must be rich: mean abs horizontal gradient of the textured surfaces.
    let w = s.disparity.width();
    let (mut g, mut m) = (0.0, 0);
    for (i, px) in s.left.as_raw().iter().enumerate() {
        if i % w + 1 < w && !s.low_texture[i] {
            g += (f64::from(*px) - f64::from(s.left.as_raw()[i + 1])).abs();
            m += 1;
        }
    }
    assert!(g / m as f64 > 4.0, "texture too weak: {}", g / m as f64);

    // A wrong disparity (off by one pixel) is far worse, so the test can fail.
    let mut shifted = s.clone();
    for d in shifted.disparity.data_mut().iter_mut() {
        *d += 1.0;
    }
    let (bad, _) = warp_error(&shifted, 1.0, 0.0);
    assert!(bad > 4.0 * mad.max(0.5), "off-by-one disparity gives {bad}");

    // With noise and a brightness change, the warp error stays at the noise level.
    let cfg = StereoSceneConfig { noise_sigma: 2.0, right_gain: 1.15, right_offset: -8.0, ..Default::default() };
    let noisy = render_stereo_scene(&cfg).unwrap();
    let (mad_noisy, _) = warp_error(&noisy, 1.15, -8.0);
    // |n_l − interp(n_r)/g| has a mean of at most √(σ² + σ²/g²)·√(2/π) ≈ 2.1 for σ = 2.
    assert!(mad_noisy < 2.2, "noisy warp mean abs diff {mad_noisy}");
}

#[test]
fn masks_match_the_scene_geometry() {
    let cfg = StereoSceneConfig::default();
    let s = render_stereo_scene(&cfg).unwrap();
    let (w, h) = (s.disparity.width(), s.disparity.height());
    assert_eq!(s.disparity.valid_count(), w * h);
    let m = cfg.max_disparity as f32;
    assert!(s.disparity.data().iter().all(|&d| d >= 0.15 * m - 1e-4 && d <= 0.9 * m + 1e-4));
    // Left of the near box (d = 0.9 M over a wall at 0.15 M) an occlusion band of 0.75 M = 48 px.
    let v = (0.5 * h as f64) as usize;
    let box_left = (0.58 * w as f64).ceil() as usize;
    let band = (box_left - 60..box_left).filter(|&u| s.occluded[v * w + u]).count();
    assert!((47..=49).contains(&band), "occlusion band {band} px");
    // The left border: wall pixels with u < d are outside the right image.
    assert!(s.occluded[v * w]);
    // Occluded pixels: none of them is matched in the right image at the same surface; visible ones are.
    let frac = s.occluded.iter().filter(|&&o| o).count() as f64 / (w * h) as f64;
    assert!((0.03..0.2).contains(&frac), "occluded fraction {frac}");
    let low = s.low_texture.iter().filter(|&&o| o).count();
    assert!(low > 5000, "low-texture pixels {low}");
    let fronto = s.fronto_parallel.iter().filter(|&&o| o).count() as f64 / (w * h) as f64;
    assert!((0.4..0.95).contains(&fronto), "fronto-parallel fraction {fronto}");
    // Low texture really is flat: its pixels' standard deviation is small.
    let vals: Vec<f64> =
        s.left.as_raw().iter().zip(&s.low_texture).filter(|(_, l)| **l).map(|(p, _)| f64::from(*p)).collect();
    let mean = vals.iter().sum::<f64>() / vals.len() as f64;
    let std = (vals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / vals.len() as f64).sqrt();
    assert!(std < 1.5, "low-texture std {std}");
    // Triangulated points follow Z = f B / d.
    let p = s.point(100, 100).unwrap();
    let d = f64::from(s.disparity.get(100, 100).unwrap());
    assert!((p.z - 700.0 * 60.0 / d).abs() < 1e-9);
    assert!((s.rig.baseline() - 60.0).abs() < 1e-12);
}

#[test]
fn stereo_scene_is_deterministic() {
    let cfg = StereoSceneConfig {
        width: 160,
        height: 120,
        max_disparity: 24.0,
        noise_sigma: 1.5,
        seed: 4,
        ..Default::default()
    };
    let a = render_stereo_scene(&cfg).unwrap();
    let b = render_stereo_scene(&cfg).unwrap();
    assert_eq!(a.left.as_raw(), b.left.as_raw());
    assert_eq!(a.right.as_raw(), b.right.as_raw());
    assert_eq!(
        a.disparity.data().iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
        b.disparity.data().iter().map(|d| d.to_bits()).collect::<Vec<_>>()
    );
    let c = render_stereo_scene(&StereoSceneConfig { seed: 5, ..cfg }).unwrap();
    assert_ne!(a.left.as_raw(), c.left.as_raw());
}

#[test]
fn bad_stereo_inputs_are_errors() {
    let e = |cfg: StereoSceneConfig| render_stereo_scene(&cfg).unwrap_err().to_string();
    assert!(e(StereoSceneConfig { width: 10, ..Default::default() }).contains("width"));
    assert!(e(StereoSceneConfig { max_disparity: 400.0, ..Default::default() }).contains("max_disparity"));
    assert!(e(StereoSceneConfig { max_disparity: f64::NAN, ..Default::default() }).contains("max_disparity"));
    assert!(e(StereoSceneConfig { right_gain: 0.0, ..Default::default() }).contains("right_gain"));
    assert!(e(StereoSceneConfig { noise_sigma: -1.0, ..Default::default() }).contains("noise_sigma"));
    assert!(e(StereoSceneConfig { samples_per_axis: 0, ..Default::default() }).contains("samples_per_axis"));
}
