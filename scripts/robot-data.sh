#!/usr/bin/env bash
# Prints the robots folder of example-robot-data 6.0.0 (a pip package of
# 69 URDFs with their meshes), downloading and unpacking it into
# target/robot-data on first use. The tests, the corpus benchmark and the
# scenes of examples/robots/ read the robots from there.
set -euo pipefail
cd "$(dirname "$0")/.."
root=target/robot-data
robots=$root/x/cmeel.prefix/share/example-robot-data/robots
if [ ! -d "$robots" ]; then
    mkdir -p "$root"
    python3 -m pip download -q --disable-pip-version-check --no-deps \
        example-robot-data==6.0.0 -d "$root" >&2
    # Unpacked beside, then moved: a reader never sees half a folder.
    rm -rf "$root/x.part"
    python3 -m zipfile -e "$root"/example_robot_data-6.0.0-*.whl "$root/x.part"
    rm -rf "$root/x"
    mv "$root/x.part" "$root/x"
fi
echo "$(pwd)/$robots"
