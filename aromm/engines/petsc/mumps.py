"""MUMPS's analysis phase (ordering and symbolic factorisation) in parallel, where the MUMPS build allows it.

By default MUMPS orders the whole matrix on one process (ICNTL(28) = 1): at 512³ that rank holds the graph of
every unknown.  Where the engine factors with MUMPS (``solver="mumps"``: :func:`aromm.engines.petsc.linear.configure`)
it asks for the parallel analysis, ICNTL(28) = 2, with ICNTL(29) = 0 (MUMPS chooses PT-Scotch or ParMETIS,
whichever it was built with).  A MUMPS built with neither (Debian 12's libmumps 5.5) cannot: asked anyway at
2 ranks or more it prints "No parallel ordering tools available" on stdout and fails the analysis (INFOG(1) = −38,
the solve then diverges: :func:`failure` says why).  This module looks for either
tool in the MUMPS library the process has loaded (their library names or their API symbols in the shared
object, found through ``/proc/self/maps``); when neither is there it keeps ICNTL(28) = 1 and says once, in the
log of rank 0, that the analysis stays sequential and why.  When the library cannot be found (not Linux, MUMPS
linked statically into another library) the parallel analysis is asked for and MUMPS decides.

PETSc options with the solver's prefix (``-aromm_steady_mat_mumps_icntl_28 1`` ...) override these values.
"""

from __future__ import annotations

import functools
import logging
import mmap
from pathlib import Path
from typing import Any

from aromm.engines.petsc import runtime

log = logging.getLogger(__name__)

#: ICNTL(28): 1 sequential analysis, 2 parallel analysis.
SEQUENTIAL, PARALLEL = 1, 2
#: ICNTL(29): the parallel ordering tool, 0 = MUMPS's choice (1 PT-Scotch, 2 ParMETIS).
ORDERING = 0
#: What a MUMPS shared object built with PT-Scotch or ParMETIS contains: the libraries it needs, or their symbols.
MARKERS = (b"libptscotch", b"libparmetis", b"SCOTCH_dgraph", b"ParMETIS_V3_NodeND")


@functools.cache
def libraries() -> tuple[Path, ...]:
    """The MUMPS shared objects mapped into this process (PETSc loaded), from ``/proc/self/maps``; () if none."""
    runtime.petsc()
    maps = Path("/proc/self/maps")
    if not maps.is_file():
        return ()
    found = {line.split()[-1] for line in maps.read_text(encoding="utf-8", errors="replace").splitlines()
             if "mumps" in line.rsplit("/", 1)[-1] and line.split()[-1].startswith("/")}
    return tuple(sorted(Path(p) for p in found))


@functools.cache
def parallel_ordering() -> bool | None:
    """Whether the loaded MUMPS has PT-Scotch or ParMETIS (:data:`MARKERS`); None when no MUMPS library is found."""
    paths = [p for p in libraries() if p.is_file()]
    if not paths:
        return None
    for path in paths:
        with path.open("rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as data:
            if any(data.find(marker) >= 0 for marker in MARKERS):
                return True
    return False


def analysis_options(prefix: str, comm: Any) -> dict[str, int]:
    """Put ICNTL(28) (and ICNTL(29) when parallel) in PETSc's options for the MUMPS factor of the solver with
    options prefix ``prefix``, unless the user set them; returns what this call set.  Logs once per process, on
    rank 0, when the analysis must stay sequential."""
    options = runtime.petsc().Options(prefix)
    tools = parallel_ordering()
    wanted = {28: SEQUENTIAL} if tools is False else {28: PARALLEL, 29: ORDERING}
    set_here = {}
    for icntl, value in wanted.items():
        name = f"mat_mumps_icntl_{icntl}"
        if not options.hasName(name):
            options.setValue(name, value)
            set_here[name] = value
    if tools is False and runtime.is_root(comm):
        _say_sequential(", ".join(str(p) for p in libraries()))
    return set_here


@functools.cache
def _say_sequential(where: str) -> None:
    log.info("MUMPS analysis falls back to sequential (ICNTL(28) = 1, one rank orders the whole matrix): this MUMPS "
             "(%s) is built without PT-Scotch or ParMETIS, which the parallel analysis ICNTL(28) = 2 needs "
             "(docs/scaling.md)", where)


def failure(ksp: Any) -> str:
    """Why the MUMPS factorisation of ``ksp`` failed (its INFOG(1) < 0), or "" (not MUMPS, or no failure)."""
    pc = ksp.getPC()
    if pc.getType() not in ("cholesky", "lu") or pc.getFactorSolverType() != "mumps":
        return ""
    code = int(pc.getFactorMatrix().getMumpsInfog(1))
    if code >= 0:
        return ""
    hint = {-38: "the parallel analysis ICNTL(28) = 2 needs PT-Scotch or ParMETIS, which this MUMPS lacks; "
                 "set ICNTL(28) to 1",
            -9: "its working memory was too small (raise ICNTL(14))",
            -10: "the matrix is numerically singular"}.get(code, "see the MUMPS user guide")
    return f"MUMPS failed with INFOG(1) = {code}: {hint}"
