"""A model's size, the sizes a tissue model plausibly has, and the loads and tool sizes that suit a model of a given
size and stiffness.

* :func:`model_size`: the diagonal of the rest bounding box [m], the size every method measures displacements by
  (``Solver.size``; linear elasticity holds to about 0.1 of it).
* :func:`size_warning`: a sentence when a model lies outside :data:`PLAUSIBLE_SIZE` (5 mm to 2 m across), where a
  wrong unit is far likelier than tissue: a mesh in cm read as metres is 100 times too large, and nothing else
  tells the user. It names the size and the ``--scale`` that would make the model organ-sized.
* :func:`load_defaults`: the default force, contact radius, incision stroke, blade depth and pull of the commands and
  the viewer, derived from the size L and Young's modulus E so the picture lies in the small-strain range whatever
  the model: lengths are fixed fractions of L, forces are those that dent an elastic half-space by a fixed fraction
  of L under a tip of radius a (Boussinesq's uniform pressure on a disc: centre deflection
  u = 2 (1 − ν²) F / (π E a), so F = π E a u / (2 (1 − ν²)), which scales as E L² at fixed strain).

Why not fixed values: 5 N on one node moves an organ-sized model (0.14–0.26 m, E = 5.5 kPa) by 0.3–0.5 of its size,
and a 2 cm liver by 200 times its size; a 30 mm stroke does not fit on it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError

#: Sizes [m] (bounding-box diagonal) of a plausible tissue model: a biopsy sample to a whole torso. Outside, a
#: model is more likely in the wrong unit than meant (it still builds: it is warned of, not refused).
PLAUSIBLE_SIZE = (0.005, 2.0)
#: The size [m] of an organ, which a suggested ``--scale`` aims at.
ORGAN_SIZE = 0.1
#: File units a mesh is commonly written in, as factors to metres, and their names.
UNITS = {1e-3: "mm", 1e-2: "cm", 1.0: "m"}

#: Fractions of the model's size L behind :func:`load_defaults` (each a choice, stated where it is used).
CONTACT_RADIUS_FRACTION = 0.05      # a pin-head of 7 mm radius on an 8 cm cube
DENT_FRACTION = 0.03                # the deformation figure's dent: visible, a third of the small-strain limit
STROKE_FRACTION = 0.15              # 21 mm on the cube, 39 mm on the liver; a quarter of the steak's width
DEPTH_FRACTION = 0.06               # the cut's depth below the top: 8 mm on the cube, 12 mm on the 25 mm steak
PULL_OFFSET_FRACTION = 0.025        # the pull's distance beside the cut: a sixth of the stroke, as 5 mm of 30 mm
PULL_DENT_FRACTION = 0.01           # the pull opens the wound by about this fraction of L over its offset
#: Floors in mean edge lengths of the surface, for a coarse mesh: a pin-head that covers a few nodes (one node is a
#: point load, whose answer depends on the mesh), and a stroke that crosses a few edges (a shorter one may cut none).
RADIUS_EDGES = 1.5
STROKE_EDGES = 3.0
#: The longest stroke, as a fraction of L, whatever the floor: the paper's incision is small (§7), and a longer one
#: leaves the top of a rounded model.
STROKE_MAX_FRACTION = 0.3
#: The largest displacement a default load may cause, as a fraction of the model's size: half of where linear
#: elasticity stops (0.1, ``Solver.warning``), so a picture drawn with the defaults is a small-strain one.
DISPLACEMENT_CAP = 0.05


def model_size(points: ArrayLike) -> float:
    """The diagonal [m] of the bounding box of ``points`` ``(n, 3) float64`` [m] (0 for fewer than two points)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 2:
        return 0.0
    return float(np.linalg.norm(np.ptp(points, axis=0)))


def size_warning(points: ArrayLike, *, scale: float = 1.0, source: str = "the model") -> str | None:
    """A one-line sentence saying that ``points`` ``(n, 3)`` [m] (already multiplied by ``scale``, the factor from
    the file's unit to metres) span an implausible size for tissue, and the ``--scale`` that would give an
    organ-sized model; None within :data:`PLAUSIBLE_SIZE`."""
    size = model_size(points)
    low, high = PLAUSIBLE_SIZE
    if low <= size <= high or size == 0.0:
        return None
    bound = f"smaller than {_length(low)}" if size < low else f"larger than {_length(high)}"
    advice = _scale_advice(size / scale)
    question = ("did you forget --scale (scale= in Python)?" if scale == 1.0 else
                f"is scale {scale:g} the factor from the file's unit to metres?")
    return f"{source} is {_length(size)} across after scale {scale:g}, {bound}: {question} {advice}"


def suggested_scale(file_size: float) -> float:
    """The factor of :data:`UNITS` that makes a model of ``file_size`` (its size in the file's unit) the most
    organ-sized: within :data:`PLAUSIBLE_SIZE` and nearest :data:`ORGAN_SIZE` on a log scale."""
    low, high = PLAUSIBLE_SIZE

    def badness(factor: float) -> tuple[bool, float]:
        size = file_size * factor
        return not low <= size <= high, abs(math.log10(size / ORGAN_SIZE))

    return min(UNITS, key=badness)


def _scale_advice(file_size: float) -> str:
    factor = suggested_scale(file_size)
    return (f"--scale {factor:g} (a file in {UNITS[factor]}) would make it {_length(file_size * factor)} across, "
            "the size of an organ")


def _length(metres: float) -> str:
    """``metres`` in the unit that reads best: µm, mm, cm or m, three significant digits."""
    for unit, factor in (("m", 1.0), ("cm", 1e-2), ("mm", 1e-3)):
        if metres >= factor:
            return f"{metres / factor:.3g} {unit}"
    return f"{metres / 1e-6:.3g} µm"


@dataclass(frozen=True)
class LoadDefaults:
    """The loads and tool sizes that suit one model (:func:`load_defaults`). SI units.

    Attributes:
        size: the model's size L [m] (:func:`model_size`).
        force: the deformation figure's pin-head force [N], spread over ``radius``.
        radius: the pin-head's contact radius [m].
        stroke: the scripted incision's length [m].
        depth: how deep the incision cuts below the top [m] (the blade reaches this far below the surface).
        pull: the force [N] beside the incision that opens the wound (on one node).
        offset: the pull's distance [m] beside the incision.
    """

    size: float
    force: float
    radius: float
    stroke: float
    depth: float
    pull: float
    offset: float

    def describe(self) -> str:
        """One line naming the values and why they were chosen."""
        return (f"{self.force:.3g} N over a {_millimetres(self.radius)} pin-head, a {_millimetres(self.stroke)} "
                f"stroke {_millimetres(self.depth)} deep, a {self.pull:.3g} N pull {_millimetres(self.offset)} beside "
                f"it: sized to a model {_length(self.size)} across and E so the answer stays in the small-strain "
                "range")


def load_defaults(points: ArrayLike, *, edge_length: float = 0.0, youngs_modulus: float = 5500.0,
                  poisson_ratio: float = 0.3) -> LoadDefaults:
    """The default loads and tool sizes for a model with rest points ``points`` ``(n, 3) float64`` [m] and surface
    mean edge length ``edge_length`` [m] (``SurfaceMesh.mean_edge_length``; 0: no floor), of a material with
    Young's modulus ``youngs_modulus`` [Pa] and Poisson ratio ``poisson_ratio``.

    Lengths are fractions of the size L, the radius and the stroke at least :data:`RADIUS_EDGES` and
    :data:`STROKE_EDGES` edges (the stroke at most :data:`STROKE_MAX_FRACTION` of L); each force dents an elastic half-space by a fixed fraction of L under its tip
    (Boussinesq, module docstring): ``force`` by :data:`DENT_FRACTION` under ``radius``, ``pull`` by
    :data:`PULL_DENT_FRACTION` under a tip of ``offset``. A finite body held at its bottom moves somewhat more than
    a half-space, and a body held on a small patch much more (:func:`fitted_force`); the tests check the
    small-strain range with the solvers' own warning.
    """
    size = model_size(points)
    if not size > 0.0:
        raise MeshError("the model has no extent (all its points coincide), so no load can be sized to it")
    compliance = 2.0 * (1.0 - poisson_ratio**2) / (math.pi * youngs_modulus)     # u a / F of the disc [m²/N]
    radius = max(CONTACT_RADIUS_FRACTION * size, RADIUS_EDGES * edge_length)
    offset = PULL_OFFSET_FRACTION * size
    stroke = min(max(STROKE_FRACTION * size, STROKE_EDGES * edge_length), STROKE_MAX_FRACTION * size)
    return LoadDefaults(size=size, force=_rounded(DENT_FRACTION * size * radius / compliance),
                        radius=_rounded(radius), stroke=_rounded(stroke),
                        depth=_rounded(DEPTH_FRACTION * size),
                        pull=_rounded(PULL_DENT_FRACTION * size * offset / compliance), offset=_rounded(offset))


def _rounded(value: float) -> float:
    """``value`` to three significant digits: a default a user reads in a title and may type back."""
    return float(f"{value:.3g}")


def fitted_force(solver: object, node: int, force: float, directions: Iterable[ArrayLike], *,
                 radius: float | None = None) -> tuple[float, float]:
    """``force`` [N] lowered, where ``solver``'s model lets it move a node farther than :data:`DISPLACEMENT_CAP` of
    its size, to the force that moves it that far; and the largest displacement under ``force`` as a fraction of
    the size.

    The half-space estimate of :func:`load_defaults` knows the size and E, not the support: a body held on a small
    patch rocks on it (the 2 cm liver2 on its bottom tenth moves 0.46 of its size under the estimate's force). So
    the force is tried on the model itself, at ``node`` in each of ``directions`` (``(3,)`` unit vectors), and
    scaled by the cap over the largest displacement (exact for a linear method; the solvers' answers are linear in
    the load where the model is linear). ``solver`` needs ``solve_static(node, force, radius=)``, ``size`` [m] and
    ``reset()``; it is left at rest.
    """
    largest = 0.0
    for direction in directions:
        positions = solver.solve_static(node, force * np.asarray(direction, dtype=np.float64), radius=radius)
        largest = max(largest, float(np.linalg.norm(positions - solver.rest_positions, axis=1).max()))
    solver.reset()
    fraction = largest / solver.size
    return (force if fraction <= DISPLACEMENT_CAP else _rounded(force * DISPLACEMENT_CAP / fraction)), fraction


def _millimetres(metres: float) -> str:
    return f"{1e3 * metres:.3g} mm"
