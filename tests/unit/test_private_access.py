"""No module reads or writes another module's private attribute (a name with one leading underscore): what one class
needs of another is public and documented there, so a rename is seen where it breaks, not lost (names held in strings
included: the snapshot reads each class's own list of what it keeps).

A module's own: the attributes it assigns or reads on ``self`` or ``cls``, the ones it assigns on anything (a marker
it sets on a class of another library), and the functions and classes it defines.
"""

import ast
from pathlib import Path

import tissuesim

PACKAGE = Path(tissuesim.__file__).parent
#: ``module: expression`` -> why it may read a private name.
ALLOWED = {"errors.py: sys._getframe": "CPython's documented frame access, the warning's caller",
           "numba_cache.py: getattr(self, '_cache_path', None)": "Numba's cache file's folder, which the lock guards"}
_BY_NAME = ("getattr", "hasattr", "setattr", "delattr")


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _by_name(node) -> tuple[ast.expr, str] | None:
    """``(object, name)`` of ``getattr(object, "name", ...)`` and its kin, else None."""
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _BY_NAME
            and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)):
        return node.args[0], node.args[1].value
    return None


def _on_self(value: ast.expr) -> bool:
    return isinstance(value, ast.Name) and value.id in ("self", "cls")


def foreign_private_access(source: str) -> list[str]:
    """``line: expression`` of each access to a private attribute that ``source`` does not define, by attribute or
    by name (``getattr(obj, "_name")``)."""
    tree = ast.parse(source)
    own = set()
    for node in ast.walk(tree):
        named = _by_name(node)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and _private(node.name):
            own.add(node.name)
        elif isinstance(node, ast.Attribute) and _private(node.attr):
            if _on_self(node.value) or isinstance(node.ctx, ast.Store):
                own.add(node.attr)
        elif named is not None and _private(named[1]) and (_on_self(named[0]) or node.func.id == "setattr"):
            own.add(named[1])
    found = []
    for node in ast.walk(tree):
        named = _by_name(node)
        if isinstance(node, ast.Attribute) and _private(node.attr) and node.attr not in own:
            value = node.value
            if isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "super":
                continue
            found.append(f"{node.lineno}: {ast.unparse(node)}")
        elif named is not None and _private(named[1]) and named[1] not in own:
            found.append(f"{node.lineno}: {ast.unparse(node)}")
    return found


def test_the_check_finds_a_private_read_of_another_module():
    assert foreign_private_access("def f(solver):\n    return solver._cache") == ["2: solver._cache"]
    assert not foreign_private_access("class A:\n    def f(self, other):\n        self._x = 1\n        return other._x")
    assert not foreign_private_access("def f(c):\n    c._marker = True\n    return c._marker")
    assert foreign_private_access("def f(s):\n    return getattr(s, '_hook', None)") == [
        "2: getattr(s, '_hook', None)"]


def test_no_module_reaches_into_another_modules_private_attributes():
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = path.relative_to(PACKAGE).as_posix()
        for entry in foreign_private_access(path.read_text()):
            if f"{module}: {entry.split(': ', 1)[1]}" not in ALLOWED:
                offenders.append(f"{module}:{entry}")
    assert not offenders, "private attributes read across modules; make them public where they belong:\n" + "\n".join(
        offenders)
