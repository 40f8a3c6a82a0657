"""Packages whose public names load on first use (PEP 562), so that a light submodule
(a method's parameter schema) can be imported without the numba kernels beside it."""

from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, exports: dict[str, str]):
    """``(__getattr__, __dir__, __all__)`` for ``package``: ``exports`` maps name ->
    submodule. ``__dir__`` lists the names not loaded yet too, so that ``dir()`` and an
    editor's completion find ``Simulator`` before its first use."""

    def __getattr__(name):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{exports[name]}"), name)

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__, sorted(exports)
