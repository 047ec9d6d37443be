//! `cargo xtask fixtures`.

use std::process::ExitCode;

/// Arguments of `cargo xtask fixtures`.
#[derive(clap::Args)]
pub struct Args {
    /// Arguments not yet defined (the stage is not available yet).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    rest: Vec<String>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let _ = args.rest;
    anyhow::bail!("`cargo xtask fixtures` is not yet available")
}
