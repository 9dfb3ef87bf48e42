#!/usr/bin/env python3
"""A cosim controller for examples/scenes/slider.toml, on the `cosim`
package: it reads the rail's offset and speed from the state frame
(`joint_positions`, `joint_rates`: protocol 3) and holds the carriage at
a target offset down its rail with a PD force, the slider's effort (a
force on the carriage along the rail), with the gravity of the carriage
and its pendulum along the rail fed forward.

    cosim-server serve examples/scenes/slider.toml --controllers 1 --name lab &
    python3 examples/python/slider_controller.py --name lab --target 0.5
"""

import argparse
import math
import sys

import numpy as np

import cosim

RAIL = 0  # joint index of "rail" in slider.toml
# The rail's axis, down 25 degrees along -x (slider.toml).
AXIS = np.array([-math.cos(math.radians(25.0)), 0.0, -math.sin(math.radians(25.0))])
# Carriage and bob (kg): gravity's pull along the rail, fed forward.
PULL = (2.0 + 0.5) * 9.81 * math.sin(math.radians(25.0))
KP, KD = 400.0, 80.0


def force(state: cosim.State, target: float):
    """The rail's force (world frame, N) and its offset (m)."""
    x, v = state.joint_positions[RAIL], state.joint_rates[RAIL]
    f = KP * (target - x) - KD * v - PULL
    return f * AXIS, x


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--target", type=float, default=0.5)
    args = p.parse_args()

    offset, sent = float("nan"), 0
    with cosim.Controller(args.name) as c:
        for state in c.states():  # until the server shuts down
            f, offset = force(state, args.target)
            c.send(torques={RAIL: f})
            sent += 1
    print(f"answered {sent} steps; rail offset {float(offset)!r} m (target {args.target})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
