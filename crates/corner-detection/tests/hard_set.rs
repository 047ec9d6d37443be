//! Issue 49 item 2: the hard-print / hard-photo set. Each factor (an outlined print, inverted
//! colours, low contrast, glare, motion blur, defocus, strong perspective, partial occlusion, a
//! small board in a large image, JPEG artefacts, uneven light) is rendered on top of the
//! acceptance sets' camera and noise (800x600, blur 0.8 px, noise σ 2), six views per factor and
//! target (ChArUco 9x7 DICT_4X4_50, chessboard 9x6 inner corners, asymmetric circle grid 4x11),
//! with the exact truth. Scored against the truth: views with the target found, points found
//! within 1 px of their id's truth, points further off (a wrong id or a lost corner), RMS.
//!
//! `HARD_SET_DUMP=DIR` writes every view (`DIR/<target>/<factor>/viewKK.png`), its truth
//! (`viewKK.truth.txt`: `id u v visible` per point with a projection) and what we found
//! (`viewKK.ours.txt`: `id u v`), for `scripts/hard_set_vs_opencv.py DIR`, which runs OpenCV's
//! detectors on the same images and prints the table side by side.

use glam::{DVec2, DVec3};
use parallax_camera_model::{
    Camera, CharucoBoard, Chessboard, CircleGrid, Distortion, Intrinsics, Isometry3, MarkerDictionary,
};
use parallax_corner_detection::{
    CharucoConfig, ChessboardConfig, CircleGridConfig, detect_charuco, detect_circle_grid, find_chessboard,
};
use parallax_synthetic::{
    Glare, Occluder, RenderOptions, ViewSetConfig, calibration_poses, render_charuco, render_chessboard,
    render_circle_grid, rng,
};
use rand::Rng;

const VIEWS: usize = 6;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Target {
    Charuco,
    Chessboard,
    Circles,
}

impl Target {
    fn name(self) -> &'static str {
        match self {
            Target::Charuco => "charuco",
            Target::Chessboard => "chessboard",
            Target::Circles => "circles",
        }
    }

    /// The view generator's chessboard with the target's extent, and the shift from its frame
    /// (origin at the first inner corner) to the target's own.
    fn extent(self) -> (Chessboard, Isometry3) {
        let none = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::ZERO);
        match self {
            Target::Charuco => {
                let b = charuco();
                let chess =
                    Chessboard { cols: b.squares_x() - 1, rows: b.squares_y() - 1, square_size: b.square_length() };
                let shift = DVec3::new(-b.square_length(), -b.square_length(), 0.0);
                (chess, Isometry3::from_rvec_tvec(DVec3::ZERO, shift))
            }
            Target::Chessboard => (chessboard(), none),
            Target::Circles => {
                let g = circles();
                (Chessboard { cols: 2 * g.cols(), rows: g.rows(), square_size: g.spacing() }, none)
            }
        }
    }
}

fn charuco() -> CharucoBoard {
    CharucoBoard::new(9, 7, 25.0, 18.0, MarkerDictionary::predefined("DICT_4X4_50").unwrap(), false).unwrap()
}

fn chessboard() -> Chessboard {
    Chessboard::new(9, 6, 25.0).unwrap()
}

fn circles() -> CircleGrid {
    CircleGrid::new(4, 11, 20.0, 10.0, true).unwrap()
}

fn camera(width: u32, height: u32, f: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics::new(f, f, 0.5 * width as f64 + 2.0, 0.5 * height as f64 - 3.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width,
        height,
    }
}

const FACTORS: [&str; 12] = [
    "clean",
    "outlined",
    "inverted",
    "low-contrast",
    "glare",
    "motion-blur",
    "defocus",
    "strong-perspective",
    "occlusion",
    "small-board",
    "jpeg",
    "uneven-light",
];

/// One view of a factor: camera, pose, options and occluders.
struct Setup {
    camera: Camera,
    pose: Isometry3,
    opts: RenderOptions,
    occluders: Vec<Occluder>,
}

/// The tilt of a pose's board plane away from fronto-parallel, degrees.
fn tilt_deg(pose: &Isometry3) -> f64 {
    pose.transform_vector(DVec3::Z).z.abs().clamp(0.0, 1.0).acos().to_degrees()
}

/// The six views of `factor` for `target` (`None` where the factor does not apply: circle grids
/// have no squares to outline; the chessboard renderer draws no occluders, and a chessboard
/// detector needs the whole grid anyway).
fn setups(target: Target, factor: &str) -> Option<Vec<Setup>> {
    if (factor == "outlined" && target == Target::Circles) || (factor == "occlusion" && target == Target::Chessboard) {
        return None;
    }
    let seed = 4900 + FACTORS.iter().position(|f| *f == factor).unwrap() as u64 * 10 + target as u64;
    let (chess, shift) = target.extent();
    let (cam, (near, far)) = if factor == "small-board" {
        (camera(2048, 1536, 1900.0), (1100.0, 1400.0))
    } else {
        (camera(800, 600, 760.0), (330.0, 600.0))
    };
    let mut cfg = ViewSetConfig { views: VIEWS, seed, min_distance: near, max_distance: far, ..Default::default() };
    if target == Target::Circles {
        cfg.border_squares = 1.0;
    }
    let poses: Vec<Isometry3> = if factor == "strong-perspective" {
        // Of a larger draw with tilts up to 70°, the first six beyond 55°.
        cfg.views = 60;
        cfg.max_tilt_deg = 70.0;
        let all = calibration_poses(&cam, &chess, &cfg).unwrap();
        all.into_iter().filter(|p| tilt_deg(p) >= 55.0).take(VIEWS).collect()
    } else {
        calibration_poses(&cam, &chess, &cfg).unwrap()
    };
    assert_eq!(poses.len(), VIEWS, "{factor}: {} poses", poses.len());
    let mut r = rng(seed);
    let mut out = Vec::new();
    for (k, pose) in poses.into_iter().enumerate() {
        // A point on the board, in the image: where glare and occluders go.
        let on_board = |r: &mut dyn rand::RngCore| {
            let p = DVec3::new(
                r.random_range(0.2..0.8) * (chess.cols + 1) as f64 * chess.square_size - chess.square_size,
                r.random_range(0.2..0.8) * (chess.rows + 1) as f64 * chess.square_size - chess.square_size,
                0.0,
            );
            cam.project(pose.transform_point(p)).unwrap()
        };
        let mut opts =
            RenderOptions { blur_sigma: 0.8, noise_sigma: 2.0, seed: seed * 100 + k as u64, ..Default::default() };
        let mut occluders = Vec::new();
        match factor {
            "clean" | "strong-perspective" | "small-board" => {}
            "outlined" => opts.square_outline = 0.08,
            "inverted" => (opts.black, opts.white, opts.background) = (220, 30, 128),
            "low-contrast" => (opts.black, opts.white) = (100, 150),
            "glare" => {
                let centre = on_board(&mut r);
                opts.glare =
                    Some(Glare { centre, radius: r.random_range(40.0..80.0), strength: r.random_range(120.0..180.0) });
            }
            "motion-blur" => (opts.motion_blur, opts.motion_angle) = (6.0, r.random_range(0.0..std::f64::consts::PI)),
            "defocus" => opts.defocus_radius = 3.0,
            "occlusion" => {
                // A quadrilateral "hand" over part of the board.
                let c = on_board(&mut r);
                let (a, l): (f64, f64) = (r.random_range(0.0..3.1), r.random_range(50.0..110.0));
                let d = DVec2::new(a.cos(), a.sin()) * l;
                let e = d.perp() * 0.5;
                occluders.push(Occluder { polygon: vec![c - d - e, c + d - e, c + d + e, c - d + e], grey: 90 });
            }
            "jpeg" => opts.jpeg_quality = Some(30),
            "uneven-light" => (opts.illumination_gradient, opts.vignetting) = (0.6, 0.5),
            _ => unreachable!("{factor}"),
        }
        out.push(Setup { camera: cam, pose: pose * shift, opts, occluders });
    }
    Some(out)
}

/// A view's truth and what was found: per point id its true position (when projected) and
/// visibility; the ids and positions found.
struct Scored {
    truth: Vec<Option<DVec2>>,
    visible: Vec<bool>,
    found: Vec<(u32, DVec2)>,
}

fn run(target: Target, factor: &str, s: &Setup) -> (image::GrayImage, Scored) {
    match target {
        Target::Charuco => {
            let b = charuco();
            let view = render_charuco(&s.camera, &b, &s.pose, &s.opts, &s.occluders, 4.0).unwrap();
            let det = detect_charuco(&view.image, &b, &CharucoConfig::default()).unwrap();
            let found = det.observation.ids().iter().copied().zip(det.observation.points().iter().copied()).collect();
            (view.image, Scored { truth: view.points, visible: view.visible, found })
        }
        Target::Chessboard => {
            let b = chessboard();
            let view = render_chessboard(&s.camera, &b, &s.pose, &s.opts).unwrap();
            let grid = find_chessboard(&view.image, b.cols, b.rows, &ChessboardConfig::default()).unwrap();
            let found =
                grid.map_or(Vec::new(), |g| g.corners.iter().enumerate().map(|(i, p)| (i as u32, *p)).collect());
            let (w, h) = (f64::from(s.camera.width), f64::from(s.camera.height));
            let mut visible: Vec<bool> =
                view.corners.iter().map(|p| p.x >= 4.0 && p.y >= 4.0 && p.x <= w - 5.0 && p.y <= h - 5.0).collect();
            let mut truth: Vec<Option<DVec2>> = view.corners.iter().map(|p| Some(*p)).collect();
            if factor == "inverted" {
                // Colours swapped, the 10x7-square board is the ordinary one turned by 180° (its
                // top-left square white): the order starts at the other end, as OpenCV's does.
                truth.reverse();
                visible.reverse();
            }
            (view.image, Scored { truth, visible, found })
        }
        Target::Circles => {
            let g = circles();
            let view = render_circle_grid(&s.camera, &g, &s.pose, &s.opts, &s.occluders, 2.0).unwrap();
            let det = detect_circle_grid(&view.image, &g, &CircleGridConfig::default()).unwrap();
            let found = det.map_or(Vec::new(), |d| {
                d.observation.ids().iter().copied().zip(d.observation.points().iter().copied()).collect()
            });
            (view.image, Scored { truth: view.points, visible: view.visible, found })
        }
    }
}

/// Totals of one target and factor.
#[derive(Default, Debug, Clone, Copy)]
struct Row {
    views: usize,
    detected: usize,
    visible: usize,
    found: usize,
    off: usize,
    sum_sq: f64,
}

impl Row {
    fn add(&mut self, s: &Scored) {
        self.views += 1;
        self.detected += usize::from(!s.found.is_empty());
        self.visible += s.visible.iter().filter(|&&v| v).count();
        for &(id, p) in &s.found {
            match s.truth[id as usize] {
                Some(t) if (p - t).length() <= 1.0 => {
                    self.found += 1;
                    self.sum_sq += (p - t).length_squared();
                }
                _ => self.off += 1,
            }
        }
    }

    fn rms(&self) -> f64 {
        (self.sum_sq / self.found.max(1) as f64).sqrt()
    }
}

fn dump(dir: &str, target: Target, factor: &str, k: usize, img: &image::GrayImage, s: &Scored) {
    let dir = std::path::Path::new(dir).join(target.name()).join(factor);
    std::fs::create_dir_all(&dir).unwrap();
    img.save(dir.join(format!("view{k:02}.png"))).unwrap();
    let truth: String = s
        .truth
        .iter()
        .enumerate()
        .filter_map(|(id, p)| p.map(|p| format!("{id} {} {} {}\n", p.x, p.y, u8::from(s.visible[id]))))
        .collect();
    std::fs::write(dir.join(format!("view{k:02}.truth.txt")), truth).unwrap();
    let ours: String = s.found.iter().map(|(id, p)| format!("{id} {} {}\n", p.x, p.y)).collect();
    std::fs::write(dir.join(format!("view{k:02}.ours.txt")), ours).unwrap();
}

#[test]
fn hard_set() {
    let dump_dir = std::env::var("HARD_SET_DUMP").ok();
    let mut rows = Vec::new();
    for target in [Target::Charuco, Target::Chessboard, Target::Circles] {
        for factor in FACTORS {
            let Some(setups) = setups(target, factor) else { continue };
            let mut row = Row::default();
            for (k, s) in setups.iter().enumerate() {
                let (img, scored) = run(target, factor, s);
                if let Some(dir) = &dump_dir {
                    dump(dir, target, factor, k, &img, &scored);
                }
                row.add(&scored);
            }
            println!(
                "{:<10} {:<18} views found {}/{}  points {} of {} visible  off {}  RMS {:.3} px",
                target.name(),
                factor,
                row.detected,
                row.views,
                row.found,
                row.visible,
                row.off,
                row.rms()
            );
            rows.push((target, factor, row));
        }
    }
    for (target, factor, row) in &rows {
        let what = format!("{} {factor}", target.name());
        assert_eq!(row.off, 0, "{what}: {} points more than 1 px from their id's truth", row.off);
        assert!(row.rms() <= 0.15, "{what}: RMS {:.3} px", row.rms());
        if !UNSUPPORTED.contains(&(*target, *factor)) {
            assert!(row.found * 2 >= row.visible, "{what}: {} of {} visible points", row.found, row.visible);
        }
    }
}

/// What no detector here finds (nor OpenCV's on the same views): a chessboard with outlined
/// squares (no saddle, and no marker to start from), a circle grid partly hidden (the grid must
/// be whole).
const UNSUPPORTED: [(Target, &str); 2] = [(Target::Chessboard, "outlined"), (Target::Circles, "occlusion")];
