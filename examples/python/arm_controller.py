#!/usr/bin/env python3
"""A cosim controller for examples/scenes/arm.toml, on the `cosim`
package: it reads the shoulder's and elbow's angles from each state frame
(`joint_positions`) and steers the joints' velocity motors towards target
angles (motor targets, protocol 4) with a proportional law,
`v* = k (q* - q)` clipped to 2 rad/s; the motors' effort bound carries
the arm's weight, so the angles reach their targets with no steady error.
The same law as the Rust `arm_controller` of the examples crate.

    cosim-server serve examples/scenes/arm.toml --controllers 1 --name lab &
    python3 examples/python/arm_controller.py --name lab --shoulder 0.6 --elbow -1.0
"""

import argparse
import sys

import cosim

GAIN, MAX_RATE = 5.0, 2.0  # 1/s, rad/s


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--shoulder", type=float, default=0.6)
    p.add_argument("--elbow", type=float, default=-1.0)
    args = p.parse_args()

    target = (args.shoulder, args.elbow)
    angles, sent = [float("nan")] * 2, 0
    with cosim.Controller(args.name) as c:
        for state in c.states():  # until the server shuts down
            angles = [float(state.joint_positions[j]) for j in (0, 1)]
            rates = {
                j: max(-MAX_RATE, min(MAX_RATE, GAIN * (q - angles[j])))
                for j, q in enumerate(target)
            }
            c.send(motors=rates)
            sent += 1
    print(f"arm: answered {sent} steps; shoulder {angles[0]!r} rad elbow {angles[1]!r} rad")
    return 0


if __name__ == "__main__":
    sys.exit(main())
