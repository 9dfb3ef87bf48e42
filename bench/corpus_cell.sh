# Sourced by bench/urdf-corpus.sh and bench/mjcf-corpus.sh: one table cell
# per run, in the form bench/corpus_summary.py reads.
#
# corpus_cell WORK STRIP CMD...: runs CMD with `--out WORK/run --overwrite
# --quiet` (600 s cap) and prints "WALL s, F failed, PENETRATION, JOINT
# ERROR" from its summary.json, or "no: " and the first two lines of why
# not, with the prefix STRIP/ taken off the paths.
corpus_cell() {
    local work=$1 strip=$2
    shift 2
    if timeout 600 "$@" --out "$work/run" --overwrite --quiet > "$work/err" 2>&1; then
        python3 - "$work/run/summary.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"{d['wall_seconds']:.2f} s, {d['failures']} failed, {d['max_penetration']:.1e}, {d['max_joint_error']:.1e}")
PY
    else
        echo "no: $(grep -v '^note' "$work/err" | head -2 | tr '\n|' '  ' | sed "s#$strip/##g" | cut -c1-120)"
    fi
}
