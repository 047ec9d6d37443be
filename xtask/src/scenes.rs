//! `cargo xtask scenes`: lists the stereo worlds of a scene set (the zoo in `fixtures/zoo` by
//! default, a folder or glob of RON worlds, or worlds drawn from a distribution) and renders
//! them with their truth.
//!
//! Output contract: one line per scene, `scene: NAME size: WxH disparities: D factors: LIST`
//! (`LIST` comma-separated, `-` when none).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use parallax_composition::io::OutputSet;
use parallax_synthetic::{WorldDistribution, render_world};

/// Arguments of `cargo xtask scenes`.
#[derive(clap::Args)]
pub struct Args {
    /// The worlds: a folder of `.ron` worlds or a glob pattern (quote it); default the zoo,
    /// `fixtures/zoo`.
    #[arg(long, conflicts_with = "random")]
    scenes: Option<String>,
    /// Draw this many worlds from a distribution instead (see --distribution, --seed).
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=10_000))]
    random: Option<usize>,
    /// The distribution of --random (a RON `WorldDistribution`; default the built-in one).
    #[arg(long, requires = "random")]
    distribution: Option<PathBuf>,
    /// First seed of --random (the worlds take seeds seed, seed + 1, …).
    #[arg(long, default_value_t = 0, requires = "random")]
    seed: u64,
    /// Render every world into DIR/NAME/: left.png, right.png, disparity.pfm,
    /// disparity_right.pfm, occluded.png, occluded_right.png (255 = occluded), world.ron.
    #[arg(long)]
    render: Option<PathBuf>,
}

/// The RON worlds of `--scenes` (a folder's `.ron` files, or a glob), or the zoo.
pub fn world_paths(scenes: Option<&str>) -> anyhow::Result<Vec<PathBuf>> {
    let spec = match scenes {
        Some(s) => s.to_string(),
        None => crate::pipeline::workspace_root().join("fixtures").join("zoo").display().to_string(),
    };
    let dir = Path::new(&spec);
    let paths = if dir.is_dir() {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .collect();
        v.sort();
        v
    } else {
        parallax_composition::io::expand_glob(&spec)?
    };
    anyhow::ensure!(!paths.is_empty(), "the scene set is empty: no .ron world in {spec}");
    Ok(paths)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let (worlds, inputs) = match args.random {
        Some(n) => {
            let d = match &args.distribution {
                Some(p) => parallax_composition::io::read_ron::<WorldDistribution>(p)?,
                None => WorldDistribution::default(),
            };
            d.validate().map_err(|e| anyhow::anyhow!("the distribution: {e}"))?;
            let worlds = (0..n as u64)
                .map(|k| {
                    let seed = args.seed.wrapping_add(k);
                    Ok((format!("random-{seed}"), d.draw(seed)?))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            (worlds, args.distribution.iter().cloned().collect::<Vec<_>>())
        }
        None => {
            let paths = world_paths(args.scenes.as_deref())?;
            (parallax_composition::tune::read_worlds(&paths)?, paths)
        }
    };
    let mut set = OutputSet::new();
    if let Some(dir) = &args.render {
        let outputs: Vec<PathBuf> = worlds.iter().map(|(n, _)| dir.join(n).join("world.ron")).collect();
        parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    }
    let started = std::time::Instant::now();
    for (name, w) in &worlds {
        if let Some(dir) = &args.render {
            let views = render_world(w).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
            parallax_composition::tune::add_world_files(&mut set, &dir.join(name), w, &views)?;
        }
        let factors = w.factors();
        println!(
            "scene: {name} size: {}x{} disparities: {} factors: {}",
            w.width,
            w.height,
            w.disparities,
            if factors.is_empty() { "-".to_string() } else { factors.join(",") }
        );
    }
    if let Some(dir) = &args.render {
        let files = set.commit()?;
        println!(
            "rendered {} scenes into {} ({} files, {:.2} s)",
            worlds.len(),
            dir.display(),
            files.len(),
            started.elapsed().as_secs_f64()
        );
    }
    Ok(ExitCode::SUCCESS)
}
