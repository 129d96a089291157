"""The .pyi stubs name exactly what the module has: every public class, function and method."""

import ast
import inspect
import os

import pytest

import tether

PACKAGE = os.path.dirname(tether.__file__)


def stub_names(path):
    """{qualified name} of the classes, functions, methods and variables a stub declares."""
    tree = ast.parse(open(path).read())
    names = set()

    def visit(body, prefix):
        for node in body:
            if isinstance(node, ast.ClassDef):
                names.add(prefix + node.name)
                # An exception's attributes (set on its instances) are not compared: runtime_names skips them.
                bases = [getattr(base, "id", getattr(base, "attr", "")) for base in node.bases]
                if not any(base.endswith(("Error", "Exception")) for base in bases):
                    visit(node.body, prefix + node.name + ".")
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if not node.name.startswith("_") or node.name in ("__init__", "__enter__", "__exit__"):
                    names.add(prefix + node.name)
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                names.add(prefix + node.target.id)
            elif isinstance(node, ast.ImportFrom) and not prefix:
                # Names taken from a private module, and explicit re-exports (`from .romi import RomiError as
                # RomiError`): the module has them.
                for alias in node.names:
                    if node.module and (node.module.startswith("_") or alias.asname == alias.name):
                        names.add(alias.asname or alias.name)
    visit(tree.body, "")
    return names


def has_constructor(cls):
    """pybind11 gives classes without a constructor an __init__ that raises: not part of the API."""
    init = vars(cls).get("__init__")
    return init is not None and not repr(init).startswith("<slot wrapper")


def runtime_names(module):
    names = set()
    for name, value in vars(module).items():
        if name.startswith("_") or inspect.ismodule(value):
            continue
        names.add(name)
        if inspect.isclass(value) and not issubclass(value, BaseException):
            for member in dir(value):
                if not member.startswith("_") or member in ("__init__", "__enter__", "__exit__"):
                    if member == "__init__" and not has_constructor(value):
                        continue
                    names.add(f"{name}.{member}")
    return names


# The codecs' submodules, as the module has them (one per codec plugin with a Python part): each needs its stub
# (tether_codec_plugin's PYTHON_STUB, shipped as tether/<codec>.pyi), whichever codecs this build has.
CODECS = sorted(name for name, value in vars(tether._tether).items()
                if inspect.ismodule(value) and name != "transports")


def test_every_codec_plugin_is_a_submodule():
    """The loop below is over something: the codecs' submodules are found (and exported by the package)."""
    assert CODECS
    assert set(CODECS) <= set(tether.__all__)


# The pure-Python modules the codec plugins ship (PYTHON_MODULES: tether.compat, ...), each with its stub.
PLUGIN_MODULES = list(tether._tether._plugin_modules)


def test_plugin_modules_are_exported():
    assert set(PLUGIN_MODULES) <= set(tether.__all__)
    for name in PLUGIN_MODULES:
        assert inspect.ismodule(getattr(tether, name))


@pytest.mark.parametrize("submodule", [*CODECS, "transports", *PLUGIN_MODULES])
def test_submodule_stub_matches(submodule):
    assert stub_names(os.path.join(PACKAGE, f"{submodule}.pyi")) == runtime_names(getattr(tether, submodule))


def test_package_stub_matches():
    declared = stub_names(os.path.join(PACKAGE, "__init__.pyi"))
    public = {name for name in tether.__all__ if not inspect.ismodule(getattr(tether, name))}
    top = {name for name in declared if "." not in name}
    assert top == public
    for cls in (tether.VirtualUno, tether.VirtualUnoClock, tether.Rover, tether.LinkCounters):
        runtime = {f"{cls.__name__}.{m}" for m in dir(cls)
                   if not m.startswith("_") or m in ("__enter__", "__exit__")}
        runtime.discard(f"{cls.__name__}.__init__")
        if has_constructor(cls):
            runtime.add(f"{cls.__name__}.__init__")
        assert {n for n in declared if n.startswith(cls.__name__ + ".")} == runtime
