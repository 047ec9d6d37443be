//! `cargo xtask rectify --calib FILE --left L.png --right R.png --out DIR`: Bouguet
//! rectification of one stereo pair with the `stereo-rectify` crate. `--calib` is any stereo
//! calibration in any format (`calibrate`'s result, a rig, OpenCV YAML/XML — also OpenCV's
//! `intrinsics.yml extrinsics.yml` pair —, two ROS camera_info files, a Kalibr camchain). Writes
//! the rectified images (`left_rectified.png`, `right_rectified.png`, same pixel type as the
//! input: 8/16-bit grey or RGB), `side_by_side.png` with guide lines along the epipolar
//! direction (horizontal lines for a horizontal rig, the pair stacked with vertical lines for a
//! vertical one) and the rectification (`rectification.ron` by default, `--format` for json /
//! opencv / ros): the rig with `R1 R2 P1 P2 Q` (row-major), image size and ROIs.
//!
//! A calibration that holds `R1 R2 P1 P2 Q` (OpenCV's `extrinsics.yml`, ROS `camera_info`, a
//! previous `rectify`'s file) is rectified with them, checked against the rig; `--recompute`
//! computes them again with `--alpha` (or `--balance`, `--fov-scale`). A file without an image
//! size (OpenCV's `stereo_calib.cpp` writes none) takes the images'. Both choices are printed.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use image::GenericImageView;

use parallax_composition::images::{rectify_pair, side_by_side};
use parallax_composition::io::OutputSet;
use parallax_interop::{Calibration, RectificationMatrices, RectifiedRecord, StereoCalibration};
use parallax_stereo_rectify::{ExtentMethod, Rectifier, RectifyConfig};

use crate::files::BASELINE_WARN_METRES;

/// Arguments of `cargo xtask rectify`.
#[derive(clap::Args)]
pub struct Args {
    /// Stereo calibration, any format (detected from the content); two files are read together
    /// (OpenCV intrinsics.yml + extrinsics.yml, or ROS camera_info left + right).
    #[arg(long, num_args = 1..=2, required = true)]
    calib: Vec<PathBuf>,
    /// Two cameras of a rig file (`calibrate --camera …`'s Kalibr camchain, OpenCV file or
    /// record; any Kalibr camchain): `I,J` rectifies camera I as the left and J as the right.
    #[arg(long, value_name = "I,J", value_parser = parse_pair)]
    pair: Option<(usize, usize)>,
    /// Left image.
    #[arg(long)]
    left: PathBuf,
    /// Right image.
    #[arg(long)]
    right: PathBuf,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Format of the rectification file in --out: ron (rectification.ron, default), json, opencv
    /// (rectification.yml), ros (rectification_left.yaml, rectification_right.yaml).
    #[arg(long, default_value = "ron")]
    format: String,
    /// Compute R1 R2 P1 P2 Q again (with --alpha, or --balance and --fov-scale) even when the
    /// calibration file holds them; without it a file's own matrices are used.
    #[arg(long)]
    recompute: bool,
    /// Free scaling of a pinhole (Brown–Conrady) rig: 0 = only valid pixels (the default), 1 =
    /// keep every source pixel; a negative value selects OpenCV's default (no scaling). Applies
    /// when the rectification is computed (no R1 R2 P1 P2 Q in the file, or --recompute).
    #[arg(long, allow_negative_numbers = true)]
    alpha: Option<f64>,
    /// A rig with a wide lens (kannala-brandt, double-sphere): OpenCV fisheye's balance, 0 =
    /// only valid pixels (the default), 1 = the whole undistorted extent.
    #[arg(long)]
    balance: Option<f64>,
    /// A rig with a wide lens: OpenCV fisheye's fov_scale, above 1 widens the field of view
    /// (default 1).
    #[arg(long)]
    fov_scale: Option<f64>,
    /// Keep only the coordinate across the baseline common (OpenCV without CALIB_ZERO_DISPARITY).
    #[arg(long)]
    no_zero_disparity: bool,
    /// Exact image extents (converged undistortion of every border pixel) instead of OpenCV's.
    #[arg(long)]
    exact_extents: bool,
    /// Distance between the guide lines of the side-by-side image, pixels.
    #[arg(long, default_value_t = 24)]
    line_spacing: u32,
}

/// `I,J`: two camera indices of a rig.
fn parse_pair(s: &str) -> Result<(usize, usize), String> {
    let (i, j) = s.split_once(',').ok_or_else(|| format!("{s:?}: give two camera indices as I,J (e.g. 0,2)"))?;
    let index = |v: &str| v.trim().parse::<usize>().map_err(|_| format!("{v:?} is no camera index"));
    let (i, j) = (index(i)?, index(j)?);
    if i == j {
        return Err(format!("{s}: two different cameras"));
    }
    Ok((i, j))
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let ext = match args.format.to_ascii_lowercase().as_str() {
        "ron" => "ron",
        "json" => "json",
        "opencv" => "yml",
        "ros" => "yaml",
        other => anyhow::bail!("--format {other:?}: the rectification is written as ron, json, opencv or ros"),
    };
    let rect_path = args.out.join(format!("rectification.{ext}"));
    let format = crate::files::output_format(&rect_path, Some(&args.format))?;
    let outputs = ["side_by_side.png", "left_rectified.png", "right_rectified.png"].map(|n| args.out.join(n));
    let inputs: Vec<&PathBuf> = args.calib.iter().chain([&args.left, &args.right]).collect();
    parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    parallax_composition::io::refuse_overwriting_inputs(&crate::files::written_paths(&rect_path, format), &inputs)?;
    let left = parallax_composition::io::load_image(&args.left)?;
    let right = parallax_composition::io::load_image(&args.right)?;
    let stereo = match args.pair {
        None => crate::files::read_calibration(&args.calib, Some(left.dimensions()))?,
        Some(pair) => {
            anyhow::ensure!(args.calib.len() == 1, "--pair reads one rig file (--calib FILE)");
            let c = parallax_interop::read_rig_pair(&args.calib[0], pair)?;
            println!("calibration: {} (cameras {} and {} of the rig)", args.calib[0].display(), pair.0, pair.1);
            c
        }
    }
    .into_stereo(&args.calib[0].display().to_string())?;
    let rig = stereo.rig;
    if crate::files::in_metres(format) && rig.baseline() >= BASELINE_WARN_METRES {
        eprintln!(
            "warning: --format {} gives lengths in metres, so this calibration's baseline, {:.4} in its own unit, is \
             written as that many metres. If the calibration is in millimetres or centimetres, calibrate again with \
             the square size in metres",
            format.name(),
            rig.baseline()
        );
    }
    for (what, img, path) in [("left", &left, &args.left), ("right", &right, &args.right)] {
        anyhow::ensure!(
            img.dimensions() == (rig.left.width, rig.left.height),
            "{what} image {} is {}x{}, the calibration is for {}x{}",
            path.display(),
            img.width(),
            img.height(),
            rig.left.width,
            rig.left.height
        );
    }
    anyhow::ensure!(args.line_spacing > 0, "--line-spacing must be positive");
    let wide = [rig.left.lens_model(), rig.right.lens_model()].into_iter().find(|m| m.is_wide());
    let config = match wide {
        None => {
            for (flag, given) in [("--balance", args.balance.is_some()), ("--fov-scale", args.fov_scale.is_some())] {
                anyhow::ensure!(!given, "{flag} applies to rigs with a wide lens; this pinhole rig takes --alpha");
            }
            let alpha = args.alpha.unwrap_or(0.0);
            anyhow::ensure!(alpha <= 1.0, "--alpha must be at most 1, got {alpha}");
            RectifyConfig {
                alpha: (alpha >= 0.0).then_some(alpha),
                zero_disparity: !args.no_zero_disparity,
                extents: if args.exact_extents { ExtentMethod::Exact } else { ExtentMethod::OpenCv },
                ..parallax_interop::default_rectify_config()
            }
        }
        Some(lens) => {
            anyhow::ensure!(
                args.alpha.is_none() && !args.exact_extents,
                "--alpha and --exact-extents apply to pinhole rigs; this rig has a {lens} lens: use --balance (0 = only \
                 valid pixels, 1 = the whole image) and --fov-scale"
            );
            RectifyConfig {
                alpha: None,
                zero_disparity: !args.no_zero_disparity,
                balance: args.balance.unwrap_or(0.0),
                fov_scale: args.fov_scale.unwrap_or(1.0),
                ..Default::default()
            }
        }
    };
    let stored = stereo.rectification.filter(|_| !args.recompute);
    if stored.is_some() {
        let options = [
            ("--alpha", args.alpha.is_some()),
            ("--balance", args.balance.is_some()),
            ("--fov-scale", args.fov_scale.is_some()),
            ("--no-zero-disparity", args.no_zero_disparity),
            ("--exact-extents", args.exact_extents),
        ];
        if let Some((flag, _)) = options.iter().find(|(_, given)| *given) {
            anyhow::bail!(
                "{flag} applies when the rectification is computed, and {} holds R1 R2 P1 P2 Q, which are used as \
                 they are: add --recompute to compute them again with {flag}",
                args.calib.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" + ")
            );
        }
    }
    let t0 = Instant::now();
    let rectifier = match &stored {
        // the rectified images are the calibrated size, as OpenCV's `newImageSize` default
        Some(m) => {
            let r = m
                .to_rectification(&rig, (rig.left.width, rig.left.height))
                .context("the calibration file's R1 R2 P1 P2 Q (--recompute computes them again from the rig)")?;
            Rectifier::from_rectification(&rig, r).context("rectifying the rig")?
        }
        None => Rectifier::new(&rig, &config).context("rectifying the rig")?,
    };
    let t_maps = t0.elapsed();
    let rect = *rectifier.rectification();
    // an absurd calibration (k1 = 1e300, f = 1e308) rectifies to black images: refused with the figure
    parallax_composition::refuse_collapsed(&rect)?;

    let t1 = Instant::now();
    let pair = rectify_pair(&rectifier, &left, &right)?;
    let (l, r) = pair.to_rgb8();
    let t_remap = t1.elapsed();
    // images and rectification file are written as one set
    let mut files = OutputSet::new();
    let made = match (wide, &stored) {
        (_, Some(_)) => "the calibration file's R1 R2 P1 P2 Q".to_string(),
        (None, None) => format!("alpha {}", config.alpha.map_or("-1 (OpenCV's default)".into(), |a| a.to_string())),
        (Some(_), None) => format!("balance {}, fov_scale {}", config.balance, config.fov_scale),
    };
    pair.add_to(&mut files, &args.out, &made, &RectificationMatrices::from(&rect))?;
    files.add_png(args.out.join("side_by_side.png"), &side_by_side(&l, &r, rect.vertical, args.line_spacing))?;
    let calibration = StereoCalibration { rectification: Some(RectificationMatrices::from(&rect)), ..stereo };
    let native = RectifiedRecord::of(&calibration, &rect);
    let written = files.add_result(&rect_path, format, &native, Some(&Calibration::Stereo(calibration)))?;
    files.commit()?;

    println!("rectify: {} rig", if rect.vertical { "vertical" } else { "horizontal" });
    match (wide, &stored) {
        (_, Some(_)) => {
            println!("  R1 R2 P1 P2 Q: the calibration file's (checked against its rig; --recompute computes them)")
        }
        (None, None) => println!(
            "  R1 R2 P1 P2 Q: computed, alpha {:?}, zero disparity {}, extents {:?}",
            config.alpha, config.zero_disparity, config.extents
        ),
        (Some(lens), None) => println!(
            "  R1 R2 P1 P2 Q: computed, {lens} lenses to a pinhole pair: balance {}, fov_scale {}, zero disparity {}",
            config.balance, config.fov_scale, config.zero_disparity
        ),
    }
    println!(
        "  maps {:.2} ms, remap pair {:.2} ms (first run, includes thread start-up)",
        t_maps.as_secs_f64() * 1e3,
        t_remap.as_secs_f64() * 1e3
    );
    println!("wrote left_rectified.png, right_rectified.png, side_by_side.png to {}", args.out.display());
    for p in &written {
        println!("wrote {} ({})", p.display(), format.name());
    }
    println!("{}", parallax_composition::summary::rectification_keys(&rect));
    println!("rectification: {}", written[0].display());
    Ok(ExitCode::SUCCESS)
}
