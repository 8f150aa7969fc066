"""The hand-written stubs (_native.pyi) say what the compiled module has."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import wetcloth
from wetcloth import _native

STUB = Path(wetcloth.__file__).with_name("_native.pyi")


def stub_tree() -> ast.Module:
    return ast.parse(STUB.read_text(encoding="utf-8"))


def params(fn: ast.FunctionDef) -> list[str]:
    a = fn.args
    names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs]
    return [n for n in names if n not in ("self",)]


def runtime_params(obj: object) -> list[str]:
    sig = inspect.signature(obj)  # pyo3 gives __text_signature__
    return [n for n in sig.parameters if n not in ("self", "$self", "cls", "$cls", "$type")]


def public(names: object) -> set[str]:
    return {n for n in dir(names) if not n.startswith("_")}


def test_every_name_of_the_module_is_in_the_stub_and_back() -> None:
    tree = stub_tree()
    stubbed = set()
    for node in tree.body:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
            stubbed.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            stubbed.add(node.target.id)
    have = public(_native) | {"__version__"}
    assert stubbed == have


def test_functions_and_methods_take_the_stubs_parameters() -> None:
    for node in stub_tree().body:
        if isinstance(node, ast.FunctionDef):
            assert params(node) == runtime_params(getattr(_native, node.name)), node.name
        if isinstance(node, ast.ClassDef):
            cls = getattr(_native, node.name)
            members = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
            runtime = {n for n in vars(cls) if not n.startswith("_")}
            assert set(m for m in members if not m.startswith("_")) == runtime, node.name
            for name, fn in members.items():
                obj = cls if name == "__init__" else getattr(cls, name)
                if isinstance(inspect.getattr_static(cls, name, None), property) or any(
                    isinstance(d, ast.Name) and d.id == "property" for d in fn.decorator_list
                ):
                    assert not callable(inspect.getattr_static(cls, name)), f"{cls.__name__}.{name}"
                    continue
                if name in ("__eq__", "__copy__", "__deepcopy__", "__reduce__"):
                    assert hasattr(cls, name)
                    continue
                got = runtime_params(obj)
                assert params(fn) == got, f"{cls.__name__}.{name}: {params(fn)} != {got}"
