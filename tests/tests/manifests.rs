//! Each crate's Cargo.toml proves what it does not depend on (issue 44,
//! point 2): the engine is pure (engine/tests/pure.rs), the importers, the
//! figures and the benchmarks do no IPC (none takes iceoryx2, directly or
//! through the scene crate's wire types) and parse no command line; the
//! importers need no engine and plot nothing. A new dependency of one of
//! them fails here until this table says why it is allowed.

use std::path::Path;

/// Each crate and the dependencies it may have (all of them, sorted); the
/// engine's list is engine/tests/pure.rs's, not repeated here.
const CRATES: [(&str, &[&str]); 3] = [
    (
        "import",
        &["cosim-shared", "mesh-loader", "nalgebra", "roxmltree"],
    ),
    (
        "figures",
        &[
            "ab_glyph",
            "color_quant",
            "cosim-engine",
            "cosim-foxglove",
            "cosim-shared",
            "gif",
            "nalgebra",
            "plotters",
            "plotters-backend",
            "serde_json",
        ],
    ),
    (
        "bench",
        &[
            "cosim-engine",
            "cosim-figures",
            "cosim-shared",
            "nalgebra",
            "plotters",
        ],
    ),
];

fn manifest(dir: &str) -> toml::Table {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(dir)
        .join("Cargo.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_pure_crates_list_only_what_their_concern_needs() {
    for (dir, allowed) in CRATES {
        let m = manifest(dir);
        let deps = m["dependencies"].as_table().expect("[dependencies]");
        let mut names: Vec<&str> = deps.keys().map(String::as_str).collect();
        names.sort_unstable();
        assert_eq!(names, allowed, "{dir}/Cargo.toml");
        // The scene description without the wire types (they bring iceoryx2).
        let shared = deps["cosim-shared"].as_table().expect("a table");
        assert_eq!(
            shared.get("default-features"),
            Some(&toml::Value::Boolean(false)),
            "{dir}: cosim-shared without its default `wire` feature"
        );
        assert!(
            shared.get("features").is_none(),
            "{dir}: no features of cosim-shared"
        );
    }
}

/// The crates the pure ones name in turn: the figures take the engine and
/// the Foxglove drawing crate, which must stay free of IPC themselves.
#[test]
fn what_the_pure_crates_build_on_does_no_ipc_either() {
    for dir in ["engine", "foxglove"] {
        let m = manifest(dir);
        let deps = m["dependencies"].as_table().expect("[dependencies]");
        for name in deps.keys() {
            assert!(
                !name.starts_with("iceoryx2") && name != "clap",
                "{dir} depends on {name}"
            );
        }
    }
}
