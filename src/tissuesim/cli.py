"""The ``tissuesim`` command: one sub-command per job, each in its own module under :mod:`tissuesim.commands`.

User mistakes (any :class:`~tissuesim.errors.TissuesimError`, a missing file) print one line and exit 1; only
genuine bugs show a traceback.
"""

from __future__ import annotations

import argparse
import sys
from importlib import import_module

from . import __version__
from .errors import TissuesimError

# sub-command name -> module under tissuesim.commands
COMMANDS = {
    "build": "build",
    "experiment": "experiment",
    "calibrate": "calibrate",
    "view": "view",
    "render": "render",
}


def _available_commands():
    for name, module in COMMANDS.items():
        try:
            yield name, import_module(f"{__package__}.commands.{module}")
        except ModuleNotFoundError as error:
            if error.name != f"{__package__}.commands.{module}":
                raise


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tissuesim", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"tissuesim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in _available_commands():
        command = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except (TissuesimError, FileNotFoundError, IsADirectoryError, PermissionError) as error:
        print(f"tissuesim {args.command}: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"tissuesim {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
