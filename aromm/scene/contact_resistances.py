"""The ``[interfaces]`` section of a scene file: contact resistances between phases of a mesh scene.

``[interfaces."matrix|filler"] R = 1e-5`` puts a thermal contact resistance R (m² K/W) on the interface between
the two named phases (the mesh model splits its nodes, :mod:`aromm.fem.mesh`; [GarnierDanes]).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from aromm.scene.toml import TableReader


def parse_interfaces(r: TableReader, data: Mapping[str, Any], names: set[str]) -> dict[tuple[str, str], float]:
    """``[interfaces."a|b"]`` tables: the contact resistance ``R`` (m² K/W, positive) between phases a and b."""
    table = r.table(data, "interfaces", None)
    out = {}
    for pair in table:
        key = f'interfaces."{pair}"'
        parts = pair.split("|")
        if len(parts) != 2 or not set(parts) <= names:
            raise r.fail(key, f'must name two phases as "a|b", phases: {", ".join(sorted(names))}')
        spec = r.table(table, key, ("R",), pair)
        out[(parts[0], parts[1])] = r.number(spec.get("R"), f"{key}.R", positive=True)
    return out
