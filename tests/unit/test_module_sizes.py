"""Modules stay small enough to read at a glance: at most 400 lines, split along their concerns beyond that. The
modules allowed more say why, and what would split them."""

from pathlib import Path

import tissuesim

PACKAGE = Path(tissuesim.__file__).parent
LIMIT = 400
#: Module (relative to the package) -> why it is longer, for now.
ALLOWED = {
    "tools/grasper.py": "its graspers' joint Newton-Broyden solve belongs in a module of its own, with its state",
}


def test_every_module_is_at_most_400_lines():
    long = {path.relative_to(PACKAGE).as_posix(): len(path.read_text().splitlines())
            for path in PACKAGE.rglob("*.py")}
    over = {module: lines for module, lines in long.items() if lines > LIMIT and module not in ALLOWED}
    assert not over, f"modules over {LIMIT} lines: {over}; split them along their concerns"
    assert all(long[module] > LIMIT for module in ALLOWED), "an allowed module is short now: drop its allowance"
