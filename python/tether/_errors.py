"""Exceptions of the tether package: every failure carries the codec's ``code`` and ``message``.

The C++ clients report failures as error codes of a category (``tether.romi``, ``tether.proxy``, ...). Each
codec plugin defines its exception classes in its submodule (``define_family``, called by the binding:
``tether.romi.RomiError``, ...) and the package exports them too (``tether.RomiError``); errors of another
Tether category are ``TransportError``s (``ConfigError`` for a configuration's). Timeouts are also builtin
``TimeoutError``s, and commands or messages rejected before anything was written are also ``ValueError``s.
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


class TransportTimeoutError(TransportError, TimeoutError):
    """A transport deadline passed (connect, boot banner)."""


class DisconnectedError(TransportError, ConnectionError):
    """The serial port vanished (unplugged): the call failed at once, and calls keep failing so until the port
    is back (it is re-opened on its own, unless ``reconnect=False``)."""


class _Family:
    """The classes errors of one category become: ``base``, ``timeout`` for timeouts, ``rejected`` for the
    codes in ``rejected_codes``."""

    def __init__(self, base, timeout, rejected=None, rejected_codes=()):
        self.base = base
        self.timeout = timeout
        self.rejected = rejected
        self.rejected_codes = frozenset(rejected_codes)


# Error category name -> family: the codecs' (define_family), then the library's own.
_FAMILIES = {}
_LIBRARY_FAMILIES = {
    "tether.devices": _Family(ConfigError, ConfigError),
    "tether": _Family(TransportError, TransportTimeoutError),
}
# The codecs' classes in the order they were defined: what the package exports beside its own.
_CODEC_CLASSES = []


def define_family(module, category, base, timeout, rejected=None, rejected_codes=(), more=()):
    """Makes a codec's exception classes in ``module`` (its submodule) and raises them for errors of the error
    category ``category`` (and of ``<category>.<sub>``). ``base``, ``timeout`` and ``rejected`` are
    ``(name, docstring)``: ``base`` derives from TetherError, ``timeout`` from ``base`` and TimeoutError,
    ``rejected`` (optional: the codes ``rejected_codes``, refused before anything was written) from ``base``
    and ValueError; ``more`` are further subclasses of ``base`` that the codec's binding raises itself.
    Returns the classes made. Called by the binding, once per codec."""
    if category in _FAMILIES:
        raise ValueError(f"the error category {category!r} has its exceptions already")

    # The submodule as users import it (`tether.romi`, an alias of the native `tether._tether.romi`): where
    # reprs and pickle look the classes up.
    public_module = module.__name__.replace("tether._tether.", "tether.", 1)

    def make(spec, bases):
        name, doc = spec
        made = type(name, bases, {"__doc__": doc, "__module__": public_module})
        setattr(module, name, made)
        _CODEC_CLASSES.append(made)
        return made

    base_class = make(base, (TetherError,))
    timeout_class = make(timeout, (base_class, TimeoutError))
    rejected_class = make(rejected, (base_class, ValueError)) if rejected else None
    others = [make(spec, (base_class,)) for spec in more]
    _FAMILIES[category] = _Family(base_class, timeout_class, rejected_class, rejected_codes)
    return tuple(c for c in (base_class, timeout_class, rejected_class, *others) if c is not None)


def codec_classes():
    """Every codec's exception classes, in the order the codecs defined them."""
    return list(_CODEC_CLASSES)


def _family_of(category):
    for families in (_FAMILIES, _LIBRARY_FAMILIES):
        name = category
        while name:
            if name in families:
                return families[name]
            name = name.rpartition(".")[0]
    return None


def make_error(category, code, message, timeout, response=None):
    """The exception for an error of the error category named ``category`` (called by the binding); None for
    a category that is not Tether's."""
    family = _family_of(category)
    if family is None:
        return None
    if timeout:
        return family.timeout(code, message, response)
    if family.rejected is not None and code in family.rejected_codes:
        return family.rejected(code, message, response)
    return family.base(code, message, response)
