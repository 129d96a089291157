"""The exception classes: each codec plugin's family (made by the binding in its submodule, exported by the
package) and the library's own, chosen by error category."""

import inspect

import pytest

import tether
from tether import _errors

CODECS = sorted(name for name, value in vars(tether._tether).items()
                if inspect.ismodule(value) and name != "transports")


def families():
    """(category, base, timeout, rejected, rejected codes) of every codec family the module defined."""
    return [(category, f.base, f.timeout, f.rejected, f.rejected_codes) for category, f in _errors._FAMILIES.items()]


def test_every_codec_defines_its_exceptions_in_its_submodule():
    assert families()
    modules = {f[1].__module__ for f in families()}
    assert modules == {f"tether.{codec}" for codec in CODECS}
    classes = _errors.codec_classes()
    for _, base, timeout, rejected, _ in families():
        assert base in classes and timeout in classes and (rejected is None or rejected in classes)
    for cls in classes:
        submodule = getattr(tether, cls.__module__.rpartition(".")[2])
        assert getattr(submodule, cls.__name__) is cls
        assert getattr(tether, cls.__name__) is cls, "exported by the package too"
        assert cls.__name__ in tether.__all__
        assert issubclass(cls, tether.TetherError)
        assert cls.__doc__


@pytest.mark.parametrize("category", sorted(_errors._FAMILIES))
def test_errors_of_a_codec_category_raise_its_classes(category):
    family = _errors._FAMILIES[category]
    timeout = _errors.make_error(category, 1, "late", True)
    assert type(timeout) is family.timeout and isinstance(timeout, TimeoutError)
    assert (timeout.code, timeout.message) == (1, "late")
    # A sub-category (`tether.proxy.compat`) is the codec's too.
    assert type(_errors.make_error(category + ".sub", 99999, "x", False)) is family.base
    for code in family.rejected_codes:
        rejected = _errors.make_error(category, code, "refused", False)
        assert type(rejected) is family.rejected and isinstance(rejected, ValueError)
    other = _errors.make_error(category, 99999, "failed", False, response=[1])
    assert type(other) is family.base and other.response == [1]
    # Only whole name parts match: `tether.romix` is not Romi's.
    assert type(_errors.make_error(category + "x", 5, "x", False)) is tether.TransportError


def test_library_categories():
    assert type(_errors.make_error("tether.devices", 3, "bad", False)) is tether.ConfigError
    assert type(_errors.make_error("tether.transport", 1, "late", True)) is tether.TransportTimeoutError
    assert type(_errors.make_error("tether.transport", 2, "eof", False)) is tether.TransportError
    assert _errors.make_error("system", 2, "no such file", False) is None


def test_a_category_gets_its_exceptions_once():
    category = next(iter(_errors._FAMILIES))
    with pytest.raises(ValueError, match="has its exceptions already"):
        _errors.define_family(tether.transports, category, ("XError", ""), ("XTimeoutError", ""))


def test_codec_exceptions_pickle():
    import pickle
    for _, base, timeout, _, _ in families():
        copy = pickle.loads(pickle.dumps(timeout(7, "late")))
        assert type(copy) is timeout and (copy.code, copy.message) == (7, "late")
