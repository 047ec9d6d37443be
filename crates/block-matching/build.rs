//! Sets `cfg(opt_level_zero)` when this crate is compiled at opt-level 0: the profile's
//! `opt-level` (a user's default `cargo run` or `cargo test`), or a later `-C opt-level` / `-O` in
//! the RUSTFLAGS. There the semi-global and block-matching kernels are not forced inline (`src/sgm.rs`, the
//! module docs): at opt-level 0 LLVM gives every local of every inlined body a stack slot of its
//! own, and the kernels' vector temporaries, pasted for every path count, mode and lane count,
//! made frames of up to 1 MiB (issue 50). Every other level inlines them, with the same code as
//! without this script.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(opt_level_zero)");
    println!("cargo::rerun-if-changed=build.rs");
    let mut level = std::env::var("OPT_LEVEL").unwrap_or_default();
    // rustc reads the profile's `-C opt-level` first and the RUSTFLAGS after it: the last wins
    let flags = std::env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let flags: Vec<&str> = flags.split('\x1f').collect();
    for (i, f) in flags.iter().enumerate() {
        let codegen = match *f {
            "-O" => Some("opt-level=2"),
            "-C" | "--codegen" => flags.get(i + 1).copied(),
            _ => f.strip_prefix("-C").or_else(|| f.strip_prefix("--codegen=")),
        };
        if let Some(v) = codegen.and_then(|c| c.strip_prefix("opt-level=")) {
            level = v.to_string();
        }
    }
    if level == "0" {
        println!("cargo::rustc-cfg=opt_level_zero");
    }
}
