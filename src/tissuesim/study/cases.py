"""A study expanded into cases: every model × method × material × load, each with a content hash of its inputs.

A case is plain data (strings, numbers, tuples): it pickles in a few hundred bytes, so a task sends little. Its
``case_id`` hashes every input that changes its answer, a model file by its bytes, so a rerun recognises a
finished case whatever the file's name, and a changed file or option makes a new case.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from itertools import product
from pathlib import Path
from typing import NamedTuple

from ..experiments.protocol import LOAD_DIRECTIONS
from ..errors import MaterialError
from ..fem.material import Material
from ..fem.presets import preset
from .load import StudyError, StudyFile
from .schema import MAX_CASES, TRAVELS

#: Changes whenever a case's answer would change for the same inputs; part of every hash.
FORMAT = "tissuesim-study-1"

#: Solver options a study sets in [materials], not in a method's options.
MATERIAL_KEYS = ("youngs_modulus", "poisson_ratio", "density")

#: The paper's material (§8.2), when the study names none: E [Pa], ν [-], ρ [kg/m³].
PAPER_MATERIAL = ("paper", 5500.0, 0.3, 1000.0)


def content_hash(*parts: object) -> str:
    """16 hex digits of SHA-256 over the canonical JSON of ``parts``."""
    text = json.dumps([FORMAT, *parts], sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class Recording(NamedTuple):
    """What a case records: the ``[record]`` table's keys (docs/studies.md)."""

    metrics: bool
    field: bool
    step_times: bool
    samples: int
    timing_steps: int
    max_steps: int


@dataclass(frozen=True)
class ModelRef:
    """One model: ``kind`` builtin/file/bundle, ``source`` its name or absolute path, and ``key``, a hash of what
    builds it (a file's bytes, not its name)."""

    kind: str
    source: str
    resolution: int | None
    scale: float
    repair: bool
    key: str

    @property
    def label(self) -> str:
        return self.source if self.kind == "builtin" else Path(self.source).stem


@dataclass(frozen=True)
class Case:
    """One case. Forces [N], lengths [m]; ``direction`` a unit ``(3,)`` tuple, or None for a random load (then
    ``random`` = (seed, index, lowest N, highest N) and the worker draws node, direction and force). A probe
    (``tool = "probe"``, sphere of ``radius``) is pressed ``depth`` into the load node along ``direction``; a
    grasper's jaws (``tool = "grasper"``, reach ``radius``) close on ``point`` ``(3,)`` [m] (None: the load node's
    rest position) and are carried ``depth`` along ``direction``."""

    model: ModelRef
    method: str
    options: str                    # the method's options as canonical JSON
    material: tuple                 # (label, E [Pa], ν, ρ [kg/m³])
    radius: float | None
    force_N: float | None
    direction: tuple | None
    random: tuple | None
    record: Recording
    tool: str = "pin-head"
    depth: float | None = None
    reference: tuple = ("fem",)      # ("fem",) or ("contact", max_levels, shipped)
    point: tuple | None = None

    @property
    def reference_key(self) -> str:
        """The hash of the reference this case is measured against (shared by every method; a contact reference,
        a response per unit force, also by every force and direction on the same node)."""
        if self.reference[0] == "contact":
            return content_hash("contact", self.model.key, self.material[1:3], self.radius, self.random,
                                self.reference, self.record.samples)
        return content_hash("reference", self.model.key, self.material, self.radius, self.force_N, self.direction,
                            self.random, self.record.max_steps, self.tool, self.depth, *self._given_point())

    @property
    def case_id(self) -> str:
        """The hash of every input; the model by its key (its content), not by its file's name or place."""
        inputs = {**asdict(self), "model": self.model.key}
        if self.point is None:      # a key added later: absent where unused, so earlier studies keep their ids
            del inputs["point"]
        return content_hash("case", inputs)

    def _given_point(self) -> tuple:
        return () if self.point is None else (self.point,)


def expand(loaded: StudyFile, *, announce: Callable[[str], None] | None = None) -> list[Case]:
    """Every case of the study, in the file's order (models, then methods, materials, loads). The cases are first
    counted, none expanded: a study of more than :data:`~.schema.MAX_CASES` is refused, and ``announce``, if given,
    is called with the count (a line of text) before the expansion, which takes a fraction of a millisecond a
    case."""
    study = loaded.study
    _check_methods(loaded)
    sources = [_sources(loaded, i, spec) for i, spec in enumerate(study.models)]
    text = counted(loaded, sum(map(len, sources)))
    if announce is not None:
        announce(text)
    models = [_model(source, spec) for spec, found in zip(study.models, sources) for source in found]
    methods = [(m.name, json.dumps(m.options, sort_keys=True)) for m in study.methods]
    record = Recording(**study.record.model_dump())
    reference = (("fem",) if study.reference.kind == "fem" else
                 ("contact", study.reference.max_levels, study.reference.shipped))
    cases = [Case(model, name, options, material, *load[:4], record, *load[4:6], reference, *load[6:])
             for model, (name, options), material, load in product(models, methods, _materials(study), _loads(study))]
    ids = [case.case_id for case in cases]
    if len(set(ids)) < len(ids):
        raise StudyError("the study lists the same case twice (a model, method, material or load repeated); "
                         "remove the repetition")
    return cases


def counted(loaded: StudyFile, models: int) -> str:
    """``"N cases (models × methods × materials × loads)"`` of the study of ``models`` models, each factor counted
    from the file, none expanded; StudyError with the same count above :data:`~.schema.MAX_CASES`."""
    study = loaded.study
    spec = study.materials
    varied = spec.youngs_modulus is not None or spec.poisson_ratio is not None or not spec.presets
    materials = len(spec.presets) + (_count(spec.youngs_modulus) * _count(spec.poisson_ratio) if varied else 0)
    loads = study.loads
    load_count = loads.random.count if loads.random is not None else len(loads.directions) * len(_sizes(loads))
    factors = [(models, "model"), (len(study.methods), "method"), (materials, "material"), (load_count, "load")]
    total = math.prod(count for count, _ in factors)
    text = f"{total} cases ({' × '.join(f'{count} {noun}' + ('' if count == 1 else 's') for count, noun in factors)})"
    if total > MAX_CASES:
        raise StudyError(f"{loaded.path.name}: {text}, more than the {MAX_CASES} one study runs; split it into "
                         f"studies of at most {MAX_CASES} cases (e.g. one per model or method, or fewer values) and "
                         "run them into the same --output")
    return text


def _count(values) -> int:
    """How many values a list or a range of ``[materials]`` gives (1 when absent: the paper's)."""
    return 1 if values is None else (len(values) if isinstance(values, list) else values.count)


def _check_methods(loaded: StudyFile) -> None:
    """StudyError unless each method exists and takes each of its options (the material is the study's)."""
    from ..solvers.registry import available_solvers, solver_options

    for i, method in enumerate(loaded.study.methods):
        where = f"{loaded.path.name}: methods[{i}]"
        if method.name not in available_solvers():
            raise StudyError(f"{where}.name: unknown method {method.name!r}; choose one of "
                             f"{', '.join(available_solvers())}")
        accepted = solver_options(method.name)
        for key in method.options:
            if key in MATERIAL_KEYS:
                raise StudyError(f"{where}.options.{key}: a study sets the material in [materials]; move it there")
            if key not in accepted:
                raise StudyError(f"{where}.options.{key}: the {method.name} method has no option {key!r}; its "
                                 f"options are {', '.join(sorted(set(accepted) - set(MATERIAL_KEYS)))}")


def _sources(loaded: StudyFile, index: int, spec) -> list[tuple[str, Path | None]]:
    """``(kind, path)`` of each model an entry names (``("builtin", None)`` for a built-in), each file found."""
    from ..io import SURFACE_EXTENSIONS

    if spec.name is not None:
        return [("builtin", None)]
    key = "folder" if spec.folder is not None else ("file" if spec.file is not None else "bundle")
    where = f"{loaded.path.name}: models[{index}].{key}"
    path = loaded.resolve(getattr(spec, key), key=f"models[{index}].{key}").resolve()
    if key == "folder":
        if not path.is_dir():
            raise StudyError(f"{where}: {str(path)!r} is a file, not a folder; name a folder of surface files"
                             if path.exists() else f"{where}: no folder {str(path)!r}; fix the path")
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in SURFACE_EXTENSIONS)
        if not files:
            raise StudyError(f"{where}: no surface file ({', '.join(SURFACE_EXTENSIONS)}) in {str(path)!r}")
        # a file in the folder may be a link out of it
        return [("file", loaded.resolve(str(f), key=f"models[{index}].folder").resolve()) for f in files]
    if path.is_dir():
        raise StudyError(f"{where}: {str(path)!r} is a folder, not a file; name a file in it, or use folder = for "
                         "every surface file in it")
    if not path.is_file():
        raise StudyError(f"{where}: no file {str(path)!r} (names are relative to the study file's folder); fix the "
                         "name or the path")
    return [(key, path)]


def _model(source: tuple[str, Path | None], spec) -> ModelRef:
    kind, path = source
    if path is None:
        return ModelRef("builtin", spec.name, spec.resolution, spec.scale, spec.repair,
                        content_hash("builtin", spec.name, spec.resolution, spec.scale))
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    scale = 1.0 if kind == "bundle" else spec.scale
    return ModelRef(kind, str(path), None, scale, spec.repair, content_hash(kind, digest, scale, spec.repair))


def _materials(study) -> list[tuple]:
    spec = study.materials
    materials = [(name, *preset(name).options().values()) for name in spec.presets]
    if spec.youngs_modulus is not None or spec.poisson_ratio is not None or not materials:
        moduli = _values(spec.youngs_modulus, PAPER_MATERIAL[1])
        ratios = _values(spec.poisson_ratio, PAPER_MATERIAL[2])
        label = "paper" if spec.youngs_modulus is None and spec.poisson_ratio is None else ""
        materials += [(label or f"E={e:g} nu={nu:g}", e, nu, spec.density) for e, nu in product(moduli, ratios)]
    for _, youngs_modulus, poisson_ratio, _ in materials:
        try:
            Material(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio)
        except MaterialError as error:
            raise StudyError(f"materials: {error}") from None
    return materials


def _values(spec, default: float) -> list[float]:
    if spec is None:
        return [default]
    return spec.values() if hasattr(spec, "values") else [float(v) for v in spec]


def _sizes(loads) -> list[float]:
    """Each load's size along a direction: forces [N], or a displacement-driven tool's travels [m]."""
    return loads.forces if loads.kind not in TRAVELS else getattr(loads, TRAVELS[loads.kind][0])


def _loads(study) -> list[tuple]:
    """(radius, force, direction, random, tool, depth, point) of every load."""
    loads = study.loads
    if loads.random is not None:
        r = loads.random
        return [(loads.radius, None, None, (r.seed, i, *r.force), "pin-head", None, None) for i in range(r.count)]
    directions = [tuple(LOAD_DIRECTIONS[d]) if isinstance(d, str) else tuple(d) for d in loads.directions]
    if loads.kind in TRAVELS:
        point = None if loads.point is None else tuple(loads.point)
        return [(loads.radius, None, d, None, loads.kind, float(travel), point) for d in directions
                for travel in _sizes(loads)]
    return [(loads.radius, float(f), d, None, "pin-head", None, None) for d in directions for f in loads.forces]
