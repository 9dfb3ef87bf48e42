#!/usr/bin/env bash
# The robots of example-robot-data (pip, 69 URDFs with their meshes) run
# as `cosim-server run ROBOT.urdf --floor --steps N --solver S` with each
# solver (lemke, pgs, auto: the default), at the defaults otherwise: for
# each, whether it loads (or the first line of why not), then per solver
# the wall time, failed steps, the worst penetration (m) and joint error
# (m). Writes bench/results/urdf-corpus.md.
# Usage: bench/urdf-corpus.sh [STEPS]   (5000: issue 45's 5 s at h = 1 ms)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/corpus_cell.sh
steps=${1:-5000}
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
    echo "# example-robot-data 6.0.0 with each solver"
    echo
    echo "\`bench/urdf-corpus.sh $steps\`: each URDF run with \`--floor --steps $steps\` (h = 1 ms) and \`--solver lemke|pgs|auto\` (auto is the default), joints passive, links apart. Per solver: wall time (s), failed steps, max penetration (m), max joint error (m)."
    echo
    echo "| robot | lemke | pgs | auto |"
    echo "|---|---|---|---|"
} > "$out"
for f in $(find "$robots" -name "*.urdf" | sort); do
    name=$(basename "$f" .urdf)
    row="| $name |"
    for solver in lemke pgs auto; do
        cell=$(corpus_cell "$work" "$robots" "$bin" run "$f" --floor --steps "$steps" --solver "$solver")
        row="$row $cell |"
    done
    echo "$row" >> "$out"
done
{ echo; python3 bench/corpus_summary.py "$out"; } >> "$out"
echo "wrote $out"
