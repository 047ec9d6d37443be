//! Stereo worlds: the truth against closed forms computed here (a slanted plane, a sphere, the
//! occlusion by a sphere), the images against the truth, the zoo, and the refusals.

use parallax_synthetic::*;

const F: f64 = 300.0;
const B: f64 = 0.1;

fn texture() -> Texture {
    Texture { scale: 0.01, ..Texture::default() }
}

fn world(surfaces: Vec<Surface>) -> StereoWorld {
    StereoWorld {
        width: 160,
        height: 120,
        focal_px: F,
        baseline: B,
        disparities: 48,
        surfaces,
        left: Photometry::default(),
        right: Photometry::default(),
        noise_sigma: 0.0,
        blur_sigma: 0.0,
        colour: false,
        samples_per_axis: 2,
        seed: 3,
    }
}

fn plane(centre: Vec3, normal: Vec3) -> Surface {
    Surface { shape: Shape::Plane { centre, normal, half_size: None }, texture: texture() }
}

/// The unit-z ray of pixel `(u, v)` of a 160x120 camera.
fn ray(u: f64, v: f64) -> [f64; 3] {
    [(u - 79.5) / F, (v - 59.5) / F, 1.0]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[test]
fn a_slanted_plane_has_the_affine_disparity_of_its_equation() {
    // n·X = c: the ray t·r meets it at depth t = c / (n·r), so d = f·B·(n·r) / c
    let (n, p) = ([0.35, -0.25, -1.0], [0.1, 0.2, 2.0]);
    let c = dot(n, p);
    let views = render_world(&world(vec![plane(p, n)])).unwrap();
    let mut worst: f64 = 0.0;
    for v in 0..120 {
        for u in 0..160 {
            let d = F * B * dot(n, ray(u as f64, v as f64)) / c;
            worst = worst.max((f64::from(views.disparity.get(u, v).unwrap()) - d).abs());
            // the right camera at (B, 0, 0): n·(B e_x + t r) = c
            let dr = F * B * dot(n, ray(u as f64, v as f64)) / (c - n[0] * B);
            worst = worst.max((f64::from(views.disparity_right.get(u, v).unwrap()) - dr).abs());
        }
    }
    assert!(worst < 1e-3, "largest error {worst} px");
}

fn sphere_world() -> (StereoWorld, [f64; 3], f64) {
    let (c, r) = ([0.05, -0.02, 1.2], 0.15);
    let w = world(vec![
        plane([0.0, 0.0, 3.0], [0.0, 0.0, -1.0]),
        Surface { shape: Shape::Sphere { centre: c, radius: r }, texture: texture() },
    ]);
    (w, c, r)
}

/// Nearest intersection of `o + t·d` with the sphere by the geometric construction (the
/// closest approach of the ray to the centre, then back along the chord).
fn sphere_hit(o: [f64; 3], d: [f64; 3], c: [f64; 3], r: f64) -> Option<(f64, f64)> {
    let len = dot(d, d).sqrt();
    let u = d.map(|x| x / len);
    let along = dot(sub(c, o), u);
    let closest2 = dot(sub(c, o), sub(c, o)) - along * along;
    let margin = r * r - closest2;
    (margin >= 0.0).then(|| ((along - margin.sqrt()) / len, margin))
}

#[test]
fn a_sphere_has_the_disparity_of_its_nearest_intersection() {
    let (w, c, r) = sphere_world();
    let views = render_world(&w).unwrap();
    let (mut worst, mut on_sphere): (f64, usize) = (0.0, 0);
    for v in 0..120 {
        for u in 0..160 {
            let d = match sphere_hit([0.0; 3], ray(u as f64, v as f64), c, r) {
                // a ray grazing the silhouette decides on rounding: skipped
                Some((_, m)) if m < 1e-9 => continue,
                Some((t, _)) => {
                    on_sphere += 1;
                    F * B / t
                }
                None => F * B / 3.0,
            };
            worst = worst.max((f64::from(views.disparity.get(u, v).unwrap()) - d).abs());
        }
    }
    assert!(on_sphere > 1000, "{on_sphere} pixels on the sphere");
    assert!(worst < 1e-3, "largest error {worst} px");
}

/// Distance from `c` to the segment `[a, b]`.
fn segment_distance(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let s = (dot(sub(c, a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
    let q = [a[0] + s * ab[0], a[1] + s * ab[1], a[2] + s * ab[2]];
    dot(sub(c, q), sub(c, q)).sqrt()
}

#[test]
fn occlusion_masks_of_both_views_agree_with_a_ray_test_against_the_sphere() {
    let (w, c, r) = sphere_world();
    let views = render_world(&w).unwrap();
    let cameras = [[0.0; 3], [B, 0.0, 0.0]];
    let (mut disagree, mut occluded) = (0, 0);
    for (view, mask) in [&views.occluded, &views.occluded_right].into_iter().enumerate() {
        let (own, other) = (cameras[view], cameras[1 - view]);
        for v in 0..120 {
            for u in 0..160 {
                let rr = ray(u as f64, v as f64);
                let truth = match sphere_hit(own, rr, c, r) {
                    Some((_, m)) if m < 1e-9 => continue,
                    // a point of the sphere: hidden only by the sphere itself (its far side)
                    Some((t, _)) => {
                        let p = [own[0] + t * rr[0], own[1] + t * rr[1], t];
                        let normal = sub(p, c);
                        dot(normal, sub(other, p)) < 0.0
                    }
                    // a point of the wall: hidden when the segment to the other camera meets the sphere
                    None => {
                        let p = [own[0] + 3.0 * rr[0], own[1] + 3.0 * rr[1], 3.0];
                        let dist = segment_distance(p, other, c);
                        if (dist - r).abs() < 1e-9 {
                            continue;
                        }
                        dist < r
                    }
                };
                // or the point leaves the other image
                let dd = f64::from(
                    if view == 0 { views.disparity.get(u, v) } else { views.disparity_right.get(u, v) }.unwrap(),
                );
                let column = if view == 0 { u as f64 - dd } else { u as f64 + dd };
                let truth = truth || !(-0.5..=159.5).contains(&column);
                occluded += usize::from(truth);
                disagree += usize::from(truth != mask[v * 160 + u]);
            }
        }
    }
    assert!(occluded > 500, "{occluded} occluded pixels");
    assert_eq!(disagree, 0);
}

/// Linear interpolation of row `v` at column `x` of one channel.
fn sample(img: &image::GrayImage, x: f64, v: u32) -> f64 {
    let i = x.floor() as u32;
    let t = x - f64::from(i);
    let p = |i: u32| f64::from(img.get_pixel(i.min(img.width() - 1), v).0[0]);
    (1.0 - t) * p(i) + t * p(i + 1)
}

#[test]
fn the_right_image_warped_by_the_true_disparity_reproduces_the_left_one() {
    // every shape: a slanted plane, a sphere, a post, a height field before a wall
    let mut w = world(vec![
        plane([0.0, 0.0, 4.0], [0.0, 0.0, -1.0]),
        Surface {
            shape: Shape::HeightField { depth: 2.5, amplitude: 0.1, scale: 0.8, bounds: Some([-1.0, 0.2, 0.0, 2.0]) },
            texture: Texture { scale: 0.03, ..texture() },
        },
        Surface {
            shape: Shape::Plane { centre: [0.3, -0.2, 2.0], normal: [-0.4, 0.1, -1.0], half_size: Some([0.2, 0.15]) },
            texture: Texture { scale: 0.03, ..texture() },
        },
        Surface {
            shape: Shape::Sphere { centre: [-0.25, -0.2, 1.6], radius: 0.12 },
            texture: Texture { scale: 0.02, ..texture() },
        },
        Surface {
            shape: Shape::Cylinder { centre: [0.1, 0.0, 1.5], axis: [0.0, 1.0, 0.0], radius: 0.03, half_length: 1.0 },
            texture: Texture { scale: 0.02, ..texture() },
        },
    ]);
    w.samples_per_axis = 4;
    let views = render_world(&w).unwrap();
    let (left, right) = (views.left.to_luma8(), views.right.to_luma8());
    let (mut sum, mut count) = (0.0, 0);
    for v in 2..118u32 {
        for u in 2..158usize {
            let i = v as usize * 160 + u;
            let d = views.disparity.get(u, v as usize).unwrap();
            // away from depth edges and occlusions
            let smooth = (u - 2..=u + 2).all(|uu| {
                (v as usize - 2..=v as usize + 2)
                    .all(|vv| !views.occluded[vv * 160 + uu] && (views.disparity.get(uu, vv).unwrap() - d).abs() < 0.5)
            });
            let x = u as f64 - f64::from(d);
            if !smooth || x < 1.0 || views.occluded[i] {
                continue;
            }
            sum += (f64::from(left.get_pixel(u as u32, v).0[0]) - sample(&right, x, v)).abs();
            count += 1;
        }
    }
    let mean = sum / f64::from(count);
    // linear interpolation of a texture with detail near a pixel, and 8 bits: a few grey levels;
    // a disparity one pixel off gives tens
    assert!(count > 10_000, "{count} pixels compared");
    assert!(mean < 4.0, "mean |left − warped right| {mean:.2} grey levels");
    // and the right disparity of a visible left pixel points back to it
    let mut worst: f64 = 0.0;
    for v in 0..120usize {
        for u in 0..160usize {
            if views.occluded[v * 160 + u] {
                continue;
            }
            let d = f64::from(views.disparity.get(u, v).unwrap());
            let x = u as f64 - d;
            let i = x.floor() as usize;
            if i + 1 >= 160 {
                continue;
            }
            let (a, b) = (views.disparity_right.get(i, v).unwrap(), views.disparity_right.get(i + 1, v).unwrap());
            if (a - b).abs() > 0.2 || views.occluded_right[v * 160 + i] || views.occluded_right[v * 160 + i + 1] {
                continue;
            }
            let t = x - i as f64;
            worst = worst.max(((1.0 - t) * f64::from(a) + t * f64::from(b) - d).abs());
        }
    }
    assert!(worst < 0.02, "left and right truth disagree by {worst} px");
}

fn zoo() -> Vec<(String, StereoWorld)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/zoo");
    let mut out: Vec<(String, StereoWorld)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            let w = StereoWorld::from_ron(&std::fs::read_to_string(&p).unwrap())
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (name, w)
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

#[test]
fn the_zoo_covers_every_factor_and_round_trips_through_ron() {
    let zoo = zoo();
    assert!(zoo.len() >= 12, "{} scenes", zoo.len());
    let mut seen: Vec<&str> = zoo.iter().flat_map(|(_, w)| w.factors()).collect();
    seen.sort_unstable();
    seen.dedup();
    for factor in [
        "slanted",
        "fronto-parallel",
        "sphere",
        "cylinder",
        "thin",
        "height-field",
        "textureless",
        "repetitive",
        "photometric",
        "vignetting",
        "noise",
        "blur",
        "colour",
    ] {
        assert!(seen.contains(&factor), "no zoo scene has {factor}: {seen:?}");
    }
    for (name, w) in &zoo {
        assert_eq!(&StereoWorld::from_ron(&w.to_ron()).unwrap(), w, "{name}");
    }
}

#[test]
fn rendering_is_deterministic_and_the_seed_changes_the_noise() {
    let (mut w, _, _) = sphere_world();
    w.noise_sigma = 2.0;
    let a = render_world(&w).unwrap();
    let b = render_world(&w).unwrap();
    assert_eq!(a.left, b.left);
    assert_eq!(a.right, b.right);
    w.seed += 1;
    let c = render_world(&w).unwrap();
    assert_ne!(a.left, c.left);
    assert_eq!(a.disparity, c.disparity);
}

#[test]
fn worlds_that_cannot_be_rendered_exactly_are_refused_naming_the_field() {
    let refused = |w: &StereoWorld, field: &str| {
        let e = render_world(w).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    };
    let (base, _, _) = sphere_world();
    // no backdrop: a pixel sees nothing
    let mut w = base.clone();
    w.surfaces.remove(0);
    refused(&w, "sees no surface");
    // a disparity beyond the range searched
    let mut w = base.clone();
    w.disparities = 20;
    refused(&w, "outside (0, 20)");
    // a camera inside a sphere
    let mut w = base.clone();
    w.surfaces.push(Surface { shape: Shape::Sphere { centre: [0.0, 0.0, 0.1], radius: 0.5 }, texture: texture() });
    refused(&w, "inside a sphere");
    // a height field steep enough to cross a ray twice
    let mut w = base.clone();
    w.surfaces.push(Surface {
        shape: Shape::HeightField { depth: 2.0, amplitude: 0.5, scale: 0.2, bounds: None },
        texture: texture(),
    });
    refused(&w, "steep");
    // beyond the memory budget, before any allocation
    let mut w = base.clone();
    w.width = 16384;
    w.height = 16384;
    w.disparities = 40;
    refused(&w, "budget");
    let mut w = base.clone();
    w.samples_per_axis = 0;
    refused(&w, "samples_per_axis");
    let mut w = base;
    w.right.vignetting = 1.5;
    refused(&w, "right");
    assert!(StereoWorld::from_ron("(width: 10)").is_err());
}

#[test]
fn a_distribution_draws_valid_worlds_deterministically_and_refuses_bad_ranges() {
    let d = WorldDistribution { width: 96, height: 72, focal_px: 90.0, ..WorldDistribution::default() };
    let mut kinds = 0;
    for seed in 0..12 {
        let w = d.draw(seed).unwrap();
        assert_eq!(w, d.draw(seed).unwrap(), "seed {seed}");
        assert_ne!(w, d.draw(seed + 100).unwrap(), "seed {seed}");
        // every draw renders: a backdrop everywhere, every disparity inside the range
        let v = render_world(&w).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert!(v.disparity.data().iter().all(|&x| x > 0.0 && x < 48.0));
        kinds += w.surfaces.len() - 1;
    }
    assert!(kinds >= 12 * 3, "{kinds} objects in 12 worlds");
    let bad = |d: WorldDistribution, field: &str| {
        let e = d.draw(0).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    };
    bad(WorldDistribution { depth: [3.0, 1.0], ..d.clone() }, "depth");
    bad(WorldDistribution { depth: [0.1, 1.0], ..d.clone() }, "beyond the 48 searched");
    bad(WorldDistribution { vignetting: [0.0, 1.5], ..d.clone() }, "vignetting");
    bad(WorldDistribution { patterns: vec![], ..d.clone() }, "patterns");
    bad(WorldDistribution { objects: [5, 2], ..d }, "objects");
}

/// The world's own rectified pair as a rig and as a rectification.
fn own_rig(w: &StereoWorld) -> (parallax_camera_model::StereoRig, RectifiedPair) {
    use parallax_camera_model::{Camera, Distortion, Isometry3, StereoRig};
    let k = w.intrinsics();
    let camera = Camera::new(k, Distortion::default(), w.width, w.height).unwrap();
    let t = glam::DVec3::new(-w.baseline, 0.0, 0.0);
    let rig = StereoRig::new(camera, camera, Isometry3::from_rvec_tvec(glam::DVec3::ZERO, t)).unwrap();
    let p1 = [[k.fx, 0.0, k.cx, 0.0], [0.0, k.fy, k.cy, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let mut p2 = p1;
    p2[0][3] = -k.fx * w.baseline;
    let pair = RectifiedPair {
        width: w.width,
        height: w.height,
        p1,
        p2,
        r1: glam::DMat3::IDENTITY,
        right_centre: glam::DVec3::new(w.baseline, 0.0, 0.0),
    };
    (rig, pair)
}

#[test]
fn a_world_through_its_own_rectified_rig_gives_its_images_and_truth() {
    let (mut w, _, _) = sphere_world();
    w.noise_sigma = 1.0;
    let (rig, pair) = own_rig(&w);
    let views = render_world(&w).unwrap();
    let (left, right) = render_world_through(&w, &rig).unwrap();
    for (a, b) in [(&views.left, &left), (&views.right, &right)] {
        let (a, b) = (a.to_luma8(), b.to_luma8());
        let diff: Vec<i32> =
            a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| (i32::from(x) - i32::from(y)).abs()).collect();
        // the lens's unprojection rounds differently from the world's own rays: at most one
        // grey level, on few pixels
        assert!(diff.iter().all(|&d| d <= 1), "largest difference {}", diff.iter().max().unwrap());
        assert!(diff.iter().filter(|&&d| d > 0).count() < diff.len() / 100);
    }
    let (truth, occluded) = world_truth_rectified(&w, &pair).unwrap();
    let worst = truth.data().iter().zip(views.disparity.data()).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
    assert!(worst < 1e-4, "largest difference {worst} px");
    assert_eq!(occluded, views.occluded);
}
