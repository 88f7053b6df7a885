"""Writing a results folder: results.json, tables.md, radar_<model>.png, report.md — all or nothing.

Everything is first written into a fresh staging folder beside the target (same file system), then moved in: a run
that fails, or is interrupted, while writing leaves the target as it was. Rules:

* before any work, :func:`check_output_folder` creates and removes a staging folder where the results will be
  staged, so an unwritable place is refused before minutes of computation, not after;
* a target that exists as a file, or an empty path, is refused;
* an existing folder is kept, and its results are replaced as a whole: every file of ours (``results.json``,
  ``tables.md``, ``report.md``, ``radar_*.png``) that the new run did not write is removed, so a one-model run into a
  four-model folder leaves no other model's plot behind; other files in the folder are left alone. The command says
  in one line which files of an earlier run it replaced and removed (:func:`replacement_note`);
* the folder and its files follow the umask (the staging folder is created private, then opened up);
* a staging folder is named ``.<target>.partial-<pid>-*``; one whose process is gone (killed while writing) is
  removed by the next write to the same target. SIGTERM is turned into a clean exit by the CLI, which removes it.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import TissuesimError
from .plots import write_radar_plots
from .report import report_markdown
from .schema import check_results
from .tables import tables_markdown

#: File-name patterns of the files a results folder holds: replaced as a whole by each write.
OUTPUT_PATTERNS = ("results.json", "tables.md", "report.md", "radar_*.png")


class OutputError(TissuesimError, OSError):
    """The results folder cannot be written where asked."""


def check_output_folder(folder) -> Path:
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
    if not target.parent.is_dir():
        raise OutputError(f"cannot create output folder {str(folder)!r}: its parent {str(target.parent)!r} does not "
                          "exist")
    if folder.exists() and not os.access(folder, os.W_OK):
        raise OutputError(f"output folder {str(folder)!r} is not writable; choose another --output")
    _remove_abandoned_staging(target)
    shutil.rmtree(_make_staging(target))
    return folder


def write_outputs(data: dict, folder, *, plots: bool = True) -> list[Path]:
    """Write the results folder for the results document ``data``; return the paths written."""
    check_results(data)

    def fill(staging: Path) -> None:
        (staging / "results.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
        (staging / "tables.md").write_text(tables_markdown(data))
        if plots:
            write_radar_plots(data, staging)
        (staging / "report.md").write_text(report_markdown(data))

    return write_staged(folder, fill)


def write_contact_outputs(data: dict, folder) -> list[Path]:
    """Write the contact protocol's folder: ``results.json``, ``report.md`` and ``errors.png``; return the paths
    written."""
    from .contact_plots import error_figure
    from .contact_report import contact_report_markdown

    def fill(staging: Path) -> None:
        (staging / "results.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
        (staging / "report.md").write_text(contact_report_markdown(data))
        error_figure(data).savefig(staging / "errors.png")

    return write_staged(folder, fill)


def write_staged(folder, fill, *, patterns=OUTPUT_PATTERNS) -> list[Path]:
    """Call ``fill(staging folder)``, then move what it wrote into ``folder`` as a whole (all or nothing: files of
    an earlier run, those matching the glob ``patterns``, that this one did not write are removed)."""
    folder = check_output_folder(folder)
    target = folder.resolve()
    staging = _make_staging(target)
    try:
        fill(staging)
        names = sorted(p.name for p in staging.iterdir())
        if not target.exists():
            staging.rename(target)  # atomic on one file system
            staging = None
        else:
            for name in names:
                os.replace(staging / name, target / name)
            for stale in earlier_outputs(target, patterns=patterns) - set(names):
                (target / stale).unlink(missing_ok=True)
        return [folder / name for name in names]
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)


def _staging_prefix(target: Path) -> str:
    return f".{target.name}.partial-"


def _make_staging(target: Path) -> Path:
    """A fresh staging folder beside ``target``, with the permissions the umask gives a new folder."""
    try:
        staging = Path(tempfile.mkdtemp(prefix=f"{_staging_prefix(target)}{os.getpid()}-", dir=target.parent))
    except OSError as error:
        raise OutputError(f"cannot write the results beside {str(target)!r}: creating a staging folder in "
                          f"{str(target.parent)!r} failed ({error.strerror or error}); choose another --output or "
                          "make that folder writable") from None
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(staging, 0o777 & ~umask)        # mkdtemp makes it private; results are ordinary files
    return staging


def _remove_abandoned_staging(target: Path) -> None:
    """Remove staging folders of ``target`` whose writing process no longer runs (it was killed)."""
    prefix = _staging_prefix(target)
    for path in target.parent.iterdir():             # not glob: the folder's name may hold [ ] * ?
        if not path.name.startswith(prefix):
            continue
        pid = path.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and int(pid) not in (0, os.getpid()) and not _running(int(pid)) and path.is_dir():
            shutil.rmtree(path, ignore_errors=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True                         # another user's process
    return True


def earlier_outputs(folder, *, patterns=OUTPUT_PATTERNS) -> set[str]:
    """Names of the files in ``folder`` matching the glob ``patterns`` (an earlier run's); empty if no folder."""
    folder = Path(folder)
    if not folder.is_dir():
        return set()
    return {p.name for pattern in patterns for p in folder.glob(pattern) if p.is_file()}


def replacement_note(folder, earlier: set[str], written: list[Path]) -> str | None:
    """One line naming the files of an earlier run in ``folder`` that a write replaced (same name) and removed (not
    written again), or None when the folder held none."""
    names = {p.name for p in written}
    replaced, removed = sorted(earlier & names), sorted(earlier - names)
    if not replaced and not removed:
        return None
    parts = [f"replaced {len(replaced)} ({', '.join(replaced)})"] if replaced else []
    parts += [f"removed {len(removed)} not written by this run ({', '.join(removed)})"] if removed else []
    return f"{folder}: earlier results " + "; ".join(parts)
