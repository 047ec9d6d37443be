//! Tidy tests (rust-analyzer style): checks of the repository itself that keep the
//! architecture's invariants true. They read files only and run with `cargo test`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the workspace").to_path_buf()
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("reading {}: {e}", p.display()))
}

/// Every `*.rs` file below `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(rust_files(&p));
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// The members of the workspace: (directory, parsed manifest).
fn members() -> Vec<(PathBuf, toml_lite::Manifest)> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root().join("crates"))
        .expect("crates/")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("Cargo.toml").is_file())
        .collect();
    dirs.push(root().join("xtask"));
    dirs.push(root().join("benches"));
    dirs.push(root().join("python"));
    dirs.sort();
    dirs.into_iter().map(|d| (d.clone(), toml_lite::Manifest::parse(&read(&d.join("Cargo.toml"))))).collect()
}

/// The stage crates: one stage each, meeting only in the composition layer.
const STAGES: [&str; 7] = [
    "parallax-corner-detection",
    "parallax-planar-calibration",
    "parallax-stereo-rectify",
    "parallax-block-matching",
    "parallax-triangulation",
    "parallax-hand-eye",
    "parallax-synthetic",
];

#[test]
fn the_crate_graph_is_a_star() {
    let shared = ["parallax-camera-model", "parallax-least-squares", "parallax-simd"];
    let mut seen = 0;
    for (dir, m) in members() {
        let ours = |deps: &[String]| deps.iter().filter(|d| d.starts_with("parallax-")).cloned().collect::<Vec<_>>();
        let deps = ours(&m.dependencies);
        match m.name.as_str() {
            "parallax-camera-model" | "parallax-least-squares" | "parallax-simd" => {
                assert!(deps.is_empty(), "{} depends on {deps:?}: the foundations depend on no stage", dir.display())
            }
            name if STAGES.contains(&name) => {
                seen += 1;
                for d in &deps {
                    assert!(
                        shared.contains(&d.as_str()),
                        "stage crate {name} depends on {d}: stages meet only in parallax-composition"
                    );
                }
                for d in ours(&m.dev_dependencies) {
                    assert!(
                        shared.contains(&d.as_str()) || d == "parallax-synthetic",
                        "stage crate {name} has the dev-dependency {d} (only parallax-synthetic is allowed)"
                    );
                }
            }
            _ => {}
        }
    }
    assert_eq!(seen, STAGES.len(), "a stage crate is missing or renamed");
}

#[test]
fn every_declared_dependency_is_used() {
    let mut unused = Vec::new();
    for (dir, m) in members() {
        let text_of = |subdirs: &[&str]| -> String {
            subdirs.iter().flat_map(|s| rust_files(&dir.join(s))).map(|p| read(&p)).collect::<Vec<_>>().join("\n")
        };
        let lib_dirs: &[&str] = if m.name == "parallax-benches" { &["src", "benches"] } else { &["src"] };
        let lib_text = text_of(lib_dirs);
        let all_text = text_of(&["src", "tests", "benches", "examples"]);
        for (deps, text, kind) in
            [(&m.dependencies, &lib_text, "dependency"), (&m.dev_dependencies, &all_text, "dev-dependency")]
        {
            for d in deps {
                let id = d.replace('-', "_");
                let used = [format!("{id}::"), format!("use {id}"), format!("{id} as "), format!("{id}!")]
                    .iter()
                    .any(|pat| text.contains(pat.as_str()));
                if !used {
                    unused.push(format!("{}: {kind} {d}", m.name));
                }
            }
        }
    }
    assert!(unused.is_empty(), "declared but never used (remove them):\n{}", unused.join("\n"));
}

#[test]
fn publishable_crates_carry_their_metadata() {
    for f in ["LICENSE-MIT", "LICENSE-APACHE"] {
        assert!(root().join(f).is_file(), "{f} is missing");
    }
    for (dir, m) in members() {
        if !m.publish {
            continue;
        }
        assert!(m.name.starts_with("parallax"), "{}: package names start with parallax (free on crates.io)", m.name);
        for key in ["description", "readme", "keywords", "categories"] {
            assert!(m.keys.contains(&key.to_string()), "{}: no `{key}` in its Cargo.toml", m.name);
        }
        assert!(dir.join("README.md").is_file(), "{}: README.md missing", m.name);
    }
}

#[test]
fn every_path_in_architecture_md_exists() {
    let text = read(&root().join("ARCHITECTURE.md"));
    let mut section: Option<PathBuf> = None;
    let mut missing = Vec::new();
    for line in text.lines() {
        if let Some(h) = line.strip_prefix("### `") {
            section = h.split('`').next().map(|p| root().join(p.trim_end_matches('/')));
        }
        for (i, token) in line.split('`').enumerate() {
            if i % 2 == 0 || token.contains(' ') || token.starts_with("../") {
                continue;
            }
            let top_level = ["crates/", "xtask", "benches", "python/", "fixtures/", ".ci/", ".cargo/"]
                .iter()
                .any(|p| token.starts_with(p));
            let file = [".rs", ".md", ".toml", ".ron"].iter().any(|x| token.ends_with(x));
            if top_level {
                if !root().join(token).exists() {
                    missing.push(token.to_string());
                }
            } else if file {
                let found = match &section {
                    Some(dir) => rust_and_other_files(dir).iter().any(|p| p.ends_with(token)),
                    None => root().join(token).exists(),
                };
                if !found {
                    missing
                        .push(format!("{token} (in section {:?})", section.as_ref().map(|s| s.display().to_string())));
                }
            }
        }
    }
    assert!(missing.is_empty(), "ARCHITECTURE.md names paths that do not exist: {missing:?}");
}

fn rust_and_other_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            if !p.ends_with("target") {
                out.extend(rust_and_other_files(&p));
            }
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn every_unsafe_fn_documents_its_safety_contract() {
    let mut bad = Vec::new();
    let mut count = 0;
    for (dir, _) in members() {
        for f in rust_files(&dir) {
            let text = read(&f);
            let lines: Vec<&str> = text.lines().collect();
            for (i, l) in lines.iter().enumerate() {
                let code = l.trim_start();
                let declares = ["unsafe fn ", "pub unsafe fn ", "pub(crate) unsafe fn ", "pub(super) unsafe fn "]
                    .iter()
                    .any(|d| code.starts_with(d));
                if !declares {
                    continue;
                }
                count += 1;
                // The doc block above the item (attributes may sit between).
                let mut j = i;
                let mut doc = String::new();
                while j > 0 {
                    j -= 1;
                    let p = lines[j].trim_start();
                    if p.starts_with("///") {
                        doc.push_str(p);
                    } else if !p.starts_with("#[") {
                        break;
                    }
                }
                if !doc.contains("# Safety") {
                    bad.push(format!("{}:{}", f.strip_prefix(root()).unwrap_or(&f).display(), i + 1));
                }
            }
        }
    }
    assert!(count > 0, "no unsafe fn found at all: the scan is broken");
    assert!(bad.is_empty(), "unsafe fn without a `# Safety` doc section: {bad:?}");
}

/// The CPU is asked in one place: `parallax-simd` detects the instruction set once per process
/// and its tokens prove it; no other file of the workspace queries CPU features or declares an
/// instruction-set enum of its own.
#[test]
fn the_cpu_is_asked_in_one_place() {
    let owner = root().join("crates/simd/src/lib.rs");
    let mut sites = Vec::new();
    let mut enums = Vec::new();
    for dir in [root().join("crates"), root().join("xtask"), root().join("benches")] {
        for f in rust_files(&dir) {
            let text = read(&f);
            let name = f.strip_prefix(root()).unwrap_or(&f).display().to_string();
            let probes = text.matches(concat!("is_x86_feature", "_detected")).count();
            if probes > 0 && f != owner {
                sites.push(format!("{name} ({probes})"));
            }
            for l in text.lines().map(str::trim_start) {
                let l = l.strip_prefix("pub ").or_else(|| l.strip_prefix("pub(crate) ")).unwrap_or(l);
                if let Some(rest) = l.strip_prefix("enum ")
                    && (rest.contains("Isa") || rest.starts_with("SimdLevel"))
                    && f != owner
                {
                    enums.push(format!("{name}: {l}"));
                }
            }
        }
    }
    assert!(read(&owner).contains(concat!("is_x86_feature", "_detected")), "the scan is broken");
    assert!(sites.is_empty(), "CPU feature queries outside parallax-simd (use its tokens): {sites:?}");
    assert!(enums.is_empty(), "instruction-set enums outside parallax-simd (use SimdLevel / its tokens): {enums:?}");
}

/// No import circle among a crate's modules (rust-analyzer's rule: a module never uses a sibling
/// that uses it back, directly or through others): the edges are `crate::<module>` paths in code
/// (not in comments). A ratchet: the crates listed in `KNOWN` still have circles to untie; every
/// other crate must have none, and a listed crate that has none must leave the list.
#[test]
fn no_module_imports_itself_back() {
    const KNOWN: [&str; 4] = ["hand-eye", "planar-calibration", "stereo-rectify", "synthetic"];
    let mut bad = Vec::new();
    for (dir, _) in members() {
        let src = dir.join("src");
        let krate = dir.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        let mut graph: BTreeMap<String, std::collections::BTreeSet<String>> = BTreeMap::new();
        for f in rust_files(&src) {
            let rel = f.strip_prefix(&src).expect("below src");
            let top = rel
                .components()
                .next()
                .expect("a path")
                .as_os_str()
                .to_string_lossy()
                .trim_end_matches(".rs")
                .to_string();
            if top == "lib" || top == "main" {
                continue;
            }
            let deps = graph.entry(top).or_default();
            for line in read(&f).lines().filter(|l| !l.trim_start().starts_with("//")) {
                for (i, _) in line.match_indices("crate::") {
                    let name: String =
                        line[i + 7..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                    deps.insert(name);
                }
            }
        }
        // edges to sibling modules only (not to re-exports at the root, not to itself)
        let names: std::collections::BTreeSet<String> = graph.keys().cloned().collect();
        for (m, deps) in graph.iter_mut() {
            deps.retain(|d| names.contains(d) && d != m);
        }
        // a module reaches itself through its dependencies
        let reaches_itself = |m: &str| {
            let mut stack: Vec<&str> = graph[m].iter().map(String::as_str).collect();
            let mut seen = std::collections::BTreeSet::new();
            while let Some(d) = stack.pop() {
                if d == m {
                    return true;
                }
                if seen.insert(d) {
                    stack.extend(graph[d].iter().map(String::as_str));
                }
            }
            false
        };
        let circular: Vec<&String> = names.iter().filter(|m| reaches_itself(m)).collect();
        match (KNOWN.contains(&krate.as_str()), circular.is_empty()) {
            (false, false) => bad.push(format!("{krate}: modules in a circle: {circular:?}")),
            (true, true) => bad.push(format!("{krate} has no circle any more: remove it from KNOWN")),
            _ => {}
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn workspace_lints_hold_the_unsafe_rules() {
    let text = read(&root().join("Cargo.toml"));
    assert!(text.contains("undocumented_unsafe_blocks = \"warn\""), "clippy::undocumented_unsafe_blocks must be on");
    assert!(text.contains("unsafe_op_in_unsafe_fn = \"deny\""));
    let mut missing = BTreeMap::new();
    for (dir, m) in members() {
        if !read(&dir.join("Cargo.toml")).contains("[lints]\nworkspace = true") {
            missing.insert(m.name, ());
        }
    }
    assert!(missing.is_empty(), "crates not using [workspace.lints]: {:?}", missing.keys());
}

/// A tiny reader of the parts of Cargo.toml these checks need (the manifests are ours and
/// simple: one key per line).
mod toml_lite {
    /// What the checks read from a manifest.
    pub struct Manifest {
        pub name: String,
        pub publish: bool,
        pub keys: Vec<String>,
        pub dependencies: Vec<String>,
        pub dev_dependencies: Vec<String>,
    }

    impl Manifest {
        pub fn parse(text: &str) -> Self {
            let mut m = Manifest {
                name: String::new(),
                publish: true,
                keys: Vec::new(),
                dependencies: Vec::new(),
                dev_dependencies: Vec::new(),
            };
            let mut section = String::new();
            for line in text.lines().map(str::trim) {
                if line.starts_with('[') {
                    section = line.trim_matches(['[', ']']).to_string();
                    continue;
                }
                let Some((key, value)) = line.split_once('=') else { continue };
                let key = key.trim().trim_end_matches(".workspace").to_string();
                match section.as_str() {
                    "package" => {
                        if key == "name" {
                            m.name = value.trim().trim_matches('"').to_string();
                        }
                        if key == "publish" && value.trim() == "false" {
                            m.publish = false;
                        }
                        m.keys.push(key);
                    }
                    "dependencies" => m.dependencies.push(key),
                    "dev-dependencies" => m.dev_dependencies.push(key),
                    _ => {}
                }
            }
            m
        }
    }
}

/// One camera vocabulary: every lens is a variant of `camera_model::Lens` and a camera of any
/// lens is one `Camera`, so no public item is a wide-lens twin of another (`FisheyeCamera` beside
/// `Camera`, `calibrate_fisheye` beside `calibrate_camera`, …): a new `pub … Fisheye…` item fails
/// this test. (OpenCV's `cv::fisheye` is named in docs and private helpers, not in the API.)
#[test]
fn no_fisheye_twins() {
    let mut names = Vec::new();
    for (dir, _) in members() {
        let src = dir.join("src");
        if !src.is_dir() {
            continue;
        }
        for f in rust_files(&src) {
            for (n, line) in read(&f).lines().enumerate() {
                let Some(rest) = line.trim_start().strip_prefix("pub ") else { continue };
                let Some(rest) =
                    ["struct ", "enum ", "fn ", "type ", "trait "].iter().find_map(|k| rest.strip_prefix(k))
                else {
                    continue;
                };
                let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                names.push((format!("{}:{}", f.display(), n + 1), name));
            }
        }
    }
    for expected in ["Camera", "Lens", "calibrate_camera", "stereo_rectify"] {
        assert!(names.iter().any(|(_, n)| n == expected), "the scan did not find `pub … {expected}`: is it broken?");
    }
    let twins: Vec<String> = names
        .iter()
        .filter(|(_, n)| n.to_ascii_lowercase().contains("fisheye"))
        .map(|(at, n)| format!("{at}: {n}"))
        .collect();
    assert!(twins.is_empty(), "public wide-lens twins: make the lens a variant of what exists:\n{}", twins.join("\n"));
}

#[test]
fn the_readme_quick_start_is_the_example_ci_runs() {
    // The README's library program is `crates/parallax/examples/quick_start.rs` from its `use`
    // line on, character for character: CI runs the example, so the README's program runs.
    let readme = read(&root().join("README.md"));
    let marker = "<!-- quick-start: crates/parallax/examples/quick_start.rs";
    let after = &readme[readme.find(marker).expect("the quick-start marker in README.md")..];
    let start = after.find("```rust\n").expect("a rust block after the marker") + "```rust\n".len();
    let block = &after[start..start + after[start..].find("```\n").expect("the end of the block")];
    let example = read(&root().join("crates/parallax/examples/quick_start.rs"));
    let body = &example[example.find("use parallax::prelude::*;").expect("the example's use line")..];
    assert_eq!(block, body, "README.md's quick start differs from crates/parallax/examples/quick_start.rs");
    let lines = body.lines().count();
    assert!(lines <= 45, "the quick start grew to {lines} lines: keep it a quick start");
}
