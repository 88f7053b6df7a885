"""Writing a results folder: results.json, tables.md, radar_<model>.png, report.md — all or nothing.

Everything is first written into a fresh temporary folder beside the target (same file system), then moved in:
a run that fails, or is interrupted, while writing leaves the target as it was. A target that exists as a file is
refused; an existing folder is kept and its files of the same names are replaced.
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


class OutputError(TissuesimError, OSError):
    """The results folder cannot be written where asked."""


def check_output_folder(folder) -> Path:
    """The target folder as a Path, or :class:`OutputError` if it is a file or its parent cannot hold it."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"output path {str(folder)!r} is a file, not a folder; give a folder path (it is created)")
    parent = folder.resolve().parent
    if not parent.is_dir():
        raise OutputError(f"cannot create output folder {str(folder)!r}: its parent {str(parent)!r} does not exist")
    if not os.access(parent if not folder.exists() else folder, os.W_OK):
        raise OutputError(f"output folder {str(folder)!r} is not writable; choose another --output")
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
    """Write the contact protocol's folder: ``results.json`` and ``report.md``; return the paths written."""
    from .contact_report import contact_report_markdown

    def fill(staging: Path) -> None:
        (staging / "results.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
        (staging / "report.md").write_text(contact_report_markdown(data))

    return write_staged(folder, fill)


def write_staged(folder, fill) -> list[Path]:
    """Call ``fill(staging folder)``, then move what it wrote into ``folder`` (all or nothing)."""
    folder = check_output_folder(folder)
    parent = folder.resolve().parent
    staging = Path(tempfile.mkdtemp(prefix=f".{folder.name}.partial-", dir=parent))
    try:
        fill(staging)
        names = sorted(p.name for p in staging.iterdir())
        if not folder.exists():
            staging.rename(folder)  # atomic on one file system
            staging = None
        else:
            for name in names:
                os.replace(staging / name, folder / name)
        return [folder / name for name in names]
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
