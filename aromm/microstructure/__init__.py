"""Voxel microstructures: load label images, generate synthetic ones, export them for ParaView.

Label images are 3-D integer arrays indexed ``[x, y, z]``; voxel sizes are in metres.
"""

from aromm.microstructure.export import export_image, export_time_series, voxel_mesh
from aromm.microstructure.generators import laminate, simple_cubic, sphere_in_cube, wood
from aromm.microstructure.io import as_labels, as_voxel_size, load_image, save_image

__all__ = [
    "as_labels",
    "as_voxel_size",
    "export_image",
    "export_time_series",
    "laminate",
    "load_image",
    "save_image",
    "simple_cubic",
    "sphere_in_cube",
    "voxel_mesh",
    "wood",
]
