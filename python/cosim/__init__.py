"""Python controllers and monitors for cosim-server (wire protocol 4).

    import cosim
    with cosim.Controller("lab") as c:
        for state in c.states():
            c.send(torques={0: -3.0 * state.angular_velocities[0]})

See python/README.md and docs/protocol.md.
"""

from .client import (
    BadFrame,
    Connection,
    Controller,
    CosimError,
    Monitor,
    Names,
    NoServer,
    Refused,
    Shutdown,
    Timeout,
)
from .wire import CONTACT_DTYPE, PROTOCOL_VERSION, State

__version__ = "0.3.0"

__all__ = [
    "BadFrame",
    "CONTACT_DTYPE",
    "Connection",
    "Controller",
    "CosimError",
    "Monitor",
    "Names",
    "NoServer",
    "PROTOCOL_VERSION",
    "Refused",
    "Shutdown",
    "State",
    "Timeout",
    "__version__",
]
