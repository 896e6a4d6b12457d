"""Anisotropic phases: a conductivity tensor with principal values and axes, or a fibre phase whose local axis
comes from the image.

A phase's conductivity is affine in named parameters, like every other term of the model [Chavez2020, eq. 2–3]:

* a **tensor** phase, ``k = { values = [k_1, k_2, k_3], axes = [v_1, v_2, v_3] }`` (orthonormal rows):
  ``K = k_1 v_1 v_1ᵀ + k_2 v_2 v_2ᵀ + k_3 v_3 v_3ᵀ``, parameters ``<phase>.k_1``, ``k_2``, ``k_3``;
* a **fibre** phase, ``k_axial``, ``k_transverse`` and ``axis`` (three numbers, or ``"image"``):
  ``K = k_axial a aᵀ + k_transverse (I − a aᵀ)``, parameters ``<phase>.k_axial``, ``<phase>.k_transverse``.
  With ``axis = "image"`` each voxel takes the local fibre direction from the structure tensor of the phase's
  mask [BigunGranlund1987] (:func:`skimage.feature.structure_tensor`, Gaussian integration scale ``axis_sigma``
  voxels, image border ``axis_border``): the eigenvector of its smallest eigenvalue, the direction along which the
  image varies least.  Inside a fibre thicker than the window the tensor vanishes; such voxels (trace below
  ``DEGENERATE`` times the largest) take the axis of the phase's mean tensor.

The axis is an estimate; its knob is ``axis_sigma``.  benchmarks/fibre_axes.py measured (48³ image of straight
round fibres of radius 2–4 voxels at 30° to z, load average 10 on 2 cores): mean angle error 3.0–3.7° at σ = 1,
2.1–2.3° at σ = 1.5 (the default), 1.5° at σ = 3, in 0.04–0.08 CPU s and 88–93 bytes per voxel of the image; the
periodic k̄ of such fibres in a matrix then differs from the exact-axis k̄ by 1.0–1.3 % (Frobenius), little
changed by σ: the staircase of the fibres' surface, not the axis, dominates.

Each term ``k_i ∫ ∇φ_a · A_i ∇φ_b`` has a unit tensor field ``A_i`` (constant, or one 3 × 3 per voxel), assembled
element by element in the voxel Q1 element (:func:`aromm.fem.voxel_grid.tensor_conduction`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import FloatArray

TENSOR_NAMES = ("k_1", "k_2", "k_3")
FIBRE_NAMES = ("k_axial", "k_transverse")
FIBRE_KEYS = ("k_axial", "k_transverse", "axis", "axis_sigma", "axis_border")
BORDERS = ("reflect", "wrap", "nearest")  # image border of the structure tensor (scipy.ndimage modes)
DEGENERATE = 1e-6  # structure-tensor trace (relative to the phase's largest) below which a voxel has no own axis
ORTHONORMAL_TOL = 1e-6  # |V Vᵀ − I| allowed for given principal axes (they are then orthonormalised)


@dataclass(frozen=True)
class PhaseTensor:
    """The anisotropic conductivity of a phase (module docstring): ``kind`` ``"tensor"`` or ``"fibre"``, the
    ``values`` (W/(m K)) of its parameters ``names``, the principal ``axes`` (tensor: three rows; fibre: one unit
    axis, or None for the image's own), and the structure tensor's ``sigma`` (voxels) and ``border``."""

    kind: str
    values: tuple[float, ...]
    axes: tuple[tuple[float, float, float], ...] | None
    sigma: float = 1.5
    border: str = "reflect"

    @property
    def names(self) -> tuple[str, ...]:
        return TENSOR_NAMES if self.kind == "tensor" else FIBRE_NAMES

    def matrix(self, values: Sequence[float] | None = None) -> FloatArray:
        """The 3 × 3 tensor (W/(m K)) for a fixed axis, at ``values`` (default its own)."""
        if self.axes is None:
            raise InputError("a fibre phase with axis = \"image\" has one tensor per voxel, not one matrix")
        v = self.values if values is None else values
        units = constant_units(self)
        return np.asarray(sum(k * u for k, u in zip(v, units, strict=True)), dtype=float)


def constant_units(spec: PhaseTensor) -> list[FloatArray]:
    """The unit tensors A_i of a phase with fixed axes (v_i v_iᵀ; or a aᵀ and I − a aᵀ)."""
    assert spec.axes is not None
    vectors = np.asarray(spec.axes, dtype=float)
    if spec.kind == "tensor":
        return [np.outer(v, v) for v in vectors]
    axial = np.outer(vectors[0], vectors[0])
    return [axial, np.eye(3) - axial]


def fibre_axes(mask: npt.NDArray[np.bool_], sigma: float, border: str = "reflect") -> FloatArray:
    """Unit fibre axis (n, 3) of each voxel of ``mask`` (C order over the ``[x, y, z]`` image), from the structure
    tensor of the mask (module docstring).

    >>> mask = np.zeros((8, 8, 8), dtype=bool)
    >>> mask[3:5, 3:5, :] = True  # a square rod along z
    >>> np.round(np.abs(fibre_axes(mask, 1.0, "wrap")[0]), 6).tolist()
    [0.0, 0.0, 1.0]
    """
    from skimage.feature import structure_tensor

    elems = structure_tensor(mask.astype(np.float64), sigma=sigma, mode=border, order="rc")
    tensors = np.empty((int(mask.sum()), 3, 3))
    for (i, j), e in zip(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)), elems, strict=True):
        tensors[:, i, j] = tensors[:, j, i] = e[mask]
    trace = np.trace(tensors, axis1=1, axis2=2)
    _, vectors = np.linalg.eigh(tensors)
    axes = vectors[:, :, 0]  # eigenvector of the smallest eigenvalue
    if trace.size == 0 or trace.max() <= 0:
        raise InputError("fibre axis = \"image\": the phase's mask has no edge, so no direction "
                         "(give axis = [x, y, z])")
    flat = trace < DEGENERATE * trace.max()
    if flat.any():
        axes[flat] = np.linalg.eigh(tensors.mean(axis=0))[1][:, 0]
    return np.asarray(axes)


def element_units(spec: PhaseTensor, mask: npt.NDArray[np.bool_]) -> list[FloatArray]:
    """The unit tensors A_i of each voxel of ``mask``: (3, 3) for fixed axes, else (n, 3, 3)."""
    if spec.axes is not None:
        return constant_units(spec)
    a = fibre_axes(mask, spec.sigma, spec.border)
    axial = a[:, :, None] * a[:, None, :]
    return [axial, np.eye(3) - axial]


def _vector(value: Any, key: str) -> FloatArray:
    if (not isinstance(value, list) or len(value) != 3
            or any(isinstance(v, bool) or not isinstance(v, int | float) for v in value)
            or not np.all(np.isfinite(value)) or np.linalg.norm(value) == 0):
        raise InputError(f"{key}: must be three finite numbers, not all zero, got {value!r}")
    v = np.asarray(value, dtype=float)
    return v / np.linalg.norm(v)


def _positive(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value) or value <= 0:
        raise InputError(f"{key}: must be a finite number > 0 (W/(m K)), got {value!r}")
    return float(value)


def phase_tensor(spec: Mapping[str, Any], key: str) -> PhaseTensor | None:
    """The anisotropic conductivity of the phase table ``spec`` (``[phases.<name>]``, named ``key``): a tensor ``k``
    or the fibre keys; None for a scalar or ``[kx, ky, kz]`` k."""
    fibre = sorted(set(spec) & set(FIBRE_KEYS))
    if fibre and "k" in spec:
        raise InputError(f"{key}.{fibre[0]}: a fibre phase takes k_axial, k_transverse and axis instead of k")
    if fibre:
        return parse_fibre(spec, key)
    return parse_tensor(spec["k"], f"{key}.k") if isinstance(spec.get("k"), Mapping) else None


def parse_tensor(value: Mapping[str, Any], key: str) -> PhaseTensor:
    """``k = { values = [k_1, k_2, k_3], axes = [[…], […], […]] }``; refusals name ``key``.

    >>> spec = parse_tensor({"values": [2.0, 1.0, 1.0], "axes": [[0, 1, 1], [0, 1, -1], [1, 0, 0]]}, "k")
    >>> round(float(spec.matrix()[1, 2]), 12)
    0.5
    """
    unknown = sorted(set(value) - {"values", "axes"})
    if unknown:
        raise InputError(f"{key}.{unknown[0]}: unknown key; a tensor k takes values and axes")
    values = value.get("values")
    if not isinstance(values, list) or len(values) != 3:
        raise InputError(f"{key}.values: must be the three principal conductivities [k_1, k_2, k_3], got {values!r}")
    k = tuple(_positive(v, f"{key}.values") for v in values)
    axes = value.get("axes")
    if not isinstance(axes, list) or len(axes) != 3:
        raise InputError(f"{key}.axes: must be three principal axes [[x, y, z], [x, y, z], [x, y, z]], got {axes!r}")
    vectors = np.stack([_vector(v, f"{key}.axes") for v in axes])
    if np.abs(vectors @ vectors.T - np.eye(3)).max() > ORTHONORMAL_TOL:
        raise InputError(f"{key}.axes: the principal axes must be mutually orthogonal, got {axes!r}")
    rows = tuple((float(v[0]), float(v[1]), float(v[2])) for v in vectors)
    return PhaseTensor("tensor", k, rows)


def parse_fibre(spec: Mapping[str, Any], key: str) -> PhaseTensor:
    """``k_axial``, ``k_transverse``, ``axis`` (three numbers or ``"image"``), ``axis_sigma``, ``axis_border``."""
    missing = [name for name in FIBRE_NAMES if name not in spec]
    if missing:
        raise InputError(f"{key}.{missing[0]}: missing; a fibre phase needs k_axial and k_transverse (W/(m K))")
    values = tuple(_positive(spec[name], f"{key}.{name}") for name in FIBRE_NAMES)
    axis = spec.get("axis")
    if axis is None:
        raise InputError(f"{key}.axis: missing; give the fibre axis [x, y, z] or \"image\" (structure tensor)")
    sigma = spec.get("axis_sigma", 1.5)
    border = spec.get("axis_border", "reflect")
    if axis != "image":
        extra = [k for k in ("axis_sigma", "axis_border") if k in spec]
        if extra:
            raise InputError(f"{key}.{extra[0]}: goes with axis = \"image\" only")
        v = _vector(axis, f"{key}.axis")
        return PhaseTensor("fibre", values, ((float(v[0]), float(v[1]), float(v[2])),))
    if isinstance(sigma, bool) or not isinstance(sigma, int | float) or not np.isfinite(sigma) or sigma <= 0:
        raise InputError(f"{key}.axis_sigma: the structure tensor's scale in voxels, > 0, got {sigma!r}")
    if border not in BORDERS:
        raise InputError(f"{key}.axis_border: must be one of {', '.join(BORDERS)}, got {border!r}")
    return PhaseTensor("fibre", values, None, float(sigma), str(border))


def rotation(axis: Sequence[float], angle: float) -> FloatArray:
    """The rotation matrix by ``angle`` (rad) about ``axis`` (Rodrigues' formula).

    >>> np.round(rotation([0, 0, 1], np.pi / 2) @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    u = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    cross = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.asarray(np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross)
