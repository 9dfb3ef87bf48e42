//! `<default>` classes: per class and element kind, the attributes an
//! element of that class takes when it does not give them, each class
//! inheriting its parent's (MuJoCo's `main` at the top).

use super::xml::El;
use std::collections::HashMap;

/// The actuator kinds share one default per class in MuJoCo: a class's
/// `<motor>`, `<position>` or `<general>` all set it.
pub const ACTUATORS: [&str; 10] = [
    "general",
    "motor",
    "position",
    "velocity",
    "intvelocity",
    "damper",
    "cylinder",
    "muscle",
    "adhesion",
    "plugin",
];

/// The kind an element's defaults are kept under.
pub fn kind(tag: &str) -> &str {
    if ACTUATORS.contains(&tag) {
        "actuator"
    } else if tag == "freejoint" {
        "joint"
    } else {
        tag
    }
}

type Attrs = Vec<(String, String)>;

#[derive(Debug, Clone, Default)]
pub struct Defaults {
    /// class -> kind -> attributes (the class's own over its parent's).
    classes: HashMap<String, HashMap<String, Attrs>>,
}

impl Defaults {
    /// The classes of the `<default>` elements under the top element.
    pub fn read(root: &El) -> Defaults {
        let mut d = Defaults::default();
        d.classes.insert("main".into(), HashMap::new());
        for top in root.all("default") {
            d.class(top, "main", None);
        }
        d
    }

    fn class(&mut self, el: &El, name: &str, parent: Option<&str>) {
        let mut own = parent
            .and_then(|p| self.classes.get(p).cloned())
            .or_else(|| self.classes.get(name).cloned())
            .unwrap_or_default();
        for c in el.children.iter().filter(|c| c.tag != "default") {
            let entry = own.entry(kind(&c.tag).to_string()).or_default();
            for (k, v) in &c.attrs {
                if let Some(slot) = entry.iter_mut().find(|(a, _)| a == k) {
                    slot.1 = v.clone();
                } else {
                    entry.push((k.clone(), v.clone()));
                }
            }
        }
        self.classes.insert(name.to_string(), own);
        for c in el.all("default") {
            let child = c.attr("class").unwrap_or("main").to_string();
            self.class(c, &child, Some(name));
        }
    }

    pub fn has(&self, class: &str) -> bool {
        self.classes.contains_key(class)
    }

    /// The attribute `attr` class `class` gives elements of tag `tag`.
    pub fn get(&self, class: &str, tag: &str, attr: &str) -> Option<&str> {
        self.classes
            .get(class)?
            .get(kind(tag))?
            .iter()
            .find(|(k, _)| k == attr)
            .map(|(_, v)| v.as_str())
    }
}
