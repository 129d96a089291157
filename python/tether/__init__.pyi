# Stubs of the package tether (hand-written: Debian has no pybind11-stubgen); python/tests/test_stubs.py
# checks that they name exactly what the module has.
import os
from types import SimpleNamespace
from typing import Optional, Union

from . import compat as compat, elcano as elcano, proxy as proxy, romi as romi, transports as transports
from ._errors import ClosedError as ClosedError
from ._errors import ConfigError as ConfigError
from ._errors import ElcanoError as ElcanoError
from ._errors import ElcanoMessageError as ElcanoMessageError
from ._errors import ElcanoTimeoutError as ElcanoTimeoutError
from ._errors import ProxyError as ProxyError
from ._errors import ProxyMessageError as ProxyMessageError
from ._errors import ProxyTimeoutError as ProxyTimeoutError
from ._errors import RomiCommandError as RomiCommandError
from ._errors import RomiError as RomiError
from ._errors import RomiTimeoutError as RomiTimeoutError
from ._errors import TetherError as TetherError
from ._errors import TransportError as TransportError
from ._errors import TransportTimeoutError as TransportTimeoutError

__version__: str

class LinkCounters:
    """Counters of a link's decoder and session engine (they only grow)."""
    frames_ok: int
    crc_errors: int
    framing_errors: int
    oversize_frames: int
    resyncs: int
    partial_timeouts: int
    stale: int
    retries: int
    timeouts: int
    resets: int

class VirtualUnoClock:
    """A virtual board's simulated time, for a client's ``clock=`` argument (``board.clock``): deadlines in
    the board's seconds, the clock of the firmware's own timeouts, whatever the machine's load."""
    @property
    def board(self) -> VirtualUno: ...

class VirtualUno:
    """A simulated Arduino Uno running a firmware image, its UART on a pty (``port``); ``start=False``: run
    only by ``run_for``, no pty. ``romi.Client(board)`` runs on the board's UART and clock."""
    def __init__(self, image: str, *, fast: bool = False, seed: Optional[int] = None, start: bool = True) -> None: ...
    @property
    def port(self) -> str: ...
    @property
    def clock(self) -> VirtualUnoClock: ...
    @property
    def simulated_time(self) -> float: ...
    def run_for(self, seconds: float) -> None: ...
    def stats(self) -> SimpleNamespace: ...
    def pin(self, pin: int) -> SimpleNamespace: ...
    def set_analog_input(self, channel: int, volts: float) -> None: ...
    def close(self) -> None: ...
    def __enter__(self) -> VirtualUno: ...
    def __exit__(self, *args: object) -> None: ...

class Rover:
    """The opened devices of a rover configuration."""
    def romi(self, name: str) -> romi.Client: ...
    def proxy(self, name: str) -> proxy.Client: ...
    def elcano(self, name: str) -> elcano.RingClient: ...
    @property
    def devices(self) -> list[SimpleNamespace]: ...
    def close(self) -> None: ...
    @property
    def is_open(self) -> bool: ...
    def __enter__(self) -> Rover: ...
    def __exit__(self, *args: object) -> None: ...

def open_rover(path: Union[str, os.PathLike[str]], *, firmware_dir: Optional[str] = None) -> Rover: ...
def firmware_dir() -> str: ...
