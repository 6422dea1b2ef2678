"""The native module's type stubs (``_flockway.pyi``, shipped with ``py.typed``) name exactly
what the module has."""

from __future__ import annotations

import ast
from pathlib import Path

import flockway
from flockway import _flockway

STUB = Path(flockway.__file__).with_name("_flockway.pyi")


def _stubbed() -> dict[str, set[str]]:
    """Top-level names, and each class's members, as the stub declares them."""
    tree = ast.parse(STUB.read_text())
    names: dict[str, set[str]] = {"": set()}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names[""].add(node.name)
            names[node.name] = {
                n.name for n in node.body if isinstance(n, ast.FunctionDef)
            }
        elif isinstance(node, ast.FunctionDef):
            names[""].add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names[""].add(node.target.id)
    return names


def _public(obj: object) -> set[str]:
    return {n for n in dir(obj) if not n.startswith("_")}


def test_the_stub_and_py_typed_are_installed_with_the_package() -> None:
    assert STUB.is_file()
    assert STUB.with_name("py.typed").is_file()


def test_the_stub_declares_every_public_name_of_the_native_module_and_no_other() -> None:
    stubbed = _stubbed()
    module = _public(_flockway) | {"__version__"}
    assert stubbed[""] == module
    for cls in ("Session", "LevelDoc"):
        members = stubbed[cls] - {"__init__"}
        assert members == _public(getattr(_flockway, cls)), cls
