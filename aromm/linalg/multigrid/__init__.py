"""Geometric multigrid for the steady voxel conduction problem: matrix-free fine level, Galerkin coarse levels."""
