"""Tether for Python: the C++ library's clients, transports, rover configurations and virtual boards.

    import tether
    with tether.VirtualUno('romi-test') as board:
        with tether.romi.Client(board) as client:   # deadlines on the board's simulated time
            print(client.call('e'))          # [0, 1, 2]

Submodules: one per codec (``tether.romi``, ``tether.proxy``, ``tether.elcano``, ...: its clients and its
exceptions) and the modules codecs ship beside it (``tether.compat``, RomiSerial's Python host);
``tether.transports`` (serial, tcp, pty). Errors (``code``, ``message``): each codec's (``RomiError``,
``ProxyError``, ..., also exported here), ``TransportError``, ``ConfigError``, their ``...TimeoutError`` (also
``TimeoutError``), ``ClosedError``; all are ``TetherError``s.
"""

import atexit as _atexit
import importlib as _importlib
import os as _os
import sys as _sys
import types as _types

from . import _errors
from . import _tether
from ._errors import ClosedError, ConfigError, DisconnectedError, TetherError, TransportError, TransportTimeoutError

VirtualUno = _tether.VirtualUno
VirtualUnoClock = _tether.VirtualUnoClock
Rover = _tether.Rover
LinkCounters = _tether.LinkCounters
__version__ = _tether.__version__

# The module's submodules: `tether.transports` and one per codec plugin (`tether.romi`, ...). `import
# tether.romi` and `from tether.romi import Client` work like for modules on disk.
_SUBMODULES = [_name for _name, _value in vars(_tether).items() if isinstance(_value, _types.ModuleType)]
for _name in _SUBMODULES:
    globals()[_name] = getattr(_tether, _name)
    _sys.modules[f"{__name__}.{_name}"] = getattr(_tether, _name)

# The codecs' exceptions (made in their submodules by the binding), exported here too: `tether.RomiError`.
_CODEC_ERRORS = [_class.__name__ for _class in _errors.codec_classes()]
for _class in _errors.codec_classes():
    globals()[_class.__name__] = _class

# Python modules the codec plugins ship in the package (PYTHON_MODULES: `tether.compat`, ...).
_PLUGIN_MODULES = list(_tether._plugin_modules)
for _name in _PLUGIN_MODULES:
    globals()[_name] = _importlib.import_module(f".{_name}", __name__)

# Installed packages find the images installed with them (share/tether/firmware beside lib/); the build
# tree's module finds the build's.
_INSTALLED_FIRMWARE = _os.path.normpath(
    _os.path.join(_os.path.dirname(__file__), "..", "..", "..", "..", "share", "tether", "firmware"))


def firmware_dir():
    """Where bare image names (``VirtualUno('romi-test')``) are looked up: $TETHER_FIRMWARE_DIR, else the
    images installed with the package, else the build's."""
    if _os.environ.get("TETHER_FIRMWARE_DIR"):
        return _os.environ["TETHER_FIRMWARE_DIR"]
    if _os.path.isdir(_INSTALLED_FIRMWARE):
        return _INSTALLED_FIRMWARE
    return _tether._build_firmware_dir


_tether._set_firmware_dir(firmware_dir())

# A child made by fork() (multiprocessing's default on Linux) has none of the parent's threads: its own
# clients get their own io thread; the objects it inherited raise ClosedError.
_os.register_at_fork(after_in_child=_tether._after_fork_in_child)


def open_rover(path, *, firmware_dir=None):
    """Opens every device of the rover configuration ``path`` (docs/config.md) and returns the ``Rover``.

    Raises ``ConfigError`` naming the JSON path of the culprit (parse errors, a port that does not exist,
    a device that does not answer its handshake). Nothing is half-opened."""
    folder = firmware_dir if firmware_dir is not None else globals()["firmware_dir"]()
    return _tether._open_rover(_os.fspath(path), _os.fspath(folder))


_atexit.register(_tether._interpreter_exiting)

__all__ = [*_SUBMODULES, *_PLUGIN_MODULES, "VirtualUno", "VirtualUnoClock", "Rover", "LinkCounters",
           "open_rover", "firmware_dir", "TetherError", "TransportError", "ConfigError", "ClosedError", "DisconnectedError",
           "TransportTimeoutError", *_CODEC_ERRORS, "__version__"]
