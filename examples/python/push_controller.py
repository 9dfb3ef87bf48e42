#!/usr/bin/env python3
"""A cosim controller for examples/scenes/push.toml, on the `cosim`
package: it pushes the box across the floor to a target point by body
impulses at its centre of mass, a velocity servo: each step it asks for
the speed `v* = k (x* - x)` (clipped to 0.5 m/s) and sends the impulse
`m (v* - v)` that would give it; friction holds the box once that impulse
is small, within `mu g h / k` (0.8 mm) of the target. The same law as the
Rust `push_controller` of the examples crate.

    cosim-server serve examples/scenes/push.toml --controllers 1 --name lab &
    python3 examples/python/push_controller.py --name lab --x 0.5 --y 0.2
"""

import argparse
import math
import sys

import cosim

BODY, MASS = 0, 2.0  # push.toml's box
GAIN, MAX_SPEED = 5.0, 0.5  # 1/s, m/s


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--x", type=float, default=0.5)
    p.add_argument("--y", type=float, default=0.2)
    args = p.parse_args()

    target = (args.x, args.y)
    at, sent = [float("nan")] * 2, 0
    with cosim.Controller(args.name) as c:
        for state in c.states():  # until the server shuts down
            at = [float(state.positions[BODY][k]) for k in (0, 1)]
            v = [float(state.linear_velocities[BODY][k]) for k in (0, 1)]
            want = [GAIN * (target[k] - at[k]) for k in (0, 1)]
            scale = min(1.0, MAX_SPEED / max(math.hypot(*want), 1e-300))
            p = [MASS * (want[k] * scale - v[k]) for k in (0, 1)] + [0.0]
            c.send(impulses={BODY: (p, (0.0, 0.0, 0.0))})
            sent += 1
    print(f"push: answered {sent} steps; x {at[0]!r} m y {at[1]!r} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
