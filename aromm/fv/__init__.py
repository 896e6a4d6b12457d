"""Cell-centred finite volumes on voxel images (two-point fluxes, harmonic-mean face conductances)."""
