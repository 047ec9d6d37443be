//! Composition check (this crate is a composition root, so it may use every stage): a
//! synthetic fisheye stereo pair of a textured room, rectified onto a cylindrical view whose
//! rows are epipolar planes (`stereo-rectify`), matched by the block matcher
//! (`block-matching`), against the exact disparity of every output pixel.

use glam::{DVec2, DVec3};
use image::Luma;
use parallax_block_matching::{BlockMatcher, MatcherConfig, evaluate};
use parallax_camera_model::{Camera, DisparityMap, Intrinsics, Isometry3, KannalaBrandt, Lens, StereoRig};
use parallax_stereo_rectify::{Border, Interpolation, WideProjection, WideView, remap, wide_rectify};
use parallax_synthetic::{TexturedRoom, render_room};

/// Two ~190° Kannala–Brandt cameras 120 mm apart inside a 4 x 3 x 5 m textured room, rectified
/// onto a 640x400 cylindrical view (120° along the baseline, 150° about it, so the view reaches
/// beyond a pinhole's 180° limit about the baseline). SAD 9x9 over 48 disparities: at least 80 %
/// of the view's pixels get a disparity and at least 95 % of those are within 1 px of the
/// truth; the disparity RMS over the matched pixels is below 0.5 px.
#[test]
fn block_matcher_runs_on_a_rectified_fisheye_pair() {
    let lens = |k1: f64| Lens::KannalaBrandt(KannalaBrandt::new(k1, -0.0043, 0.0011, -0.00017).unwrap());
    let left = Camera::new(Intrinsics::new(290.0, 290.0, 511.5, 383.5), lens(0.021), 1024, 768).unwrap();
    let right = Camera::new(Intrinsics::new(292.0, 291.0, 514.0, 381.0), lens(0.019), 1024, 768).unwrap();
    let right_from_left = Isometry3::from_rvec_tvec(DVec3::new(0.004, -0.01, 0.003), DVec3::new(-120.0, 1.0, 2.0));
    let rig = StereoRig::new(left, right, right_from_left).unwrap();
    let room = TexturedRoom {
        min: DVec3::new(-2000.0, -1500.0, -2000.0),
        max: DVec3::new(2000.0, 1500.0, 3000.0),
        texture_scale: 60.0,
        seed: 11,
    };
    let left_from_room = Isometry3::from_rvec_tvec(DVec3::new(0.02, -0.05, 0.0), DVec3::new(0.0, 100.0, 0.0));
    let right_from_room = right_from_left * left_from_room;
    let (l_img, r_img) = rayon::join(
        || render_room(&left, &left_from_room, &room, 3).unwrap(),
        || render_room(&right, &right_from_room, &room, 3).unwrap(),
    );
    let view = WideView::with_field_of_view(WideProjection::Cylindrical, 120.0, 150.0, 640, 400).unwrap();
    let rect = wide_rectify(&rig, &view).unwrap();
    let border = Border::Constant(Luma([0u8]));
    let l = remap(&l_img, &rect.left_map, Interpolation::Bilinear, border).unwrap();
    let r = remap(&r_img, &rect.right_map, Interpolation::Bilinear, border).unwrap();
    let mut matcher = BlockMatcher::new(MatcherConfig { num_disparities: 48, ..Default::default() }).unwrap();
    let disparity = matcher.compute(&l, &r).unwrap();
    // Truth: the wall point seen by each left output pixel, then d = f·B/ρ (cylinder).
    let origin = left_from_room.inverse().translation;
    let (w, h) = (view.width() as usize, view.height() as usize);
    let mut truth = vec![f32::NAN; w * h];
    let mut mask = vec![false; w * h];
    let margin = 12;
    for v in margin..h - margin {
        for u in margin..w - margin {
            let ray_rect = view.ray(DVec2::new(u as f64, v as f64));
            let ray_cam = rect.r1.transpose() * ray_rect;
            let (p, _) = room.hit(origin, left_from_room.inverse().transform_vector(ray_cam)).unwrap();
            let pr = rect.r1 * left_from_room.transform_point(p);
            let d = view.focal() * rect.baseline / pr.y.hypot(pr.z);
            truth[v * w + u] = d as f32;
            // Both images must hold the point (the cylinder's ends lie outside the lenses).
            let in_right = rig.right.project(right_from_room.transform_point(p)).is_ok_and(|q| rig.right.contains(q));
            mask[v * w + u] = in_right && left.project(left_from_room.transform_point(p)).is_ok();
        }
    }
    let truth = DisparityMap::from_data(w, h, truth).unwrap();
    let eval = evaluate(&disparity, &truth, Some(&mask), &[1.0]).unwrap();
    let bad = eval.bad_at(1.0).unwrap();
    // `bad` counts missing pixels too: matched-and-wrong = bad − (100 − density).
    let wrong = bad - (100.0 - eval.density);
    println!(
        "fisheye stereo: {} px evaluated, density {:.1} %, bad-1 {:.2} % (missing counted), wrong among matched {:.2} %, RMS {:.3} px",
        eval.evaluated,
        eval.density,
        bad,
        100.0 * wrong / eval.density,
        eval.rms
    );
    assert!(eval.evaluated > w * h / 2, "only {} pixels evaluated", eval.evaluated);
    assert!(eval.density >= 80.0, "density {:.1} %", eval.density);
    assert!(
        100.0 * wrong / eval.density <= 5.0,
        "{:.2} % of matched pixels off by > 1 px",
        100.0 * wrong / eval.density
    );
    assert!(eval.rms < 0.6, "RMS {:.3} px", eval.rms);
}
