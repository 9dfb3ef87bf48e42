#!/usr/bin/env bash
# Issue 45, point 9: the step's cost on two robots others wrote, beside
# MuJoCo on the same MJCF file, in one run, both at their defaults:
# dm_control's humanoid_CMU (a 31-body humanoid, passive: its motors at 0,
# falling onto its floor) and gymnasium-robotics' Franka Panda (its
# kitchen model's arm, its position actuators holding the start, on a
# floor: the file below includes theirs). 5 s simulated at the model's own
# h. Ours: the sum of steps.csv's t_total (the step alone, no output);
# MuJoCo 4.0.1: mj_step in a Python loop (its C step; the loop's overhead,
# ~1 us, counted against it). Three rounds, alternating; the median.
# Writes bench/results/mjcf-cost.md.
# Usage: bench/mjcf-cost.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-5}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
data=$(scripts/mjcf-data.sh)
robotics=target/mjcf-data/robotics
if [ ! -d "$robotics/x" ]; then
    mkdir -p "$robotics"
    python3 -m pip download --quiet --no-deps 'gymnasium-robotics==1.4.2' -d "$robotics" >&2
    python3 -c "import zipfile, glob, sys; zipfile.ZipFile(glob.glob(sys.argv[1] + '/*.whl')[0]).extractall(sys.argv[1] + '/x')" "$robotics"
fi
kitchen=$robotics/x/gymnasium_robotics/envs/assets/kitchen_franka
cat > "$kitchen/panda_bench.xml" <<'XML'
<mujoco model="panda">
  <compiler inertiafromgeom="auto" inertiagrouprange="3 5" angle="radian" meshdir="franka_assets/meshes"/>
  <include file="franka_assets/assets.xml"/>
  <include file="franka_assets/actuator.xml"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0 0 0">
      <include file="franka_assets/chain.xml"/>
    </body>
  </worldbody>
</mujoco>
XML
cargo build --release -q -p cosim-server
cp target/release/cosim-server "$work/"
bin=$work/cosim-server
python3 -c 'import mujoco' || { echo "needs the mujoco package: pip install mujoco==4.0.1" >&2; exit 1; }
ours() { # file -> us per step
    "$bin" run "$1" --duration "$seconds" --out "$work/run" --overwrite --quiet >/dev/null
    python3 - "$work/run/steps.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print(f"{1e6 * sum(float(r['t_total']) for r in rows) / len(rows):.1f} {len(rows)} {max(float(r['lcp_size']) for r in rows):.0f}")
PY
}
theirs() { # file -> us per step
    python3 - "$1" "$seconds" <<'PY'
import sys, time, mujoco
m = mujoco.MjModel.from_xml_path(sys.argv[1])
d = mujoco.MjData(m)
# As the importer starts it: a coordinate outside its range at the nearer
# limit; position actuators hold the start.
for j in range(m.njnt):
    if m.jnt_limited[j] and m.jnt_type[j] in (2, 3):
        a = m.jnt_qposadr[j]
        d.qpos[a] = min(max(d.qpos[a], m.jnt_range[j][0]), m.jnt_range[j][1])
for u in range(m.nu):
    if m.actuator_trntype[u] == 0 and m.actuator_biastype[u] == 1:
        d.ctrl[u] = d.qpos[m.jnt_qposadr[m.actuator_trnid[u][0]]]
n = round(float(sys.argv[2]) / m.opt.timestep)
t = time.perf_counter()
for _ in range(n):
    mujoco.mj_step(m, d)
print(f"{1e6 * (time.perf_counter() - t) / n:.1f} {n} {m.opt.integrator}")
PY
}
out=bench/results/mjcf-cost.md
{
    echo "# The step's cost beside MuJoCo, on the same MJCF file"
    echo
    echo "\`bench/mjcf-cost.sh $seconds\` ($(date -u +%Y-%m-%d), this machine: 2 cores, shared): $seconds s simulated at each model's own h, both at their defaults (ours: solver auto; MuJoCo 4.0.1: Euler, Newton, pyramidal cone, soft contact). Ours: the step alone (steps.csv's t_total); MuJoCo: mj_step in a Python loop. Three rounds, alternating; the median and the ratio."
    echo
    echo "| model | h (s) | steps | ours (us/step) | largest LCP | MuJoCo (us/step) | ours / MuJoCo |"
    echo "|---|---|---|---|---|---|---|"
} > "$out"
for f in "$data/dm_control/suite/humanoid_CMU.xml" "$kitchen/panda_bench.xml"; do
    a=(); b=()
    for round in 1 2 3; do
        read -r us steps lcp < <(ours "$f")
        a+=("$us")
        read -r them n _ < <(theirs "$f")
        b+=("$them")
    done
    python3 - "$f" "$steps" "$lcp" "${a[*]}" "${b[*]}" "$seconds" >> "$out" <<'PY'
import statistics, sys
f, steps, lcp, a, b, seconds = sys.argv[1:]
a = statistics.median(map(float, a.split()))
b = statistics.median(map(float, b.split()))
name = "dm_control/humanoid_CMU" if "humanoid" in f else "gymnasium-robotics/Franka Panda (kitchen arm)"
print(f"| {name} | {float(seconds) / int(steps):g} | {steps} | {a:.1f} | {lcp} | {b:.1f} | {a / b:.1f} |")
PY
done
cat "$out"
