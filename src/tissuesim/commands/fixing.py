"""``--fix``: a command's fixed region, as text → the plain-data spec of :func:`tissuesim.mesh.regions.fixed_region`.

Forms (lengths in metres, after ``--scale``; coordinates separated by commas):

* ``bottom:F``: the nodes within the fraction F of the model's height above its lowest point (default ``bottom:0.1``,
  the experiments' support);
* ``box:x0,y0,z0:x1,y1,z1``: the nodes in the axis-aligned box between two corners;
* ``plane:px,py,pz:nx,ny,nz``: the nodes on or behind the plane through p, whose normal n points out of the held
  region (``plane:0,0,0.01:0,0,1`` holds what lies below 1 cm);
* ``mask:FILE``: one 0/1 per surface vertex (``.npy`` or text); ``indices:FILE``: surface vertex indices.

Every command that holds a model shares this parser, so ``--fix`` means the same everywhere.
"""

from __future__ import annotations

import argparse

import numpy as np

from ..errors import BoundaryConditionError
from ..mesh.regions import BOTTOM_FRACTION

DEFAULT_FIX = f"bottom:{BOTTOM_FRACTION:g}"
FORMS = "bottom:F, box:x0,y0,z0:x1,y1,z1, plane:px,py,pz:nx,ny,nz, mask:FILE or indices:FILE"
FIX_HELP = (f"the region held at rest, lengths in metres: {FORMS} (default: {DEFAULT_FIX}, the bottom tenth of the "
            "model's height)")


def add_fix_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--fix TEXT`` (default :data:`DEFAULT_FIX`) to a command's ``parser``."""
    parser.add_argument("--fix", default=DEFAULT_FIX, metavar="REGION", help=FIX_HELP)


def parse_fix(text: str) -> dict:
    """The spec of ``--fix`` ``text`` (e.g. ``{"box": {"lower": [...], "upper": [...]}}``), or a
    BoundaryConditionError in one line naming what is wrong and the accepted forms. Files are not read here."""
    kind, _, rest = str(text).strip().partition(":")
    kind = kind.strip().lower()
    if kind in ("mask", "indices") and rest.strip():
        return {"mask" if kind == "mask" else "indices_file": rest.strip()}
    parts = rest.split(":") if rest else []
    if kind == "bottom" and len(parts) == 1:
        return {"bottom": _numbers(text, parts[0], 1)[0]}
    if kind == "box" and len(parts) == 2:
        return {"box": {"lower": _numbers(text, parts[0], 3), "upper": _numbers(text, parts[1], 3)}}
    if kind == "plane" and len(parts) == 2:
        return {"plane": {"point": _numbers(text, parts[0], 3), "normal": _numbers(text, parts[1], 3)}}
    raise BoundaryConditionError(f"--fix {text!r} is not a region; give one of {FORMS} (lengths in metres), e.g. "
                                 "--fix bottom:0.1")


def _numbers(text: str, group: str, count: int) -> list[float]:
    try:
        values = [float(word) for word in group.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not np.all(np.isfinite(values)):
        what = "a number" if count == 1 else f"{count} numbers separated by commas"
        raise BoundaryConditionError(f"--fix {text!r}: {group!r} must be {what}; the forms are {FORMS}")
    return values


def fixed_option(text: str, points: np.ndarray) -> tuple[np.ndarray | None, str]:
    """The solver option ``fixed=`` for ``--fix`` ``text`` on a model with M_S rest positions ``points``
    ``(n, 3) float64`` [m], and a line saying what is held. The default region gives None, the solvers' own bottom
    (which also fixes the volume nodes below the same height), so the default is bit-identical to a solver made
    without ``fixed``. A file is read relative to the current folder."""
    from ..mesh.regions import fixed_region

    spec = parse_fix(text)
    if spec == {"bottom": BOTTOM_FRACTION}:
        count = fixed_region(spec, points).size
        return None, f"fixed: the bottom {BOTTOM_FRACTION:g} of the height ({count} surface vertices)"
    nodes = fixed_region(spec, points)
    return nodes, f"fixed: --fix {text} ({nodes.size} of {len(points)} surface vertices)"


def check_fix(text: str) -> dict:
    """``--fix`` parsed, and its file found, before any work (a typo is refused before minutes of mesh building);
    returns its spec. The file's contents are checked against the model once it is built."""
    from pathlib import Path

    spec = parse_fix(text)
    (kind, value), = spec.items()
    if kind in ("mask", "indices_file") and not Path(value).is_file():
        raise BoundaryConditionError(f"--fix {text}: the file {value} does not exist or is not a file; give the path "
                                     "of a .npy or text file")
    return spec
