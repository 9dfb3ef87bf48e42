//! The engine is a pure library, and its manifest says so (issue 14,
//! point 7): nothing that does IPC, parses a command line, plots or writes
//! files may become one of its dependencies without this test failing.

#[test]
fn the_manifest_lists_only_the_math_the_log_and_the_scene() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"))
        .expect("engine/Cargo.toml");
    let manifest: toml::Table = toml::from_str(&text).expect("TOML");
    let deps = manifest["dependencies"].as_table().expect("[dependencies]");
    let mut names: Vec<&str> = deps.keys().map(String::as_str).collect();
    names.sort_unstable();
    assert_eq!(names, ["cosim-shared", "faer", "nalgebra", "tracing"]);
    // The scene description without the wire types (they bring iceoryx2).
    let shared = deps["cosim-shared"].as_table().expect("a table");
    assert_eq!(
        shared.get("default-features"),
        Some(&toml::Value::Boolean(false))
    );
    assert!(shared.get("features").is_none());
}
