#!/usr/bin/env python3
"""A cosim controller in Python, on the `cosim` package (pip install
./python; it speaks docs/protocol.md over the official iceoryx2 package).

It joins the server NAME, answers STEPS steps with a PD torque that holds
the reference scene's upper arm at a target elevation (gravity
compensated), then leaves.

    cosim-server serve --controllers 1 --name lab &
    python3 examples/python/controller.py --name lab --steps 2000
"""

import argparse
import math
import os
import sys

import numpy as np

import cosim

SHOULDER = np.array([0.0, 0.0, 0.45])
MASSES = np.array([1.0, 0.5])
GRAVITY = np.array([0.0, 0.0, -9.81])
KP, KD = 20.0, 3.0


def pd_torque(state: cosim.State, elevation_deg: float):
    """Shoulder torque: PD on the arm direction, plus the chain's gravity
    moment; and the arm's elevation (deg)."""
    arm = state.positions[0] - SHOULDER
    d = arm / np.linalg.norm(arm)
    e = math.radians(elevation_deg)
    target = np.array([math.cos(e), 0.0, math.sin(e)])
    tau = KP * np.cross(d, target) - KD * state.angular_velocities[0]
    for x, m in zip(state.positions[:2], MASSES):
        tau -= np.cross(x - SHOULDER, m * GRAVITY)
    return tau, math.degrees(math.asin(d[2]))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--elevation", type=float, default=10.0)
    p.add_argument("--exit-without-leave", type=int, metavar="N",
                   help="answer N steps, then end the process at once, skipping "
                        "leave and every cleanup (as a crashed controller would)")
    args = p.parse_args()

    with cosim.Controller(args.name) as c:
        print(f"joined '{args.name}' as controller {c.id}: "
              f"{c.info.body_count} bodies, {c.info.joint_count} joints, dt {c.info.dt}")
        elevation, sent, shutdown = float("nan"), 0, False
        while sent < args.steps:
            try:
                state = c.next_state()
            except cosim.Shutdown:
                shutdown = True
                break
            tau, elevation = pd_torque(state, args.elevation)
            c.send(torques={0: tau})
            sent += 1
            if sent == args.exit_without_leave:
                print(f"answered {sent} steps; exiting without leave", flush=True)
                os._exit(0)
    print(f"{'server shut down; ' if shutdown else ''}answered {sent} steps; "
          f"elevation {elevation:.3f} deg (target {args.elevation})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
