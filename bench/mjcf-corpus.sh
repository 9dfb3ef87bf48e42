#!/usr/bin/env bash
# The MJCF models of the dm_control suite and gymnasium (33 files, written
# by others) run as `cosim-server run MODEL.xml --solver S` for 5 s
# simulated at each model's own time step, with each solver: its own floor,
# springs, dampers and servos holding their initial coordinates, no other
# input. For each: whether it loads (or the first line of why not), then
# per solver the wall time, failed steps, worst penetration (m) and joint
# error (m). Writes bench/results/mjcf-corpus.md.
# Usage: bench/mjcf-corpus.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/corpus_cell.sh
seconds=${1:-5}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
data=$(scripts/mjcf-data.sh)
cargo build --release -q -p cosim-server
# A copy, so that a build during the run does not change what runs.
cp target/release/cosim-server "$work/"
bin=$work/cosim-server
out=bench/results/mjcf-corpus.md
{
    echo "# The dm_control suite (1.0.52) and gymnasium (1.4.0) MJCF models"
    echo
    echo "\`bench/mjcf-corpus.sh $seconds\`: each model run $seconds s at its own time step with each solver (\`--solver lemke|pgs|auto\`; auto is the default), at the defaults otherwise. Per solver: wall time (s), failed steps, max penetration (m), max joint error (m)."
    echo
    echo "| model | h (s) | lemke | pgs | auto |"
    echo "|---|---|---|---|---|"
} > "$out"
for f in "$data"/dm_control/suite/*.xml "$data"/gymnasium/envs/mujoco/assets/*.xml; do
    case "$f" in
        */dm_control/*) name="dm_control/$(basename "$f" .xml)" ;;
        *) name="gymnasium/$(basename "$f" .xml)" ;;
    esac
    row="| $name |"
    h=""
    for solver in lemke pgs auto; do
        cell=$(corpus_cell "$work" "$data" "$bin" run "$f" --solver "$solver" --duration "$seconds")
        if [[ $cell != no:* ]]; then
            h=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['dt'])" "$work/run/summary.json" 2>/dev/null || echo "")
        fi
        row="$row $cell |"
    done
    echo "${row/| $name |/| $name | $h |}" >> "$out"
done
echo "wrote $out"
