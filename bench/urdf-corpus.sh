#!/usr/bin/env bash
# The robots of example-robot-data (pip, 69 URDFs with their meshes) run
# as `cosim-server run ROBOT.urdf --floor --steps N` at the defaults: for
# each, whether it loads (or the first line of why not), the wall time,
# failed steps, the worst penetration (m) and joint error (m). Writes
# bench/results/urdf-corpus.md. Usage: bench/urdf-corpus.sh [STEPS]
set -euo pipefail
cd "$(dirname "$0")/.."
steps=${1:-500}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
robots=$(scripts/robot-data.sh)
export ROS_PACKAGE_PATH="$robots"
cargo build --release -q -p cosim-server
# A copy, so that a build during the run does not change what runs.
cp target/release/cosim-server "$work/"
bin=$work/cosim-server
out=bench/results/urdf-corpus.md
{
    echo "# example-robot-data 6.0.0 at the defaults"
    echo
    echo "\`bench/urdf-corpus.sh $steps\`: each URDF run with \`--floor --steps $steps\` (h = 1 ms), joints passive, links apart."
    echo
    echo "| robot | loads and runs | wall (s) | failed steps | max penetration (m) | max joint error (m) |"
    echo "|---|---|---|---|---|---|"
} > "$out"
for f in $(find "$robots" -name "*.urdf" | sort); do
    name=$(basename "$f" .urdf)
    if timeout 300 "$bin" run "$f" --floor --steps "$steps" --out "$work/run" --overwrite --quiet > "$work/err" 2>&1; then
        python3 - "$work/run/summary.json" "$name" >> "$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"| {sys.argv[2]} | yes | {d['wall_seconds']:.2f} | {d['failures']} | {d['max_penetration']:.1e} | {d['max_joint_error']:.1e} |")
PY
    else
        why=$(grep -v '^note' "$work/err" | head -2 | tr '\n|' '  ' | sed "s#$robots/##g" | cut -c1-160)
        echo "| $name | no: $why | | | | |" >> "$out"
    fi
done
echo "wrote $out"
