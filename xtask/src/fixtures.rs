//! `cargo xtask fixtures [--check]`: writes the committed fixtures
//! (`parallax_composition::fixtures`) into `fixtures/`, or checks that they are up to date.
//! Regeneration removes the files of the fixture folders that are not generated any more, so
//! `--check` passes right after it.

use std::path::PathBuf;
use std::process::ExitCode;

use parallax_composition::fixtures::{FixturePlan, check_fixtures, fixture_files, write_fixtures};

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
        return Ok(match check_fixtures(&dir, &files)? {
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
    let removed = write_fixtures(&dir, &files)?;
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
