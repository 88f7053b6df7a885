"""Every public function and method of the package has type hints: each parameter (``self`` and ``cls`` aside) and
its return (``__init__`` aside). Public: a module-level function or a method of a module-level class, whose name and
whose class's name do not start with an underscore; functions nested in functions are the function's own business.
"""

import ast
from pathlib import Path

import tissuesim

PACKAGE = Path(tissuesim.__file__).parent


def unhinted(source: str) -> list[str]:
    """``name (line): what lacks a hint`` for each public function of ``source`` without its full hints."""
    found = []

    def check(function, owner: str) -> None:
        if function.name.startswith("_") and function.name != "__init__":
            return
        arguments = function.args
        named = [*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs]
        named += [a for a in (arguments.vararg, arguments.kwarg) if a is not None]
        missing = [a.arg for a in named if a.annotation is None and a.arg not in ("self", "cls")]
        if function.returns is None and function.name != "__init__":
            missing.append("return")
        if missing:
            found.append(f"{owner}{function.name} ({function.lineno}): {', '.join(missing)}")

    for node in ast.parse(source).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            check(node, "")
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    check(item, f"{node.name}.")
    return found


def test_the_check_finds_a_missing_hint():
    assert unhinted("def f(a, b: int): pass\nclass C:\n    def g(self, x: int): pass") == [
        "f (1): a, return", "C.g (3): return"]
    assert not unhinted("def _f(a): pass\nclass _C:\n    def g(self, x): pass\ndef h(*a: int, **k: str) -> None: pass")


def test_every_public_function_has_type_hints():
    missing = []
    for path in sorted(PACKAGE.rglob("*.py")):
        missing += [f"{path.relative_to(PACKAGE).as_posix()}: {entry}" for entry in unhinted(path.read_text())]
    assert not missing, f"{len(missing)} public functions lack type hints:\n" + "\n".join(missing)
