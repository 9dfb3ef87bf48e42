//! MJCF text as an owned element tree, `<include>`s spliced in where they
//! stand (MuJoCo's reader: the included file's top element is dropped and
//! its children take the include's place), each element with its file and
//! line for the problems.

use crate::problems::Problems;
use std::path::{Path, PathBuf};

/// One element: its tag, attributes in file order, children, and where it
/// was written.
#[derive(Debug, Clone)]
pub struct El {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<El>,
    pub line: u32,
    /// Index into [`Tree::files`]: 0 is the main file.
    pub file: usize,
}

impl El {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The children with tag `tag`.
    pub fn all<'a>(&'a self, tag: &'a str) -> impl Iterator<Item = &'a El> + 'a {
        self.children.iter().filter(move |c| c.tag == tag)
    }
}

/// The main file's top element with every include spliced in, and the
/// files read (the main one first).
#[derive(Debug, Clone)]
pub struct Tree {
    pub root: El,
    pub files: Vec<String>,
}

impl Tree {
    /// How an element is named in a problem: `<tag name="...">`, with its
    /// file when that is not the main one.
    pub fn label(&self, el: &El) -> String {
        let name = el
            .attr("name")
            .map_or(String::new(), |n| format!(" name={n:?}"));
        if el.file == 0 {
            format!("<{}{name}>", el.tag)
        } else {
            format!(
                "<{}{name}> ({} line {})",
                el.tag, self.files[el.file], el.line
            )
        }
    }

    /// The line a problem about `el` is reported at in the main file (an
    /// included element's own line is in its label).
    pub fn line(&self, el: &El) -> u32 {
        if el.file == 0 {
            el.line
        } else {
            0
        }
    }
}

/// Parses `text` (from `file`, whose folder includes are relative to) and
/// splices its includes; `None` when the text is not XML (said).
pub fn parse(text: &str, file: &str, dir: Option<&Path>, problems: &mut Problems) -> Option<Tree> {
    let mut files = vec![file.to_string()];
    let root = parse_file(text, 0, dir, &mut files, problems, 0)?;
    if root.tag != "mujoco" {
        problems.add(
            root.line,
            format!("<{}>", root.tag),
            "an MJCF file's top element is <mujoco>",
        );
    }
    Some(Tree { root, files })
}

fn parse_file(
    text: &str,
    index: usize,
    dir: Option<&Path>,
    files: &mut Vec<String>,
    problems: &mut Problems,
    depth: usize,
) -> Option<El> {
    let doc = match roxmltree::Document::parse(text) {
        Ok(d) => d,
        Err(e) => {
            let at = if index == 0 {
                String::new()
            } else {
                format!("{}: ", files[index])
            };
            problems.add(e.pos().row, "", format!("{at}not well-formed XML: {e}"));
            return None;
        }
    };
    Some(convert(
        doc.root_element(),
        &doc,
        index,
        dir,
        files,
        problems,
        depth,
    ))
}

fn convert(
    node: roxmltree::Node,
    doc: &roxmltree::Document,
    index: usize,
    dir: Option<&Path>,
    files: &mut Vec<String>,
    problems: &mut Problems,
    depth: usize,
) -> El {
    let line = doc.text_pos_at(node.range().start).row;
    let mut el = El {
        tag: node.tag_name().name().to_string(),
        attrs: node
            .attributes()
            .map(|a| (a.name().to_string(), a.value().to_string()))
            .collect(),
        children: Vec::new(),
        line,
        file: index,
    };
    for child in node.children().filter(|c| c.is_element()) {
        if child.tag_name().name() != "include" {
            let c = convert(child, doc, index, dir, files, problems, depth);
            el.children.push(c);
            continue;
        }
        let line = doc.text_pos_at(child.range().start).row;
        let where_ = |files: &Vec<String>| {
            if index == 0 {
                (line, "<include>".to_string())
            } else {
                (0, format!("<include> ({} line {line})", files[index]))
            }
        };
        let Some(name) = child.attribute("file") else {
            let (l, w) = where_(files);
            problems.add(l, w, "has no file attribute");
            continue;
        };
        // Includes nest; a file including itself would not end.
        if depth > 16 {
            let (l, w) = where_(files);
            problems.add(l, w, format!("{name:?}: includes nest deeper than 16"));
            continue;
        }
        let path: PathBuf = dir.map_or_else(|| PathBuf::from(name), |d| d.join(name));
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) => {
                let (l, w) = where_(files);
                problems.add(l, w, format!("cannot read {}: {e}", path.display()));
                continue;
            }
        };
        files.push(path.display().to_string());
        let k = files.len() - 1;
        if let Some(top) = parse_file(&text, k, dir, files, problems, depth + 1) {
            el.children.extend(top.children);
        }
    }
    el
}
