"""How far a sample's k̄ and c̄ may be from the image's: the representativeness row of an identification's budget.

An identification fits phase properties so that the image's model reproduces measurements on a sample.  When the
image is not representative of that sample, the sample's effective conductivity k̄ along the loaded axis differs
from the image's by a relative δ_k (and its mean capacity c̄ by δ_c), and the fitted phase properties absorb it.  The
spread of δ is estimated from the image itself [Kanit2003]: the apparent k̄ of its eight octants (fixed temperatures
on the two faces normal to the axis, the others adiabatic, as a measurement) and their c̄ = Σ φ_i c_i have relative
standard deviations s_k, s_c.  Volumes larger than the integral range average independent parts, so the variance
falls as 1/V at most, and the image's own spread is ``s / d`` with the decay d per eightfold volume measured between
the 64 sub-volumes of a quarter edge and the octants, ``d = s_quarter / s_octant`` clipped to [1, √8]: √8 (the 1/V
law) once the octants exceed the integral range, 1 (no decay: the image is one heterogeneity) when the spread does
not fall with size.  Below 12 voxels a side there are no quarters to measure and √8 is assumed (said in ``decay``).

The shift of the estimates follows to first order from the fit's own structure: the outputs' change caused by a
relative change δ_k of k̄ is exactly what scaling the unknown phase conductivities together by ``δ_k / S_k`` causes,
``S_k = Σ_j ∂ln k̄/∂ln k_j`` over the unknown conductivities (k̄ is homogeneous of degree 1 in the phase
conductivities), so least squares moves each of them by ``δ_k/S_k`` relatively, and nothing else; likewise the
unknown capacities by ``δ_c/S_c``, ``S_c = Σ_j φ_j c_j / c̄``.  The 95 % half-widths are 1.96 times those, from
s_k/d and s_c/d.  ∂ln k̄/∂ln k_j is a central difference of the whole image's k̄ (two more cell problems per
unknown conductivity).  What it leaves out: a spread of the other parameters' effects (h, a clock offset); and d is
measured on 8 octants and 64 quarters, itself uncertain (``aromm rev`` shows the trend with size).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

#: Relative step of the central differences of k̄ in the phase conductivities.
STEP = 1e-3
#: Two-sided 95 % factor of a normal spread.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Representativeness:
    """The octants' k̄ along ``axis`` and c̄, the image's relative spreads of both (the octants' std / mean, ddof 1,
    over the decay d), each unknown's relative 95 % half-width (``half``, by parameter name) and d."""

    axis: int
    octant_k: FloatArray
    octant_c: FloatArray | None
    spread_k: float
    spread_c: float
    half: Mapping[str, float]
    decay: float | None = None  # measured d of the module docstring (None: √8 assumed)

    @property
    def octant_spread_k(self) -> float:
        """The octants' own relative spread of k̄ (before the decay to the image's size)."""
        return _spread(self.octant_k)

    def as_dict(self) -> dict[str, object]:
        return {"axis": "xyz"[self.axis], "octant_k": self.octant_k.tolist(),
                "octant_c": None if self.octant_c is None else self.octant_c.tolist(),
                "spread_k": self.spread_k, "spread_c": self.spread_c, "decay": self.decay,
                "relative_half_width": dict(self.half)}


#: Smallest side (voxels) of a sub-volume.
MIN_SIDE = 2


def blocks(scene: Scene, parts: int = 2) -> list[Scene]:
    """The ``parts³`` sub-scenes of a voxel image cut into ``parts`` equal blocks along each axis (the remainder of
    a side that ``parts`` does not divide is dropped); 2 gives the octants."""
    geometry = scene.geometry
    if not isinstance(geometry, VoxelGeometry):
        raise InputError(f"{scene.where}representativeness: a mesh scene has no octants of voxels")
    labels = np.asarray(geometry.labels)
    if min(labels.shape) < parts * MIN_SIDE:
        raise InputError(f"{scene.where}representativeness: the image ({'×'.join(map(str, labels.shape))} voxels) "
                         f"is too small to cut in {parts} (at least {parts * MIN_SIDE} voxels per side)")
    cuts = [[slice(i * (n // parts), (i + 1) * (n // parts)) for i in range(parts)] for n in labels.shape]
    return [replace(scene, geometry=VoxelGeometry(labels[a, b, c], geometry.voxel_size), sensors=())
            for a in cuts[0] for b in cuts[1] for c in cuts[2]]


def with_values(scene: Scene, values: Mapping[str, float]) -> Scene:
    """``scene`` with the phase conductivities and capacities of ``values`` (``"<phase>.k"``, ``"<phase>.c"``)."""
    phases = tuple(replace(ph, k=float(values.get(f"{ph.name}.k", ph.k)),  # type: ignore[arg-type]
                           c=values.get(f"{ph.name}.c", ph.c)) if not ph.orthotropic and ph.tensor is None else ph
                   for ph in scene.phases)
    return replace(scene, phases=phases)


def unknown_conductivities(scene: Scene, names: Iterable[str]) -> tuple[list[str], list[str]]:
    """The unknown phase conductivities (``<phase>.k``) among ``names``, and those of them that are an anisotropic
    phase's (orthotropic, a tensor or a fibre: scaling ``k`` does not scale them)."""
    phases = {ph.name: ph for ph in scene.phases}
    unknown_k = [n for n in names if n.endswith(".k") and n[:-2] in phases]
    return unknown_k, [n for n in unknown_k if phases[n[:-2]].orthotropic or phases[n[:-2]].tensor is not None]


def phase_unknowns(scene: Scene, names: Iterable[str]) -> tuple[list[str], list[str]]:
    """The unknown phase conductivities and capacities among ``names``; InputError when there is none, or when a
    conductivity is an anisotropic phase's (the check scales isotropic ones only).  Cheap: commands call it before
    any work."""
    names = list(names)
    unknown_k, tensors = unknown_conductivities(scene, names)
    phases = {ph.name for ph in scene.phases}
    unknown_c = [n for n in names if n.endswith(".c") and n[:-2] in phases]
    if not unknown_k and not unknown_c:
        raise InputError("representativeness: it maps the spread of k̄ and c̄ onto unknown phase conductivities or "
                         "capacities: give a <phase>.k or <phase>.c among the unknowns (--unknown on the command line)")
    if tensors:
        raise InputError(f"representativeness: {tensors[0]} is an anisotropic phase's conductivity; the check scales "
                         "isotropic phase conductivities only")
    return unknown_k, unknown_c


def representativeness(scene: Scene, estimates: Mapping[str, float], axis: int,
                       method: str = "auto") -> Representativeness:
    """The module docstring's spreads and relative half-widths for the unknowns ``estimates`` (name → value) of an
    identification on ``scene`` loaded along ``axis``.

    >>> from aromm.core.vocabulary import PhaseSpec
    >>> labels = np.zeros((4, 4, 4), dtype=int); labels[:2] = 1  # two halves across x, loaded along z
    >>> s = Scene(VoxelGeometry(labels, (1e-3,) * 3), (PhaseSpec("a", 0, 1.0, 1e6), PhaseSpec("b", 1, 3.0, 1e6)))
    >>> r = representativeness(s, {"a.k": 1.0}, axis=2, method="splu")
    >>> sorted(np.round(r.octant_k, 9).tolist())  # homogeneous octants: each phase's own k
    [1.0, 1.0, 1.0, 1.0, 3.0, 3.0, 3.0, 3.0]
    >>> round(r.half["a.k"] / (1.96 * r.spread_k * 4.0), 2)  # k̄ = (k_a + k_b)/2: ∂ln k̄/∂ln k_a = 1/4
    1.0
    """
    unknown_k, unknown_c = phase_unknowns(scene, estimates)
    base = with_values(scene, estimates)

    def k_bar(s: Scene) -> float:
        return float(effective_conductivity(s, "temperature", method, axes=(axis,)).k[axis, axis])

    parts = blocks(base)
    octant_k = np.array([k_bar(p) for p in parts])
    quarters = blocks(base, 4) if min(np.shape(base.geometry.labels)) >= 6 * MIN_SIDE else None  # type: ignore[union-attr]
    decay = None
    if quarters is not None:
        quarter_k = np.array([k_bar(p) for p in quarters])
        decay = float(np.clip(_spread(quarter_k) / max(_spread(octant_k), np.finfo(float).tiny), 1.0, math.sqrt(8)))
    spread_k = _spread(octant_k) / (decay or math.sqrt(8))
    fractions = [p.volume_fractions() for p in parts]
    capacities = all(ph.c is not None for ph in base.phases)
    octant_c = np.array([sum(f[ph.name] * float(ph.c or 0.0) for ph in base.phases) for f in fractions]) \
        if capacities else None
    spread_c = _spread(octant_c) / (decay or math.sqrt(8)) if octant_c is not None else 0.0
    half: dict[str, float] = {}
    if unknown_k:
        if k_bar(base) <= 0:
            raise InputError(f"{scene.where}representativeness: the image has no conducting path along "
                             f"{'xyz'[axis]} at the estimates (k̄ = 0): its conductivities cannot be scaled")
        slope = conductivity_slope(base, estimates, unknown_k, k_bar)
        half.update({name: Z95 * spread_k / slope if slope > 0 else math.inf for name in unknown_k})
    if unknown_c:
        whole = base.volume_fractions()
        c_bar = sum(whole[ph.name] * float(ph.c or 0.0) for ph in base.phases)
        share = sum(whole[n[:-2]] * estimates[n] for n in unknown_c) / c_bar if c_bar else 0.0
        half.update({name: Z95 * spread_c / share if share > 0 else math.inf for name in unknown_c})
    return Representativeness(axis, octant_k, octant_c, spread_k, spread_c, half, decay)


def conductivity_slope(scene: Scene, estimates: Mapping[str, float], unknown_k: Sequence[str],
                       k_bar: Callable[[Scene], float]) -> float:
    """``S_k = Σ_j ∂ln k̄/∂ln k_j`` over the unknown conductivities ``unknown_k`` at ``estimates`` (central differences
    of relative step :data:`STEP`; ``k_bar`` the scene's k̄ along the loaded axis): the relative change of k̄ when
    they are scaled together, 1 when they are every phase (k̄ is homogeneous of degree 1)."""
    slope = 0.0
    for name in unknown_k:
        up, down = ({**estimates, name: estimates[name] * (1 + sign * STEP)} for sign in (1, -1))
        slope += (math.log(k_bar(with_values(scene, up))) - math.log(k_bar(with_values(scene, down)))) / (
            math.log1p(STEP) - math.log1p(-STEP))
    return slope


def _spread(values: FloatArray) -> float:
    """std / mean (ddof 1) of values ≥ 0; 0 for a constant set (all 0 included)."""
    mean = float(np.mean(values))
    return float(np.std(values, ddof=1)) / mean if mean > 0 else 0.0


def half_widths(relative: Mapping[str, float], names: Sequence[str], estimates: FloatArray) -> FloatArray:
    """Relative half-widths (name → fraction of the estimate) in the estimates' units, in the order of ``names``
    (0 for the other unknowns)."""
    return np.array([relative.get(n, 0.0) * abs(float(v)) for n, v in zip(names, estimates, strict=True)])
