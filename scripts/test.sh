#!/usr/bin/env bash
# The tests, on a fresh clone with the toolchains alone (Rust, Python 3 with
# pip, Node.js with npm): installs the third-party readers some tests use,
# then runs every test. The README's test command; .ci/run calls it too.
# The robot tests download example-robot-data (pip, 131 MB) into
# target/robot-data on their first run (scripts/robot-data.sh), the MJCF
# tests dm_control's suite and gymnasium's models (57 MB) into
# target/mjcf-data (scripts/mjcf-data.sh).
#
#   scripts/test.sh            # everything
#   scripts/test.sh -p cosim-engine   # extra arguments go to cargo test
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== python: the cosim package as a user installs it (iceoryx2 0.10, numpy), mcap (reads our recordings back), mujoco (its compiler is the MJCF importer's reference)"
python3 -m pip install --quiet --disable-pip-version-check ./python 'mcap==1.6.0' 'mujoco==4.0.1'
python3 -c 'import cosim, iceoryx2, mcap, numpy, mujoco'

echo "== node: Foxglove's own client of its WebSocket protocol (@foxglove/ws-protocol), which reads cosim view"
npm ci --prefix server/tests/foxglove_client --no-audit --no-fund --loglevel=error

log=$(mktemp)
trap 'rm -f "$log"' EXIT
set +e
echo "== cargo test --release --workspace $*"
cargo test --release --workspace --no-fail-fast "$@" 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
if [ "$#" -eq 0 ]; then
    echo "== the analytic engine tests again, with the iterative solver (prox PGS)"
    COSIM_TEST_SOLVER=pgs cargo test --release -p cosim-tests --test contact_analytic \
        --test joints --test hinges --test inputs --test held_contacts --test sliders \
        --test limits --test motors --test shapes --test cylinders --test couplings --test armature 2>&1 | tee -a "$log"
    pgs_status=${PIPESTATUS[0]}
    [ "$status" -eq 0 ] && status=$pgs_status
fi
set -e
# One closing line over every test binary (cargo prints one per binary).
awk '/^test result:/ { p += $4; f += $6 } END { printf "%d passed, %d failed\n", p, f }' "$log"
exit "$status"
