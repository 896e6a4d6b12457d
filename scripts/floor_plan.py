"""The floor plan of the packages: modules per folder, import arrows, cycles and arrows against the layers.

Reads the import graph with grimp (import-linter's graph library) and the layer contract from pyproject.toml
(``[tool.importlinter]``), and prints, for the tree at ``--root`` (default: this repository)::

    modules per folder, import arrows between modules, import cycles (strongly connected groups of modules,
    and of wings), arrows that run up the layers

Run ``python scripts/floor_plan.py`` (or ``--root`` another checkout, e.g. an older commit's ``git archive``) to
compare two trees; ``--layers`` prints the layer list that docs/design.md and CONTRIBUTING.md quote.
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import grimp

PACKAGES = ("aromm", "inverse")


def contract_layers(pyproject: Path) -> list[list[str]]:
    """The layers of the first layers contract, top to bottom, each a list of independent wings."""
    config = tomllib.loads(pyproject.read_text(encoding="utf-8"))["tool"]["importlinter"]
    layers = next(c["layers"] for c in config["contracts"] if c["type"] == "layers")
    return [[wing.strip() for wing in layer.split("|")] for layer in layers]


def wing_of(module: str, wings: list[str]) -> str:
    """The wing a module belongs to: the longest listed prefix, else ``aromm.<folder>``, else its package."""
    best = [w for w in wings if module == w or module.startswith(w + ".")]
    if best:
        return max(best, key=len)
    parts = module.split(".")
    return parts[0] if parts[0] != "aromm" else ".".join(parts[:2])


def strongly_connected(edges: dict[str, set[str]]) -> list[list[str]]:
    """Groups of more than one node that reach each other (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    groups: list[list[str]] = []
    counter = 0
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = []
                    while True:
                        top = stack.pop()
                        on.discard(top)
                        group.append(top)
                        if top == node:
                            break
                    if len(group) > 1:
                        groups.append(sorted(group))
            elif nxt not in index:
                index[nxt] = low[nxt] = counter
                counter += 1
                stack.append(nxt)
                on.add(nxt)
                work.append((nxt, iter(sorted(edges.get(nxt, ())))))
            elif nxt in on:
                low[node] = min(low[node], index[nxt])
    return groups


@dataclass(frozen=True)
class FloorPlan:
    """Counts of one tree: modules, modules per folder, import arrows, cycles and arrows up the layers."""

    modules: int
    folders: dict[str, int]
    arrows: int
    module_cycles: list[list[str]]
    wing_cycles: list[list[str]]
    upward: list[str]


def report(root: Path, layers: list[list[str]]) -> FloorPlan:
    """Counts of the tree at ``root`` against ``layers``."""
    sys.path.insert(0, str(root))
    graph = grimp.build_graph(*[p for p in PACKAGES if (root / p).is_dir()], cache_dir=None)
    sys.path.pop(0)
    modules = sorted(m for m in graph.modules if not m.endswith(".__init__"))
    edges = {m: {i for i in graph.find_modules_directly_imported_by(m)} for m in modules}
    arrows = sum(len(v) for v in edges.values())
    folders = Counter(m.rsplit(".", 1)[0] if graph.find_children(m) == set() else m for m in modules)
    wings = [w for layer in layers for w in layer]
    rank = {w: i for i, layer in enumerate(layers) for w in layer}
    wing_edges: dict[str, set[str]] = {}
    upward = []
    for a, targets in edges.items():
        for b in targets:
            wa, wb = wing_of(a, wings), wing_of(b, wings)
            if wa != wb:
                wing_edges.setdefault(wa, set()).add(wb)
                if wa in rank and wb in rank and rank[wb] < rank[wa]:
                    upward.append(f"{a} -> {b}")
    return FloorPlan(len(modules), dict(sorted(folders.items())), arrows, strongly_connected(edges),
                     strongly_connected(wing_edges), sorted(upward))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1])
    parser.add_argument("--layers", action="store_true", help="print the contract's layers, top to bottom")
    args = parser.parse_args()
    layers = contract_layers(Path(__file__).resolve().parents[1] / "pyproject.toml")
    if args.layers:
        for layer in layers:
            print(" | ".join(layer))
        return
    r = report(args.root.resolve(), layers)
    print(f"{r.modules} modules in {len(r.folders)} folders; {r.arrows} import arrows")
    for folder, count in r.folders.items():
        print(f"  {folder:32s} {count}")
    for label, groups in (("module cycles", r.module_cycles), ("wing cycles", r.wing_cycles)):
        print(f"{label}: {len(groups)}")
        for group in groups:
            print("  " + " <-> ".join(group))
    print(f"arrows up the layers: {len(r.upward)}")
    for arrow in r.upward:
        print("  " + arrow)

if __name__ == "__main__":
    main()
