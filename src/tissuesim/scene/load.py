"""Reading a scene file: TOML → the validated :class:`~.schema.Scene`, or one :class:`SceneError` naming every
defect by its key (``tools[1].path[3].time``), what is wrong and the fix."""

from __future__ import annotations

import sys
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pydantic import BaseModel, ValidationError

from ..errors import TissuesimError
from .schema import LOCATED, TOOL_CLASSES, TOOL_KINDS, Scene

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - the dependency is declared for these versions
    import tomli as tomllib

#: At most this many defects are listed in one message; the rest are counted.
MAX_LISTED = 8


class SceneError(TissuesimError, ValueError):
    """A scene file is unreadable, or a key in it is missing, unknown or out of range."""


@dataclass(frozen=True)
class SceneFile:
    """A validated scene and where it came from.

    Attributes:
        scene: the validated :class:`~.schema.Scene`.
        path: the scene file. folder: its folder, against which the file names in it are resolved.
        confine: whether the files it names must lie in that folder (see :func:`named_path`).
    """

    scene: Scene
    path: Path
    confine: bool = False

    @property
    def folder(self) -> Path:
        return self.path.parent

    def resolve(self, name: str, *, key: str) -> Path:
        """``name`` (a file named in the scene under ``key``) as a path, as :func:`named_path` resolves it."""
        return named_path(name, self.path, key=key, confine=self.confine, error=SceneError, kind="scene")


def read_scene(path: Path | str, *, confine: bool = False) -> SceneFile:
    """The scene in the TOML file ``path``, validated; SceneError for an unreadable file or any invalid key (all of
    them, one per line of the message), for a model file that does not exist, and, with ``confine``, for a file
    named in it that lies outside its folder."""
    path = Path(path)
    return parse_scene(read_text(path, error=SceneError, kind="scene"), path, confine=confine)


def read_text(path: Path, *, error: type, kind: str) -> str:
    """The text of the ``kind`` file ``path`` (a scene, a study), or ``error`` naming it when it cannot be read."""
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as reason:
        raise error(f"cannot read the {kind} file {str(path)!r}: {reason}") from None


def validated(text: str, path: Path, model: type[BaseModel], *, error: type, doc: str,
              line: Callable[[dict], str] | None = None) -> BaseModel:
    """``model`` validated from the TOML ``text`` of the file ``path``; ``error`` for text that is no TOML (pointing
    to ``doc``, the format's page), nests too deep for the reader, or for every invalid key (:func:`describe`,
    each told by ``line``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as reason:
        raise error(f"{path.name} is not valid TOML: {reason}; see {doc} for the format") from None
    except RecursionError:
        # the reader recurses once per level of nesting: thousands of levels exhaust Python's stack
        raise error(f"{path.name}: arrays or tables nested too deep to read (about {sys.getrecursionlimit()} levels "
                    f"or more); flatten them: no key of the format nests more than a few levels (see {doc})") from None
    try:
        return model.model_validate(data)
    except ValidationError as reason:
        raise error(describe(reason, path.name, line=line)) from None


def named_path(name: str, file: Path, *, key: str, confine: bool, error: type, kind: str) -> Path:
    """``name``, a path written under ``key`` in the ``kind`` file ``file``: relative to that file's folder when
    relative. Paths outside the folder are allowed unless ``confine`` (what a service reading others' files needs):
    then ``error`` unless the path, its links followed, lies inside the folder."""
    path = Path(name).expanduser()
    path = path if path.is_absolute() else file.parent / path
    if confine and not path.resolve().is_relative_to(file.parent.resolve()):
        raise error(f"{file.name}: {key}: {name!r} lies outside the {kind} file's folder, to which its files are "
                    f"confined (confine, --confine); put the file in {str(file.parent.resolve())!r} and name it "
                    "from there")
    return path


def parse_scene(text: str, path: Path | str, *, confine: bool = False) -> SceneFile:
    """The scene in the TOML ``text`` of the file ``path`` (which names its folder), validated as
    :func:`read_scene` does."""
    path = Path(path)
    scene = validated(text, path, Scene, error=SceneError, doc="docs/scenes.md")
    loaded = SceneFile(scene, path, confine)
    for key, name in _region_files(scene):
        loaded.resolve(name, key=key)
    if scene.model.file is not None:
        model = loaded.resolve(scene.model.file, key="model.file")
        if model.is_dir():
            raise SceneError(f"{path.name}: model.file: {str(model)!r} is a folder, not a file; name a surface file "
                             "(.obj, .stl, .ply, .off) in it")
        if not model.is_file():
            raise SceneError(f"{path.name}: model.file: no file {str(model)!r} (a file name is relative to the scene "
                             "file's folder); fix the name or the path")
    return loaded


def _region_files(scene: Scene):
    """``(key, name)`` of every file of vertices the scene names (read once the mesh is built)."""
    regions = [("support.fixed", scene.support.fixed)] + [
        (f"support.attachments[{i}].nodes", attachment.nodes) for i, attachment in enumerate(scene.support.attachments)]
    for key, region in regions:
        for kind in ("mask", "indices_file"):
            if getattr(region, kind) is not None:
                yield f"{key}.{kind}", getattr(region, kind)


def describe(error: ValidationError, name: str, *, line: Callable[[dict], str] | None = None) -> str:
    """One message for every defect pydantic found in the file ``name``, each told by ``line`` (a pydantic error's
    dict → ``key: what is wrong; the fix``; default: a scene file's keys)."""
    line = _line if line is None else line
    lines = [line(item) for item in error.errors(include_url=False)]
    lines = list(dict.fromkeys(lines))   # a union's members may report the same defect twice
    more = len(lines) - MAX_LISTED
    listed = " | ".join(lines[:MAX_LISTED]) + (f" | and {more} more" if more > 0 else "")
    count = f"{len(lines)} problems" if len(lines) > 1 else "1 problem"
    return f"{name}: {count}: {listed}"


def _line(item: dict) -> str:
    """``key: what is wrong; the fix`` for one pydantic error."""
    loc, message, kind = list(item["loc"]), item["msg"], item["type"]
    message = message.removeprefix("Value error, ")
    if message.startswith(LOCATED):
        _, below, message = message.split(LOCATED, 2)
        loc += _split(below)
    model, field = _field(loc)
    where = _key([part for part in loc if part not in TOOL_KINDS])     # the tag pydantic adds inside a tool
    if kind == "extra_forbidden":
        accepted = ", ".join(model.model_fields) if model is not None else "see docs/scenes.md"
        return f"{where}: unknown key; the keys accepted here are {accepted}"
    if kind == "missing":
        return f"{where}: missing; add it: {_described(field)}"
    if kind in ("union_tag_not_found", "union_tag_invalid"):
        return f"{where}: a tool needs kind = one of {', '.join(map(repr, TOOL_KINDS))}"
    hint = "" if field is None or kind in ("value_error", "assertion_error") else f"; give {_described(field)}"
    return f"{where}: {message[0].lower() + message[1:]}{hint}"


def _split(below: str) -> list:
    """``"tools[0].path[2].time"`` or ``"[3].time"`` → ``["tools", 0, "path", 2, "time"]``."""
    parts: list = []
    for word in below.replace("[", ".[").split("."):
        if word.startswith("["):
            parts.append(int(word[1:-1]))
        elif word:
            parts.append(word)
    return parts


def _key(loc: list) -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "the scene"


def _field(loc: list):
    """The model holding the last key of ``loc`` (None where it is not a model's) and that key's FieldInfo."""
    model, field = Scene, None
    for part in loc:
        if isinstance(part, int):
            continue
        if part in TOOL_CLASSES:
            model, field = TOOL_CLASSES[part], None
            continue
        if model is None or part not in model.model_fields:
            return model, None
        field = model.model_fields[part]
        model = _model_of(field.annotation)
    return (model if field is None else None), field


def _model_of(annotation):
    """The model class inside an annotation such as ``list[Keyframe]`` or ``Region | None`` (the first found)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType, list, typing.Annotated):
        for arg in typing.get_args(annotation):
            found = _model_of(arg)
            if found is not None:
                return found
    return None


def _described(field) -> str:
    return field.description if field is not None and field.description else "a value as docs/scenes.md says"
