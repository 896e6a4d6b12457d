"""The PETSc/SLEPc engine: voxel assembly by 3-D boxes, eigenbases, steady and transient solves under MPI.

Run under ``mpiexec -n P``; every rank executes the same calls (SPMD).  The voxel image is cut into
``m × n × p = P`` boxes (:mod:`aromm.engines.petsc.layout`, the ownership of a PETSc DMDA of the node grid);
each rank reads only its box of the image file (:mod:`aromm.engines.petsc.images`), assembles it with the
serial voxel assembler (:func:`aromm.fem.assemble_voxels`, the same Q1 element matrices) and owns the DMDA's
rows of its nodes, a contiguous block of PETSc's numbering.  PETSc holds the affine terms (C_j, K_j, H_j as
MPIAIJ matrices, loads as vectors); SLEPc computes the Dirichlet and Steklov bases
(:mod:`aromm.engines.petsc.eigen`); PETSc CG preconditioned by GAMG does the steady solves
(:mod:`aromm.engines.petsc.steady`).  Rank 0 receives only small things (projected reduced operators, face
means) and writes results and caches.

Modules: ``runtime`` (imports, communicator helpers), ``layout`` (who owns what), ``images`` (opening
the image for box reading), ``problem`` (a voxel scene whose image is read by boxes), ``assembly`` (the
distributed ThermalSystem), ``linear`` (KSP solvers), ``eigen`` (SLEPc bases), ``basis`` (the detailed
modal basis and its correction modes), ``projection`` (Galerkin projection onto a distributed basis),
``reduction`` (``reduce``), ``krylov_engine`` and ``krylov_reduction`` (the eigen-free Krylov reductor of
:mod:`aromm.reduction.krylov` on KSP solves only), ``steady`` and ``transient`` (full-order solves), ``homogenization``
(eq. 13 probes).
Importing :mod:`aromm` never imports this package (petsc4py is an optional extra).
"""
