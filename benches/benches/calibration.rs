//! Calibration speed: 14 views of a 9x6 board (756 corners), as OpenCV's `calibrateCamera`
//! (~18 ms on this machine for the real 14-view set), the 14-pair stereo calibration, and a
//! rig of 8 cameras × 200 frames (`calibrate_rig`; the goal: under 10 s).

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_planar_calibration::{
    CalibrationConfig, CameraView, RigConfig, StereoConfig, calibrate_camera, calibrate_rig, calibrate_stereo,
};
use parallax_synthetic::{ViewSetConfig, add_pixel_noise, project_corners, rng, stereo_calibration_poses};

/// Object points and the left and right corners of every view.
type Views = (Vec<Vec<DVec3>>, Vec<Vec<DVec2>>, Vec<Vec<DVec2>>);

fn setup() -> Views {
    let left = Camera::new(
        Intrinsics::new(533.0, 533.0, 341.6, 234.3),
        Distortion::new(-0.28, 0.05, 0.001, 0.0, 0.1),
        640,
        480,
    )
    .unwrap();
    let right = Camera::new(
        Intrinsics::new(537.0, 536.6, 326.5, 249.3),
        Distortion::new(-0.29, 0.13, 0.0, 0.0, -0.04),
        640,
        480,
    )
    .unwrap();
    let rig = StereoRig::new(
        left,
        right,
        Isometry3::from_rvec_tvec(DVec3::new(0.0067, 0.0045, -0.0035), DVec3::new(-99.8, 1.12, 0.05)),
    )
    .unwrap();
    let board = Chessboard::new(9, 6, 30.0).unwrap();
    let cfg =
        ViewSetConfig { views: 14, seed: 5, min_distance: 350.0, max_distance: 600.0, ..ViewSetConfig::default() };
    let poses = stereo_calibration_poses(&rig, &board, &cfg).unwrap();
    let mut r = rng(6);
    let mut proj = |cam: &Camera, p: &Isometry3| {
        let mut c = project_corners(cam, &board, p).unwrap();
        add_pixel_noise(&mut c, 0.15, &mut r);
        c
    };
    let l: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.left, p)).collect();
    let rr: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.right, &(rig.right_from_left * *p))).collect();
    (vec![board.object_points(); poses.len()], l, rr)
}

/// Eight pinhole cameras on a ring of radius 150 looking outwards 45° apart (neighbours' fields
/// overlap), 200 frames of a 9x6 board each placed before one camera (tilted 20–45°,
/// 450–900 away), seen by every camera that has all its corners in view (σ = 0.2 px).
fn ring_rig() -> Vec<Vec<Option<CameraView>>> {
    use rand::Rng;
    let cam =
        Camera::new(Intrinsics::new(600.0, 600.0, 640.0, 480.0), Distortion::new(-0.2, 0.05, 0.0, 0.0, 0.0), 1280, 960)
            .unwrap();
    let board = Chessboard::new(9, 6, 40.0).unwrap();
    let centre = DVec3::new(160.0, 100.0, 0.0);
    // camI_from_cam0: camera I turned by 45°·I about y, on the ring.
    let from0: Vec<Isometry3> = (0..8)
        .map(|i| {
            let yaw = (45.0 * i as f64).to_radians();
            let world_from_cam = Isometry3::from_rvec_tvec(
                DVec3::new(0.0, yaw, 0.0),
                DVec3::new(150.0 * yaw.sin(), 0.0, 150.0 * yaw.cos()),
            );
            let world_from_cam0 = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.0, 0.0, 150.0));
            world_from_cam.inverse() * world_from_cam0
        })
        .collect();
    let mut r = rng(17);
    let mut frames = Vec::new();
    while frames.len() < 200 {
        let aim = frames.len() % 8;
        let tilt = r.random_range(20f64..45.0).to_radians();
        let phi = r.random_range(0.0..std::f64::consts::TAU);
        let rv = DVec3::new(phi.cos(), phi.sin(), 0.0) * tilt;
        let rot = Isometry3::from_rvec_tvec(rv, DVec3::ZERO);
        let at = DVec3::new(r.random_range(-150.0..150.0), r.random_range(-100.0..100.0), r.random_range(450.0..900.0));
        let cam_from_board = Isometry3::from_rvec_tvec(rv, at - rot.transform_vector(centre));
        let cam0_from_board = from0[aim].inverse() * cam_from_board;
        let views: Vec<Option<CameraView>> = from0
            .iter()
            .map(|e| {
                let p = *e * cam0_from_board;
                let px: Option<Vec<DVec2>> = board
                    .object_points()
                    .iter()
                    .map(|x| {
                        (p.transform_point(*x).z > 100.0)
                            .then(|| cam.project_from(&p, *x).ok())
                            .flatten()
                            .filter(|u| u.x > 10.0 && u.y > 10.0 && u.x < 1269.0 && u.y < 949.0)
                    })
                    .collect();
                px.map(|mut image| {
                    add_pixel_noise(&mut image, 0.2, &mut r);
                    CameraView { object: board.object_points(), image }
                })
            })
            .collect();
        if views[aim].is_some() {
            frames.push(views);
        }
    }
    frames
}

fn bench_rig(c: &mut Criterion) {
    let (frames, sizes) = (ring_rig(), vec![(1280, 960); 8]);
    let seen: usize = frames.iter().map(|f| f.iter().flatten().count()).sum();
    eprintln!("rig: 8 cameras x {} frames, {seen} views", frames.len());
    let cfg = RigConfig::uniform(8, CalibrationConfig::default());
    c.bench_function("calibrate_rig 8 cameras x 200 frames", |b| {
        b.iter(|| calibrate_rig(&frames, &sizes, &cfg).unwrap())
    });
}

fn bench(c: &mut Criterion) {
    let (object, left, right) = setup();
    let cfg = CalibrationConfig::default();
    c.bench_function("calibrate_camera 14 views x 54 corners", |b| {
        b.iter(|| calibrate_camera(&object, &left, 640, 480, &cfg).unwrap())
    });
    let scfg = StereoConfig::default();
    c.bench_function("calibrate_stereo 14 pairs x 54 corners", |b| {
        b.iter(|| calibrate_stereo(&object, &left, &right, (640, 480), (640, 480), &scfg).unwrap())
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_group! {
    name = rig;
    config = Criterion::default().sample_size(10);
    targets = bench_rig
}
criterion_main!(benches, rig);
