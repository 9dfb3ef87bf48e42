#!/usr/bin/env bash
# Runs the README's quick starts as a newcomer would (after scripts/test.sh
# has installed the Python package), each into a folder of its own and with
# a server name of its own, and checks what each leaves behind. .ci/run
# calls it; the demo and the test command it runs itself, and `cosim view`
# is run by server/tests/cosim/view.rs against Foxglove's own client.
set -euo pipefail
cd "$(dirname "$0")/.."
out=$(mktemp -d)
name="readme-$$"
pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    rm -rf "$out"
}
trap cleanup EXIT
run() { cargo run --release -q -p cosim-server -- "$@"; }
# The servers in the background run as built (not under `cargo run`, whose
# child a kill would leave behind when a step fails).
cargo build --release -q -p cosim-server -p cosim-examples
server_bin=target/release/cosim-server

echo "== a scene alone, with figures, the animation and a recording"
run run examples/scenes/shapes.toml --plot --animate --mcap --out "$out/shapes" > /dev/null
test -s "$out/shapes/plots/positions.png"
test -s "$out/shapes/animation.gif"
test -s "$out/shapes/recording.mcap"
grep -q '"failures": 0' "$out/shapes/summary.json"

echo "== your robot: a URDF file"
run run examples/urdf/arm.urdf --plot --out "$out/urdf" > /dev/null
test -s "$out/urdf/plots/positions.png"
grep -q '"failures": 0' "$out/urdf/summary.json"

echo "== a Python controller beside its server"
"$server_bin" serve --name "$name-py" --controllers 1 --duration 2 --out "$out/py" --quiet &
pids+=($!)
python3 examples/python/controller.py --name "$name-py" --steps 2000
wait "${pids[-1]}"
grep -q '"deadline_misses": 0' "$out/py/summary.json"

echo "== a Rust controller beside its server"
"$server_bin" serve examples/scenes/arm.toml --name "$name-rs" --controllers 1 --duration 3 --out "$out/rs" --quiet &
pids+=($!)
server=${pids[-1]}
cargo run --release -q -p cosim-examples --bin arm_controller -- --name "$name-rs"
wait "$server"
grep -q '"deadline_misses": 0' "$out/rs/summary.json"
echo "README commands: all ran"
