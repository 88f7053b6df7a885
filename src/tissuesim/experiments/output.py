"""Writing a results folder: results.json, tables.md, radar_<model>.png, report.md — all or nothing.

Everything is first written into a fresh staging folder on the target's own file system, then moved in: a run
that fails, or is interrupted, while writing leaves the target as it was. Rules:

* before any work, :func:`check_output_folder` creates and removes a staging folder where the results will be
  staged, so an unwritable place is refused before minutes of computation, not after;
* a target that exists as a file, or an empty path, is refused;
* a new folder is staged beside it (its parent must be writable to create it) and renamed into place in one step;
  an existing folder is staged inside itself (a hidden ``.<name>.partial-<pid>-*`` subfolder), so a folder on
  another file system (a mount point) works, and its parent need not be writable;
* an existing folder is kept, and its results are replaced as a whole, all or nothing: the files it holds under the
  new names, and the files its earlier run of ours wrote that this one does not (those its own index lists:
  ``results.json`` here, ``incision.json`` for ``tissuesim incise``), are first moved aside into the staging folder,
  then the new files are moved in; any failure or interruption moves everything back. Other files in the folder are
  left alone, whatever their names. The command says in one line which files of an earlier run it replaced and
  removed (:func:`replacement_note`);
* the folder and its files follow the umask;
* a staging folder whose process is gone (killed while writing) is removed by the next write to the same target.
  SIGTERM is turned into a clean exit by the CLI, which removes it. No message names a staging path.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from ..errors import TissuesimError
from ..io import process_running
from .plots import write_radar_plots
from .report import report_markdown
from .schema import SCHEMA_VERSION, check_results
from .tables import tables_markdown


class OutputError(TissuesimError, OSError):
    """The results folder cannot be written where asked."""


def check_output_folder(folder: Path | str) -> Path:
    """The target folder as a Path, or :class:`OutputError` if it cannot be written there.

    Refused: an empty path, an existing file, a missing parent, and a place where the staging folder cannot be
    created (tried for real, then removed). Abandoned staging folders of this target are cleaned up.
    """
    if not str(folder).strip():
        raise OutputError("the output path is empty; give a folder path, e.g. --output results")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"output path {str(folder)!r} is a file, not a folder; give a folder path (it is created)")
    target = folder.resolve()
    if not target.is_dir() and not target.parent.is_dir():
        what = ("is a file, not a folder; choose another --output" if target.parent.exists()
                else "does not exist; create it, or choose another --output")
        raise OutputError(f"cannot create output folder {str(folder)!r}: its parent {str(target.parent)!r} {what}")
    if target.is_dir() and not os.access(target, os.W_OK):
        raise OutputError(f"output folder {str(folder)!r} is not writable; choose another --output")
    _remove_abandoned_staging(target)
    shutil.rmtree(_make_staging(target, folder))
    return folder


def write_outputs(data: dict, folder: Path | str, *, plots: bool = True) -> list[Path]:
    """Write the results folder for the results document ``data``; return the paths written."""
    check_results(data)

    def fill(staging: Path) -> None:
        (staging / "results.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
        (staging / "tables.md").write_text(tables_markdown(data))
        if plots:
            write_radar_plots(data, staging)
        (staging / "report.md").write_text(report_markdown(data))

    return write_staged(folder, fill)


def write_contact_outputs(data: dict, folder: Path | str) -> list[Path]:
    """Write the contact protocol's folder: ``results.json``, ``report.md`` and ``errors.png``; return the paths
    written."""
    from .contact_plots import error_figure
    from .contact_report import contact_report_markdown

    def fill(staging: Path) -> None:
        (staging / "results.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
        (staging / "report.md").write_text(contact_report_markdown(data))
        error_figure(data).savefig(staging / "errors.png")

    return write_staged(folder, fill)


def results_files(folder: Path) -> set[str]:
    """Names of the files an earlier ``tissuesim experiment`` wrote into ``folder``, as its ``results.json`` says
    (paper protocol: the tables, report and one radar plot per model; contact: the report and ``errors.png``);
    empty when there is no readable ``results.json`` of ours."""
    from .contact_protocol import SCHEMA as CONTACT_SCHEMA

    data = read_index(folder / "results.json")
    if not isinstance(data, dict):
        return set()
    if data.get("schema") == CONTACT_SCHEMA:
        return {"results.json", "report.md", "errors.png"}
    models = (data.get("metadata") or {}).get("models") if data.get("schema") == SCHEMA_VERSION else None
    if not isinstance(models, dict):
        return set()
    return {"results.json", "tables.md", "report.md", *(f"radar_{name}.png" for name in models)}


def read_index(path: Path) -> Any:
    """The JSON document at ``path``, or None where there is none or it is not JSON (then nothing is ours)."""
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return None


def write_staged(folder: Path | str, fill: Callable[[Path], None], *,
                 ours: Callable[[Path], set[str]] = results_files) -> list[Path]:
    """Call ``fill(staging folder)``, then move what it wrote into ``folder`` as a whole, all or nothing: the files
    of an earlier run, ``ours(folder)`` (a set of names), that this one did not write are removed; no other file."""
    folder = check_output_folder(folder)
    target = folder.resolve()
    root = _make_staging(target, folder)
    try:
        new = root / "new"
        new.mkdir()
        _filled(fill, new, folder)
        names = sorted(p.name for p in new.iterdir())
        if not target.exists():
            os.rename(new, target)  # one step on one file system: the staging root is beside the target
        else:
            _swap_in(new, target, folder, names, stale=sorted(earlier_outputs(target, ours=ours) - set(names)),
                     aside=root / "old")
        return [folder / name for name in names]
    finally:
        shutil.rmtree(root, ignore_errors=True)


def _filled(fill, new: Path, folder: Path) -> None:
    """``fill(new)``; an OSError there names the file it was writing by its place in ``folder``, not the staging
    path."""
    try:
        fill(new)
    except OSError as error:
        if isinstance(error, TissuesimError):
            raise
        where = Path(error.filename).name if error.filename else None
        what = f" while writing {folder / where}" if where else ""
        raise OutputError(f"cannot write the results into {str(folder)!r}: {error.strerror or error}{what}; the "
                          "folder is left as it was") from None


def _swap_in(new: Path, target: Path, folder: Path, names: list[str], *, stale: list[str], aside: Path) -> None:
    """Move the files ``names`` of ``new`` into ``target`` and remove ``stale`` there, as one step: every file they
    replace or remove is moved into ``aside`` first; on any failure or interruption everything moves back."""
    check_no_folder(folder, names)
    aside.mkdir()
    moved_aside, moved_in = [], []
    try:
        for name in [*names, *stale]:
            if os.path.lexists(target / name):
                os.replace(target / name, aside / name)
                moved_aside.append(name)
        for name in names:
            os.replace(new / name, target / name)
            moved_in.append(name)
    except BaseException as error:
        _move_back(moved_in, target, new)
        _move_back(moved_aside, aside, target)
        if isinstance(error, OSError) and not isinstance(error, TissuesimError):
            raise OutputError(f"cannot move the results into {str(folder)!r}: {error.strerror or error}; the folder "
                              "is left as it was") from None
        raise


def check_no_folder(folder: Path | str, names: Iterable[str]) -> None:
    """Refuse (OutputError) result file ``names`` that are folders in ``folder``: a file cannot replace them."""
    folders = [name for name in names if (Path(folder) / name).is_dir()]
    if folders:
        raise OutputError(f"cannot write {len(folders)} result file(s) into {str(folder)!r}: "
                          f"{', '.join(folders[:3])} there {'is a folder' if len(folders) == 1 else 'are folders'}; "
                          "move it away or choose another --output (nothing was changed)")


def _move_back(names: list[str], source: Path, destination: Path) -> None:
    """Undo moves of ``names`` (last first); each is tried even if one fails, so as much as possible is restored."""
    for name in reversed(names):
        try:
            os.replace(source / name, destination / name)
        except OSError:
            pass


def _staging_prefix(target: Path) -> str:
    return f".{target.name}.partial-"


def _make_staging(target: Path, folder: Path) -> Path:
    """A fresh private staging folder on ``target``'s file system: inside it when it exists, else beside it."""
    place = target if target.is_dir() else target.parent
    try:
        return Path(tempfile.mkdtemp(prefix=f"{_staging_prefix(target)}{os.getpid()}-", dir=place))
    except OSError as error:
        where = f"in {str(folder)!r}" if place == target else f"{str(folder)!r} in {str(place)!r}"
        raise OutputError(f"cannot write the results: creating {where} failed ({error.strerror or error}); choose "
                          "another --output or make that folder writable") from None


def _remove_abandoned_staging(target: Path) -> None:
    """Remove staging folders of ``target`` (inside it or beside it) whose writing process no longer runs."""
    prefix = _staging_prefix(target)
    for place in (target, target.parent):
        try:
            entries = list(place.iterdir())             # not glob: the folder's name may hold [ ] * ?
        except OSError:
            continue                                    # no such folder, or not readable: nothing of ours to find
        for path in entries:
            if not path.name.startswith(prefix):
                continue
            pid = path.name[len(prefix):].split("-", 1)[0]
            abandoned = pid.isdigit() and int(pid) not in (0, os.getpid()) and not process_running(int(pid))
            if abandoned and path.is_dir():
                shutil.rmtree(path, ignore_errors=True)


def earlier_outputs(folder: Path | str, *, ours: Callable[[Path], set[str]] = results_files) -> set[str]:
    """Names of the files in ``folder`` that an earlier run of ours wrote (``ours(folder)``, those still there as
    files); empty if there is no folder."""
    folder = Path(folder)
    if not folder.is_dir():
        return set()
    # a name is taken only as a plain file name in the folder: an index is data, and may be hostile ("../x")
    return {name for name in ours(folder) if Path(name).name == name and name not in (".", "..")
            and (folder / name).is_file()}


def replacement_note(folder: Path | str, earlier: set[str], written: list[Path]) -> str | None:
    """One line naming the files of an earlier run in ``folder`` that a write replaced (same name) and removed (not
    written again), or None when the folder held none."""
    names = {p.name for p in written}
    replaced, removed = sorted(earlier & names), sorted(earlier - names)
    if not replaced and not removed:
        return None
    parts = [f"replaced {len(replaced)} ({', '.join(replaced)})"] if replaced else []
    parts += [f"removed {len(removed)} not written by this run ({', '.join(removed)})"] if removed else []
    return f"{folder}: earlier results " + "; ".join(parts)
