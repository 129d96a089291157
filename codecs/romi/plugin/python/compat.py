"""RomiSerial's Python host, on Tether: ``from tether.compat import ControlSerial``.

Programs written for RomiSerial's ``ControlSerial(device)`` run with only their import line changed, and get
Tether's client underneath: ids and CRCs checked, damaged answers re-sent, stale answers never pinned on the
wrong request, bounded waits.
"""

from . import _tether
from .romi import RomiError


class ControlSerial:
    """A Romi device on a serial port: ``execute(opcode, *args)`` returns the answer list, code first.

    ``device`` is the port path (an Uno resets when it opens: ``boot_wait`` seconds, 2 by default), a
    ``tether.transports.Transport``, or a ``tether.VirtualUno`` (its UART and its simulated time as the
    clock of the call windows). ``options`` go to ``tether.romi.Client`` (``attempt_timeout``, ``clock``...). An answer with a non-zero code raises ``RomiError`` (its ``code``,
    ``message`` and ``response``); so does a call without an answer (``RomiTimeoutError``)."""

    def __init__(self, device, baudrate=115200, *, boot_wait=2.0, **options):
        self._debug = False
        self._client = _tether.romi.Client(device, baud=baudrate, boot_wait=boot_wait, **options)

    def set_debug(self, value):
        """Prints every command and answer when ``value`` is true (RomiSerial's debugging aid)."""
        self._debug = bool(value)

    def execute(self, opcode, *args):
        """Sends ``opcode`` with ``args`` (ints, then at most one string) and returns the answer list:
        ``execute('A')`` -> ``[0, 512]``."""
        if self._debug:
            print(f"ControlSerial: -> {opcode} {list(args)}")
        try:
            response = self._client.call(opcode, *args)
        except RomiError as error:
            if self._debug:
                print(f"ControlSerial: <- error {error.code}: {error.message}")
            raise
        if self._debug:
            print(f"ControlSerial: <- {response}")
        return response

    def close(self):
        """Closes the port."""
        self._client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
