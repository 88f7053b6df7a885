"""Every list of methods in the package is derived from the registry (each method's card), so a method registered
anywhere joins the experiments, the figures, the CLI and the calibration without an edit elsewhere.

The check reads the package's source: a list, tuple or set literal, or a dict's keys, naming two or more registered
methods is a literal list of methods. The modules allowed one say why below.
"""

import ast
from pathlib import Path

import pytest

import tissuesim
from tissuesim.solvers import available_solvers

PACKAGE = Path(tissuesim.__file__).parent
#: Module (relative to the package) -> why a literal naming several methods belongs there.
ALLOWED = {
    "solvers/registry.py": "the registry itself: where each built-in method's module is",
    "experiments/paper.py": "the paper's published figures, keyed by the methods it compares",
    "solvers/calibrated.py": "written by `tissuesim calibrate --write`: each free scalar's frozen value",
    "experiments/contact_report.py": "the accuracy targets are set against two named baselines, Emb. and PBD",
}


def method_lists(source: str, names) -> list[tuple[int, list[str]]]:
    """``(line, names)`` of each literal in ``source`` that names two or more of ``names``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
            items = node.elts
        elif isinstance(node, ast.Dict):
            items = [key for key in node.keys if key is not None]
        else:
            continue
        named = [item.value for item in items if isinstance(item, ast.Constant) and item.value in names]
        if len(named) >= 2:
            found.append((node.lineno, named))
    return found


@pytest.mark.parametrize("snippet", ['A = ("hybrid", "pbd")', 'B = {"fem": 1, "embedded": 2}',
                                     'C = [m for m in ["pbd", "mass-spring"]]'])
def test_the_check_finds_a_literal_list_of_methods(snippet):
    assert method_lists(snippet, available_solvers())


def test_one_method_named_is_no_list():
    assert not method_lists('D = ("hybrid", "linear"); E = {"pbd": 1}', available_solvers())


def test_no_module_of_the_package_lists_methods_literally():
    names = set(available_solvers())
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = path.relative_to(PACKAGE).as_posix()
        if module in ALLOWED:
            continue
        offenders += [f"{module}:{line} {found}" for line, found in method_lists(path.read_text(), names)]
    assert not offenders, ("literal lists of methods; read them from the registry (tissuesim.solvers.method_names, "
                           "the method's card) instead:\n" + "\n".join(offenders))


def test_every_allowed_module_still_needs_its_allowance():
    names = set(available_solvers())
    assert all(method_lists((PACKAGE / module).read_text(), names) for module in ALLOWED)
