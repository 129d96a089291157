"""Exceptions of the tether package: every failure carries the codec's ``code`` and ``message``.

The C++ clients report failures as error codes of a category (``tether.romi``, ``tether.proxy``, ...);
the binding raises the class of that category here. Timeouts are also builtin ``TimeoutError``s, and
commands or messages rejected before anything was written are also ``ValueError``s.
"""


class TetherError(Exception):
    """Base of every tether exception: ``code`` (the codec's number) and ``message`` (its text)."""

    def __init__(self, code, message, response=None):
        super().__init__(code, message)
        self.code = code
        self.message = message
        #: Romi: the device's whole answer (a list, code first) when the device answered.
        self.response = response

    def __str__(self):
        return f"{self.message} (code {self.code})"

    def __repr__(self):
        return f"{type(self).__name__}(code={self.code!r}, message={self.message!r})"


class RomiError(TetherError):
    """A Romi call failed: the device's error code (-16 unknown opcode, > 0 application errors) or the
    client's (-25 timeout, -1..-6 damaged answers, -24/-14/-8..-13/-22/-32 rejected commands)."""


class ProxyError(TetherError):
    """A proxy send failed (``code`` is the ``ProxyError`` value: 1 timed_out, 2 queue_timeout,
    3 device_reset, 4 wrong_mode, 5 invalid_message, 6 reserved_message, 7 message_too_large,
    8 too_many_inits)."""


class ElcanoError(TetherError):
    """An Elcano ring operation failed (``code`` is the ``RingError`` value: 1 timed_out, 2 undeliverable,
    3 reply_type_busy, 4 send_queue_full, 5 send_timed_out, 6 receive_timed_out, 7 invalid_message,
    8 invalid_reply_type)."""


class TransportError(TetherError):
    """The byte stream failed for a reason of its own (``code``: 1 timed_out, ... boot_timeout)."""


class ConfigError(TetherError):
    """A rover configuration cannot be parsed or opened; the message names the JSON path."""


class ClosedError(TetherError):
    """The client (or rover) was closed before or while the operation ran."""

    def __init__(self, message):
        super().__init__(None, message)

    def __str__(self):
        return self.message


class RomiTimeoutError(RomiError, TimeoutError):
    """No answer within the attempt window or the call budget (code -25)."""


class ProxyTimeoutError(ProxyError, TimeoutError):
    """No ack within the send budget, or not sent within the queue timeout."""


class ElcanoTimeoutError(ElcanoError, TimeoutError):
    """No reply, room or message in time."""


class TransportTimeoutError(TransportError, TimeoutError):
    """A transport deadline passed (connect, boot banner)."""


class RomiCommandError(RomiError, ValueError):
    """The command was rejected before anything was written (bad opcode, value out of int16, ...)."""


class ProxyMessageError(ProxyError, ValueError):
    """The message was rejected before anything was written."""


class ElcanoMessageError(ElcanoError, ValueError):
    """The message or reply type was rejected before anything was written."""


_ROMI_REJECTED = {-24, -14, -8, -9, -10, -11, -12, -13, -22, -32}
_PROXY_REJECTED = {4, 5, 6, 7, 8}
_ELCANO_REJECTED = {7, 8}

_FAMILIES = {
    # family: (base, timeout class, rejected class, rejected codes)
    "romi": (RomiError, RomiTimeoutError, RomiCommandError, _ROMI_REJECTED),
    "proxy": (ProxyError, ProxyTimeoutError, ProxyMessageError, _PROXY_REJECTED),
    "elcano": (ElcanoError, ElcanoTimeoutError, ElcanoMessageError, _ELCANO_REJECTED),
    "transport": (TransportError, TransportTimeoutError, None, set()),
    "config": (ConfigError, ConfigError, None, set()),
}


def make_error(family, code, message, timeout, response=None):
    """The exception for an error of ``family`` (called by the binding)."""
    base, timeout_class, rejected_class, rejected = _FAMILIES[family]
    if timeout:
        return timeout_class(code, message, response)
    if rejected_class is not None and code in rejected:
        return rejected_class(code, message, response)
    return base(code, message, response)
