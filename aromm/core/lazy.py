"""A package's public names imported on first use (PEP 562): ``import aromm`` or a light module of ``inverse`` does not
load scipy, the solvers and every wing (``python -X importtime -c "import aromm"``; tests/test_startup.py).

Usage, in a package's ``__init__``::

    __getattr__, __dir__ = lazy.exports(__name__, {"identify": "inverse.identification"})
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def exports(package: str, where: Mapping[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` whose public names live in the modules ``where`` names (name →
    module); a name is imported at its first use and then kept in the package."""

    def __getattr__(name: str) -> Any:
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(where[name]), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *where})

    return __getattr__, __dir__
