#!/usr/bin/env python3
"""A cosim controller for examples/scenes/limits.toml, on the `cosim`
package: it sets the rail's motor to a target speed (a motor target,
protocol 4) and reads the rail's speed back from the state frame
(`joint_rates`), printing the last one.

    cosim-server serve examples/scenes/limits.toml --controllers 1 --name lab &
    python3 examples/python/motor_controller.py --name lab --speed 0.3
"""

import argparse
import sys

import cosim

RAIL = 2  # joint index of "rail" in limits.toml (the joint with a motor)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--speed", type=float, default=0.3)
    args = p.parse_args()

    rate, sent = float("nan"), 0
    with cosim.Controller(args.name) as c:
        for state in c.states():  # until the server shuts down
            rate = state.joint_rates[RAIL]
            # Held by the server until changed: sent once would do; sent
            # every step it changes nothing.
            c.send(motors={RAIL: args.speed})
            sent += 1
    print(f"answered {sent} steps; rail rate {float(rate)!r} m/s (target {args.speed})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
