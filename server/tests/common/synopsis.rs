//! The command synopses of the docs checked against the program they
//! describe (issue 46, point 1: every command in the docs is run by a test
//! or CI). A synopsis is a line of a code block that starts with the
//! program's name, with its continuation lines (indented, starting with `[`
//! or `|`); alternatives at bracket depth 0 are separated by `|`. Each
//! alternative's subcommand must exist (`PROG SUB --help` succeeds) and
//! every `--flag` it names must be one of that subcommand's options. Used by
//! the server's tests (`cosim-server`) and the client's (`cosim`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// One synopsis: where it is and its text after the program's name.
pub struct Synopsis {
    pub at: String,
    pub text: String,
}

/// Every synopsis of `prog` in the README, python/README.md and docs/*.md.
pub fn synopses(root: &Path, prog: &str) -> Vec<Synopsis> {
    let mut files: Vec<PathBuf> = vec![root.join("README.md"), root.join("python/README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .expect("docs/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    let mut out = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).expect("read a doc");
        let mut in_block = false;
        let mut shell = false;
        let mut current: Option<Synopsis> = None;
        for (i, line) in text.lines().enumerate() {
            if let Some(lang) = line.trim_start().strip_prefix("```") {
                in_block = !in_block;
                shell = in_block && matches!(lang.trim(), "" | "sh" | "bash" | "console");
                out.extend(current.take());
                continue;
            }
            if !shell {
                continue;
            }
            let t = line.trim_start();
            let continues = line.starts_with(' ') && (t.starts_with('[') || t.starts_with('|'));
            match (&mut current, continues) {
                (Some(s), true) => {
                    s.text.push(' ');
                    s.text.push_str(t);
                }
                _ => {
                    out.extend(current.take());
                    let t = t.split(" #").next().unwrap_or(t);
                    if let Some(rest) = t.strip_prefix(prog).and_then(|r| r.strip_prefix(' ')) {
                        current = Some(Synopsis {
                            at: format!("{}:{}", file.display(), i + 1),
                            text: rest.to_string(),
                        });
                    }
                }
            }
        }
        out.extend(current);
    }
    out
}

/// The alternatives of a synopsis: split at `|` outside brackets.
fn alternatives(text: &str) -> Vec<String> {
    let mut alts = vec![String::new()];
    let mut depth = 0i32;
    for c in text.chars() {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            '|' if depth == 0 => {
                alts.push(String::new());
                continue;
            }
            _ => {}
        }
        alts.last_mut().expect("one").push(c);
    }
    alts
}

/// The `--flags` a piece of a synopsis names.
fn flags(text: &str) -> Vec<String> {
    text.split(|c: char| c.is_whitespace() || "[]|=".contains(c))
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(str::to_string)
        .collect()
}

/// Whether `help` lists `flag` as an option (not as a prefix of another).
fn lists(help: &str, flag: &str) -> bool {
    help.match_indices(flag).any(|(i, _)| {
        help[i + flag.len()..]
            .chars()
            .next()
            .is_none_or(|c| !(c.is_alphanumeric() || c == '-'))
    })
}

/// `exe ARGS --help`: its output, or why it failed.
fn help(exe: &str, args: &[String]) -> Result<String, String> {
    let out = Command::new(exe)
        .args(args)
        .arg("--help")
        .output()
        .map_err(|e| format!("{exe}: {e}"))?;
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).into_owned())
    }
}

/// Every problem of every synopsis of `prog` (run as `exe`), and how many
/// subcommands were checked.
pub fn check(root: &Path, prog: &str, exe: &str) -> (Vec<String>, usize) {
    let mut problems = Vec::new();
    let mut checked = 0;
    for s in synopses(root, prog) {
        for alt in alternatives(&s.text) {
            // Leading bracketed groups are the program's own options
            // (`cosim [--name NAME] list`); the bare lowercase words after
            // them name the subcommand (`bench ipc`), up to the first
            // argument (`DIR`, `[...]`, `--flag`).
            let mut rest = alt.trim();
            let mut global = String::new();
            while rest.starts_with('[') {
                let end = rest.find(']').map_or(rest.len(), |e| e + 1);
                global.push_str(&rest[..end]);
                rest = rest[end..].trim_start();
            }
            let sub: Vec<String> = rest
                .split_whitespace()
                .take_while(|w| {
                    w.chars()
                        .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
                        && !w.starts_with('-')
                })
                .map(str::to_string)
                .collect();
            for (args, named) in [(vec![], flags(&global)), (sub.clone(), flags(rest))] {
                if args.is_empty() && named.is_empty() {
                    continue;
                }
                match help(exe, &args) {
                    Ok(h) => {
                        checked += 1;
                        for f in named.iter().filter(|f| !lists(&h, f)) {
                            problems.push(format!(
                                "{}: `{prog} {}` has no option {f}",
                                s.at,
                                args.join(" ")
                            ));
                        }
                    }
                    Err(e) => problems.push(format!(
                        "{}: `{prog} {} --help` failed: {}",
                        s.at,
                        args.join(" "),
                        e.lines().next().unwrap_or("")
                    )),
                }
            }
        }
    }
    (problems, checked)
}
