#!/usr/bin/env bash
# Prints the folder of the MJCF corpus: the dm_control suite (dm_control
# 1.0.52's suite/*.xml and their assets) and gymnasium 1.4.0's MuJoCo
# models (envs/mujoco/assets/*.xml), downloaded (pip, 57 MB, no
# dependencies installed) and unpacked into target/mjcf-data on first use.
# The MJCF tests and bench/mjcf-corpus.sh read them from there.
set -euo pipefail
cd "$(dirname "$0")/.."
root=target/mjcf-data
if [ ! -d "$root/x" ]; then
    mkdir -p "$root"
    python3 -m pip download -q --disable-pip-version-check --no-deps \
        dm_control==1.0.52 gymnasium==1.4.0 -d "$root" >&2
    # Unpacked beside, then moved: a reader never sees half a folder.
    rm -rf "$root/x.part"
    python3 -m zipfile -e "$root"/dm_control-1.0.52-*.whl "$root/x.part"
    python3 -m zipfile -e "$root"/gymnasium-1.4.0-*.whl "$root/x.part"
    rm -rf "$root/x"
    mv "$root/x.part" "$root/x"
fi
echo "$(pwd)/$root/x"
