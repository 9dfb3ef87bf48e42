//! Every problem of a file, gathered in one pass and said at once (issue
//! 45: fixing a file was one run per fault), each with the element it is
//! about and its line.

use cosim_shared::SceneError;
use std::fmt;

/// One problem: where (line, element) and what.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// 1-based line of the element in the file (0: the file as a whole).
    pub line: u32,
    /// The element, e.g. `link "base" <collision> 2` or `joint "elbow" <limit>`.
    pub element: String,
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: ", self.line)?;
        }
        if self.element.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.element, self.message)
        }
    }
}

/// The problems found so far in one file.
#[derive(Debug, Clone, Default)]
pub struct Problems {
    pub file: String,
    pub list: Vec<Problem>,
}

impl Problems {
    pub fn new(file: &str) -> Problems {
        Problems {
            file: file.into(),
            list: Vec::new(),
        }
    }

    pub fn add(&mut self, line: u32, element: impl Into<String>, message: impl Into<String>) {
        self.list.push(Problem {
            line,
            element: element.into(),
            message: message.into(),
        });
    }

    /// Ok when none was found; else one error that lists them all.
    pub fn check(&self) -> Result<(), SceneError> {
        let mut list = self.list.clone();
        list.sort_by_key(|p| p.line);
        match list.as_slice() {
            [] => Ok(()),
            [p] => Err(SceneError {
                file: self.file.clone(),
                location: (p.line > 0).then_some((p.line as usize, 1)),
                field: p.element.clone(),
                message: p.message.clone(),
            }),
            many => {
                let mut message = format!("{} problems:", many.len());
                for p in many {
                    message.push_str(&format!("\n  {p}"));
                }
                Err(SceneError {
                    file: self.file.clone(),
                    location: None,
                    field: String::new(),
                    message,
                })
            }
        }
    }
}
