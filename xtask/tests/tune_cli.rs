//! `scenes` and `tune` through the built binary: the zoo listed and rendered with its truth,
//! a search whose choice beats the defaults and that `disparity --config` reproduces bit for
//! bit, the refusals before any work, and the realism check on `../shared`'s pairs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use parallax_composition::tune::{DisparityConfig, TuneScene};
use parallax_synthetic::{StereoWorld, render_world};

mod common;
use common::Temp;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the workspace").to_path_buf()
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask")).args(args).current_dir(root()).output().expect("running xtask")
}

fn ok(out: &Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    stdout
}

fn fails_naming(out: &Output, word: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit 0 on a bad input:\n{}", String::from_utf8_lossy(&out.stdout));
    assert!(stderr.contains(word), "the error does not name {word:?}:\n{stderr}");
}

/// The value of `key:` in a contract line.
fn key(line: &str, key: &str) -> f64 {
    let tokens: Vec<&str> = line.split_whitespace().collect();
    let i = tokens.iter().position(|t| *t == format!("{key}:")).unwrap_or_else(|| panic!("no {key} in {line}"));
    tokens[i + 1].parse().unwrap_or_else(|_| panic!("{key} in {line}"))
}

fn world(name: &str) -> StereoWorld {
    let p = root().join("fixtures").join("zoo").join(format!("{name}.ron"));
    StereoWorld::from_ron(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn scenes_lists_the_zoo_and_renders_each_world_with_its_truth() {
    let dir = Temp::new("tune", "scenes");
    let stdout = ok(&run(&["scenes", "--render", dir.to_str().unwrap()]));
    let lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("scene: ")).collect();
    assert!(lines.len() >= 12, "{stdout}");
    for l in &lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        assert_eq!((t[0], t[2], t[4], t[6]), ("scene:", "size:", "disparities:", "factors:"), "{l}");
        assert_eq!(t.len(), 8, "{l}");
    }
    let line = lines.iter().find(|l| l.starts_with("scene: posts-and-wires ")).unwrap();
    assert!(line.contains(" size: 320x240 disparities: 48 factors: ") && line.contains("thin"), "{line}");
    // the files hold the world's truth and views
    let w = world("spheres");
    let v = render_world(&w).unwrap();
    let d = dir.join("spheres");
    let truth = parallax_block_matching::from_pfm(&std::fs::read(d.join("disparity.pfm")).unwrap(), "truth").unwrap();
    assert_eq!(truth, v.disparity);
    assert_eq!(image::open(d.join("left.png")).unwrap().to_luma8(), v.left.to_luma8());
    let occluded = image::open(d.join("occluded.png")).unwrap().to_luma8();
    assert!(occluded.as_raw().iter().zip(&v.occluded).all(|(&p, &o)| (p == 255) == o));
    assert_eq!(StereoWorld::from_ron(&std::fs::read_to_string(d.join("world.ron")).unwrap()).unwrap(), w);
}

#[test]
fn scenes_draws_random_worlds_from_a_distribution() {
    let a = ok(&run(&["scenes", "--random", "3", "--seed", "7"]));
    let b = ok(&run(&["scenes", "--random", "3", "--seed", "7"]));
    assert_eq!(a, b);
    assert_eq!(a.lines().filter(|l| l.starts_with("scene: random-")).count(), 3, "{a}");
}

#[test]
fn tune_chooses_a_configuration_that_beats_the_defaults_and_disparity_config_reproduces_its_maps() {
    let dir = Temp::new("tune", "search");
    // a grid around the filling settings (no left–right check, no speckle filter): with missing
    // counted as bad they score better than the defaults on the zoo
    let space = dir.join("space.ron");
    std::fs::write(
        &space,
        "(method: [Sgm], prefilter: [XSobel(cap: 31)], sgm_block: (min: 3, max: 5, step: 2), sgm_paths: [Five], \
         p1: (min: 24, max: 24, step: 1), p2: (min: 32, max: 32, step: 1), uniqueness: (min: 0, max: 0, step: 1), \
         lr_max_diff: [None, Some(2)], speckle_window: (min: 0, max: 0, step: 1), colour: [true])",
    )
    .unwrap();
    let out = dir.join("out");
    let stdout =
        ok(&run(&["tune", "--space", space.to_str().unwrap(), "--search", "grid", "--out", out.to_str().unwrap()]));
    let configs: Vec<&str> = stdout.lines().filter(|l| l.starts_with("config: ")).collect();
    assert_eq!(configs.len(), 2 + 4, "{stdout}");
    for (i, l) in configs.iter().enumerate() {
        assert_eq!(key(l, "config") as usize, i);
        assert!(l.contains(" method: ") && l.ends_with(" pareto: yes") || l.ends_with(" pareto: no"), "{l}");
    }
    let best: usize = stdout.lines().find_map(|l| l.strip_prefix("best: ")).unwrap().parse().unwrap();
    let bad2: Vec<f64> = configs.iter().map(|l| key(l, "bad2")).collect();
    assert!(bad2.iter().all(|&b| b >= bad2[best]), "best {best} of {bad2:?}");
    assert!(best >= 2 && bad2[best] < bad2[0] && bad2[best] < bad2[1], "the defaults won: {bad2:?}");
    // the best is on the Pareto front (nothing is both more accurate and faster)
    assert!(configs[best].ends_with("pareto: yes"));
    assert!(out.join("report.html").is_file() && out.join("tune-pareto.svg").is_file());

    // disparity --config matches as tune did: the same maps bit for bit, grey and colour
    let config_path = out.join("config.ron");
    let config = DisparityConfig::read(&config_path).unwrap();
    assert!(config.colour());
    let images = dir.join("images");
    ok(&run(&["scenes", "--scenes", "fixtures/zoo/colour.ron", "--render", images.to_str().unwrap()]));
    ok(&run(&["scenes", "--scenes", "fixtures/zoo/planes.ron", "--render", images.to_str().unwrap()]));
    for name in ["colour", "planes"] {
        let d = images.join(name);
        let map_dir = dir.join(format!("map-{name}"));
        ok(&run(&[
            "disparity",
            "--config",
            config_path.to_str().unwrap(),
            "--left",
            d.join("left.png").to_str().unwrap(),
            "--right",
            d.join("right.png").to_str().unwrap(),
            "--disparities",
            "48",
            "--runs",
            "1",
            "--threads",
            "2",
            "--out",
            map_dir.to_str().unwrap(),
        ]));
        let cli =
            parallax_block_matching::from_pfm(&std::fs::read(map_dir.join("disparity.pfm")).unwrap(), "map").unwrap();
        let scene = TuneScene::from_world(name.into(), &world(name)).unwrap();
        let (lib, _) = scene.run(&config, 2, 1).unwrap();
        assert_eq!(cli.data().len(), lib.data().len());
        assert!(cli.data().iter().zip(lib.data()).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: maps differ");
    }
}

#[test]
fn tune_refuses_bad_input_before_any_work() {
    let dir = Temp::new("tune", "bad");
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    // a range out of bounds (an even window)
    let space = dir.join("even.ron");
    std::fs::write(&space, "(block: (min: 4, max: 8, step: 2))").unwrap();
    fails_naming(&run(&["tune", "--space", space.to_str().unwrap(), "--out", o]), "block");
    let space = dir.join("p1.ron");
    std::fs::write(&space, "(p1: (min: 0, max: 8, step: 4))").unwrap();
    fails_naming(&run(&["tune", "--space", space.to_str().unwrap(), "--out", o]), "p1");
    // an empty scene set
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    fails_naming(&run(&["tune", "--scenes", empty.to_str().unwrap(), "--out", o]), "empty");
    // a world beyond the memory budget
    let huge = dir.join("huge");
    std::fs::create_dir_all(&huge).unwrap();
    let mut w = world("planes");
    w.width = 16384;
    w.height = 16384;
    std::fs::write(huge.join("huge.ron"), w.to_ron()).unwrap();
    fails_naming(&run(&["tune", "--scenes", huge.to_str().unwrap(), "--out", o]), "budget");
    // ground truth of the wrong size
    let pair = dir.join("pair");
    std::fs::create_dir_all(&pair).unwrap();
    image::GrayImage::new(64, 48).save(pair.join("imL.png")).unwrap();
    image::GrayImage::new(64, 48).save(pair.join("imR.png")).unwrap();
    image::GrayImage::new(60, 48).save(pair.join("groundtruth.png")).unwrap();
    image::GrayImage::new(64, 48).save(pair.join("nonocc.png")).unwrap();
    std::fs::write(pair.join("info.txt"), "4\n20\n").unwrap();
    fails_naming(&run(&["tune", "--pairs", pair.to_str().unwrap(), "--out", o]), "60x48");
    // and nothing was written
    assert!(!out.exists(), "{} appeared", out.display());
}

#[test]
fn the_zoo_ranks_matchers_as_the_real_middlebury_pairs_do() {
    let shared = root().join("..").join("shared").join("data").join("middlebury");
    let stdout = ok(&run(&["tune", "--realism", "--threads", "2"]));
    if !shared.is_dir() {
        assert!(stdout.contains("skipped"), "{stdout}");
        println!("skipped: ../shared not found");
        return;
    }
    let zoo: Vec<f64> = stdout.lines().filter(|l| l.starts_with("config: ")).map(|l| key(l, "bad2")).collect();
    let real: Vec<f64> = stdout.lines().filter(|l| l.starts_with("real: ")).map(|l| key(l, "bad2")).collect();
    assert!(zoo.len() >= 8 && zoo.len() == real.len(), "{stdout}");
    let rho: f64 = key(stdout.lines().find(|l| l.starts_with("rank_correlation: ")).unwrap(), "rank_correlation");
    // the printed correlation is Spearman's of the printed scores (no ties among them)
    let rank = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| v.iter().filter(|y| *y < x).count() as f64).collect() };
    let (a, b) = (rank(&zoo), rank(&real));
    let n = a.len() as f64;
    let d2: f64 = a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum();
    let independent = 1.0 - 6.0 * d2 / (n * (n * n - 1.0));
    assert!((rho - independent).abs() < 2e-3, "printed {rho}, recomputed {independent}");
    assert!(rho >= 0.8, "rank correlation {rho}\n{stdout}");
}
