"""Packages whose public names load on first use.

A package's ``__init__.py`` maps each public name to the module that defines it and lets
this module write its ``__getattr__`` and ``__dir__`` (PEP 562), so importing the package
imports none of its heavy modules (MuJoCo, OpenCV, the detector) until a name is used::

    _WHERE = {"PartDetector": "detector", "describe_footprint": "steps.footprint:describe"}
    __all__ = sorted(_WHERE)
    __getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())

``"module:attr"`` names an attribute whose name differs from the exported one.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(package: str, where: dict[str, str], namespace: dict[str, Any]
               ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``: a name of ``where`` is imported from
    ``package.<module>`` on first use and kept in ``namespace`` (the package's globals);
    any other name is an ``AttributeError`` naming the package."""

    def __getattr__(name: str) -> Any:  # noqa: N807 (the module-level hook's own name)
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attr = where[name].partition(":")
        value = getattr(importlib.import_module(f"{package}.{module}"), attr or name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:  # noqa: N807
        return sorted(where)

    return __getattr__, __dir__
