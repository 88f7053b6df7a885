"""Reading a study file: TOML → the validated :class:`~.schema.Study`, or one :class:`StudyError` naming every
defect by its key (``materials.youngs_modulus.count``), what is wrong and the fix."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import TissuesimError
from ..scene.load import named_path, read_text, validated
from ..scene.schema import LOCATED
from .schema import Study


class StudyError(TissuesimError, ValueError):
    """A study file is unreadable, a key in it is missing, unknown or out of range, or a study's output folder
    belongs to another study."""


@dataclass(frozen=True)
class StudyFile:
    """A validated study and where it came from (file names in it are relative to its folder; with ``confine``
    they must lie in it, see :func:`~tissuesim.scene.load.named_path`)."""

    study: Study
    path: Path
    confine: bool = False

    def resolve(self, name: str, *, key: str) -> Path:
        """``name`` (a file named in the study under ``key``) as a path: relative names are relative to the study
        file; StudyError for one outside its folder when confined."""
        return named_path(name, self.path, key=key, confine=self.confine, error=StudyError, kind="study")


def read_study(path: Path | str, *, confine: bool = False) -> StudyFile:
    """The study in the TOML file ``path``, validated; StudyError for an unreadable file or any invalid key, and,
    with ``confine``, for a file named in it that lies outside its folder."""
    path = Path(path)
    return parse_study(read_text(path, error=StudyError, kind="study"), path, confine=confine)


def parse_study(text: str, path: Path | str, *, confine: bool = False) -> StudyFile:
    """The study in the TOML ``text`` of the file ``path`` (which names its folder), validated."""
    path = Path(path)
    study = StudyFile(validated(text, path, Study, error=StudyError, doc="docs/studies.md", line=_line), path,
                      confine)
    for index, model in enumerate(study.study.models):
        for key in ("file", "bundle", "folder"):
            if getattr(model, key) is not None:
                study.resolve(getattr(model, key), key=f"models[{index}].{key}")
    return study


def _line(item: dict) -> str:
    loc, message, kind = [str(p) if isinstance(p, str) else p for p in item["loc"]], item["msg"], item["type"]
    message = message.removeprefix("Value error, ")
    if message.startswith(LOCATED):
        _, below, message = message.split(LOCATED, 2)
        loc.append(below)
    # a union's member names (list[...], Range, a Literal) are pydantic's, not keys of the file
    where = "".join(f"[{p}]" if isinstance(p, int) else (p if p.startswith("[") else f".{p}")
                    for p in loc if isinstance(p, int) or not _member(p)).lstrip(".") or "the study"
    if kind == "extra_forbidden":
        return f"{where}: unknown key; see docs/studies.md for the keys of this table"
    if kind == "missing":
        return f"{where}: missing; add it (docs/studies.md)"
    return f"{where}: {message[0].lower() + message[1:]}"


def _member(part: str) -> bool:
    return part.startswith(("list[", "literal[", "function-")) or part in ("Range", "str", "list", "range")
