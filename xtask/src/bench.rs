//! `cargo xtask bench`: runs the criterion benchmarks of the `parallax-benches` crate in release.

use std::process::{Command, ExitCode};

/// Arguments of `cargo xtask bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Only benchmarks whose name contains this filter (criterion's filter).
    filter: Option<String>,
    /// Criterion's quick mode: fewer samples, for a first look.
    #[arg(long)]
    quick: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args(["bench", "-p", "parallax-benches", "--"]);
    if let Some(f) = &args.filter {
        cmd.arg(f);
    }
    if args.quick {
        cmd.arg("--quick");
    }
    let status = cmd.status()?;
    println!("bench: {}", if status.success() { "done" } else { "FAILED" });
    Ok(if status.success() { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}
