//! The engine's folders are the stages of the step, in layers (lib.rs
//! draws them): a module uses only its own folder and the layers below, so
//! that no import circle can form between stages and a lower stage never
//! defines a type for a higher one (issue 44). Read from the sources: every
//! `crate::STAGE` path in code (comments aside), and `super::STAGE` in a
//! folder's `mod.rs`, where `super` is the crate.

use std::path::{Path, PathBuf};

/// Bottom to top; a module may use its own layer and those before it.
const LAYERS: [&str; 8] = [
    "model",
    "collision",
    "constraint",
    "solver",
    "integrate",
    "sleep",
    "measure",
    "step",
];

fn layer(name: &str) -> Option<usize> {
    LAYERS.iter().position(|&l| l == name)
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("engine/src is readable") {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The stage names that `prefix` (`crate::` or `super::`) leads to in
/// `code`, with their line numbers.
fn uses(code: &str, prefix: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        let line = line.split("//").next().unwrap_or("");
        let mut rest = line;
        while let Some(at) = rest.find(prefix) {
            let after = &rest[at + prefix.len()..];
            let name: String = after
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            // `crate::{a, b}` would hide its names from this reader.
            assert!(
                !after.starts_with('{'),
                "line {}: name each stage's path on its own (`{prefix}{{`)",
                n + 1
            );
            found.push((n + 1, name));
            rest = after;
        }
    }
    found
}

#[test]
fn each_stage_uses_only_itself_and_the_layers_below() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&root, &mut files);
    files.sort();
    let mut wrong = Vec::new();
    let mut seen = vec![false; LAYERS.len()];
    for path in &files {
        let rel = path.strip_prefix(&root).expect("under src");
        let parts: Vec<&str> = rel.iter().filter_map(|p| p.to_str()).collect();
        // lib.rs declares the stages; testing.rs is the unit tests' generator.
        if parts.len() == 1 && matches!(parts[0], "lib.rs" | "testing.rs") {
            continue;
        }
        let own = layer(parts[0].trim_end_matches(".rs"))
            .unwrap_or_else(|| panic!("{}: not in a stage's folder of {LAYERS:?}", rel.display()));
        seen[own] = true;
        let code = std::fs::read_to_string(path).expect("readable source");
        let mut named = uses(&code, "crate::");
        if parts.len() == 2 && parts[1] == "mod.rs" {
            named.extend(
                uses(&code, "super::")
                    .into_iter()
                    .filter(|(_, n)| layer(n).is_some()),
            );
        }
        for (line, name) in named {
            if name == "testing" {
                continue;
            }
            match layer(&name) {
                Some(l) if l <= own => {}
                Some(_) => wrong.push(format!(
                    "{}:{line}: {} uses {name}, a higher stage",
                    rel.display(),
                    LAYERS[own]
                )),
                None => wrong.push(format!(
                    "{}:{line}: crate::{name} is not a stage",
                    rel.display()
                )),
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // Every layer exists: a renamed folder fails here, not silently.
    assert!(seen.iter().all(|&s| s), "layers found: {seen:?}");
}

#[test]
fn the_reader_sees_a_path_in_code_and_not_in_comments() {
    let code = "use crate::solver::Lemke; // crate::step\n/// crate::measure\nlet x = crate::model::State::default();";
    let names: Vec<String> = uses(code, "crate::").into_iter().map(|(_, n)| n).collect();
    assert_eq!(names, ["solver", "model"]);
}
