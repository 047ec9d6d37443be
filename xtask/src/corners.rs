//! `cargo xtask corners`.

use std::process::ExitCode;

/// Arguments of `cargo xtask corners`.
#[derive(clap::Args)]
pub struct Args {
    /// Arguments not yet defined (the stage is not available yet).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    rest: Vec<String>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let _ = args.rest;
    anyhow::bail!("`cargo xtask corners` is not yet available")
}
