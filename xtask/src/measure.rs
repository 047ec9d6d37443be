//! `cargo xtask measure`: triangulate left/right pixel pairs with a stereo calibration and print
//! the 3D points and all pairwise distances with their first-order uncertainty.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail, ensure};
use parallax_triangulation::{Method, TriangulationConfig, measure_stereo};

/// Triangulation method (see the `triangulation` crate).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum MethodArg {
    /// Minimise the reprojection error through the full camera model (maximum likelihood).
    Optimal,
    /// The linear least-squares form `A X = B`.
    Linear,
    /// The homogeneous DLT by SVD.
    Dlt,
    /// Midpoint of the common perpendicular.
    Midpoint,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Optimal => Method::Optimal,
            MethodArg::Linear => Method::Linear,
            MethodArg::Dlt => Method::Dlt,
            MethodArg::Midpoint => Method::Midpoint,
        }
    }
}

/// Largest `--pixel-sigma`, pixels per coordinate.
const MAX_PIXEL_SIGMA: f64 = 100.0;

/// Arguments of `cargo xtask measure`.
#[derive(clap::Args)]
pub struct Args {
    /// Stereo calibration, any format (detected from the content: `calibrate` or `rectify` output,
    /// a rig, OpenCV YAML/XML, ROS camera_info left + right, Kalibr); two files are read together.
    #[arg(long, num_args = 1..=2, required = true)]
    calib: Vec<PathBuf>,
    /// Left image (optional: checks the image size against the calibration and that every
    /// point lies inside the image).
    #[arg(long)]
    left: Option<PathBuf>,
    /// Right image (optional, as `--left`).
    #[arg(long)]
    right: Option<PathBuf>,
    /// Raw (distorted) pixel pairs `"ul,vl,ur,vr;ul,vl,ur,vr;..."`, or left pixels `"u,v;u,v;..."`
    /// together with `--right-points`. Without it, dark circular targets are found in both
    /// images by the blob detector and matched along the epipolar lines.
    #[arg(long, allow_hyphen_values = true)]
    points: Option<String>,
    /// Blob mode: bright targets on a dark background instead of dark on bright.
    #[arg(long)]
    bright_blobs: bool,
    /// Blob mode: largest distance of a right blob from the epipolar line of a left blob, pixels.
    #[arg(long, default_value_t = 2.0)]
    max_epipolar_px: f64,
    /// Right pixels `"u,v;u,v;..."` matching `--points` given as left pixels.
    #[arg(long, allow_hyphen_values = true)]
    right_points: Option<String>,
    /// Triangulation method.
    #[arg(long, value_enum, default_value = "optimal")]
    method: MethodArg,
    /// Pixel noise per coordinate used for the uncertainties, pixels (at most 100).
    #[arg(long, default_value_t = 0.1)]
    pixel_sigma: f64,
    /// Flag a point whose RMS reprojection error is above this, pixels (its left and right
    /// pixels do not lie on corresponding epipolar lines); any flagged point makes the exit
    /// code 2. `inf` turns the check off.
    #[arg(long, default_value_t = 1.0)]
    max_reprojection_px: f64,
    /// Write the measurement to this file (`.ron`, `.json`, or `.csv` for points plus
    /// `<stem>_distances.csv`).
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(out) = &args.out {
        let csv = out.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let native = out.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron") || e.eq_ignore_ascii_case("json"));
        ensure!(csv || native, "{}: a measurement is written as .ron, .json or .csv", out.display());
        let mut outputs = vec![out.clone()];
        if csv {
            let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            outputs.push(out.with_file_name(format!("{stem}_distances.csv")));
        }
        let inputs: Vec<&PathBuf> = args.calib.iter().chain(&args.left).chain(&args.right).collect();
        parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    }
    let mut loaded = Vec::new();
    for (side, path) in [("left", &args.left), ("right", &args.right)] {
        let Some(path) = path else { continue };
        // measure triangulates raw pixels through the rig: a rectified image (its size may be
        // the raw one) would give wrong points without a word
        if let Some(stamp) = parallax_composition::images::read_stamp(path)? {
            bail!(
                "{} is a rectified image ({}, recorded in it by `rectify`): measure takes pixels of the raw \
                 (distorted) images and triangulates them through the rig — give the original {side} image",
                path.display(),
                stamp.made
            );
        }
        loaded.push((side, path, parallax_composition::io::load_gray(path)?));
    }
    let size = loaded.first().map(|(_, _, img)| img.dimensions());
    let stereo =
        crate::files::read_calibration(&args.calib, size)?.into_stereo(&args.calib[0].display().to_string())?;
    if stereo.rectification.is_some() {
        println!(
            "  raw pixels are triangulated through the rig (K, distortion, R, T); the file's R1 R2 P1 P2 Q are not needed"
        );
    }
    let rig = stereo.rig;
    let mut images = Vec::new();
    for (side, path, img) in loaded {
        let cam = if side == "left" { &rig.left } else { &rig.right };
        ensure!(
            img.width() == cam.width && img.height() == cam.height,
            "{side} image {} is {}x{} but the calibration's {side} camera is {}x{}",
            path.display(),
            img.width(),
            img.height(),
            cam.width,
            cam.height
        );
        images.push(img);
    }
    ensure!(
        args.right_points.is_none() || args.points.is_some(),
        "--right-points needs --points (the left pixels they match)"
    );
    let pairs = match (&args.points, images.as_slice()) {
        (Some(points), _) => {
            parallax_composition::measurement::parse_pixel_pairs(points, args.right_points.as_deref())?
        }
        (None, [left, right]) => {
            let pairs = parallax_composition::match_blobs(&rig, left, right, args.bright_blobs, args.max_epipolar_px)
                .context("blob targets (give --points to measure chosen pixels instead)")?;
            println!("blob targets: {} matched pairs", pairs.len());
            pairs
        }
        (None, _) => bail!("give --points, or both --left and --right images to find blob targets"),
    };
    for (i, (l, r)) in pairs.iter().enumerate() {
        ensure!(rig.left.contains(*l), "point {i}: left pixel ({}, {}) is outside the left image", l.x, l.y);
        ensure!(rig.right.contains(*r), "point {i}: right pixel ({}, {}) is outside the right image", r.x, r.y);
    }
    // beyond 100 px per coordinate the first-order uncertainty measures nothing (and overflowed
    // to inf: every distance then read "no covariance: a point behind a camera?")
    ensure!(
        (0.0..=MAX_PIXEL_SIGMA).contains(&args.pixel_sigma),
        "--pixel-sigma must be within 0..={MAX_PIXEL_SIGMA} px, got {}",
        args.pixel_sigma
    );
    ensure!(args.max_reprojection_px > 0.0, "--max-reprojection-px must be > 0 (inf: no check)");
    let config = TriangulationConfig {
        method: args.method.into(),
        pixel_sigma: args.pixel_sigma,
        max_reprojection_px: args.max_reprojection_px,
        ..Default::default()
    };
    let m = measure_stereo(&rig, &pairs, &config)?;

    println!(
        "rig: baseline {:.4} (calibration length unit), method {:?}, pixel noise {} px per coordinate",
        rig.baseline(),
        config.method,
        config.pixel_sigma
    );
    println!("{}", parallax_composition::summary::measurement_table(&m));
    if let Some(out) = &args.out {
        // the CSV form is two files (points, distances), written as a set
        let mut files = parallax_composition::io::OutputSet::new();
        let ext = out.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
        match ext.as_str() {
            "json" => files.add(out, parallax_interop::native_string(&m, parallax_interop::Format::Json)?)?,
            "csv" => {
                let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                files.add(out, m.points_csv())?;
                files.add(out.with_file_name(format!("{stem}_distances.csv")), m.distances_csv())?;
            }
            _ => files.add(out, m.to_ron()?)?,
        }
        for p in files.commit()? {
            println!("wrote {}", p.display());
        }
    }
    println!("{}", parallax_composition::summary::measurement_keys(&m));
    let off = m.points.iter().filter(|p| p.high_reprojection).count();
    if off > 0 {
        eprintln!(
            "warning: {off} point(s) reproject more than {} px (HIGH-REPROJECTION): their left and right pixels do \
             not lie on corresponding epipolar lines (a wrong match or row, swapped images, or another rig's \
             calibration); their coordinates and distances are not measurements",
            args.max_reprojection_px
        );
    }
    Ok(if parallax_composition::summary::flagged(&m) == 0 { ExitCode::SUCCESS } else { ExitCode::from(2) })
}
