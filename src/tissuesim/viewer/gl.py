"""Polyscope, imported only here and only when a window or an image is wanted.

``polyscope`` is a dependency of tissuesim; where it is missing, or where no OpenGL driver can be opened at all,
:class:`NoOpenGLError` says what to install. Headless images use polyscope's EGL backend, which runs on Mesa's
software renderer (llvmpipe) on machines without a GPU: Debian packages ``libegl1``, ``libegl-mesa0`` and
``libgl1-mesa-dri`` (the Makefile installs them).
"""

from __future__ import annotations

import contextlib
import os
import sys
from typing import TYPE_CHECKING

from ..errors import TissuesimError

if TYPE_CHECKING:
    from types import ModuleType

    from numpy.typing import ArrayLike

HEADLESS_BACKEND = "openGL3_egl"
WINDOW_BACKEND = "openGL3_glfw"
# Mesa's software renderer rasterises on one thread per core, which then compete with the simulation's steps on
# small machines: on 2 cores one thread gave 89 instead of 46 simulation steps/s while drawing (liver, hybrid;
# benchmarks/bench_viewer.py). Only llvmpipe reads this; a user's own setting wins.
SOFTWARE_RENDER_THREADS = "1"
INSTALL_HINT = ("pip install polyscope; for headless images also the Debian packages libegl1 libegl-mesa0 "
                "libgl1-mesa-dri")
_state = {"backend": None}


class NoOpenGLError(TissuesimError, RuntimeError):
    """Polyscope or an OpenGL driver is missing, so nothing can be drawn."""


def polyscope(*, headless: bool) -> ModuleType:
    """The initialised ``polyscope`` module: an offscreen EGL context with ``headless``, else a window.

    Polyscope has one context per process: the first call decides, and a later call asking for the other kind
    raises NoOpenGLError.
    """
    try:
        import polyscope as ps
    except ImportError:
        raise NoOpenGLError(f"drawing needs polyscope, which is not installed: {INSTALL_HINT}") from None
    wanted = HEADLESS_BACKEND if headless else WINDOW_BACKEND
    if _state["backend"] is not None:
        if _state["backend"] != wanted:
            raise NoOpenGLError("polyscope is already running with another backend in this process; draw windows "
                                "and headless images from separate processes")
        return ps
    os.environ.setdefault("LP_NUM_THREADS", SOFTWARE_RENDER_THREADS)
    _preflight(headless)
    ps.set_program_name("tissuesim")
    ps.set_use_prefs_file(False)
    ps.set_errors_throw_exceptions(True)
    ps.set_allow_headless_backends(headless)
    try:
        with _quiet_stdout():  # polyscope prints its backend probing on stdout
            ps.init(wanted)
    except Exception as error:  # polyscope raises a bare RuntimeError for every backend failure
        ps.set_errors_throw_exceptions(False)  # else its exit hook raises again on the uninitialised context
        raise NoOpenGLError(f"no OpenGL available ({str(error).strip().splitlines()[-1]}); {INSTALL_HINT}") from None
    _state["backend"] = wanted
    return ps


def _preflight(headless: bool) -> None:
    """Refuse what is sure to fail before polyscope tries: a failed init leaves it raising again at exit."""
    import ctypes.util

    if headless and ctypes.util.find_library("EGL") is None:
        raise NoOpenGLError(f"no EGL library (libEGL) for headless drawing; {INSTALL_HINT}")
    if not headless and sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or
                                                                  os.environ.get("WAYLAND_DISPLAY")):
        raise NoOpenGLError("no display to open a window on (DISPLAY is unset); run tissuesim view on a desktop, "
                            "or draw images headless with tissuesim render")


def opengl_available() -> bool:
    """Whether headless drawing works here (tries once; initialises polyscope's EGL context if it does)."""
    try:
        polyscope(headless=True)
    except NoOpenGLError:
        return False
    return True


@contextlib.contextmanager
def _quiet_stdout():
    """Silence the C++ side's stdout (file descriptor 1) for the duration."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def look_at_oblique(ps: ModuleType, points: ArrayLike, *, elevation: float = 35.0, azimuth: float = -60.0,
                    distance: float = 2.2, pane: int = 0) -> None:
    """Point polyscope's camera at the bounding box of ``points`` ``(p, 3)`` [m] from ``elevation`` degrees above
    and ``azimuth`` degrees around z (front-left), ``distance`` box half-diagonals away, so all of it is framed.

    ``pane``: pixels on the window's right taken by a panel. The camera then slides right by half of it, so the box
    sits in the middle of the free part, and the view centre (which the mouse turns about) stays on the box: a turn
    moves the camera rigidly about it, so the box's centre keeps its place on the screen."""
    import numpy as np

    points = np.asarray(points, dtype=np.float64)
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    up, around = np.radians(elevation), np.radians(azimuth)
    view = np.array([np.cos(up) * np.cos(around), np.cos(up) * np.sin(around), np.sin(up)])
    ps.set_automatically_compute_scene_extents(False)
    ps.set_length_scale(2.0 * radius)
    ps.set_bounding_box(lo, hi)
    height = ps.get_window_size()[1]
    # a pixel at the box's depth spans 2 d tan(fov / 2) / height metres
    slide = pane * distance * radius * np.tan(np.radians(0.5 * ps.get_vertical_fov_degrees())) / height
    right = np.cross(-view, [0.0, 0.0, 1.0])
    right *= slide / max(float(np.linalg.norm(right)), np.finfo(float).tiny)
    ps.look_at(centre + distance * radius * view + right, centre + right)
    if pane:
        ps.set_view_center_raw(centre)
