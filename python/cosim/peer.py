"""A controller that answers every step with no input, for measuring what
the lockstep costs with a Python controller (`cosim-server bench ipc`):

    python3 -m cosim.peer NAME [spin|block]
"""

import sys

import cosim


def main() -> int:
    name = sys.argv[1] if len(sys.argv) > 1 else "default"
    wait = sys.argv[2] if len(sys.argv) > 2 else "block"
    with cosim.Controller(name, timeout=30.0, wait=wait) as c:
        for _ in c.states():
            c.send()
    return 0


if __name__ == "__main__":
    sys.exit(main())
