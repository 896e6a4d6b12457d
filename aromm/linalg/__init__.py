"""Linear algebra: direct factorisations, orderings, eigensolvers, multigrid."""
