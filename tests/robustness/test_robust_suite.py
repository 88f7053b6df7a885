"""The suite itself: slow checks skipped by default with the way to run them, a cache of its own, reproducible
property tests whose health checks speak."""

import os
import re
import subprocess
import sys
from pathlib import Path

from hypothesis import settings

from tissuesim.experiments.reference import default_cache_dir

ROOT = Path(__file__).resolve().parents[2]


def test_references_are_cached_in_a_folder_of_this_run_not_the_users(tmp_path_factory):
    folder = default_cache_dir()
    assert folder.is_relative_to(tmp_path_factory.getbasetemp())
    assert not folder.is_relative_to(Path.home() / ".cache")


def test_slow_checks_are_skipped_by_default_and_say_how_to_run_them():
    environment = {key: value for key, value in os.environ.items() if key != "TISSUESIM_SLOW"}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "-m", "slow", "-p", "no:cacheprovider",
                           "tests/robustness/test_robust_fuzz.py"], cwd=ROOT, env=environment,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-2000:]
    assert " skipped" in done.stdout and " passed" not in done.stdout
    assert "--run-slow" in done.stdout and "TISSUESIM_SLOW=1" in done.stdout


def test_hypothesis_prints_a_failure_to_replay_keeps_its_database_and_every_health_check():
    active = settings()
    assert active.print_blob and active.deadline is None
    assert tuple(active.suppress_health_check) == ()
    if "CI" in os.environ:
        assert active.derandomize                  # the same examples on every CI run
    else:
        assert active.database is not None and not active.derandomize


def declared_dependencies() -> set[str]:
    """Import names of the library's dependencies and of its ``test`` extra (pyproject.toml)."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    specs = project["dependencies"] + project["optional-dependencies"]["test"]
    names = {re.split(r"[<>=!~\[; ]", spec, maxsplit=1)[0].lower() for spec in specs}
    return {IMPORT_NAMES.get(name, name.replace("-", "_")) for name in names}


#: Distribution names whose import name differs.
IMPORT_NAMES = {"scikit-fem": "skfem"}


def test_no_declared_dependency_is_skipped_when_missing():
    declared = declared_dependencies()
    assert {"skfem", "cvxopt", "pymetis"} <= declared
    skipped = []
    for path in sorted((ROOT / "tests").rglob("test_*.py")):
        for name in re.findall(r"importorskip\(\s*[\"']([\w.]+)[\"']", path.read_text()):
            if name.split(".")[0] in declared | {"tissuesim"}:
                skipped.append(f"{path.relative_to(ROOT)}: {name}")
    assert skipped == []


def test_no_test_asserts_on_the_wall_clock():
    clock = re.compile(r"assert\b.*\b(perf_counter|monotonic|process_time|time\.time)\(")
    found = [f"{path.relative_to(ROOT)}:{number}" for path in sorted((ROOT / "tests").rglob("test_*.py"))
             for number, line in enumerate(path.read_text().splitlines(), 1) if clock.search(line)]
    assert found == []
