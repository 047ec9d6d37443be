//! Calibrate a camera from chessboard images and undistort one of them, with `parallax` as the
//! only parallax dependency — in a program whose own dependency tree also holds another `glam`
//! version (here glam 0.29, as `other_glam`): the facade's `parallax::glam` is the one its API
//! takes, so the two never meet.
//!
//! ```text
//! cargo run -p parallax --example calibrate_undistort -- 'left*.jpg' 9x6 30 out/
//! ```
//! Without arguments it runs on the repository's `fixtures/mono` renders (9x6, 25 mm).

use parallax::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fixtures = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/mono/view_*.png");
    let pattern = args.first().map_or(fixtures, String::as_str);
    let (cols, rows) = args
        .get(1)
        .map_or(Some((9, 6)), |s| s.split_once('x').and_then(|(c, r)| Some((c.parse().ok()?, r.parse().ok()?))))
        .ok_or("board must be COLSxROWS, e.g. 9x6")?;
    let square: f64 = args.get(2).map_or(Ok(25.0), |s| s.parse())?;
    let out = std::path::PathBuf::from(args.get(3).map_or("target/calibrate-undistort", String::as_str));

    let board = Chessboard::new(cols, rows, square)?;
    let paths = parallax::pipeline::io::expand_glob(pattern)?;
    let images: Vec<image::GrayImage> =
        paths.iter().map(|p| parallax::pipeline::io::load_gray(p)).collect::<Result<_, _>>()?;
    let found = parallax::pipeline::detect_boards(&images, &board, &ChessboardConfig::default())?;
    let grids: Vec<CornerGrid> = found.iter().flatten().cloned().collect();
    println!("board found in {}/{} images", grids.len(), images.len());
    let (w, h) = images[0].dimensions();
    let result = calibrate_chessboard(&board, &grids, w, h, &CalibrationConfig::default())?;
    let k = result.camera.intrinsics;
    println!("fx {:.3} fy {:.3} cx {:.3} cy {:.3}  RMS {:.4} px", k.fx, k.fy, k.cx, k.cy, result.rms_px);

    let map = parallax::rectify::init_undistort_map(&result.camera, k.matrix(), w, h)?;
    let undistorted =
        parallax::rectify::remap(&images[0], &map, Interpolation::Bilinear, Border::Constant(image::Luma([0u8])))?;
    std::fs::create_dir_all(&out)?;
    undistorted.save(out.join("undistorted.png"))?;
    parallax::pipeline::io::write_ron(&out.join("calibration.ron"), &result)?;

    // Another glam in the same program: its vectors are other types, converted through arrays.
    let principal_point = other_glam::DVec2::new(k.cx, k.cy);
    let ours: DVec2 = DVec2::from_array(principal_point.to_array());
    println!("principal point {ours} (through glam 0.29: {principal_point})");
    println!("wrote {}", out.display());
    Ok(())
}
