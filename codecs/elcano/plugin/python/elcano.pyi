import os
from types import SimpleNamespace
from typing import Awaitable, Callable, Optional, Sequence, Union

from . import LinkCounters, VirtualUno, VirtualUnoClock
from .transports import Transport
from tether._errors import TetherError

class ElcanoError(TetherError):
    """An Elcano ring operation failed (``code`` is the ``RingError`` value: 1 timed_out, 2 undeliverable,
    3 reply_type_busy, 4 send_queue_full, 5 send_timed_out, 6 receive_timed_out, 7 invalid_message,
    8 invalid_reply_type)."""

class ElcanoTimeoutError(ElcanoError, TimeoutError):
    """No reply, room or message in time."""

class ElcanoMessageError(ElcanoError, ValueError):
    """The message or reply type was rejected before anything was written."""


class Message:
    """One Elcano message: ``Message(type='drive', speed=50, angle=25)``; unset fields are None."""
    def __init__(self, type: str = "drive", **fields: Optional[int]) -> None: ...
    @property
    def type(self) -> str: ...
    @property
    def number(self) -> Optional[int]: ...
    @property
    def speed(self) -> Optional[int]: ...
    @property
    def angle(self) -> Optional[int]: ...
    @property
    def obstacle(self) -> Optional[int]: ...
    @property
    def bearing(self) -> Optional[int]: ...
    @property
    def probability(self) -> Optional[int]: ...
    @property
    def east(self) -> Optional[int]: ...
    @property
    def north(self) -> Optional[int]: ...
    def to_wire(self, generation: str = "B") -> bytes: ...

class RingCounters:
    """What the host's node did in the ring."""
    captured: int
    forwarded: int
    originated: int
    undeliverable: int
    queue_full_drops: int
    origins_expired: int
    origins_evicted: int

class Counters:
    """What a ring client counted (they only grow)."""
    link: LinkCounters
    ring: RingCounters
    replies: int
    receive_overflows: int
    bytes_written: int

class RingClient:
    """The host's node in an Elcano ring."""
    def __init__(self, port_or_transport: Union[str, Transport, VirtualUno], *, generation: str = "B",
                 capture: Sequence[str] = (), baud: int = 115200, boot_wait: float = 2.0,
                 on_event: Optional[Callable[[SimpleNamespace], None]] = None,
                 clock: Optional[VirtualUnoClock] = None, boot: Optional[str] = None,
                 record: Union[str, os.PathLike[str], dict[str, object], None] = None) -> None: ...
    def request(self, message: Message, *, reply_type: str) -> Message: ...
    def request_async(self, message: Message, *, reply_type: str) -> Awaitable[Message]: ...
    def send(self, message: Message) -> None: ...
    def receive(self, timeout: float = 1.0) -> Message: ...
    def counters(self) -> Counters: ...
    def close(self) -> None: ...
    @property
    def is_open(self) -> bool: ...
    def __enter__(self) -> RingClient: ...
    def __exit__(self, *args: object) -> None: ...
