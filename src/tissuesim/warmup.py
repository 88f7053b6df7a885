"""Compile what a session can use before it starts: every kernel a simulator session may call, run once on a small
model, so that no grab, material switch, probe press or cut waits on Numba later.

Numba compiles a kernel the first time it is called with a new type signature and caches it on disk; a fresh
install therefore stalls the first grab under a finite-strain material, the first probe press and the first cut for
seconds to minutes each. :func:`warm_up` plays a short session on a 200-vertex cube instead: every method with
every material it has (and the hybrid's quadratic M_V), a pin-head grab and drag, a grasper's lift, a probe press,
and two scalpel strokes with the step after each, gravity and a ligament on, with a progress bar. Where the kernels are cached already
it only loads them: about 5 s on 2 cores, which :func:`ensure_warm` (what the simulator calls before its window
opens) spares: it plays the session only where no stamp says it was played for these sources and this Numba.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from pathlib import Path

import numpy as np

#: The session's model: the built-in cube at this many vertices (small, so a warm run is quick).
VERTICES = 200
#: The stamp's file name (:func:`stamp_path`).
STAMP = "tissuesim-warm.stamp"


def sessions() -> list[tuple[str, dict]]:
    """``(method, options)`` of every configuration a simulator session can switch to: each method with each
    material it takes, and the hybrid's quadratic M_V with each of its materials."""
    from .solvers.registry import available_solvers, solver_class

    configurations = []
    for method in available_solvers():
        for material in solver_class(method).materials:
            configurations.append((method, {"material": material}))
            if method == "hybrid":
                configurations.append((method, {"material": material, "element": "quadratic"}))
    return configurations


def warm_up(*, progress: bool = True) -> int:
    """Play the warm-up session (module docstring); returns how many configurations were played. ``progress``
    draws a bar on stderr."""
    from tqdm import tqdm

    from .errors import TissuesimWarning
    from .mesh import models
    from .mesh.hybrid import HybridMesh

    hybrid = HybridMesh.build(models.cube(VERTICES))
    played = sessions()
    with warnings.catch_warnings():     # what the small model's tools warn of concerns no user's model
        warnings.simplefilter("ignore", TissuesimWarning)
        for method, options in tqdm(played, desc="preparing the kernels", unit="method", disable=not progress,
                                    leave=False):
            _play(hybrid, method, options)
    return len(played)


def _play(hybrid, method: str, options: dict) -> None:
    """One configuration: built with gravity and a ligament, a grab and a drag, a grasper's lift, a probe press, a
    cut and a step."""
    from .errors import TissuesimError
    from .tools.grasper import Grasper
    from .tools.pinhead import PinHead
    from .tools.probe import Probe
    from .tools.scalpel import Scalpel
    from .solvers.attachments import Attachment
    from .solvers.registry import make_solver

    rest = hybrid.surface.vertices
    top = rest[:, 2].max()
    corner = int(np.argmax(rest[:, 0] + rest[:, 1] + rest[:, 2]))
    solver = make_solver(method, hybrid, gravity=(0.0, 0.0, -9.81), attachments=(Attachment([corner], 10.0),),
                         **options)
    size = float(np.ptp(rest, axis=0).max())
    centre = rest[np.argmax(rest[:, 2])]
    pin = PinHead(solver, stiffness=20.0, radius=0.1 * size)
    pin.grab(centre)
    for lift in (0.01, 0.02):
        pin.drag(centre + [0.0, 0.0, lift * size])
        solver.step()
    pin.release()
    grasper = Grasper(solver, radius=0.1 * size)
    grasper.grab(centre)
    try:            # the static solves, each method's compliance and the finite-strain checks run before any refusal
        grasper.settle(centre + [0.0, 0.0, 0.01 * size], max_iterations=2)
    except TissuesimError:
        pass
    grasper.release()
    probe = Probe(solver, radius=0.3 * size)
    probe.press_static([0.0, 0.0, top + 0.3 * size - 0.02 * size])
    probe.release()
    solver.reset()
    if method != "fem":                       # the fine FEM reference does not cut
        scalpel = Scalpel(solver)
        # a stroke across triangles, askew to the mesh's rows, and one that starts and ends inside one (each
        # topology case has kernels of its own)
        for start, travel in (((-0.23, 0.07), (0.5, 0.13)), ((0.11, 0.23), (0.03, 0.0))):
            point = np.array([start[0] * size, start[1] * size, top])
            scalpel.press(point)
            scalpel.move(point + [travel[0] * size, travel[1] * size, 0.0])
            scalpel.release()
            solver.step()


def ensure_warm(*, progress: bool = True) -> bool:
    """Play the warm-up session unless :func:`stamp_path` holds this build's :func:`fingerprint` (written after
    the session); returns whether it played. A folder where no stamp can be written plays it every time."""
    path = stamp_path()
    mark = fingerprint()
    try:
        if path.read_text() == mark:
            return False
    except OSError:
        pass
    warm_up(progress=progress)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(mark)
    except OSError:
        pass
    return True


def stamp_path() -> Path:
    """Where the warm-up leaves its stamp: beside Numba's cache of the package (``NUMBA_CACHE_DIR`` if set, else
    the package's ``__pycache__``, where Numba puts its files; where the package's folder cannot be written, as in
    a system-wide install, Numba caches under the user's cache folder, and so does the stamp)."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if folder:
        return Path(folder) / STAMP
    package = Path(__file__).parent
    if _writable(package):
        return package / "__pycache__" / STAMP
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "tissuesim" / STAMP


def _writable(folder: Path) -> bool:
    return os.access(folder, os.W_OK)


def fingerprint() -> str:
    """Numba's version and a digest of the package's sources: a changed kernel, or another Numba, compiles anew."""
    import numba

    digest = hashlib.sha256(numba.__version__.encode())
    for source in sorted(Path(__file__).parent.rglob("*.py")):
        digest.update(source.read_bytes())
    return digest.hexdigest()
