//! Helpers shared by the xtask commands: atomic file output, RON, image loading.

use std::path::Path;

use anyhow::Context;

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, then a rename,
/// so a failed run never leaves a half-written result. Creates the parent directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("creating directory {}", dir.display()))?;
    let name = path.file_name().with_context(|| format!("{} has no file name", path.display()))?;
    let tmp = dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    std::fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))?;
    Ok(())
}

/// Serialises `value` as pretty RON and writes it atomically.
pub fn write_ron<T: serde::Serialize>(path: &Path, value: &T) -> anyhow::Result<()> {
    let text = ron::ser::to_string_pretty(value, ron::ser::PrettyConfig::default())
        .with_context(|| format!("serialising {}", path.display()))?;
    write_atomic(path, text.as_bytes())
}

/// Reads and deserialises a RON file, naming the file in every error.
pub fn read_ron<T: serde::de::DeserializeOwned>(path: &Path) -> anyhow::Result<T> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    ron::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

/// Loads an image as 8-bit grayscale (colour is converted with the image crate's luma weights).
pub fn load_gray(path: &Path) -> anyhow::Result<image::GrayImage> {
    let img = image::open(path).with_context(|| format!("reading image {}", path.display()))?;
    Ok(img.into_luma8())
}

/// Encodes an image as PNG and writes it atomically.
pub fn save_png<P, C>(path: &Path, img: &image::ImageBuffer<P, C>) -> anyhow::Result<()>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .with_context(|| format!("encoding {}", path.display()))?;
    write_atomic(path, &bytes)
}

/// Expands a glob pattern into a sorted list of paths; errors when nothing matches.
pub fn expand_glob(pattern: &str) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let mut paths: Vec<_> =
        glob::glob(pattern).with_context(|| format!("bad glob pattern {pattern:?}"))?.filter_map(Result::ok).collect();
    paths.sort();
    anyhow::ensure!(!paths.is_empty(), "no file matches {pattern:?}");
    Ok(paths)
}

/// `|v_left − v_right|` of every corner of matched left/right grids after rectification
/// (point-level: undistort, rotate, project; no image resampling), in pixels.
pub fn rectified_abs_dv(
    rig: &parallax_camera_model::StereoRig,
    rect: &parallax_stereo_rectify::Rectification,
    left: &[parallax_camera_model::CornerGrid],
    right: &[parallax_camera_model::CornerGrid],
) -> anyhow::Result<Vec<f64>> {
    let mut dv = Vec::new();
    for (l, r) in left.iter().zip(right) {
        let lp = parallax_stereo_rectify::rectify_points(&rig.left, rect.r1, &rect.p1, &l.corners)?;
        let rp = parallax_stereo_rectify::rectify_points(&rig.right, rect.r2, &rect.p2, &r.corners)?;
        dv.extend(lp.iter().zip(&rp).map(|(a, b)| (a.y - b.y).abs()));
    }
    Ok(dv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp_file() {
        let dir = std::env::temp_dir().join(format!("xtask-util-{}", std::process::id()));
        let path = dir.join("a.ron");
        write_ron(&path, &vec![1, 2, 3]).unwrap();
        write_ron(&path, &vec![4]).unwrap();
        let back: Vec<i32> = read_ron(&path).unwrap();
        assert_eq!(back, vec![4]);
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1, "temporary files left behind: {names:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unreadable_inputs_name_the_file() {
        let err = read_ron::<Vec<i32>>(Path::new("/nonexistent/x.ron")).unwrap_err();
        assert!(format!("{err:#}").contains("/nonexistent/x.ron"));
        let err = load_gray(Path::new("/nonexistent/x.png")).unwrap_err();
        assert!(format!("{err:#}").contains("/nonexistent/x.png"));
        assert!(expand_glob("/nonexistent/*.png").is_err());
    }
}
