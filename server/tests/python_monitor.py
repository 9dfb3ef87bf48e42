"""A monitor on the `cosim` Python package: reads the decimated stream of
server NAME until its last frame and prints, per frame, the step and the
numpy arrays' first rows as JSON lines (the Rust test compares them with
states.csv). Prints "ready" once subscribed."""

import json
import sys

import cosim

name = sys.argv[1]
m = cosim.Monitor(name, buffer=16, every=True)
print("ready", flush=True)
while True:
    s = m.next(timeout=20.0)
    print(json.dumps({
        "step": s.step,
        "shape": list(s.positions.shape),
        # As text (repr: the shortest exact one): the reader parses it
        # exactly, where a JSON number parser may round.
        "position": [repr(x) for x in s.positions[1].tolist()],
        "orientation": [repr(x) for x in s.orientations[1].tolist()],
        "angular_velocity": [repr(x) for x in s.angular_velocities[1].tolist()],
        "joints": list(s.joint_impulses.shape),
        # The reference scene's spherical joints have no coordinate: NaN.
        "joint_positions": [repr(x) for x in s.joint_positions.tolist()],
        "contacts": len(s.contacts),
        "contact_fields": list(s.contacts.dtype.names),
    }), flush=True)
    if s.status & 16:
        break
