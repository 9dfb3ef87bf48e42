//! Example programs; the example scenes live in `examples/scenes/`.

/// The value after `flag` among the command line's `args`, or `default`.
pub fn arg(args: &[String], flag: &str, default: &str) -> String {
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1))
        .cloned()
        .unwrap_or_else(|| default.to_string())
}
