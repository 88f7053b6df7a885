"""From a validated scene to what a solver takes: its material, its options (fixed region, attachments, gravity,
the method's own), and the solver with the scene's tools on it.

The hybrid mesh is built by the caller (the ``run`` and ``view`` commands build it as for a model named on their
command line), so a scene is checked whole (:func:`check_method`) before minutes of mesh building.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import BoundaryConditionError, MaterialError, SolverError
from ..mesh.regions import BOTTOM_FRACTION
from .load import SceneError, SceneFile

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..solvers.base import Solver

#: Solver options a scene sets in its own tables, and the table that sets each.
SET_ELSEWHERE = {
    "youngs_modulus": "[material]", "poisson_ratio": "[material]", "density": "[material]",
    "material": "[material] model", "fixed": "[support] fixed", "attachments": "[[support.attachments]]",
    "gravity": "gravity (a top-level key)", "dt": "[run] dt",
}


def material_options(loaded: SceneFile) -> dict:
    """``youngs_modulus`` [Pa], ``poisson_ratio`` [-], ``density`` [kg/m³] and ``material`` (the constitutive
    model) of the scene: its preset's, each overridden where the scene gives it, else the paper's defaults."""
    from ..fem.material import Material
    from ..fem.presets import preset
    from ..solvers.base import DEFAULT_DENSITY

    spec = loaded.scene.material
    values = preset(spec.preset).options() if spec.preset else {
        "youngs_modulus": Material().youngs_modulus, "poisson_ratio": Material().poisson_ratio,
        "density": DEFAULT_DENSITY}
    for key in values:
        if getattr(spec, key) is not None:
            values[key] = getattr(spec, key)
    try:
        Material(youngs_modulus=values["youngs_modulus"], poisson_ratio=values["poisson_ratio"])
    except MaterialError as error:
        raise SceneError(f"{loaded.path.name}: material: {error}") from None
    return {**values, "material": spec.model}


def check_method(loaded: SceneFile) -> None:
    """SceneError unless the method exists and takes each of its options, and each option the scene sets
    elsewhere (gravity, attachments) is one the method has."""
    from ..solvers.registry import available_solvers, solver_options

    scene, name = loaded.scene, loaded.path.name
    method = scene.method.name
    if method not in available_solvers():
        raise SceneError(f"{name}: method.name: unknown method {method!r}; choose one of "
                         f"{', '.join(available_solvers())}")
    accepted = solver_options(method)
    for key in scene.method.options:
        if key in SET_ELSEWHERE:
            raise SceneError(f"{name}: method.options.{key}: the scene sets {key} in {SET_ELSEWHERE[key]}; move it "
                             "there")
        if key not in accepted:
            own = sorted(set(accepted) - set(SET_ELSEWHERE))
            raise SceneError(f"{name}: method.options.{key}: the {method} method has no option {key!r}; its options "
                             f"are {', '.join(own)}")
    needed = [("gravity", scene.gravity is not None), ("attachments", bool(scene.support.attachments))]
    for key, used in needed:
        if used and key not in accepted:
            raise SceneError(f"{name}: {key}: the {method} method takes no {key} option; remove {key} or choose "
                             "another method")
    if scene.gravity is not None:
        from ..solvers.checks import gravity_vector

        try:
            gravity_vector(scene.gravity)
        except SolverError as error:
            raise SceneError(f"{name}: gravity: {error}") from None


def solver_options(loaded: SceneFile, hybrid: HybridMesh) -> dict:
    """Every keyword option of :func:`tissuesim.make_solver` the scene gives, on ``hybrid``'s surface: material,
    ``dt``, ``fixed`` (``(k,) int32`` M_S vertices; absent for the default bottom tenth, the solvers' own),
    ``gravity`` [m/s²], ``attachments`` and the method's own."""
    check_method(loaded)
    scene, points = loaded.scene, hybrid.surface.vertices
    options = {**material_options(loaded), "dt": scene.run.dt, **scene.method.options}
    fixed = _region(loaded, "support.fixed", scene.support.fixed, points)
    if scene.support.fixed.spec() != {"bottom": BOTTOM_FRACTION}:
        # the default region is the solvers' own bottom, which also fixes the volume nodes below the same height
        # (a set of M_S vertices fixes only the volume nodes on them), as --fix's default does
        options["fixed"] = fixed
    if scene.gravity is not None:
        options["gravity"] = tuple(scene.gravity)
    if scene.support.attachments:
        options["attachments"] = tuple(_attachment(loaded, i, spec, points)
                                       for i, spec in enumerate(scene.support.attachments))
    return options


def _region(loaded: SceneFile, key: str, region, points: np.ndarray) -> np.ndarray:
    from ..mesh.regions import fixed_region

    try:
        return fixed_region(region.spec(), points, folder=loaded.folder)
    except BoundaryConditionError as error:
        raise SceneError(f"{loaded.path.name}: {key}: {error}") from None


def _attachment(loaded: SceneFile, index: int, spec, points: np.ndarray):
    from ..solvers.attachments import Attachment

    key = f"support.attachments[{index}]"
    nodes = _region(loaded, f"{key}.nodes", spec.nodes, points)
    try:
        return Attachment(nodes=nodes, stiffness=spec.stiffness, anchor=spec.anchor)
    except BoundaryConditionError as error:
        raise SceneError(f"{loaded.path.name}: {key}: {error}") from None


def make_scene_solver(loaded: SceneFile, hybrid: HybridMesh) -> Solver:
    """The solver of the scene's method over ``hybrid`` with every option of :func:`solver_options`; a refusal of
    the solver (e.g. supports that do not hold the body) is a SceneError naming the scene."""
    from ..solvers.registry import make_solver

    options = solver_options(loaded, hybrid)
    try:
        return make_solver(loaded.scene.method.name, hybrid, **options)
    except (SolverError, BoundaryConditionError, MaterialError) as error:
        raise SceneError(f"{loaded.path.name}: the {loaded.scene.method.name} solver refused the scene: "
                         f"{error}") from None
