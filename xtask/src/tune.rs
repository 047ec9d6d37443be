//! `cargo xtask tune`: searches the matcher's parameters over a scene set (the zoo, rendered
//! worlds, real pairs with ground truth) and writes the chosen configuration for
//! `disparity --config`; `--realism` ranks a fixed set of configurations on the zoo and on real
//! pairs and prints the rank correlation.
//!
//! Output contract: one line per configuration, `config: N method: M bad2: X bad2_overlap: Y
//! density: Z ms: T pareto: yes|no` (bad2 with missing = bad and density in percent of the
//! scored pixels, bad2_overlap where OpenCV's matchers also answer, ms per scene; means over the
//! scenes), then `best: N`; with `--realism` also `real: N bad2: X bad2_overlap: Y density: Z`
//! per configuration on the real pairs and `rank_correlation: R`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use parallax_composition::io::OutputSet;
use parallax_composition::plots::Pictures;
use parallax_composition::tune::{self, DisparityConfig, Score, TuneScene, TuneSpace};

/// Arguments of `cargo xtask tune`.
#[derive(clap::Args)]
pub struct Args {
    /// Worlds to tune on: a folder of `.ron` worlds or a glob pattern (default the zoo,
    /// `fixtures/zoo`, unless --pairs is given alone).
    #[arg(long)]
    scenes: Option<String>,
    /// Real pairs with ground truth in Middlebury's layout (imL.png, imR.png, groundtruth.png,
    /// nonocc.png, info.txt): a pair's folder or a folder of pair folders; repeatable. With
    /// --realism, default `../shared/data/middlebury`.
    #[arg(long)]
    pairs: Vec<PathBuf>,
    /// The parameter space (a RON `TuneSpace`: each parameter's values or `(min, max, step)`
    /// range; default the built-in space).
    #[arg(long)]
    space: Option<PathBuf>,
    /// grid (every configuration of the space; refused when it holds more than --configs) or
    /// random (--configs drawn without repeats).
    #[arg(long, default_value = "random")]
    search: String,
    /// Configurations searched, besides the two defaults scored first (1..=10000).
    #[arg(long, default_value_t = 50, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=10_000))]
    configs: usize,
    /// Seed of the random search.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Timed runs per scene and configuration (the median is reported; 1..=100).
    #[arg(long, default_value_t = 1, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=100))]
    runs: usize,
    /// Matcher threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Rank the fixed realism set on the worlds and on the real pairs, and print the rank
    /// correlation (skipped with a message when the real pairs are absent).
    #[arg(long)]
    realism: bool,
    /// Output folder: config.ron (the chosen configuration, for `disparity --config`),
    /// report.html and tune-pareto.png / .svg (required without --realism).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The real pairs of `paths`: each a pair folder (it holds imL.png) or a folder of them.
fn pair_dirs(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut dirs = Vec::new();
    for p in paths {
        anyhow::ensure!(p.is_dir(), "--pairs {}: no such folder", p.display());
        if p.join("imL.png").is_file() {
            dirs.push(p.clone());
        } else {
            let mut sub: Vec<PathBuf> = std::fs::read_dir(p)?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|d| d.join("imL.png").is_file())
                .collect();
            sub.sort();
            anyhow::ensure!(!sub.is_empty(), "--pairs {}: no pair folder (with imL.png) in it", p.display());
            dirs.extend(sub);
        }
    }
    Ok(dirs)
}

fn load_pairs(dirs: &[PathBuf]) -> anyhow::Result<Vec<TuneScene>> {
    dirs.iter().map(|d| TuneScene::from_middlebury(d).with_context(|| format!("pair {}", d.display()))).collect()
}

fn load_worlds(scenes: Option<&str>) -> anyhow::Result<Vec<TuneScene>> {
    Ok(tune::scenes_from_worlds(&crate::scenes::world_paths(scenes)?)?)
}

/// Scores every configuration on every scene with a progress bar.
fn score_all(
    configs: &[DisparityConfig],
    scenes: &[TuneScene],
    args: &Args,
    label: &'static str,
) -> anyhow::Result<Vec<Score>> {
    let progress = crate::progress::Progress::new(label, configs.len() as u64, "configurations")?;
    let mut out = Vec::with_capacity(configs.len());
    for c in configs {
        out.push(tune::score(c, scenes, args.threads, args.runs)?);
        progress.inc();
    }
    progress.finish();
    Ok(out)
}

fn print_scores(configs: &[DisparityConfig], scores: &[Score], pareto: &[bool]) {
    for (i, ((c, s), p)) in configs.iter().zip(scores).zip(pareto).enumerate() {
        println!(
            "config: {i} method: {} bad2: {:.3} bad2_overlap: {:.3} density: {:.2} ms: {:.2} pareto: {}",
            c.method_name(),
            s.bad2,
            s.bad2_overlap,
            s.density,
            s.ms,
            if *p { "yes" } else { "no" }
        );
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if args.realism {
        return realism(&args);
    }
    let out = args.out.as_deref().context("--out is required: the folder of config.ron and the report")?;
    // everything is checked before any scene is rendered or matched
    let space = match &args.space {
        Some(p) => parallax_composition::io::read_ron::<TuneSpace>(p)?,
        None => TuneSpace::default(),
    };
    space.check()?;
    let mut configs = tune::default_configs();
    let defaults = configs.len();
    match args.search.as_str() {
        "grid" => {
            let size = space.size();
            anyhow::ensure!(
                size <= args.configs,
                "the grid holds {size} configurations, more than --configs {}: raise --configs, narrow the space, or \
                 use --search random",
                args.configs
            );
            configs.extend(space.grid());
        }
        "random" => configs.extend(space.random(args.configs, args.seed)),
        other => anyhow::bail!("--search must be grid or random (got {other:?})"),
    }
    anyhow::ensure!(configs.len() > defaults, "the space holds no configuration the matcher accepts");
    let pair_dirs = pair_dirs(&args.pairs)?;
    let outputs = ["config.ron", "report.html", "tune-pareto.png", "tune-pareto.svg"].map(|n| out.join(n));
    let mut inputs: Vec<PathBuf> = args.space.iter().cloned().chain(pair_dirs.iter().cloned()).collect();
    if args.scenes.is_some() || pair_dirs.is_empty() {
        inputs.extend(crate::scenes::world_paths(args.scenes.as_deref())?);
    }
    parallax_composition::io::refuse_overwriting_inputs(&outputs, &inputs)?;
    let mut scenes =
        if args.scenes.is_some() || pair_dirs.is_empty() { load_worlds(args.scenes.as_deref())? } else { Vec::new() };
    scenes.extend(load_pairs(&pair_dirs)?);
    anyhow::ensure!(!scenes.is_empty(), "the scene set is empty");

    let started = std::time::Instant::now();
    let scores = score_all(&configs, &scenes, &args, "tune")?;
    let pareto = tune::pareto(&scores);
    let best = tune::best(&scores).context("no configuration scored")?;
    let names: Vec<String> = configs.iter().map(DisparityConfig::describe).collect();
    for (i, n) in names.iter().enumerate() {
        let tag = if i < defaults { " (default)" } else { "" };
        println!("# {i}: {n}{tag}");
    }
    print_scores(&configs, &scores, &pareto);
    println!("best: {best}");
    let scene_names: Vec<String> = scenes.iter().map(|s| s.name.clone()).collect();
    let mut pictures = Pictures::new("parallax tune");
    pictures.sections.push(parallax_composition::plots::tune::section(
        &names,
        &scores,
        &pareto,
        best,
        defaults,
        &scene_names,
    )?);
    let mut set = OutputSet::new();
    pictures.add_to(&mut set, out)?;
    set.add(out.join("config.ron"), parallax_composition::io::to_ron(&configs[best])?)?;
    set.commit()?;
    eprintln!(
        "{} configurations over {} scenes in {:.1} s; chosen: {} ({})",
        configs.len(),
        scenes.len(),
        started.elapsed().as_secs_f64(),
        best,
        names[best]
    );
    println!("wrote {}", out.join("config.ron").display());
    Ok(ExitCode::SUCCESS)
}

/// `--realism`: the fixed set on the worlds and on the real pairs, and their rank correlation.
fn realism(args: &Args) -> anyhow::Result<ExitCode> {
    let pairs = if args.pairs.is_empty() {
        let shared = crate::pipeline::workspace_root().join("..").join("shared").join("data").join("middlebury");
        if !shared.is_dir() {
            println!("skipped: no real pairs (../shared/data/middlebury not found; give --pairs)");
            return Ok(ExitCode::SUCCESS);
        }
        vec![shared]
    } else {
        args.pairs.clone()
    };
    let dirs = pair_dirs(&pairs)?;
    let configs = tune::realism_configs();
    let worlds = load_worlds(args.scenes.as_deref())?;
    let real = load_pairs(&dirs)?;
    let zoo_scores = score_all(&configs, &worlds, args, "zoo")?;
    let real_scores = score_all(&configs, &real, args, "real")?;
    let pareto = tune::pareto(&zoo_scores);
    for (i, c) in configs.iter().enumerate() {
        println!("# {i}: {}", c.describe());
    }
    print_scores(&configs, &zoo_scores, &pareto);
    println!("best: {}", tune::best(&zoo_scores).context("no configuration scored")?);
    for (i, s) in real_scores.iter().enumerate() {
        println!("real: {i} bad2: {:.3} bad2_overlap: {:.3} density: {:.2}", s.bad2, s.bad2_overlap, s.density);
    }
    let rho = tune::spearman(
        &zoo_scores.iter().map(|s| s.bad2).collect::<Vec<_>>(),
        &real_scores.iter().map(|s| s.bad2).collect::<Vec<_>>(),
    );
    let names: Vec<String> = real.iter().map(|s| s.name.clone()).collect();
    eprintln!(
        "{} configurations ranked on {} worlds and {} real pairs ({})",
        configs.len(),
        worlds.len(),
        real.len(),
        names.join(", ")
    );
    println!("rank_correlation: {rho:.3}");
    if let Some(out) = &args.out {
        let mut pictures = Pictures::new("parallax tune --realism");
        let names: Vec<String> = configs.iter().map(DisparityConfig::describe).collect();
        let best = tune::best(&zoo_scores).unwrap_or(0);
        let scene_names: Vec<String> = worlds.iter().map(|s| s.name.clone()).collect();
        let mut section =
            parallax_composition::plots::tune::section(&names, &zoo_scores, &pareto, best, 0, &scene_names)?;
        section
            .notes
            .push(format!("Spearman rank correlation of bad-2 between the worlds and the real pairs: {rho:.3}"));
        pictures.sections.push(section);
        pictures.write(out)?;
    }
    Ok(ExitCode::SUCCESS)
}
