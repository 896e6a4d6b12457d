"""Voxel microstructures: load label images, generate synthetic ones, export them for ParaView.

Label images are 3-D integer arrays indexed ``[x, y, z]``; voxel sizes are in metres.  The names are imported on
first use (:mod:`aromm.core.lazy`): a scene that needs a generator does not load meshio (≈ 65 ms with rich) for the
export.
"""

from aromm.core import lazy

_WHERE = {
    **dict.fromkeys(("export_image", "export_time_series", "voxel_mesh"), "aromm.microstructure.export"),
    **dict.fromkeys(("laminate", "simple_cubic", "sphere_in_cube", "wood"), "aromm.microstructure.generators"),
    **dict.fromkeys(("as_labels", "as_voxel_size", "load_image", "save_image"), "aromm.microstructure.io"),
}
__getattr__, __dir__ = lazy.exports(__name__, _WHERE)
__all__ = ["as_labels", "as_voxel_size", "export_image", "export_time_series", "laminate", "load_image", "save_image",
           "simple_cubic", "sphere_in_cube", "voxel_mesh", "wood"]
