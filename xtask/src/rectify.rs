//! `cargo xtask rectify --calib FILE.ron --left L.png --right R.png --out DIR`: Bouguet
//! rectification of one stereo pair with the `stereo-rectify` crate. Writes the rectified
//! images (`left_rectified.png`, `right_rectified.png`, same pixel type as the input: 8/16-bit
//! grey or RGB), `side_by_side.png` with guide lines along the epipolar direction (horizontal
//! lines for a horizontal rig, the pair stacked with vertical lines for a vertical one) and
//! `rectification.ron` (`R1`, `R2`, `P1`, `P2`, `Q`, ROIs).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use image::{DynamicImage, GenericImageView, Luma, Rgb, RgbImage};

use parallax_stereo_rectify::{Border, ExtentMethod, Image, Rectifier, RectifyConfig};

use parallax_composition::io::{save_png, write_ron};

/// Arguments of `cargo xtask rectify`.
#[derive(clap::Args)]
pub struct Args {
    /// Stereo calibration (RON): a `parallax_camera_model::StereoRig`, or any result holding one in a
    /// `rig` field (planar-calibration's `StereoCalibrationResult`).
    #[arg(long)]
    calib: PathBuf,
    /// Left image.
    #[arg(long)]
    left: PathBuf,
    /// Right image.
    #[arg(long)]
    right: PathBuf,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Free scaling: 0 = only valid pixels, 1 = keep every source pixel; a negative value
    /// selects OpenCV's default (no scaling).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    alpha: f64,
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

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let rig = parallax_composition::io::load_rig(&args.calib)?;
    let left = image::open(&args.left).with_context(|| format!("reading image {}", args.left.display()))?;
    let right = image::open(&args.right).with_context(|| format!("reading image {}", args.right.display()))?;
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
    anyhow::ensure!(args.alpha <= 1.0, "--alpha must be at most 1, got {}", args.alpha);
    anyhow::ensure!(args.line_spacing > 0, "--line-spacing must be positive");
    let config = RectifyConfig {
        alpha: (args.alpha >= 0.0).then_some(args.alpha),
        new_size: None,
        zero_disparity: !args.no_zero_disparity,
        extents: if args.exact_extents { ExtentMethod::Exact } else { ExtentMethod::OpenCv },
    };
    let t0 = Instant::now();
    let rectifier = Rectifier::new(&rig, &config).context("rectifying the rig")?;
    let t_maps = t0.elapsed();
    let rect = *rectifier.rectification();

    let t1 = Instant::now();
    let (l, r) = match (&left, &right) {
        (DynamicImage::ImageLuma16(_), _) | (_, DynamicImage::ImageLuma16(_)) => {
            let (l, r) =
                rectifier.rectify_pair(&left.to_luma16(), &right.to_luma16(), Border::Constant(Luma([0u16])))?;
            write_pair(&args.out, &l, &r)?;
            (to_rgb16(&l), to_rgb16(&r))
        }
        (DynamicImage::ImageLuma8(_), DynamicImage::ImageLuma8(_)) => {
            let (l, r) = rectifier.rectify_pair(&left.to_luma8(), &right.to_luma8(), Border::Constant(Luma([0u8])))?;
            write_pair(&args.out, &l, &r)?;
            (DynamicImage::ImageLuma8(l).to_rgb8(), DynamicImage::ImageLuma8(r).to_rgb8())
        }
        _ => {
            let (l, r) = rectifier.rectify_pair(&left.to_rgb8(), &right.to_rgb8(), Border::Constant(Rgb([0u8; 3])))?;
            write_pair(&args.out, &l, &r)?;
            (l, r)
        }
    };
    let t_remap = t1.elapsed();
    let side = side_by_side(&l, &r, rect.vertical, args.line_spacing);
    save_png(&args.out.join("side_by_side.png"), &side)?;
    write_ron(&args.out.join("rectification.ron"), &rect)?;

    let p2 = rect.p2.rows;
    println!("rectify: {} ({} rig)", args.calib.display(), if rect.vertical { "vertical" } else { "horizontal" });
    println!("  alpha {:?}, zero disparity {}, extents {:?}", config.alpha, config.zero_disparity, config.extents);
    println!("  focal_px: {:.4}", rect.focal());
    println!("  principal_point_left: ({:.4}, {:.4})", rect.p1.rows[0][2], rect.p1.rows[1][2]);
    println!("  principal_point_right: ({:.4}, {:.4})", p2[0][2], p2[1][2]);
    println!("  rectified_baseline: {:.4}", rect.rectified_baseline());
    println!("  roi_left: {:?}", rect.roi1);
    println!("  roi_right: {:?}", rect.roi2);
    println!(
        "  maps {:.2} ms, remap pair {:.2} ms (first run, includes thread start-up)",
        t_maps.as_secs_f64() * 1e3,
        t_remap.as_secs_f64() * 1e3
    );
    println!(
        "  wrote left_rectified.png, right_rectified.png, side_by_side.png, rectification.ron to {}",
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn write_pair<P>(dir: &Path, l: &Image<P>, r: &Image<P>) -> anyhow::Result<()>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    save_png(&dir.join("left_rectified.png"), l)?;
    Ok(save_png(&dir.join("right_rectified.png"), r)?)
}

fn to_rgb16(img: &Image<Luma<u16>>) -> RgbImage {
    RgbImage::from_fn(img.width(), img.height(), |u, v| {
        let g = (img.get_pixel(u, v)[0] >> 8) as u8;
        Rgb([g, g, g])
    })
}

/// The two rectified images side by side (stacked for a vertical rig) with guide lines along
/// the epipolar direction every `spacing` pixels, alternating green and magenta.
fn side_by_side(l: &RgbImage, r: &RgbImage, vertical: bool, spacing: u32) -> RgbImage {
    let (w, h) = l.dimensions();
    let (ow, oh) = if vertical { (w, 2 * h) } else { (2 * w, h) };
    let mut out = RgbImage::new(ow, oh);
    for (u, v, p) in l.enumerate_pixels() {
        out.put_pixel(u, v, *p);
    }
    for (u, v, p) in r.enumerate_pixels() {
        if vertical {
            out.put_pixel(u, v + h, *p);
        } else {
            out.put_pixel(u + w, v, *p);
        }
    }
    let colours = [Rgb([0, 255, 0]), Rgb([255, 0, 255])];
    if vertical {
        for (k, u) in (spacing / 2..ow).step_by(spacing as usize).enumerate() {
            for v in 0..oh {
                out.put_pixel(u, v, colours[k % 2]);
            }
        }
    } else {
        for (k, v) in (spacing / 2..oh).step_by(spacing as usize).enumerate() {
            for u in 0..ow {
                out.put_pixel(u, v, colours[k % 2]);
            }
        }
    }
    out
}
