"""pytest configuration for the doctest run over the packages: modules of optional extras are collected
only when their extra is installed (``pip install -e ".[mor]"`` ...)."""

from __future__ import annotations

import importlib.util

OPTIONAL = {"aromm/interop/pymor.py": "pymor"}

collect_ignore = [path for path, module in OPTIONAL.items() if importlib.util.find_spec(module) is None]
