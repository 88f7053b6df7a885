"""Where a recording goes: its target checked before a session starts, the name of its frames folder and of the
partial folder it is written into, fresh session names, and the partial folders that killed sessions left."""

from __future__ import annotations

import itertools
import os
import re
import shutil
import tempfile
from datetime import datetime
from pathlib import Path

from .errors import TissuesimError
from .io import process_running


class RecordingError(TissuesimError, OSError):
    """A recording cannot be written or read where asked."""


def check_target(path: Path | str) -> Path:
    """``path`` as a Path if a recording can be written there, else a :class:`RecordingError` saying why: checked
    before a session starts, so that nothing is simulated for a recording that could not be kept."""
    if not str(path):
        raise RecordingError("a recording needs a file name, got an empty one; name it e.g. session.pvd")
    path = Path(path)
    if path.suffix.lower() != ".pvd":
        raise RecordingError(f"a recording is a ParaView .pvd file, got {str(path)!r}; name it e.g. session.pvd")
    try:
        _check_place(path)
    except OSError as error:  # e.g. a name too long for the file system
        if isinstance(error, RecordingError):
            raise
        raise RecordingError(f"cannot record to {str(path)!r}: {error.strerror or error}; use a shorter name or "
                             "another folder") from None
    return path


def _check_place(path: Path) -> None:
    folder, frames = path.parent, frames_folder(path)
    if not folder.is_dir():
        what = "is a file, not a folder; record into a folder" if folder.exists() else \
            "does not exist; create it or record into another folder"
        raise RecordingError(f"cannot record to {str(path)!r}: folder {str(folder)!r} {what}")
    if path.exists() and not path.is_file():
        raise RecordingError(f"cannot record to {str(path)!r}: it is a folder; name a .pvd file beside it")
    if frames.exists() and not frames.is_dir():
        raise RecordingError(f"cannot record to {str(path)!r}: its frames go into {str(frames)!r}, which is a file; "
                             "move that file away or record under another name")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise RecordingError(f"cannot record to {str(path)!r}: folder {str(folder)!r} is not writable")
    longest = f"{partial_stem(path)}-0-old"  # the longest name a recording creates there (see Recorder.close)
    limit = _name_max(folder)
    if len(os.fsencode(longest)) > limit:
        raise RecordingError(f"cannot record to {str(path)!r}: the name is too long; its frames folder is written "
                             f"as {longest!r} ({len(os.fsencode(longest))} bytes), more than the {limit} bytes a "
                             "file name may have there; use a shorter name")
    try:
        # the permission bits do not tell everything (root, /proc, a read-only mount, ACLs): try it for real
        os.rmdir(tempfile.mkdtemp(prefix=".tissuesim-check-", dir=folder))
    except OSError as error:
        raise RecordingError(f"cannot record to {str(path)!r}: folder {str(folder)!r} cannot be written (creating a "
                             f"folder there failed: {error.strerror or error}); record into another folder") from None


def _name_max(folder: Path) -> int:
    """The longest file name [bytes] ``folder``'s file system takes (255 where it does not say)."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def partial_stem(path: Path, pid: int | None = None) -> str:
    """The name of a recording's partial frames folder, without its ``-<n>`` (see :func:`fresh_folder`)."""
    return f"{frames_folder(path).name}.partial-{os.getpid() if pid is None else pid}"


def session_path(folder: Path | str, *, stem: str = "tissuesim_session") -> Path:
    """A fresh recording name in ``folder``: ``<stem>_<YYYYmmdd-HHMMSS>.pvd`` of now, with ``-2``, ``-3`` ... where a
    recording of that name (its .pvd or its frames) already exists."""
    stamped = f"{stem}_{datetime.now():%Y%m%d-%H%M%S}"
    path, n = Path(folder) / f"{stamped}.pvd", 1
    while path.exists() or frames_folder(path).exists():
        n += 1
        path = Path(folder) / f"{stamped}-{n}.pvd"
    return path


def frames_folder(path: Path) -> Path:
    """The folder of the VTU frames of the recording ``path`` (``NAME.pvd`` -> ``NAME_frames``)."""
    return path.with_name(path.stem + "_frames")


def remove_stale_partials(path: Path) -> list[Path]:
    """Remove the partial frames folders of recordings of ``path`` that a process now dead left (killed before it
    closed them); returns them. A partial of a live process, or of one this user may not signal, is kept."""
    pattern = re.compile(re.escape(frames_folder(path).name) + r"\.partial-(\d+)-\d+(-old)?")
    stale = []
    for entry in path.parent.iterdir():
        found = pattern.fullmatch(entry.name)
        if found and not process_running(int(found.group(1))):
            remove_path(entry)
            stale.append(entry)
    return stale


def remove_path(path: Path) -> None:
    """Remove the folder ``path``, or the link itself where it is one (rmtree refuses links); errors ignored: what
    is left is only a leftover."""
    if path.is_symlink():
        path.unlink(missing_ok=True)
    else:
        shutil.rmtree(path, ignore_errors=True)


def fresh_folder(parent: Path, stem: str) -> Path:
    """A new folder ``parent/stem-<n>`` (not tempfile's, whose folders only their owner may read)."""
    for n in itertools.count():
        folder = parent / f"{stem}-{n}"
        try:
            folder.mkdir()
            return folder
        except FileExistsError:
            continue
        except OSError as error:
            raise RecordingError(f"cannot create {str(folder)!r} for a recording: {error}") from None
