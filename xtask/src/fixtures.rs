//! `cargo xtask fixtures [--check]`: writes the committed fixtures
//! (`parallax_composition::fixtures`) into `fixtures/`, or checks that they are up to date.
//! Regeneration removes the files of the fixture folders that are not generated any more, so
//! `--check` passes right after it.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use parallax_composition::fixtures::{FixturePlan, fixture_files};
use parallax_composition::io::write_atomic;

/// Arguments of `cargo xtask fixtures`.
#[derive(clap::Args)]
pub struct Args {
    /// Do not write: regenerate in memory and fail when a committed file differs, is missing
    /// or is not generated any more.
    #[arg(long)]
    check: bool,
    /// The fixtures directory (default: `fixtures/` at the workspace root).
    #[arg(long)]
    dir: Option<PathBuf>,
}

/// Runs `cargo xtask fixtures`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let dir = args.dir.unwrap_or_else(|| crate::pipeline::workspace_root().join("fixtures"));
    let start = std::time::Instant::now();
    let files = fixture_files(&FixturePlan::default())?;
    if args.check {
        return Ok(match check(&dir, &files)? {
            None => {
                println!(
                    "fixtures are up to date: {} files in {} match a fresh generation ({:.1} s)",
                    files.len(),
                    dir.display(),
                    start.elapsed().as_secs_f64()
                );
                ExitCode::SUCCESS
            }
            Some(problem) => {
                eprintln!("fixtures are stale: {problem}\nrun `cargo xtask fixtures` and commit the result");
                ExitCode::FAILURE
            }
        });
    }
    let removed = write(&dir, &files)?;
    let bytes: usize = files.iter().map(|f| f.1.len()).sum();
    println!(
        "wrote {} fixture files ({:.2} MB) to {} in {:.1} s; removed {removed} stale files",
        files.len(),
        bytes as f64 / 1e6,
        dir.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// The fixture folders (first path component) that generation owns.
fn owned_folders(files: &[(PathBuf, Vec<u8>)]) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> =
        files.iter().filter_map(|f| f.0.components().next()).map(|c| PathBuf::from(c.as_os_str())).collect();
    dirs.dedup();
    dirs
}

/// Writes every file and removes the files of the owned folders that are not generated any
/// more (never anything outside them); returns how many were removed.
fn write(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> anyhow::Result<usize> {
    for (rel, bytes) in files {
        write_atomic(&dir.join(rel), bytes)?;
    }
    let mut removed = 0;
    for rel in list_files(dir)? {
        let owned = owned_folders(files).iter().any(|d| rel.starts_with(d));
        if owned && !files.iter().any(|f| f.0 == rel) {
            std::fs::remove_file(dir.join(&rel))
                .with_context(|| format!("removing stale {}", dir.join(&rel).display()))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Every regular file under `dir` (relative, sorted), skipping hidden entries (temporary files).
fn list_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    fn walk(root: &Path, sub: &Path, out: &mut Vec<PathBuf>) -> anyhow::Result<()> {
        let here = root.join(sub);
        for entry in std::fs::read_dir(&here).with_context(|| format!("reading {}", here.display()))? {
            let entry = entry?;
            let name = entry.file_name();
            if name.to_string_lossy().starts_with('.') {
                continue;
            }
            let rel = sub.join(&name);
            if entry.file_type()?.is_dir() {
                walk(root, &rel, out)?;
            } else {
                out.push(rel);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    if dir.exists() {
        walk(dir, Path::new(""), &mut out)?;
    }
    out.sort();
    Ok(out)
}

/// Compares the committed folder with a fresh generation; `Some(description of the first
/// difference)` when stale.
fn check(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> anyhow::Result<Option<String>> {
    for (rel, bytes) in files {
        let committed = dir.join(rel);
        let Ok(old) = std::fs::read(&committed) else {
            return Ok(Some(format!("{} is missing", committed.display())));
        };
        if &old != bytes {
            return Ok(Some(format!("{} differs from a fresh generation", committed.display())));
        }
    }
    for rel in list_files(dir)? {
        if !files.iter().any(|f| f.0 == rel) {
            return Ok(Some(format!("{} is not generated any more", dir.join(rel).display())));
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("xtask-fixtures-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// Writing then checking passes; an altered, a missing and an extra file are each named;
    /// regeneration removes the extra file so the check passes again.
    #[test]
    fn check_names_every_kind_of_staleness_and_regeneration_cures_it() {
        let plan = FixturePlan {
            mono_views: 2,
            stereo_views: 1,
            scene_width: 96,
            scene_height: 64,
            scene_max_disparity: 12.0,
            handeye_stations: 1,
        };
        let files = fixture_files(&plan).unwrap();
        let a = temp("a");
        write(&a, &files).unwrap();
        assert_eq!(list_files(&a).unwrap(), files.iter().map(|f| f.0.clone()).collect::<Vec<_>>(), "no other file");
        assert_eq!(check(&a, &files).unwrap(), None);
        let victim = a.join("mono/view_01.png");
        let mut bytes = std::fs::read(&victim).unwrap();
        let n = bytes.len();
        bytes[n / 2] ^= 1;
        std::fs::write(&victim, &bytes).unwrap();
        let problem = check(&a, &files).unwrap().expect("altered file must fail the check");
        assert!(problem.contains("mono/view_01.png") && problem.contains("differs"), "{problem}");
        write(&a, &files).unwrap();
        std::fs::remove_file(a.join("handeye/eye-in-hand.ron")).unwrap();
        assert!(check(&a, &files).unwrap().unwrap().contains("eye-in-hand.ron"));
        write(&a, &files).unwrap();
        std::fs::write(a.join("stereo/stale.png"), b"x").unwrap();
        assert!(check(&a, &files).unwrap().unwrap().contains("stale.png"));
        assert_eq!(write(&a, &files).unwrap(), 1);
        assert_eq!(check(&a, &files).unwrap(), None);
        std::fs::remove_dir_all(&a).unwrap();
    }
}
