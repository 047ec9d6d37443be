//! The library quick start of the README: detect → stereo calibrate → rectify → semi-global
//! matching → triangulate, on the repository's rendered stereo pairs (`fixtures/stereo`: a 9x6
//! board of 25 mm squares seen by a 640x480 rig 60 mm wide). CI builds and runs it.
//!
//! ```text
//! cargo run -p parallax --example quick_start
//! ```

use parallax::prelude::*;

fn main() -> parallax::Result<()> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/stereo");
    let load = |name: String| -> parallax::Result<image::GrayImage> { Ok(image::open(dir.join(name))?.into_luma8()) };
    let find = |img: &image::GrayImage| find_chessboard(img, 9, 6, &ChessboardConfig::default());
    // 1. Detect the board in five stereo pairs (corners in OpenCV's order).
    let (mut images, mut left, mut right) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..5 {
        let (l, r) = (load(format!("left_{i:02}.png"))?, load(format!("right_{i:02}.png"))?);
        if let (Some(gl), Some(gr)) = (find(&l)?, find(&r)?) {
            left.push(gl);
            right.push(gr);
            images.push((l, r));
        }
    }
    // 2. Calibrate the rig (Zhang, then one joint refinement, as OpenCV's stereoCalibrate).
    let board = Chessboard::new(9, 6, 25.0)?;
    let size = images[0].0.dimensions();
    let calib = calibrate_stereo_chessboard(&board, &left, &right, size, size, &StereoConfig::default())?;
    println!("{} pairs: RMS {:.3} px, baseline {:.2} mm", left.len(), calib.rms_px, calib.rig.baseline());
    // 3. Rectify the first pair (Bouguet, as OpenCV's stereoRectify).
    let rectifier = Rectifier::new(&calib.rig, &RectifyConfig::default())?;
    let (l, r) = rectifier.rectify_pair(&images[0].0, &images[0].1, Border::Constant(image::Luma([0])))?;
    // 4. Dense disparity by semi-global matching, then 3D points through Q.
    let mut matcher = BlockMatcher::new(MatcherConfig { num_disparities: 64, ..MatcherConfig::sgm() })?;
    let disparity = matcher.compute(&l, &r)?;
    let q = ReprojectionMatrix::new(rectifier.rectification().q)?;
    let cloud = disparity_to_point_cloud(&disparity, &q, &CloudConfig::default(), None)?;
    println!("disparity {:.0} % dense, {} points", 100.0 * disparity.density(), cloud.points.len());
    // 5. Triangulate two board corners 8 squares apart (200 mm) from the raw pixels.
    let corner =
        |k: usize| triangulate_stereo(&calib.rig, left[0].corners[k], right[0].corners[k], &Default::default());
    let distance: glam::DVec3 = corner(8)?.point - corner(0)?.point;
    println!("corner 0 to corner 8: {:.2} mm (200 on the board)", distance.length());
    assert!((distance.length() - 200.0).abs() < 0.5 && cloud.points.len() > 10_000);
    Ok(())
}
