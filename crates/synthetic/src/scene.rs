//! Scene descriptions in RON: cameras, board, view generators, rendering, stereo scene,
//! robot trajectory and the pipeline's pass/fail tolerances.

use glam::DVec3;
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use serde::{Deserialize, Serialize};

use crate::world::StereoWorld;
use crate::{
    RenderOptions, RenderedView, StereoSceneConfig, SyntheticError, TrajectoryConfig, ViewSetConfig, WideViewSetConfig,
    calibration_poses, render_chessboard, stereo_calibration_poses, wide_angle_stereo_calibration_poses,
};

/// Pass/fail bars of `cargo xtask pipeline`, one per stage. Lengths are in the scene's unit
/// ([`SceneDescription::unit`], millimetres in the built-in scenes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Tolerances {
    /// Largest RMS distance of detected chessboard corners from the true corners, pixels.
    pub corner_rms_px: f64,
    /// Largest relative error of `fx` and `fy` after mono and stereo calibration, percent.
    pub focal_error_pct: f64,
    /// Largest principal point error `|(cx, cy) − truth|`, pixels.
    pub principal_point_px: f64,
    /// Largest RMS reprojection error of a calibration (mono or stereo), pixels.
    pub reprojection_rms_px: f64,
    /// Largest error of the calibrated baseline (the translation of `right_from_left`), scene
    /// length unit.
    pub baseline_error: f64,
    /// Largest rotation error of the calibrated `right_from_left`, degrees.
    pub rig_rotation_deg: f64,
    /// Largest RMS vertical disparity `|v_left − v_right|` of corresponding board corners after
    /// rectification, pixels.
    pub rectification_dv_px: f64,
    /// Largest Middlebury bad-2.0 rate of block matching on the stereo scene: percent of the
    /// non-occluded pixels whose disparity is invalid or off by more than 2 px.
    pub disparity_bad2_pct: f64,
    /// Smallest density of block matching: percent of the non-occluded pixels with a valid
    /// disparity.
    pub disparity_density_pct: f64,
    /// Largest median relative depth error of the triangulated disparity map, percent.
    pub cloud_depth_error_pct: f64,
    /// Largest RMS 3-D error of triangulated chessboard corners (stereo views), scene unit.
    pub point_error: f64,
    /// Largest error of a measured distance between two triangulated corners, scene unit.
    pub distance_error: f64,
    /// Largest rotation error of the hand-eye transform, degrees.
    pub handeye_rot_deg: f64,
    /// Largest translation error of the hand-eye transform, scene length unit.
    pub handeye_trans: f64,
    /// Largest error of a measured point expressed in the robot base frame, scene length unit.
    pub base_point_error: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            corner_rms_px: 0.1,
            focal_error_pct: 0.5,
            principal_point_px: 2.0,
            reprojection_rms_px: 0.15,
            baseline_error: 0.5,
            rig_rotation_deg: 0.1,
            rectification_dv_px: 0.2,
            disparity_bad2_pct: 10.0,
            disparity_density_pct: 85.0,
            cloud_depth_error_pct: 2.0,
            point_error: 2.0,
            distance_error: 1.0,
            handeye_rot_deg: 0.5,
            handeye_trans: 5.0,
            base_point_error: 5.0,
        }
    }
}

impl Tolerances {
    fn validate(&self) -> Result<(), SyntheticError> {
        for (field, v) in [
            ("tolerances.corner_rms_px", self.corner_rms_px),
            ("tolerances.focal_error_pct", self.focal_error_pct),
            ("tolerances.principal_point_px", self.principal_point_px),
            ("tolerances.rig_rotation_deg", self.rig_rotation_deg),
            ("tolerances.disparity_density_pct", self.disparity_density_pct),
            ("tolerances.cloud_depth_error_pct", self.cloud_depth_error_pct),
            ("tolerances.base_point_error", self.base_point_error),
            ("tolerances.reprojection_rms_px", self.reprojection_rms_px),
            ("tolerances.baseline_error", self.baseline_error),
            ("tolerances.rectification_dv_px", self.rectification_dv_px),
            ("tolerances.disparity_bad2_pct", self.disparity_bad2_pct),
            ("tolerances.point_error", self.point_error),
            ("tolerances.distance_error", self.distance_error),
            ("tolerances.handeye_rot_deg", self.handeye_rot_deg),
            ("tolerances.handeye_trans", self.handeye_trans),
        ] {
            crate::error::positive(field, v)?;
        }
        Ok(())
    }
}

/// A synthetic scene a user can describe in RON: the mono camera, the stereo rig, the board,
/// how views are generated (or explicit poses), how they are rendered, the stereo scene with
/// true disparity, the robot trajectory, and the tolerances the pipeline checks.
///
/// All lengths (board squares, distances, baseline, trajectory) are in [`Self::unit`].
///
/// The rig may have any lens: with a wide one (Kannala–Brandt, double sphere) the stereo session
/// is generated over the whole field of view ([`Self::wide_views`]) and the pipeline rectifies
/// the rig to a pinhole pair. Files of the earlier form, with the wide rig under
/// `fisheye: Some((rig: …, views: …))`, are read as that rig and generator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "SceneFile")]
pub struct SceneDescription {
    /// Short name (used for output folders).
    pub name: String,
    /// Length unit of every length in the scene, for reports (e.g. `"mm"`).
    pub unit: String,
    /// The camera of the mono session.
    pub camera: Camera,
    /// The stereo rig of the stereo session.
    pub rig: StereoRig,
    /// The calibration board.
    pub board: Chessboard,
    /// Generator of the mono session's `camera_from_board` poses.
    pub views: ViewSetConfig,
    /// Explicit mono poses (`camera_from_board`); when set they replace the generator.
    #[serde(default)]
    pub mono_poses: Option<Vec<Isometry3>>,
    /// Generator of the stereo session's left `camera_from_board` poses.
    pub stereo_views: ViewSetConfig,
    /// Explicit stereo poses (left `camera_from_board`); when set they replace the generator.
    #[serde(default)]
    pub stereo_poses: Option<Vec<Isometry3>>,
    /// Appearance of every rendered view (each view gets its own noise seed derived from
    /// `render.seed`).
    pub render: RenderOptions,
    /// The rectified stereo scene with true disparity.
    pub stereo_scene: StereoSceneConfig,
    /// The robot trajectory for hand-eye calibration.
    pub trajectory: TrajectoryConfig,
    /// Pass/fail bars of the pipeline.
    #[serde(default)]
    pub tolerances: Tolerances,
    /// Generator of the stereo session of a rig with a wide lens (the board anywhere in the
    /// field of view, [`crate::wide_angle_stereo_calibration_poses`]); `None` with a
    /// Brown–Conrady rig, whose session comes from `stereo_views`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wide_views: Option<WideViewSetConfig>,
    /// A 3D stereo world that replaces `stereo_scene` in the disparity stage (`None`: the
    /// planar stereo scene), seen through the scene's rig: rendered by each camera with its lens
    /// ([`crate::render_world_through`]) after scaling the world so that its baseline becomes
    /// the rig's ([`StereoWorld::scaled`]); the pipeline rectifies the raw pair with the rig it
    /// calibrated, and the truth is the world's in the true rig's rectification
    /// ([`crate::world_truth_rectified`]) — calibration, rectification and matching judged
    /// together.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stereo_world: Option<StereoWorld>,
}

/// A scene as files hold it: today's form, or the earlier one with the wide rig under
/// `fisheye` (its `rig` then served no stage).
#[derive(Deserialize)]
struct SceneFile {
    name: String,
    unit: String,
    camera: Camera,
    rig: StereoRig,
    board: Chessboard,
    views: ViewSetConfig,
    #[serde(default)]
    mono_poses: Option<Vec<Isometry3>>,
    stereo_views: ViewSetConfig,
    #[serde(default)]
    stereo_poses: Option<Vec<Isometry3>>,
    render: RenderOptions,
    stereo_scene: StereoSceneConfig,
    trajectory: TrajectoryConfig,
    #[serde(default)]
    tolerances: Tolerances,
    #[serde(default)]
    wide_views: Option<WideViewSetConfig>,
    #[serde(default)]
    fisheye: Option<WideRigFile>,
    #[serde(default)]
    stereo_world: Option<StereoWorld>,
}

/// The earlier form's wide rig and its generator.
#[derive(Deserialize)]
struct WideRigFile {
    rig: StereoRig,
    views: WideViewSetConfig,
}

impl From<SceneFile> for SceneDescription {
    fn from(f: SceneFile) -> Self {
        let (rig, wide_views) = match f.fisheye {
            Some(w) => (w.rig, Some(w.views)),
            None => (f.rig, f.wide_views),
        };
        Self {
            name: f.name,
            unit: f.unit,
            camera: f.camera,
            rig,
            board: f.board,
            views: f.views,
            mono_poses: f.mono_poses,
            stereo_views: f.stereo_views,
            stereo_poses: f.stereo_poses,
            render: f.render,
            stereo_scene: f.stereo_scene,
            trajectory: f.trajectory,
            tolerances: f.tolerances,
            wide_views,
            stereo_world: f.stereo_world,
        }
    }
}

impl SceneDescription {
    /// The built-in scene of `cargo xtask pipeline` ("easy"): a 640x480 camera with moderate
    /// distortion, a 9x6 board of 25 mm squares, 12 mono and 10 stereo views at 300–600 mm, a
    /// 60 mm baseline, light noise, and an eye-in-hand trajectory of 10 stations (board centre
    /// 450–700 mm in front of the left camera, ±25 mm laterally, within 45° of facing it, so
    /// the board stays in view of both cameras) with 0.1° / 1 mm pose noise. Lengths in
    /// millimetres.
    pub fn builtin() -> Self {
        let camera = Camera {
            intrinsics: Intrinsics::new(600.0, 600.0, 322.0, 238.0),
            lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
            width: 640,
            height: 480,
        };
        let right = Camera {
            intrinsics: Intrinsics::new(603.0, 602.0, 317.0, 242.0),
            lens: Distortion::new(-0.1, 0.04, -0.0004, 0.0002, 0.0).into(),
            width: 640,
            height: 480,
        };
        let right_from_left = Isometry3::from_rvec_tvec(DVec3::new(0.005, -0.01, 0.002), DVec3::new(-60.0, 0.4, -0.3));
        let board = Chessboard { cols: 9, rows: 6, square_size: 25.0 };
        let views =
            ViewSetConfig { views: 12, min_distance: 300.0, max_distance: 600.0, seed: 1, ..Default::default() };
        Self {
            name: "easy".into(),
            unit: "mm".into(),
            camera,
            rig: StereoRig { left: camera, right, right_from_left },
            board,
            views: views.clone(),
            mono_poses: None,
            stereo_views: ViewSetConfig { views: 10, seed: 2, ..views },
            stereo_poses: None,
            render: RenderOptions { blur_sigma: 0.5, noise_sigma: 1.0, seed: 3, ..Default::default() },
            stereo_scene: StereoSceneConfig {
                noise_sigma: 1.0,
                focal_px: 600.0,
                baseline: 60.0,
                seed: 4,
                ..Default::default()
            },
            trajectory: TrajectoryConfig {
                min_distance: 450.0,
                max_distance: 700.0,
                trans_noise: 1.0,
                lateral_range: 25.0,
                hand_eye_offset: 100.0,
                base_distance: 600.0,
                board_centre: DVec3::new(100.0, 62.5, 0.0),
                seed: 5,
                ..Default::default()
            },
            // No looser than the stage issues' bars (corners ≤ 0.03 px, fx within 0.1 %, cx/cy
            // within 0.5 px, baseline within 0.2 mm, rotation within 0.05°, thesis Table 3:
            // distances within 0.5 mm); hand-eye per single trial (the bar is a mean).
            // Every bar holds for any draw of the scene: over `with_seed(1..=50)` the worst
            // figures were hand-eye 0.30° / 5.26 mm, target 3D error 0.46 mm, base-frame error
            // 6.67 mm (medians 0.15° / 2.0 mm, 0.16 mm, 3.0 mm), so those three bars sit at
            // about 1.5x the worst draw (8 mm, 0.8 mm, 12 mm) — a bar that one draw in fifty
            // fails measures luck, not the code.
            tolerances: Tolerances {
                corner_rms_px: 0.03,
                focal_error_pct: 0.1,
                principal_point_px: 0.5,
                reprojection_rms_px: 0.1,
                baseline_error: 0.2,
                rig_rotation_deg: 0.05,
                rectification_dv_px: 0.05,
                disparity_bad2_pct: 10.0,
                disparity_density_pct: 85.0,
                cloud_depth_error_pct: 1.0,
                point_error: 0.8,
                distance_error: 0.5,
                handeye_rot_deg: 0.5,
                handeye_trans: 8.0,
                base_point_error: 12.0,
            },
            wide_views: None,
            stereo_world: None,
        }
    }

    /// A harder variant of [`Self::builtin`] ("hard"): strong distortion, tilts up to 60°,
    /// blur, noise, impulse noise, uneven lighting, clutter, a brightness change between the
    /// stereo images, doubled robot noise, and looser tolerances.
    pub fn builtin_hard() -> Self {
        let mut s = Self::builtin();
        s.name = "hard".into();
        s.camera.lens = Distortion::new(-0.3, 0.12, 0.001, -0.001, -0.02).into();
        s.rig.left = s.camera;
        s.rig.right.lens = Distortion::new(-0.28, 0.1, -0.0008, 0.0006, -0.015).into();
        s.views.max_tilt_deg = 60.0;
        s.stereo_views.max_tilt_deg = 60.0;
        s.render = RenderOptions {
            blur_sigma: 1.0,
            noise_sigma: 3.0,
            salt_fraction: 0.002,
            illumination_gradient: 0.3,
            vignetting: 0.3,
            clutter: true,
            seed: 13,
            ..Default::default()
        };
        s.stereo_scene.noise_sigma = 3.0;
        s.stereo_scene.right_gain = 1.2;
        s.stereo_scene.right_offset = -10.0;
        s.trajectory.rot_noise_rad = 0.2f64.to_radians();
        s.trajectory.trans_noise = 2.0;
        s.tolerances = Tolerances {
            corner_rms_px: 0.3,
            focal_error_pct: 1.0,
            principal_point_px: 4.0,
            reprojection_rms_px: 0.3,
            baseline_error: 1.0,
            rig_rotation_deg: 0.2,
            rectification_dv_px: 0.4,
            disparity_bad2_pct: 20.0,
            disparity_density_pct: 70.0,
            cloud_depth_error_pct: 4.0,
            point_error: 4.0,
            distance_error: 2.0,
            handeye_rot_deg: 1.0,
            handeye_trans: 10.0,
            // doubled robot noise (0.2°, 2 mm) at a ~0.6 m lever arm, plus the hand-eye error
            base_point_error: 20.0,
        };
        s
    }

    /// [`Self::builtin`] with the camera fixed in the robot base (eye-to-hand).
    pub fn builtin_eye_to_hand() -> Self {
        let mut s = Self::builtin();
        s.name = "eye-to-hand".into();
        s.trajectory.eye_in_hand = false;
        s
    }

    /// [`Self::builtin`] through a wide-angle stereo rig ("fisheye",
    /// `fixtures/scenes/fisheye.ron`): two 640x480 Kannala–Brandt cameras (fx ≈ 230 px, about
    /// 155° horizontally and beyond 180° across the diagonal) 60 mm apart, 14 stereo views of
    /// the 9x6 board anywhere in the field at 160–320 mm, tilted up to 40°, the robot stations
    /// at 250–380 mm (the board keeps squares of ~10 px). The pinhole scene's tolerances: every
    /// stage meets them (measured: focal 0.003 %, rectified |Δv| 0.007 px, target distances
    /// 0.09 mm, hand-eye 0.20° / 3.1 mm, base frame 4.5 mm).
    pub fn builtin_wide() -> Self {
        use parallax_camera_model::{Camera, KannalaBrandt, Lens};
        let mut s = Self::builtin();
        s.name = "fisheye".into();
        s.trajectory.min_distance = 250.0;
        s.trajectory.max_distance = 380.0;
        s.trajectory.base_distance = 350.0;
        let camera = |k: Intrinsics, c: [f64; 4]| {
            let lens = KannalaBrandt::new(c[0], c[1], c[2], c[3]).expect("finite coefficients");
            Camera::new(k, Lens::KannalaBrandt(lens), 640, 480).expect("a valid camera")
        };
        let rig = StereoRig {
            left: camera(Intrinsics::new(230.0, 229.5, 321.5, 238.5), [0.021, -0.0043, 0.0011, -0.00017]),
            right: camera(Intrinsics::new(231.0, 230.0, 318.0, 241.0), [0.019, -0.004, 0.0009, -0.00015]),
            right_from_left: s.rig.right_from_left,
        };
        let views = WideViewSetConfig {
            views: 14,
            max_tilt_deg: 40.0,
            min_distance: 160.0,
            max_distance: 320.0,
            seed: 6,
            ..Default::default()
        };
        s.rig = rig;
        s.wide_views = Some(views);
        s
    }

    /// The same scene with every length multiplied by `factor` and the unit renamed (e.g.
    /// `in_unit(0.001, "m")` turns a scene in millimetres into one in metres): board squares,
    /// baselines, view and trajectory distances, explicit poses, pose noise and the length
    /// tolerances. Pixel quantities and angles are unchanged, so the rendered images are the
    /// same and every length the pipeline measures scales by `factor`.
    pub fn in_unit(&self, factor: f64, unit: &str) -> Self {
        let mut s = self.clone();
        s.unit = unit.to_string();
        let scale_pose = |p: &Isometry3| p.with_translation(p.translation * factor);
        s.rig.right_from_left = scale_pose(&s.rig.right_from_left);
        s.board.square_size *= factor;
        for v in [&mut s.views, &mut s.stereo_views] {
            v.min_distance *= factor;
            v.max_distance *= factor;
        }
        if let Some(v) = &mut s.wide_views {
            v.min_distance *= factor;
            v.max_distance *= factor;
        }
        for poses in [&mut s.mono_poses, &mut s.stereo_poses].into_iter().flatten() {
            poses.iter_mut().for_each(|p| *p = scale_pose(p));
        }
        s.stereo_scene.baseline *= factor;
        if let Some(w) = &mut s.stereo_world {
            *w = w.scaled(factor);
        }
        let t = &mut s.trajectory;
        t.min_distance *= factor;
        t.max_distance *= factor;
        t.trans_noise *= factor;
        t.lateral_range *= factor;
        t.hand_eye_offset *= factor;
        t.base_distance *= factor;
        t.board_centre *= factor;
        let tol = &mut s.tolerances;
        tol.baseline_error *= factor;
        tol.point_error *= factor;
        tol.distance_error *= factor;
        tol.handeye_trans *= factor;
        tol.base_point_error *= factor;
        s
    }

    /// The same scene drawn again: every generator (views, rendering noise, stereo scene,
    /// trajectory) reseeded from `seed`, so a tolerance can be checked over many draws.
    pub fn with_seed(&self, seed: u64) -> Self {
        let mut s = self.clone();
        let mix = |k: u64| seed.wrapping_mul(0x9e37_79b9_7f4a_7c15).wrapping_add(k);
        s.views.seed = mix(1);
        s.stereo_views.seed = mix(2);
        s.render.seed = mix(3);
        s.stereo_scene.seed = mix(4);
        s.trajectory.seed = mix(5);
        if let Some(v) = &mut s.wide_views {
            v.seed = mix(6);
        }
        if let Some(w) = &mut s.stereo_world {
            w.seed = mix(7);
        }
        s
    }

    /// Parses and validates a RON description.
    pub fn from_ron(text: &str) -> Result<Self, SyntheticError> {
        let scene: Self = ron::from_str(text).map_err(|e| SyntheticError::Scene(format!("parse error: {e}")))?;
        scene.validate()?;
        Ok(scene)
    }

    /// Pretty RON text ([`Self::from_ron`] reads it back exactly).
    pub fn to_ron(&self) -> String {
        ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default())
            .expect("a scene description always serialises to RON")
    }

    /// Memory a run of this scene may hold at once, in bytes, the figure [`Self::validate`]
    /// compares with [`Self::MEMORY_BUDGET`]: every rendered chessboard image kept (1 byte per
    /// pixel: the mono views, both images of each stereo view, one image per hand-eye station)
    /// plus the largest working set — rendering one chessboard view
    /// ([`Self::BYTES_PER_RENDERED_PIXEL`] per pixel of the largest camera) or the stereo scene
    /// and its matching ([`Self::BYTES_PER_STEREO_SCENE_PIXEL`] per pixel). Saturates instead of
    /// overflowing.
    pub fn estimated_bytes(&self) -> u64 {
        let pixels = |c: &Camera| u64::from(c.width) * u64::from(c.height);
        let mono_views = self.mono_poses.as_ref().map_or(self.views.views, Vec::len) as u64;
        let stereo_views = self.stereo_poses.as_ref().map_or(self.stereo_views.views, Vec::len) as u64;
        let stations = self.trajectory.stations as u64;
        let left_right = pixels(&self.rig.left).saturating_add(pixels(&self.rig.right));
        let kept = mono_views
            .saturating_mul(pixels(&self.camera))
            .saturating_add(stereo_views.saturating_mul(left_right))
            .saturating_add(stations.saturating_mul(pixels(&self.rig.left).max(pixels(&self.camera))));
        let largest_camera = pixels(&self.camera).max(pixels(&self.rig.left)).max(pixels(&self.rig.right));
        let scene_pixels = u64::from(self.stereo_scene.width) * u64::from(self.stereo_scene.height);
        // a world is rendered at the rig's size
        let world = self.stereo_world.as_ref().map_or(0, |_| {
            largest_camera.saturating_mul(StereoWorld::BYTES_PER_PIXEL + Self::BYTES_PER_STEREO_SCENE_PIXEL)
        });
        let working = largest_camera
            .saturating_mul(Self::BYTES_PER_RENDERED_PIXEL)
            .max(scene_pixels.saturating_mul(Self::BYTES_PER_STEREO_SCENE_PIXEL))
            .max(world);
        kept.saturating_add(working)
    }

    /// Largest [`Self::estimated_bytes`] a scene may have: 4 GiB. A description above it (e.g.
    /// a 40000x30000 stereo scene, ≈ 38 GB) is refused when it is read, with both figures,
    /// instead of aborting on an allocation half-way through a run.
    pub const MEMORY_BUDGET: u64 = 4 << 30;

    /// Bytes per pixel of rendering one chessboard view: the `f64` background, the `f32`
    /// radiance, the board-plane point of every pixel corner (`Option<DVec2>`, 24 bytes) and the
    /// 8-bit image.
    pub const BYTES_PER_RENDERED_PIXEL: u64 = 8 + 4 + 24 + 1;

    /// Bytes per pixel of the stereo scene and its matching: two `f64` radiance images, the two
    /// 8-bit images, the `f32` true disparity, three masks, and the `f32` disparity map of the
    /// matcher with its left-right copy.
    pub const BYTES_PER_STEREO_SCENE_PIXEL: u64 = 2 * 8 + 2 + 4 + 3 + 2 * 4;

    /// Checks every part of the description (cameras, rig, board, generators, options) and
    /// refuses a scene whose [`Self::estimated_bytes`] exceed [`Self::MEMORY_BUDGET`].
    pub fn validate(&self) -> Result<(), SyntheticError> {
        self.camera.validate().map_err(SyntheticError::model("camera"))?;
        self.rig.left.validate().map_err(SyntheticError::model("rig.left"))?;
        self.rig.right.validate().map_err(SyntheticError::model("rig.right"))?;
        if !self.rig.right_from_left.is_finite() {
            return Err(SyntheticError::config("rig.right_from_left", "pose is not finite"));
        }
        self.board.validate().map_err(SyntheticError::model("board"))?;
        self.views.validate()?;
        self.stereo_views.validate()?;
        self.render.validate()?;
        self.stereo_scene.validate()?;
        self.trajectory.validate()?;
        self.tolerances.validate()?;
        if let Some(v) = &self.wide_views {
            v.validate()?;
        }
        if let Some(w) = &self.stereo_world {
            w.validate()?;
        }
        for (field, poses) in [("mono_poses", &self.mono_poses), ("stereo_poses", &self.stereo_poses)] {
            if let Some(p) = poses {
                if p.is_empty() {
                    return Err(SyntheticError::config(field, "is an empty list"));
                }
                if p.iter().any(|x| !x.is_finite()) {
                    return Err(SyntheticError::config(field, "contains a non-finite pose"));
                }
            }
        }
        let bytes = self.estimated_bytes();
        if bytes > Self::MEMORY_BUDGET {
            let gb = |b: u64| b as f64 / 1e9;
            return Err(SyntheticError::Scene(format!(
                "the scene needs about {bytes} bytes ({:.1} GB) of memory, above the {} byte ({:.1} GB) budget: \
                 reduce the image sizes (camera {}x{}, rig {}x{} and {}x{}, stereo_scene {}x{}) or the numbers of \
                 views and stations",
                gb(bytes),
                Self::MEMORY_BUDGET,
                gb(Self::MEMORY_BUDGET),
                self.camera.width,
                self.camera.height,
                self.rig.left.width,
                self.rig.left.height,
                self.rig.right.width,
                self.rig.right.height,
                self.stereo_scene.width,
                self.stereo_scene.height,
            )));
        }
        Ok(())
    }

    /// The mono session's `camera_from_board` poses (explicit or generated).
    pub fn mono_poses(&self) -> Result<Vec<Isometry3>, SyntheticError> {
        match &self.mono_poses {
            Some(p) => Ok(p.clone()),
            None => calibration_poses(&self.camera, &self.board, &self.views),
        }
    }

    /// The stereo session's left `camera_from_board` poses: explicit, or generated by
    /// `wide_views` over the whole field of view of both cameras, else by `stereo_views`.
    pub fn stereo_poses(&self) -> Result<Vec<Isometry3>, SyntheticError> {
        match (&self.stereo_poses, &self.wide_views) {
            (Some(p), _) => Ok(p.clone()),
            (None, Some(v)) => wide_angle_stereo_calibration_poses(
                &self.rig.left,
                &self.rig.right,
                &self.rig.right_from_left,
                &self.board,
                v,
            ),
            (None, None) => stereo_calibration_poses(&self.rig, &self.board, &self.stereo_views),
        }
    }

    /// Renders the mono session; view `i` uses noise seed `render.seed + i`.
    pub fn render_mono_views(&self) -> Result<Vec<RenderedView>, SyntheticError> {
        self.mono_poses()?
            .iter()
            .enumerate()
            .map(|(i, pose)| {
                let opts = RenderOptions { seed: self.render.seed.wrapping_add(i as u64), ..self.render.clone() };
                render_chessboard(&self.camera, &self.board, pose, &opts)
            })
            .collect()
    }

    /// Renders the stereo session as `(left, right)` views; the right view's pose is
    /// `rig.right_from_left * left pose`; view `i` uses noise seeds `render.seed + 1000 + 2i`
    /// (left) and `+ 1` (right).
    pub fn render_stereo_views(&self) -> Result<Vec<(RenderedView, RenderedView)>, SyntheticError> {
        self.stereo_poses()?
            .iter()
            .enumerate()
            .map(|(i, pose)| {
                let seed = self.render.seed.wrapping_add(1000 + 2 * i as u64);
                let left_opts = RenderOptions { seed, ..self.render.clone() };
                let right_opts = RenderOptions { seed: seed.wrapping_add(1), ..self.render.clone() };
                let left = render_chessboard(&self.rig.left, &self.board, pose, &left_opts)?;
                let right_pose = self.rig.right_from_left * *pose;
                let right = render_chessboard(&self.rig.right, &self.board, &right_pose, &right_opts)?;
                Ok((left, right))
            })
            .collect()
    }
}

impl Default for SceneDescription {
    fn default() -> Self {
        Self::builtin()
    }
}
