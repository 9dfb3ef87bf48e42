//! Example programs; the example scenes live in `examples/scenes/`.
