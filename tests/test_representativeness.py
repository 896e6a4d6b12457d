"""The representativeness row of the budget (aromm.homogenization.representativeness, identify
--representativeness-check) against closed forms.

Truth: images whose octants are homogeneous or identical, so that every octant's k̄ is a phase's k or the laminate's,
the whole image's k̄ along the layers is the arithmetic mean (Wiener's parallel bound, exact for a laminate loaded
along its layers, and exact for Q1 and finite volumes alike), and c̄ = Σ φ c.  Tolerances: the cell problems are
solved directly (splu), their k̄ to rounding; the central difference of ln k̄ is exact for a k̄ linear in k.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.homogenization.representativeness import Z95, blocks, half_widths, representativeness
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

KA, KB, CA, CB = 1.0, 3.0, 1.0e6, 3.0e6


def halves(discretisation: str = "q1", n: int = 6) -> Scene:
    labels = np.zeros((n, n, n), dtype=int)
    labels[: n // 2] = 1  # two halves across x; loaded along z: a laminate along the flux
    phases = (PhaseSpec("a", 0, KA, CA), PhaseSpec("b", 1, KB, CB))
    return Scene(VoxelGeometry(labels, (1e-3,) * 3), phases, (FaceSpec("z0", T=1.0), FaceSpec("z1", T=0.0)),
                 discretisation=discretisation)


@pytest.mark.parametrize("discretisation", ["q1", "fv"])
def test_halves_give_the_closed_form_spread_and_half_widths(discretisation: str) -> None:
    """Octants: four of a, four of b, so k̄ ∈ {k_a, k_b} and c̄ ∈ {c_a, c_b}; the whole: k̄ = (k_a + k_b)/2, so
    ∂ln k̄/∂ln k_a = k_a/(k_a + k_b), and 1 for both conductivities together (k̄ is homogeneous of degree 1)."""
    scene = halves(discretisation)
    octant = np.array([KA] * 4 + [KB] * 4)
    spread_k = float(octant.std(ddof=1) / octant.mean()) / math.sqrt(8)
    c_octant = np.array([CA] * 4 + [CB] * 4)
    spread_c = float(c_octant.std(ddof=1) / c_octant.mean()) / math.sqrt(8)
    one = representativeness(scene, {"a.k": KA, "a.c": CA}, axis=2, method="splu")
    np.testing.assert_allclose(np.sort(one.octant_k), np.sort(octant), rtol=1e-9)
    assert one.spread_k == pytest.approx(spread_k, rel=1e-9) and one.spread_c == pytest.approx(spread_c, rel=1e-12)
    assert one.half["a.k"] == pytest.approx(Z95 * spread_k * (KA + KB) / KA, rel=1e-6)
    assert one.half["a.c"] == pytest.approx(Z95 * spread_c * (CA + CB) / CA, rel=1e-12)
    both = representativeness(scene, {"a.k": KA, "b.k": KB}, axis=2, method="splu")
    assert both.half["a.k"] == pytest.approx(Z95 * spread_k, rel=1e-6) == both.half["b.k"]
    np.testing.assert_allclose(half_widths(both.half, ("b.k", "a.k", "z1.h"), np.array([KB, KA, 5.0])),
                               [Z95 * spread_k * KB, Z95 * spread_k * KA, 0.0], rtol=1e-6)


def test_an_image_of_identical_octants_adds_nothing() -> None:
    """Layers across the loaded axis with a period that divides the octants: all eight are the same laminate."""
    labels = np.zeros((4, 4, 8), dtype=int)
    labels[:, :, 1::2] = 1
    scene = Scene(VoxelGeometry(labels, (1e-3,) * 3), (PhaseSpec("a", 0, KA, CA), PhaseSpec("b", 1, KB, CB)),
                  (FaceSpec("z0", T=1.0),))
    rep = representativeness(scene, {"a.k": KA, "b.c": CB}, axis=2, method="splu")
    assert len(blocks(scene)) == 8
    assert rep.spread_k <= 1e-12 and rep.spread_c == 0.0 and max(rep.half.values()) <= 1e-11


def test_the_decay_is_measured_between_quarters_and_octants() -> None:
    """Two halves (12³): quarters and octants are all homogeneous, so the spread does not fall with size (d = 1, the
    image is one heterogeneity: the octants' spread is the image's).  Independent voxels (24³, integral range one
    voxel): the spread falls close to the 1/V law, d near √8 (a sample of 8 octants: d ≥ 1.5 with this seed)."""
    two = representativeness(halves(n=12), {"a.k": KA}, axis=2, method="splu")
    octant = np.array([KA] * 4 + [KB] * 4)
    assert two.decay == 1.0 and two.spread_k == pytest.approx(float(octant.std(ddof=1) / octant.mean()), rel=1e-9)
    labels = (np.random.default_rng(4).random((24, 24, 24)) < 0.4).astype(int)
    grains = Scene(VoxelGeometry(labels, (1e-3,) * 3), (PhaseSpec("a", 0, KA, CA), PhaseSpec("b", 1, KB, CB)),
                   (FaceSpec("z0", T=1.0),))
    rep = representativeness(grains, {"a.k": KA}, axis=2, method="splu")
    assert rep.decay is not None and 1.5 <= rep.decay <= math.sqrt(8)
