#!/usr/bin/env python3
"""A posture controller for examples/robots/go1_stand.toml, on the
`cosim` package: Go1's twelve joints are position servos in the scene
(implicit PD, bounded by the URDF's efforts); the controller moves their
targets, by name, from the crouch the scene starts in to a stand over
`--rise` seconds (a smooth step), then holds it. It prints the base's
height and tilt for the last frame.

    cosim-server serve examples/robots/go1_stand.toml --controllers 1 --name go1 &
    python3 examples/python/go1_stand.py --name go1
"""

import argparse
import math
import sys

import cosim

LEGS = ("FR", "FL", "RR", "RL")
# Thigh and calf angles (rad): the scene's crouch, and the stand.
CROUCH = (1.3, -2.6)
STAND = (0.9, -1.8)


def targets(t: float, rise: float):
    """Every joint's servo target at time t (s), by name."""
    s = min(max(t / rise, 0.0), 1.0)
    s = s * s * (3.0 - 2.0 * s)  # smooth: no jerk at either end
    thigh, calf = (a + s * (b - a) for a, b in zip(CROUCH, STAND))
    out = {}
    for leg in LEGS:
        out[f"go1/{leg}_hip_joint"] = 0.0
        out[f"go1/{leg}_thigh_joint"] = thigh
        out[f"go1/{leg}_calf_joint"] = calf
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--rise", type=float, default=1.0)
    args = p.parse_args()

    height, tilt, sent = float("nan"), float("nan"), 0
    with cosim.Controller(args.name) as c:
        base = c.names.body("go1/base")
        for state in c.states():  # until the server shuts down
            c.send(motors=targets(state.t, args.rise))
            sent += 1
            height = float(state.positions[base][2])
            w, x, y, z = state.orientations[base]
            # The angle between the base's z axis and the world's.
            tilt = math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y))))
    print(f"answered {sent} steps; base height {height!r} m, tilt {tilt!r} rad")
    return 0


if __name__ == "__main__":
    sys.exit(main())
