//! The workspace's modules point one way (docs/design.md §2): no two source files import each
//! other, none of the trainer's layers imports one listed after it (`trainer/src/lib.rs`), and the
//! trainer uses the bench only in the commands about it. Read from the sources, as a newcomer
//! would follow them: `crate::…`, `super::…` and a child module's `use child::…`, comments and
//! tests left out. And no source file is longer than a newcomer reads whole (800 lines).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates' source roots, by the name their own paths use.
const CRATES: [&str; 6] = [
    "trainer/src",
    "data/src",
    "terminal/src",
    "firmware-sim/src",
    "firmware-core/src",
    "firmware-core/ffi/src",
];

/// The trainer's layers, each using only those before it.
const TRAINER_LAYERS: [&str; 9] = [
    "progress", "data", "models", "firmware", "analysis", "plot", "report", "pipeline", "cli",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs")
            && path.file_name().is_some_and(|n| n != "tests.rs")
        {
            out.push(path);
        }
    }
}

/// The module path of `file` under `root` (`lib.rs`, `main.rs` and `mod.rs` name their folder).
fn module_of(root: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(root).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("lib" | "main" | "mod")
    ) {
        parts.pop();
    }
    parts
}

/// The file that defines the longest prefix of `path` under `root`, if any.
fn file_of(root: &Path, path: &[String]) -> Option<PathBuf> {
    (1..=path.len()).rev().find_map(|k| {
        let base = path[..k].iter().fold(root.to_path_buf(), |p, s| p.join(s));
        let file = base.with_extension("rs");
        let module = base.join("mod.rs");
        file.is_file()
            .then_some(file)
            .or_else(|| module.is_file().then_some(module))
    })
}

/// The code of a file without its comments and its tests.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every module path `text` names from `module`: `crate::a::b`, `super::a`, `use child::a` and
/// each item of a `{…}` group.
fn named_paths(text: &str, module: &[String]) -> Vec<Vec<String>> {
    let children: BTreeSet<String> = text
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l.strip_prefix("pub ").unwrap_or(l);
            let l = l.strip_prefix("pub(crate) ").unwrap_or(l);
            let l = l.strip_prefix("pub(super) ").unwrap_or(l);
            l.strip_prefix("mod ")?.strip_suffix(';').map(str::to_owned)
        })
        .collect();
    let mut out = Vec::new();
    let chars: Vec<char> = text.chars().collect();
    let word = |c: char| c.is_alphanumeric() || c == '_';
    let mut i = 0;
    while i < chars.len() {
        if !word(chars[i]) || (i > 0 && (word(chars[i - 1]) || chars[i - 1] == ':')) {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < chars.len() && word(chars[j]) {
            j += 1;
        }
        let head: String = chars[i..j].iter().collect();
        // A path goes on with `::`, and a visibility (`pub(super)`, `pub(in crate::cli)`) is none.
        let followed = chars.get(j) == Some(&':') && chars.get(j + 1) == Some(&':');
        let before: String = chars[i.saturating_sub(3)..i].iter().collect();
        if !followed || before.ends_with('(') || before == "in " {
            i = j;
            continue;
        }
        let base: Option<Vec<String>> = match head.as_str() {
            "crate" => Some(Vec::new()),
            "super" => Some(module[..module.len().saturating_sub(1)].to_vec()),
            h if children.contains(h) => {
                let before: String = chars[i.saturating_sub(4)..i].iter().collect();
                (before == "use ").then(|| {
                    let mut m = module.to_vec();
                    m.push(h.to_owned());
                    m
                })
            }
            _ => None,
        };
        let Some(mut base) = base else {
            i = j;
            continue;
        };
        // Follow ::segments, and a {group} of them.
        let mut k = j;
        loop {
            if chars.get(k) == Some(&':') && chars.get(k + 1) == Some(&':') {
                k += 2;
                if chars.get(k) == Some(&'{') {
                    let end = (k..chars.len()).find(|&e| chars[e] == '}').unwrap_or(k);
                    let group: String = chars[k + 1..end].iter().collect();
                    for item in group.split(',') {
                        let item = item.split(" as ").next().unwrap_or("").trim();
                        let mut p = base.clone();
                        p.extend(
                            item.split("::")
                                .filter(|s| !s.is_empty() && *s != "self")
                                .map(str::to_owned),
                        );
                        out.push(p);
                    }
                    k = end;
                    base.clear();
                    break;
                }
                let s = k;
                while k < chars.len() && word(chars[k]) {
                    k += 1;
                }
                let seg: String = chars[s..k].iter().collect();
                if seg == "super" {
                    base.pop();
                } else {
                    base.push(seg);
                }
            } else {
                break;
            }
        }
        if !base.is_empty() {
            out.push(base);
        }
        i = k.max(j);
    }
    out
}

#[test]
fn no_two_files_import_each_other_and_no_layer_looks_up() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut imports: BTreeMap<PathBuf, BTreeSet<PathBuf>> = BTreeMap::new();
    let mut upward = Vec::new();
    for krate in CRATES {
        let root = workspace.join(krate);
        let mut files = Vec::new();
        rust_files(&root, &mut files);
        for file in files {
            let module = module_of(&root, &file);
            let text = code(&std::fs::read_to_string(&file).unwrap());
            for path in named_paths(&text, &module) {
                let Some(target) = file_of(&root, &path) else {
                    continue;
                };
                if target == file {
                    continue;
                }
                if krate == "trainer/src" {
                    let layer = |m: &[String]| {
                        m.first()
                            .and_then(|s| TRAINER_LAYERS.iter().position(|l| l == s))
                    };
                    if let (Some(a), Some(b)) = (layer(&module), layer(&path))
                        && b > a
                    {
                        upward.push(format!("{} uses {}", file.display(), path.join("::")));
                    }
                }
                imports.entry(file.clone()).or_default().insert(target);
            }
        }
    }
    let graph = &imports;
    let mutual: Vec<String> = graph
        .iter()
        .flat_map(|(a, bs)| {
            bs.iter()
                .filter(move |b| a < *b && graph.get(*b).is_some_and(|back| back.contains(a)))
                .map(move |b| format!("{} <-> {}", a.display(), b.display()))
        })
        .collect();
    assert!(
        mutual.is_empty(),
        "files importing each other:\n{}",
        mutual.join("\n")
    );
    assert!(
        upward.is_empty(),
        "a layer using one after it:\n{}",
        upward.join("\n")
    );
}

/// The bench is not the floor under the trainer: only the commands about the bench (`demo`, which
/// simulates the data it fits, and `challenge`, which hides effects in simulated gyros) use
/// firmware-sim. Everything else reads data through fog-data.
#[test]
fn the_trainer_uses_the_bench_only_in_the_commands_about_it() {
    const ABOUT_THE_BENCH: [&str; 2] = ["cli/demo.rs", "analysis/challenge.rs"];
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../trainer/src");
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let users: Vec<String> = files
        .iter()
        .filter(|f| {
            let rel = f
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            !ABOUT_THE_BENCH.contains(&rel.as_str())
        })
        .filter(|f| code(&std::fs::read_to_string(f).unwrap()).contains("firmware_sim"))
        .map(|f| f.display().to_string())
        .collect();
    assert!(
        users.is_empty(),
        "trainer files using firmware-sim outside demo and challenge:\n{}",
        users.join("\n")
    );
}

/// No source file of the workspace is over 800 lines (its tests' files and the crates built for
/// another target included): a newcomer reads a file whole.
#[test]
fn no_source_file_is_over_800_lines() {
    fn all_files(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                all_files(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    for root in CRATES.iter().chain(&["python/src", "firmware-sim/m4/src"]) {
        all_files(&workspace.join(root), &mut files);
    }
    assert!(files.len() > 100, "{} files", files.len());
    let long: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let n = std::fs::read_to_string(f).unwrap().lines().count();
            (n > 800).then(|| format!("{}: {n} lines", f.display()))
        })
        .collect();
    assert!(long.is_empty(), "{long:#?}");
}
