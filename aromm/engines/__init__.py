"""Computational engines behind the public API: ``"scipy"`` (one process, today's path) or ``"petsc"``.

``engine="petsc"`` (``--engine petsc`` on the command line) runs the assembly, the eigenbases and the
steady solves on PETSc/SLEPc under MPI (``mpiexec -n P``): each rank holds a 3-D box of the voxel image
and its rows of the operators (aromm.engines.petsc).  The petsc engine is an optional extra: nothing
here imports petsc4py; :func:`check_engine` refuses ``"petsc"`` with the install routes when it is absent.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import re
import sys

from aromm.core.errors import InputError

ENGINES = ("scipy", "petsc")


def is_root(engine: str) -> bool:
    """True on the process that prints and writes: the only one for scipy, rank 0 for petsc."""
    if engine != "petsc":
        return True
    from aromm.engines.petsc import runtime

    return runtime.is_root(runtime.world())

#: What to do when petsc4py is missing (README "Running on a cluster").
INSTALL_HINT = (
    "the petsc engine needs petsc4py, slepc4py and mpi4py: on Debian 12 `apt-get install python3-petsc4py "
    "python3-slepc4py python3-mpi4py`, a venv made with `/usr/bin/python3 -m venv --system-site-packages`, "
    "`pip install \"numpy<2\" -e .` (README, 'Running on a cluster'); on a "
    "cluster load the site's PETSc/SLEPc modules or `pip install petsc4py slepc4py` built from source"
)

#: Debian installs petsc4py/slepc4py under these directories and finds them through PETSC_DIR/SLEPC_DIR.
DEBIAN_PETSC_DIRS = "/usr/lib/petscdir/petsc3.*/*-real"
DEBIAN_SLEPC_DIRS = "/usr/lib/slepcdir/slepc3.*/*-real"
#: The system Python's site directory, whose petsc4py.pth / slepc4py.pth read PETSC_DIR / SLEPC_DIR at start-up.
DEBIAN_SITE = "/usr/lib/python3/dist-packages"
#: (variable, installed directories, the -dev packages' default link, the .pth hook in DEBIAN_SITE).
DEBIAN_LAYOUT = (("PETSC_DIR", DEBIAN_PETSC_DIRS, "/usr/lib/petsc", "petsc4py.pth"),
                 ("SLEPC_DIR", DEBIAN_SLEPC_DIRS, "/usr/lib/slepc", "slepc4py.pth"))


def _version_key(path: str) -> list[int]:
    return [int(n) for n in re.findall(r"\d+", path)]


def find_debian_petsc() -> dict[str, str]:
    """Set PETSC_DIR / SLEPC_DIR to Debian's newest installed PETSc / SLEPc when this Python sees Debian's
    site directory (the system Python, or a venv made from it with ``--system-site-packages``), the variable is
    unset and the ``-dev`` packages' default link (``/usr/lib/petsc``, ``/usr/lib/slepc``) is absent; add their
    module directories to ``sys.path`` as Debian's ``.pth`` hooks would have at start-up.  Processes started
    from here (``mpiexec``) inherit the variables.  Returns what was set (nothing elsewhere: site modules,
    Spack, pip builds set their own)."""
    if DEBIAN_SITE not in sys.path:
        return {}
    found = {}
    for var, pattern, link, hook in DEBIAN_LAYOUT:
        dirs = sorted(glob.glob(pattern), key=_version_key)
        hooked = os.path.isfile(os.path.join(DEBIAN_SITE, hook))
        if os.environ.get(var) or os.path.isdir(link) or not dirs or not hooked:
            continue
        os.environ[var] = found[var] = dirs[-1]
        modules = os.path.join(dirs[-1], "lib", "python3", "dist-packages")
        if modules not in sys.path:
            sys.path.append(modules)
    if found:
        importlib.invalidate_caches()
    return found


def petsc_available() -> bool:
    """True when petsc4py, slepc4py and mpi4py can be imported (nothing is imported here; Debian's packages are
    found without PETSC_DIR / SLEPC_DIR, :func:`find_debian_petsc`)."""
    find_debian_petsc()
    return all(importlib.util.find_spec(name) is not None for name in ("petsc4py", "slepc4py", "mpi4py"))


def check_engine(engine: str) -> str:
    """``engine`` when known and usable, else :class:`InputError` naming the allowed engines or the install."""
    if engine not in ENGINES:
        raise InputError(f"unknown engine {engine!r}; allowed: {', '.join(ENGINES)}")
    if engine == "petsc" and not petsc_available():
        hint = ""
        if glob.glob(DEBIAN_PETSC_DIRS) and DEBIAN_SITE not in sys.path:
            hint = (f" (Debian's PETSc is installed but this Python does not see {DEBIAN_SITE}: use /usr/bin/python3 "
                    "or a venv made from it with --system-site-packages)")
        raise InputError(f"engine 'petsc' is not available{hint}; {INSTALL_HINT}")
    return engine


#: Linear solvers of the petsc engine (aromm.engines.petsc.linear); "auto" means "gamg".
PETSC_SOLVERS = ("gamg", "mumps")


def check_solver(engine: str, solver: str, scipy_solvers: tuple[str, ...]) -> str:
    """``solver`` when it belongs to ``engine`` (``scipy_solvers`` for scipy, :data:`PETSC_SOLVERS` for petsc)."""
    allowed = ("auto", *PETSC_SOLVERS) if engine == "petsc" else scipy_solvers
    if solver not in allowed:
        raise InputError(f"solver {solver!r} does not belong to engine {engine!r}; allowed: {', '.join(allowed)}")
    return solver
