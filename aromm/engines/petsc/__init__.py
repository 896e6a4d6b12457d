"""The PETSc/SLEPc engine: voxel assembly by z-slabs, eigenbases, steady and transient solves under MPI.

Run under ``mpiexec -n P``; every rank executes the same calls (SPMD).  Each rank reads the voxel layers
``k0 <= k < k1`` of the image (:mod:`aromm.engines.petsc.layout`), assembles them with the serial voxel
assembler (:func:`aromm.fem.assemble_voxels`, the same Q1 element matrices) and owns the node planes
``k0 <= k < k1`` — a contiguous block of the global numbering of aromm.fem, so PETSc vectors are laid out
exactly as the serial ones.  PETSc holds the affine terms (C_j, K_j, H_j as MPIAIJ matrices, loads as
vectors); SLEPc computes the Dirichlet and Steklov bases (:mod:`aromm.engines.petsc.eigen`); PETSc CG
preconditioned by GAMG does the steady solves (:mod:`aromm.engines.petsc.steady`).  Rank 0 receives
only small things (projected reduced operators, face means) and writes results and caches.

Modules: ``runtime`` (imports, communicator helpers), ``layout`` (who owns what), ``problem`` (a voxel
scene whose image is read by slabs), ``assembly`` (the distributed ThermalSystem), ``linear`` (KSP
solvers), ``eigen`` (SLEPc bases), ``basis`` (the detailed modal basis and its correction modes),
``projection`` (Galerkin projection onto a distributed basis), ``reduction`` (``reduce``), ``steady``
and ``transient`` (full-order solves), ``homogenization`` (eq. 13 probes).
Importing :mod:`aromm` never imports this package (petsc4py is an optional extra).
"""
