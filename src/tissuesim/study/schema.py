"""The shape of a study file, validated by pydantic: every table and key, its type, unit, default and range.

A study declares lists (models, methods, materials, loads); :mod:`.cases` expands their product into cases. Each
table refuses unknown keys and numbers are strict, as in a scene file (the same base types,
:mod:`tissuesim.scene.schema`); lengths are in metres, forces in newtons. ``docs/studies.md`` documents every key.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import Discriminator, Field, Tag, field_validator, model_validator

from ..experiments.protocol import LOAD_DIRECTIONS, RMSE_SAMPLES
from ..fem.presets import PRESETS
from ..mesh.models import MODELS
from ..scene.schema import Flag, Positive, Resolution, Strict, Vector, finite_options, located

Count = Annotated[int, Field(strict=True, ge=1)]

#: The most cases one study runs: each is a Dask task submitted at the start, and expanding 100,000 cases takes
#: about half a minute and 40 MB on the client; a larger study is split into several (docs/studies.md).
MAX_CASES = 100_000


def bounded(count: int, what: str) -> int:
    """``count`` (of ``what``, e.g. "values") unless it alone exceeds :data:`MAX_CASES`."""
    if count > MAX_CASES:
        raise ValueError(f"{count} {what}, more than the {MAX_CASES} cases a study runs; give fewer, or split them "
                         "over several studies (docs/studies.md)")
    return count

#: What a model entry may name, exactly one of them.
MODEL_SOURCES = ("name", "file", "bundle", "folder")


class ModelSpec(Strict):
    """``[[models]]``: a built-in model, a surface file, a saved hybrid bundle, or a folder of surface files."""

    name: str | None = Field(None, description="a built-in model: " + ", ".join(MODELS))
    file: str | None = Field(None, description="a surface file (.obj, .stl, .ply, .off), relative to the study file")
    bundle: str | None = Field(None, description="a saved hybrid bundle with its fine volume, relative to the study")
    folder: str | None = Field(None, description="a folder whose surface files are each a model")
    resolution: Resolution | None = Field(None, description="the vertex count of a built-in model (50 to 100000)")
    scale: Positive = Field(1.0, description="the factor from a surface file's unit to metres (0.01 for cm)")
    repair: Flag = Field(False, description="true to repair a surface file's safe defects")

    @model_validator(mode="after")
    def _one_source(self):
        given = [key for key in MODEL_SOURCES if getattr(self, key) is not None]
        if len(given) != 1:
            raise ValueError(f"a model takes exactly one of {', '.join(MODEL_SOURCES)}, got "
                             f"{', '.join(given) or 'none'}; e.g. {{ name = \"cube\" }}")
        if self.name is not None and self.name not in MODELS:
            raise located("name", f"unknown built-in model {self.name!r}; choose one of {', '.join(MODELS)}")
        if self.resolution is not None and self.name is None:
            raise located("resolution", "only a built-in model takes a resolution; remove it")
        return self


class MethodSpec(Strict):
    """``[[methods]]``: a deformation method and its own keyword options."""

    name: str = Field(description="the method: hybrid, pbd, mass-spring, embedded or fem")
    options: dict[str, Any] = Field(default_factory=dict, description="the method's own keyword options")

    @field_validator("options")
    @classmethod
    def _finite(cls, options):
        return finite_options(options)


class Range(Strict):
    """``{ start, stop, count }``: ``count`` values evenly spaced from ``start`` to ``stop``, both included."""

    start: Positive = Field(description="the first value")
    stop: Positive = Field(description="the last value")
    count: Count = Field(description="how many values (1: start alone)")

    @field_validator("count")
    @classmethod
    def _bounded(cls, count):
        return bounded(count, "values")

    def values(self) -> list[float]:
        return [float(v) for v in np.linspace(self.start, self.stop, self.count)]


# told apart by the value's type, so that a range's defect is not also reported as "not a list"
Values = Annotated[Union[Annotated[Annotated[list[Positive], Field(min_length=1)], Tag("list")],
                         Annotated[Range, Tag("range")]],
                   Discriminator(lambda value: "list" if isinstance(value, list) else "range")]


class Materials(Strict):
    """``[materials]``: tissue presets, and/or the product of E and ν values (each a list or a range)."""

    presets: list[str] = Field(default_factory=list, description="tissue presets: " + ", ".join(PRESETS))
    youngs_modulus: Values | None = Field(None, description="Young's moduli E [Pa]: a list or { start, stop, count }")
    poisson_ratio: Values | None = Field(None, description="Poisson's ratios ν: a list or { start, stop, count }")
    density: Positive = Field(1000.0, description="density ρ [kg/m³] of the E, ν materials")

    @field_validator("presets")
    @classmethod
    def _known(cls, presets):
        for i, name in enumerate(presets):
            if name not in PRESETS:
                raise located(f"[{i}]", f"unknown preset {name!r}; choose among {', '.join(PRESETS)}")
        return presets


class RandomLoads(Strict):
    """``[loads.random]``: ``count`` pin-head loads, each on a random free surface node, in a random direction,
    of a force drawn uniformly from ``force``."""

    count: Count = Field(description="how many random loads per model, method and material")
    seed: Annotated[int, Field(strict=True, ge=0)] = Field(0, description="the seed: the same seed, the same loads")
    force: Annotated[list[Positive], Field(min_length=2, max_length=2)] = Field(
        description="[lowest, highest] force magnitude [N]")

    @field_validator("count")
    @classmethod
    def _bounded(cls, count):
        return bounded(count, "random loads")

    @field_validator("force")
    @classmethod
    def _ordered(cls, force):
        if force[0] > force[1]:
            raise ValueError(f"[{force[0]:g}, {force[1]:g}] is not [lowest, highest]; swap them")
        return force


Direction = Union[Literal[tuple(LOAD_DIRECTIONS)], Vector]

#: The displacement-driven tools: the key of their travels [m], what their radius is, and an example.
TRAVELS = {
    "probe": ("depths", "its sphere's radius", "pressed to depths [m], e.g. depths = [0.001, 0.002]"),
    "grasper": ("displacements", "its jaws' reach",
                "moved by displacements [m], e.g. displacements = [0.001, 0.002]"),
}


class Loads(Strict):
    """``[loads]``: a pin-head on the protocol's load node (§8.3), each force in each direction, or random ones;
    or a rigid spherical probe pressed into the load node, each depth in each direction; or a grasper's jaws closed
    on the load node (or a given point) and carried each displacement in each direction (a pull that has an
    equilibrium at any depth, where a dead load may have none)."""

    kind: Literal["pin-head", "probe", "grasper"] = Field("pin-head", description="the tool: pin-head, probe or "
                                                                                  "grasper")
    depths: list[Positive] | None = Field(None, description="a probe's indentation depths [m] along the direction")
    displacements: list[Positive] | None = Field(
        None, description="a grasper's travels [m] along the direction, from where its jaws close")
    point: Vector | None = Field(None, description="where a grasper's jaws close [x, y, z] [m]; absent: the load "
                                                   "node's rest position")
    radius: Positive | None = Field(None, description="the tip's contact radius [m]; absent: one node, as the "
                                                      "paper's protocol (§8.3) loads; a probe's sphere's, a "
                                                      "grasper's reach")
    forces: list[Positive] = Field(default_factory=lambda: [1.0], description="force magnitudes [N]")
    directions: list[Direction] = Field(default_factory=lambda: ["tension"],
                                        description="tension, pressure, or unit vectors [x, y, z]")
    random: RandomLoads | None = Field(None, description="random loads instead of forces × directions")

    @model_validator(mode="after")
    def _tool_keys(self):
        for kind, (key, _, _) in TRAVELS.items():    # another tool's travels
            if kind != self.kind and getattr(self, key) is not None:
                loaded = "loaded by forces" if self.kind == "pin-head" else f"moved by {TRAVELS[self.kind][0]}"
                raise located(key, f"a {self.kind} is {loaded}; remove {key} or set kind = \"{kind}\"")
        if self.kind in TRAVELS:
            key, radius, example = TRAVELS[self.kind]
            if self.radius is None:
                raise located("radius", f"a {self.kind} needs {radius} [m], e.g. radius = 0.005")
            if getattr(self, key) is None:
                raise located(key, f"a {self.kind} is {example}")
            if self.random is not None:
                raise located("random", "random loads are pin-head loads; remove [loads.random] or use "
                                        "kind = \"pin-head\"")
        if self.point is not None and self.kind != "grasper":
            raise located("point", "only a grasper's jaws close on a given point; remove point or set "
                                   "kind = \"grasper\"")
        return self

    @field_validator("directions")
    @classmethod
    def _unit(cls, directions):
        for i, direction in enumerate(directions):
            if not isinstance(direction, str) and abs(float(np.linalg.norm(direction)) - 1.0) > 1e-6:
                raise located(f"[{i}]", f"{direction} is not a unit vector (length "
                                        f"{float(np.linalg.norm(direction)):.6g}); divide it by its length")
        return directions


class Reference(Strict):
    """``[reference]``: what the metrics compare against."""

    kind: Literal["fem", "contact"] = Field(
        "fem", description="fem: the fem method on the hybrid's fine volume (the paper's protocol); contact: the "
                           "quadratic-tet reference refined near the patch until it converges (the contact protocol)")
    max_levels: Annotated[int, Field(strict=True, ge=0)] = Field(
        4, description="contact: the last refinement level tried (the contact protocol's default 4, --quick 2)")
    shipped: Flag = Field(True, description="contact: read a reference shipped with the package where one matches")


class Record(Strict):
    """``[record]``: what each case keeps beside its inputs."""

    metrics: Flag = Field(True, description="RMSE (eq 26) and relative RMSE against the fem reference")
    field: Flag = Field(False, description="the displacement field (n, 3) [m] of every surface node, in Zarr")
    step_times: Flag = Field(False, description="the median time of a step under the load [ms]")
    samples: Count = Field(RMSE_SAMPLES, description="sample nodes of the RMSE (50 as in §8.3.1)")
    timing_steps: Count = Field(10, description="timed steps per case when step_times is on")
    max_steps: Count = Field(1000, description="cap on the steps of a quasi-static solve")


class Study(Strict):
    """A whole study file."""

    title: str = Field("", description="a title for the reports")
    models: Annotated[list[ModelSpec], Field(min_length=1)] = Field(description="the [[models]] tables")
    methods: Annotated[list[MethodSpec], Field(min_length=1)] = Field(description="the [[methods]] tables")
    materials: Materials = Field(default_factory=Materials, description="the [materials] table")
    loads: Loads = Field(default_factory=Loads, description="the [loads] table")
    reference: Reference = Field(default_factory=Reference, description="the [reference] table")
    record: Record = Field(default_factory=Record, description="the [record] table")

    @model_validator(mode="after")
    def _contact_needs_a_patch(self):
        if self.reference.kind == "contact" and (self.loads.kind != "pin-head" or self.loads.radius is None):
            raise located("reference.kind", "the contact reference is that of a pin-head's patch: give [loads] "
                                            "kind = \"pin-head\" and a radius, or use kind = \"fem\"")
        return self
