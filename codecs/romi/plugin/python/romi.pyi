import os
from typing import Awaitable, Callable, Iterator, Optional, Union

from . import LinkCounters, VirtualUno, VirtualUnoClock
from .transports import Transport
from tether._errors import TetherError

class RomiError(TetherError):
    """A Romi call failed: the device's error code (-16 unknown opcode, > 0 application errors) or the
    client's (-25 timeout, -1..-6 damaged answers, -24/-14/-8..-13/-22/-32 rejected commands)."""

class RomiTimeoutError(RomiError, TimeoutError):
    """No answer within the attempt window or the call budget (code -25)."""

class RomiCommandError(RomiError, ValueError):
    """The command was rejected before anything was written (bad opcode, value out of int16, ...)."""


class Counters:
    """What a Romi client counted: the link's decoder and engine."""
    link: LinkCounters

class LogLines(Iterator[str]):
    """Iterator over a Romi client's log lines (``Client.log_lines``)."""
    def __iter__(self) -> LogLines: ...
    def __next__(self) -> str: ...
    @property
    def dropped(self) -> int: ...
    def close(self) -> None: ...

class Client:
    """Romi client for one device: ``call('L[1]')``, ``call('M', 16, 'Shutdown')``."""
    def __init__(self, port_or_transport: Union[str, Transport, VirtualUno], *, baud: int = 115200, boot_wait: float = 2.0,
                 attempt_timeout: float = 1.0, call_budget: float = 2.0, max_attempts: int = 3,
                 retry_on_timeout: bool = False, on_log: Optional[Callable[[str], None]] = None,
                 clock: Optional[VirtualUnoClock] = None, boot: Optional[str] = None,
                 record: Union[str, os.PathLike[str], dict[str, object], None] = None) -> None: ...
    def call(self, command: str, *args: Union[int, str], check: bool = True) -> list: ...
    def call_async(self, command: str, *args: Union[int, str], check: bool = True) -> Awaitable[list]: ...
    def on_log(self, callback: Optional[Callable[[str], None]]) -> None: ...
    def log_lines(self, *, timeout: Optional[float] = None) -> LogLines: ...
    def counters(self) -> Counters: ...
    def close(self) -> None: ...
    @property
    def is_open(self) -> bool: ...
    def __enter__(self) -> Client: ...
    def __exit__(self, *args: object) -> None: ...
