"""The shape of a scene file, validated by pydantic: every table and key, its type, unit, default and range.

Each model refuses unknown keys (``extra="forbid"``); numbers are strict (a quoted "0.1" is no number) and lengths
are in metres, as everywhere in tissuesim. :mod:`.load` turns pydantic's errors into one line per defect that
names the key, e.g. ``tools[1].path[3].time``, and the fix. ``docs/scenes.md`` documents every key.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ..fem.hyperelastic import MATERIALS
from ..fem.presets import PRESETS
from ..mesh.models import MAX_RESOLUTION, MIN_RESOLUTION, MODELS
from ..mesh.regions import REGION_KINDS

#: Marks a location inside a validator's message: ``LOCATED + "path[3].time" + LOCATED + message`` makes the error
#: point at that key below the model that raised it (pydantic locates a validator's error at its model).
LOCATED = "\x00"

Number = Annotated[float, Field(strict=True, allow_inf_nan=False)]
Positive = Annotated[float, Field(strict=True, gt=0.0, allow_inf_nan=False)]
Flag = Annotated[bool, Field(strict=True)]
Vector = Annotated[list[Number], Field(min_length=3, max_length=3)]
Resolution = Annotated[int, Field(strict=True, ge=MIN_RESOLUTION, le=MAX_RESOLUTION)]

#: The most steps a run takes: at 0.1 ms a step (a small model's fastest method) over 15 minutes, so a duration or
#: dt off by orders of magnitude is refused before the mesh is built rather than run for ever.
MAX_STEPS = 10_000_000

#: The deepest nesting of tables and arrays in a method's options; the methods take flat numbers and strings.
MAX_OPTION_DEPTH = 8


def located(where: str, message: str) -> ValueError:
    """A ValueError whose message :mod:`.load` places at ``where`` below the model raising it."""
    return ValueError(f"{LOCATED}{where}{LOCATED}{message}")


def finite_options(options: dict) -> dict:
    """``options`` (a method's keyword options, as read from TOML) unless a number in them is NaN or infinite, or
    they nest deeper than :data:`MAX_OPTION_DEPTH`: TOML reads ``nan`` and ``inf``, which no option means."""
    def check(value, where: str, depth: int) -> None:
        if depth > MAX_OPTION_DEPTH:
            raise located(where, f"nested more than {MAX_OPTION_DEPTH} deep; give the option a number or a string")
        if isinstance(value, float) and not math.isfinite(value):
            raise located(where, f"{value} is not a finite number; give a number")
        items = value.items() if isinstance(value, dict) else (
            ((f"[{i}]", item) for i, item in enumerate(value)) if isinstance(value, list) else ())
        for key, item in items:
            check(item, f"{where}{key}" if key.startswith("[") else f"{where}.{key}", depth + 1)

    for key, value in options.items():
        check(value, key, 1)
    return options


class Strict(BaseModel):
    """Base of every table: unknown keys are refused, values are not coerced across types."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Model(Strict):
    """``[model]``: what is simulated."""

    name: str | None = Field(None, description="a built-in model: " + ", ".join(MODELS))
    file: str | None = Field(None, description="a surface file (.obj, .stl, .ply, .off), relative to the scene file")
    scale: Positive = Field(1.0, description="the factor from the file's unit to metres (0.01 for cm)")
    resolution: Resolution | None = Field(
        None, description=f"the vertex count of a built-in model ({MIN_RESOLUTION} to {MAX_RESOLUTION})")
    repair: Flag = Field(False, description="true to repair a surface file's safe defects")

    @model_validator(mode="after")
    def _one_source(self):
        if (self.name is None) == (self.file is None):
            raise ValueError("give exactly one of name (a built-in model: " + ", ".join(MODELS) + ") and file "
                             "(a surface file relative to the scene file)")
        if self.name is not None and self.name not in MODELS:
            raise located("name", f"unknown built-in model {self.name!r}; choose one of {', '.join(MODELS)}, or "
                                  "give file = \"surface.obj\" instead")
        if self.file is not None and self.resolution is not None:
            raise located("resolution", "a surface file has its own vertices; remove resolution (it sets the "
                                        "vertex count of a built-in model)")
        return self


class Material(Strict):
    """``[material]``: a preset, or E, ν and density (a preset's values can be overridden one by one)."""

    preset: str | None = Field(None, description="a tissue preset: " + ", ".join(PRESETS))
    youngs_modulus: Positive | None = Field(None, description="Young's modulus E [Pa] (default 5500, the paper's)")
    poisson_ratio: Number | None = Field(None, description="Poisson's ratio ν in (-1, 0.49] (default 0.3)")
    density: Positive | None = Field(None, description="density ρ [kg/m³] (default 1000)")
    model: Literal[MATERIALS] = Field("linear", description="the constitutive model: " + ", ".join(MATERIALS))

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, value):
        if value is not None and value not in PRESETS:
            raise ValueError(f"unknown preset {value!r}; choose one of {', '.join(PRESETS)}")
        return value


class Method(Strict):
    """``[method]``: the deformation method and its own options (``[method.options]``)."""

    name: str = Field("hybrid", description="the method: hybrid, pbd, mass-spring, embedded or fem")
    options: dict[str, Any] = Field(default_factory=dict, description="the method's own keyword options")

    @field_validator("options")
    @classmethod
    def _finite(cls, options):
        return finite_options(options)


class Box(Strict):
    lower: Vector = Field(description="the box's lower corner [x, y, z] [m]")
    upper: Vector = Field(description="the box's upper corner [x, y, z] [m]")


class Plane(Strict):
    point: Vector = Field(description="a point of the plane [x, y, z] [m]")
    normal: Vector = Field(description="the plane's outward normal [x, y, z]; the nodes behind it are selected")


class Region(Strict):
    """A set of M_S vertices: exactly one of the keys (the spec of :func:`tissuesim.mesh.regions.fixed_region`)."""

    bottom: Annotated[float, Field(strict=True, gt=0.0, lt=1.0)] | None = Field(
        None, description=REGION_KINDS["bottom"])
    box: Box | None = Field(None, description=REGION_KINDS["box"])
    plane: Plane | None = Field(None, description=REGION_KINDS["plane"])
    indices: Annotated[list[Annotated[int, Field(strict=True, ge=0)]], Field(min_length=1)] | None = Field(
        None, description=REGION_KINDS["indices"])
    mask: str | None = Field(None, description=REGION_KINDS["mask"] + ", relative to the scene file")
    indices_file: str | None = Field(None, description=REGION_KINDS["indices_file"] + ", relative to the scene file")

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [name for name in REGION_KINDS if getattr(self, name) is not None]
        if len(given) != 1:
            raise ValueError(f"a region takes exactly one of {', '.join(REGION_KINDS)}, got "
                             f"{', '.join(given) or 'none'}; e.g. {{ bottom = 0.1 }}")
        return self

    def spec(self) -> dict:
        """The plain spec of :func:`tissuesim.mesh.regions.fixed_region`."""
        return self.model_dump(exclude_none=True)


class Attachment(Strict):
    """``[[support.attachments]]``: springs from a set of vertices to fixed points (a ligament, a vessel)."""

    nodes: Region = Field(description="the attached vertices, a region as for fixed")
    stiffness: Positive = Field(description="the spring's stiffness [N/m]")
    anchor: Vector | None = Field(None, description="the point the springs pull towards [x, y, z] [m]; none: each "
                                                    "vertex's rest position")


class Support(Strict):
    """``[support]``: what holds the body."""

    fixed: Region = Field(default_factory=lambda: Region(bottom=0.1),
                          description="the vertices held at rest (default: bottom = 0.1)")
    attachments: list[Attachment] = Field(default_factory=list, description="elastic attachments")


class Keyframe(Strict):
    """One point of a tool's scripted path."""

    time: Annotated[float, Field(strict=True, ge=0.0, allow_inf_nan=False)] = Field(
        description="when the tool is there [s], from the run's start")
    position: Vector = Field(description="where the tool is [x, y, z] [m]")
    pressed: Flag = Field(True, description="true: the tool acts from this keyframe on; false: it is lifted")


class GrasperKeyframe(Keyframe):
    """One point of a grasper's scripted path: the jaws' position, and their orientation."""

    rotation: Vector | None = Field(None, description="the jaws' orientation, a rotation vector [rx, ry, rz] [rad] "
                                                      "(axis × angle); none: as at the keyframe before (none at the "
                                                      "first)")
    pressed: Flag = Field(True, description="true: the jaws hold from this keyframe on; false: they let go")


class Tool(Strict):
    """What every tool has: a name and an optional scripted path."""

    name: str = Field("", description="a name for the reports (default: its kind and index)")
    path: list[Keyframe] = Field(default_factory=list, description="keyframes, their times increasing")

    @field_validator("path")
    @classmethod
    def _increasing(cls, path):
        for i in range(1, len(path)):
            if not path[i].time > path[i - 1].time:
                raise located(f"[{i}].time", f"{path[i].time:g} s is not after path[{i - 1}].time "
                                             f"{path[i - 1].time:g} s; keyframe times must increase")
        return path


class PinHead(Tool):
    """``kind = "pin-head"``: grabs the node nearest its press and pulls it with a spring (eq 24)."""

    kind: Literal["pin-head"]
    stiffness: Positive = Field(50.0, description="the spring's stiffness k [N/m]")
    radius: Positive | None = Field(None, description="the tip's contact radius [m]; none: one node")


class Probe(Tool):
    """``kind = "probe"``: a rigid sphere (or capsule) pushing the surface."""

    kind: Literal["probe"]
    radius: Positive = Field(description="the sphere's (capsule's) radius [m]")
    shaft: Vector | None = Field(None, description="a capsule's second end, relative to the position [m]; none: "
                                                   "a sphere")


class Scalpel(Tool):
    """``kind = "scalpel"``: cuts the surface while pressed and moving."""

    kind: Literal["scalpel"]
    depth: Positive | None = Field(None, description="the blade's length into the tissue [m]; default two mean "
                                                     "edge lengths")


class Grasper(Tool):
    """``kind = "grasper"``: jaws that hold the surface vertices within ``radius`` of the press and carry them
    rigidly along the path (a prescribed displacement); the force is the output."""

    kind: Literal["grasper"]
    radius: Positive = Field(description="the jaws' reach [m]: they hold the surface vertices within it")
    tolerance: Positive | None = Field(None, description="the largest distance [m] of a held vertex from where the "
                                                         "jaws put it; none: radius / 1000")
    path: list[GrasperKeyframe] = Field(default_factory=list, description="keyframes, their times increasing")


ToolSpec = Annotated[Union[PinHead, Probe, Scalpel, Grasper], Field(discriminator="kind")]
TOOL_CLASSES = {"pin-head": PinHead, "probe": Probe, "scalpel": Scalpel, "grasper": Grasper}
TOOL_KINDS = tuple(TOOL_CLASSES)


class Run(Strict):
    """``[run]``: the headless run of ``tissuesim run``."""

    duration: Positive = Field(1.0, description="the simulated time [s]")
    dt: Positive = Field(0.01, description="the time step [s]")

    @model_validator(mode="after")
    def _step_fits(self):
        if self.dt > self.duration:
            raise located("dt", f"{self.dt:g} s is longer than the duration {self.duration:g} s; give a smaller dt")
        if self.duration / self.dt > MAX_STEPS:
            raise located("dt", f"duration {self.duration:g} s / dt {self.dt:g} s is {self.duration / self.dt:.3g} "
                                f"steps; a run takes at most {MAX_STEPS} (over 15 minutes at 0.1 ms a step): give a "
                                "shorter duration or a larger dt")
        return self

    @property
    def steps(self) -> int:
        """The number of steps: duration / dt, rounded up (a partial last step is a whole one)."""
        return max(1, math.ceil(self.duration / self.dt - 1e-9))


class Scene(Strict):
    """A whole scene file."""

    title: str = Field("", description="a title for the window and the reports")
    gravity: Vector | None = Field(None, description="the acceleration of gravity [gx, gy, gz] [m/s²]; none: no "
                                                     "gravity")
    model: Model = Field(description="the [model] table")
    material: Material = Field(default_factory=Material, description="the [material] table")
    method: Method = Field(default_factory=Method, description="the [method] table")
    support: Support = Field(default_factory=Support, description="the [support] table")
    tools: list[ToolSpec] = Field(default_factory=list, description="the [[tools]] tables")
    run: Run = Field(default_factory=Run, description="the [run] table")

    @model_validator(mode="after")
    def _paths_within_run(self):
        for t, tool in enumerate(self.tools):
            for k, key in enumerate(tool.path):
                if key.time > self.run.duration + 1e-12:
                    raise located(f"tools[{t}].path[{k}].time",
                                  f"{key.time:g} s is after the run's end (run.duration = {self.run.duration:g} s); "
                                  "lengthen the run or move the keyframe")
        return self
