"""Every list of methods in the package and in the tests is derived from the registry (each method's card), so a
method registered anywhere joins the experiments, the figures, the CLI, the calibration and the tests that apply to
it without an edit elsewhere.

The check reads the source: a list, tuple or set literal, or a dict's keys, naming two or more registered methods is
a literal list of methods. In the tests a dict keyed by method is measured data (each method's expected figure), and
a command line (a list with an ``--option``) is read as given; the modules allowed a literal say why below.
"""

import ast
from pathlib import Path

import pytest

import tissuesim
from tissuesim.solvers import available_solvers

PACKAGE = Path(tissuesim.__file__).parent
TESTS = Path(__file__).parents[1]
#: Module (relative to the package) -> why a literal naming several methods belongs there.
ALLOWED = {
    "solvers/registry.py": "the registry itself: where each built-in method's module is",
    "experiments/paper.py": "the paper's published figures, keyed by the methods it compares",
    "solvers/calibrated.py": "written by `tissuesim calibrate --write`: each free scalar's frozen value",
    "experiments/contact_report.py": "the accuracy targets are set against two named baselines, Emb. and PBD",
}
#: Test module (relative to tests/) -> why it names several methods.
ALLOWED_TESTS = {
    "unit/test_solvers.py": "the registry's own test: the built-in methods are all registered",
}


def method_lists(source: str, names, *, data_keys: bool = False) -> list[tuple[int, list[str]]]:
    """``(line, names)`` of each literal in ``source`` that names two or more of ``names``; with ``data_keys``, dicts
    and command lines are passed (see the module docstring)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
            items = node.elts
            strings = [item.value for item in items if isinstance(item, ast.Constant) and isinstance(item.value, str)]
            if data_keys and any(text.startswith("--") for text in strings):
                continue
        elif isinstance(node, ast.Dict) and not data_keys:
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


def test_no_test_lists_methods_literally():
    names = set(available_solvers())
    offenders = []
    for path in sorted(TESTS.rglob("*.py")):
        module = path.relative_to(TESTS).as_posix()
        if module in ALLOWED_TESTS:
            continue
        offenders += [f"{module}:{line} {found}"
                      for line, found in method_lists(path.read_text(), names, data_keys=True)]
    assert not offenders, ("literal lists of methods in the tests; derive them by the capability the test needs "
                           "(tissuesim.solvers.method_names(cuts=..., material=..., where=...)):\n"
                           + "\n".join(offenders))


def test_a_test_may_key_measured_data_by_method_and_run_a_command_line():
    assert not method_lists('X = {"hybrid": 0.9, "pbd": 0.4}; main(["incise", "--methods", "pbd", "fem"])',
                            available_solvers(), data_keys=True)


def test_every_allowed_module_still_needs_its_allowance():
    names = set(available_solvers())
    assert all(method_lists((PACKAGE / module).read_text(), names) for module in ALLOWED)
    assert all(method_lists((TESTS / module).read_text(), names, data_keys=True) for module in ALLOWED_TESTS)
