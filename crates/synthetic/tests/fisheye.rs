//! Chessboards rendered through wide-angle lens models (up to 190° field of view) against an
//! independent computation through the same model, and wide-angle view sets.

use glam::{DQuat, DVec2, DVec3};
use parallax_camera_model::{
    Camera, CameraModel, Chessboard, DoubleSphere, Intrinsics, Isometry3, KannalaBrandt, Lens,
};
use parallax_synthetic::*;

/// 1024x768, horizontal field of view ≈ 190° (θ = 95° lands 503 px from the centre).
fn kb190() -> Camera {
    Camera::new(
        Intrinsics::new(290.0, 290.0, 511.5, 383.5),
        Lens::KannalaBrandt(KannalaBrandt::new(0.021, -0.0043, 0.0011, -0.00017).unwrap()),
        1024,
        768,
    )
    .unwrap()
}

fn ds() -> Camera {
    Camera::new(
        Intrinsics::new(330.0, 330.0, 511.5, 383.5),
        Lens::DoubleSphere(DoubleSphere::new(-0.15, 0.6).unwrap()),
        1024,
        768,
    )
    .unwrap()
}

/// Colour of a board point in squares (black 0, white 255, margin 1 square white), `None` off it.
fn colour(p: DVec2, cols: usize, rows: usize) -> Option<f64> {
    if p.x < -2.0 || p.y < -2.0 || p.x >= cols as f64 + 1.0 || p.y >= rows as f64 + 1.0 {
        return None;
    }
    if p.x < -1.0 || p.y < -1.0 || p.x >= cols as f64 || p.y >= rows as f64 {
        return Some(255.0);
    }
    let (i, j) = (p.x.floor() as i64, p.y.floor() as i64);
    Some(if (i + j).rem_euclid(2) == 0 { 0.0 } else { 255.0 })
}

/// Board point (in squares) seen through a pixel position, computed independently of the
/// renderer: unproject through the model, intersect the plane.
fn board_point<C: CameraModel>(camera: &C, pose: &Isometry3, square: f64, px: DVec2) -> Option<DVec2> {
    let ray = camera.unproject_ray(px).ok()?;
    let n = pose.transform_vector(DVec3::Z);
    let lambda = n.dot(pose.translation) / n.dot(ray);
    if !(lambda > 0.0 && lambda.is_finite()) {
        return None;
    }
    let p = pose.inverse().transform_point(ray * lambda) / square;
    Some(p.truncate())
}

/// Checks a rendered view: pixels well inside one square equal its colour (±0.5 grey level),
/// and pixels on edges equal the coverage of 64x64 point samples through the model (±4 grey
/// levels: the sampling error of 1/64 of a pixel per crossing edge). Returns the number of
/// interior pixels whose ray points behind the image plane.
fn check_view<C: CameraModel + Sync>(camera: &C, board: &Chessboard, pose: &Isometry3) -> usize {
    let opts = RenderOptions { black: 0, white: 255, background: 128, ..Default::default() };
    let view = render_chessboard(camera, board, pose, &opts).unwrap();
    for (c, x) in view.corners.iter().zip(board.object_points()) {
        assert!((*c - camera.project_from(pose, x).unwrap()).length() < 1e-12);
    }
    let s = board.square_size;
    let (mut interior, mut behind, mut edges) = (0, 0, 0);
    for v in (0..camera.height()).step_by(3) {
        for u in (0..camera.width()).step_by(3) {
            let centre = DVec2::new(u as f64, v as f64);
            let Some(pc) = board_point(camera, pose, s, centre) else { continue };
            let got = f64::from(view.image.get_pixel(u, v).0[0]);
            let corners: Vec<Option<DVec2>> = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
                .iter()
                .map(|&(a, b)| board_point(camera, pose, s, centre + DVec2::new(a, b)))
                .collect();
            let Some(corners) = corners.into_iter().collect::<Option<Vec<_>>>() else { continue };
            let same_cell = corners.iter().all(|q| q.floor() == pc.floor());
            if same_cell && let Some(c) = colour(pc, board.cols, board.rows) {
                assert!((got - c).abs() <= 0.5, "interior pixel ({u}, {v}) = {got}, expected {c}");
                interior += 1;
                if camera.unproject_ray(centre).unwrap().z < 0.0 {
                    behind += 1;
                }
            } else if !same_cell && edges < 150 {
                const N: usize = 64;
                let mut sum = 0.0;
                for j in 0..N {
                    for i in 0..N {
                        let px =
                            centre + DVec2::new((i as f64 + 0.5) / N as f64 - 0.5, (j as f64 + 0.5) / N as f64 - 0.5);
                        sum += board_point(camera, pose, s, px)
                            .and_then(|q| colour(q, board.cols, board.rows))
                            .unwrap_or(128.0);
                    }
                }
                let expected = sum / (N * N) as f64;
                assert!((got - expected).abs() <= 4.0, "edge pixel ({u}, {v}) = {got}, sampled {expected}");
                edges += 1;
            }
        }
    }
    assert!(interior > 200 && edges > 50, "interior {interior}, edges {edges}");
    behind
}

/// A board 93° off the optical axis of a 190° Kannala–Brandt lens (behind the image plane)
/// and a board in front of a double sphere lens render with the model's geometry.
#[test]
fn renders_through_fisheye_models_up_to_190_degrees() {
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let centre = DVec3::new(100.0, 62.5, 0.0);
    let camera = kb190();
    assert!(camera.max_field_angle() > 95f64.to_radians());
    // Board centre 93° off axis to the right, facing the camera.
    let dir = DVec3::new(93f64.to_radians().sin(), 0.0, 93f64.to_radians().cos());
    let rot = DQuat::from_rotation_arc(DVec3::Z, dir) * DQuat::from_rotation_z(0.3);
    let pose = Isometry3::from_quat_translation(rot, dir * 180.0 - rot * centre);
    let behind = check_view(&camera, &board, &pose);
    assert!(behind > 20, "only {behind} checked pixels see behind the image plane");
    let rot = DQuat::from_rotation_x(0.4) * DQuat::from_rotation_y(-0.3);
    let pose = Isometry3::from_quat_translation(rot, DVec3::new(0.0, 0.0, 250.0) - rot * centre);
    check_view(&ds(), &board, &pose);
}

/// Wide-angle view sets: every corner inside the image, deterministic per seed, and the
/// board centres spread to more than 70° off axis on the 190° lens.
#[test]
fn wide_angle_views_cover_the_periphery() {
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let camera = kb190();
    let cfg = WideViewSetConfig { views: 20, seed: 5, ..Default::default() };
    let poses = wide_angle_calibration_poses(&camera, &board, &cfg).unwrap();
    assert_eq!(poses, wide_angle_calibration_poses(&camera, &board, &cfg).unwrap());
    assert_ne!(
        poses,
        wide_angle_calibration_poses(&camera, &board, &WideViewSetConfig { seed: 6, ..cfg.clone() }).unwrap()
    );
    let mut widest: f64 = 0.0;
    for pose in &poses {
        for c in project_corners(&camera, &board, pose).unwrap() {
            assert!(c.x >= 4.0 && c.y >= 4.0 && c.x <= 1019.0 && c.y <= 763.0, "{c}");
        }
        for p in board.object_points() {
            let q = pose.transform_point(p);
            widest = widest.max(q.normalize().z.acos().to_degrees());
        }
    }
    assert!(widest > 70.0, "widest corner only {widest:.1}° off axis");
    let rig = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.02, 0.0), DVec3::new(-60.0, 0.0, 0.0));
    let stereo = wide_angle_stereo_calibration_poses(&camera, &ds(), &rig, &board, &cfg).unwrap();
    for pose in &stereo {
        assert!(project_corners(&camera, &board, pose).unwrap().iter().all(|c| camera.contains(*c)));
        assert!(project_corners(&ds(), &board, &(rig * *pose)).unwrap().iter().all(|c| ds().contains(*c)));
    }
    assert!(
        wide_angle_calibration_poses(&camera, &board, &WideViewSetConfig { max_tilt_deg: 80.0, ..cfg.clone() })
            .is_err()
    );
    assert!(wide_angle_calibration_poses(&camera, &board, &WideViewSetConfig { views: 0, ..cfg }).is_err());
}

/// The room seen through a 190° lens: with one sample per pixel each pixel is the grey level
/// of the wall its centre ray hits (±0.5 from rounding), behind the image plane too; pixels
/// without a ray are 0; a camera outside the room is an error.
#[test]
fn room_renders_through_the_lens() {
    let room = TexturedRoom {
        min: DVec3::new(-2000.0, -1500.0, -2000.0),
        max: DVec3::new(2000.0, 1500.0, 3000.0),
        texture_scale: 80.0,
        seed: 3,
    };
    let camera = Camera::new(
        Intrinsics::new(150.0, 150.0, 255.5, 191.5),
        Lens::KannalaBrandt(KannalaBrandt::new(0.021, -0.0043, 0.0011, -0.00017).unwrap()),
        512,
        384,
    )
    .unwrap();
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.05, 0.3, 0.0), DVec3::new(100.0, -50.0, 200.0));
    let img = render_room(&camera, &pose, &room, 1).unwrap();
    let origin = pose.inverse().translation;
    let (mut behind, mut dark) = (0, 0);
    for v in (0..384).step_by(7) {
        for u in (0..512).step_by(7) {
            let got = f64::from(img.get_pixel(u, v).0[0]);
            match camera.unproject_ray(DVec2::new(u as f64, v as f64)) {
                Ok(ray) => {
                    let (_, g) = room.hit(origin, pose.inverse().transform_vector(ray)).unwrap();
                    assert!((got - g).abs() <= 0.5, "({u}, {v}): {got} vs {g}");
                    behind += usize::from(ray.z < 0.0);
                }
                Err(_) => {
                    assert_eq!(got, 0.0);
                    dark += 1;
                }
            }
        }
    }
    assert!(behind > 10, "behind {behind}, dark {dark}");
    let outside = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.0, 0.0, -5000.0));
    assert!(render_room(&camera, &outside, &room, 1).is_err());
}
