"""The ``tissuesim`` command: one sub-command per job, each in its own module under :mod:`tissuesim.commands`.

User mistakes (any :class:`~tissuesim.errors.TissuesimError`, a missing file) and what the machine refuses (any
``OSError``: a full disk, a read-only place) print one line and exit 1; only genuine bugs show a traceback.
SIGTERM, like Ctrl-C, unwinds the command (so half-written outputs are cleaned up) and exits with 128 + the signal
number.

Numba compiles each kernel the first time it runs and caches it on disk beside its source (``cache=True``), so a
fresh install, or a changed source, spends about 20 s compiling (the first build measured 22 s, later ones 0.4 s).
A command says so on stderr when the first kernel starts compiling (:func:`~tissuesim.compile_notice.announce_compilation`,
which listens to Numba's own compile events: a kernel loaded from the cache fires none, so a warm run prints
nothing), and at its end how many kernels it compiled and how long that took.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import warnings
from importlib import import_module

from . import __version__
from .compile_notice import announce_compilation
from .errors import TissuesimError, TissuesimWarning

DESCRIPTION = ("Soft-tissue surface deformation with the hybrid FEM + PBD method: build hybrid meshes, run the "
               "paper's experiments, calibrate the free scalars.")

# sub-command name -> module under tissuesim.commands
COMMANDS = {
    "build": "build",
    "experiment": "experiment",
    "calibrate": "calibrate",
    "incise": "incise",
    "view": "view",
    "render": "render",
    "run": "run",
    "study": "study",
}


def _available_commands():
    for name, module in COMMANDS.items():
        try:
            yield name, import_module(f"{__package__}.commands.{module}")
        except ModuleNotFoundError as error:
            if error.name != f"{__package__}.commands.{module}":
                raise


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tissuesim", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"tissuesim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in _available_commands():
        command = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(run=module.run)
    return parser


class Terminated(BaseException):
    """Raised in the main thread on SIGTERM, so ``finally`` blocks run (as for Ctrl-C)."""


def _terminate(signum, frame):
    raise Terminated()


def _one_line_warning(name: str, default):
    """A ``warnings.showwarning`` that prints this package's warnings as one line, as errors are (others as
    ``default`` does)."""
    def show(message, category, filename, lineno, file=None, line=None):
        if not issubclass(category, TissuesimWarning):
            return default(message, category, filename, lineno, file, line)
        print(f"{name}: warning: {message}", file=sys.stderr if file is None else file)
    return show


def main(argv: list[str] | None = None) -> int:
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main_thread else None
    name = "tissuesim"                      # until the command is known: an interrupt may come while parsing
    try:
        args = build_parser().parse_args(argv)
        name = f"tissuesim {args.command}"
        with warnings.catch_warnings(), announce_compilation(name):
            warnings.showwarning = _one_line_warning(name, warnings.showwarning)
            return int(args.run(args) or 0)
    except (TissuesimError, OSError) as error:
        print(f"{name}: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{name}: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print(f"{name}: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


if __name__ == "__main__":
    sys.exit(main())
