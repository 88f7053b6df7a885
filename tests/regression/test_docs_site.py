"""The docs site builds strict (how CI builds it), the API reference covers the public API, and the README's
library example runs as printed and does what it says."""

import os
import re
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np

import tissuesim

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
GETTING_STARTED = ROOT / "docs" / "getting-started.md"
PUBLIC_API = ROOT / "docs" / "api" / "public.md"
EXAMPLE_HEADING = "## The library in 20 lines"
# The README's sections a newcomer reads first, in this order (what it is comes before the first of them): a
# simulator builder's job first, the paper's reproduction after.
README_ORDER = ["## Install", "## See it", EXAMPLE_HEADING, "## Accuracy and cost", "## Reproducing the paper"]


def test_the_site_builds_strict_without_a_warning(tmp_path):
    site = tmp_path / "site"
    # the changelog is included from the repository's root, so the build runs there
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    warnings = [line for line in done.stderr.splitlines() + done.stdout.splitlines() if line.startswith("WARNING")]
    assert done.returncode == 0 and not warnings, done.stderr[-4000:]
    for page in ("index.html", "getting-started.html", "api/public.html", "changelog.html"):
        assert (site / page).is_file(), page
    # the changelog is the repository's own, included, not a copy that could drift
    first_entry = next(line for line in (ROOT / "CHANGELOG.md").read_text().splitlines() if line.startswith("### "))
    assert first_entry[4:].split(" (")[0] in (site / "changelog.html").read_text()
    # opened from disk (file://): every link between pages names a file that is there (a link to a folder shows a
    # folder listing there), and the search index is a script, which a page loads without a server
    broken = []
    for page in site.rglob("*.html"):
        if page.name == "404.html":      # what a server answers for a missing page: its links are absolute
            continue
        for target in re.findall(r'href="([^"#?:]+)(?:#[^"]*)?"', page.read_text()):
            if not (page.parent / target).is_file():
                broken.append(f"{page.relative_to(site)} -> {target}")
    assert not broken, broken[:10]
    assert (site / "search" / "search_index.js").is_file()
    # every registered method has its options table, built from the registry
    methods = (site / "api" / "methods.html").read_text()
    from tissuesim.solvers.registry import available_solvers, solver_options

    for method in available_solvers():
        assert f'id="{method}"' in methods, method
        assert all(f"<code>{option}</code>" in methods for option in solver_options(method)), method


def _defined_in(name: str) -> str:
    value = getattr(tissuesim, name)
    return value.__name__ if isinstance(value, type(tissuesim)) else f"{value.__module__}.{name}"


def test_the_api_reference_links_every_public_name_where_it_is_defined():
    page = PUBLIC_API.read_text()
    targets = dict(re.findall(r"\[`([\w.]+)`\]\[([\w.]+)\]", page))
    public = [name for name in tissuesim.__all__ if name != "__version__"]
    missing = sorted(set(public) - set(targets))
    assert not missing, f"docs/api/public.md lacks {missing}: add a row linking each to where it is defined"
    wrong = {name: targets[name] for name in public if targets[name] != _defined_in(name)}
    assert not wrong, f"docs/api/public.md links to the wrong place: {wrong}"


def _example(path: Path) -> str:
    """The first Python block after the example's heading in ``path``."""
    text = path.read_text()
    assert EXAMPLE_HEADING in text, f"{path.name} has no {EXAMPLE_HEADING!r} section"
    block = re.search(r"```python\n(.*?)```", text[text.index(EXAMPLE_HEADING):], re.S)
    return block.group(1)


def test_the_readme_reads_in_a_newcomers_order():
    text = README.read_text()
    places = [text.find(f"\n{heading}\n") for heading in README_ORDER]
    assert -1 not in places, [h for h, p in zip(README_ORDER, places) if p == -1]
    assert places == sorted(places), "README sections out of order: " + ", ".join(README_ORDER)
    assert re.search(r"!\[[^\]]+\]\(docs/figures/\w+\.png\)", text[:places[0]]), "no picture before Install"
    assert "tissuesim view liver" in text[places[1]:places[2]]


def test_the_readme_links_to_files_that_exist():
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README.read_text())
    local = [link for link in links if not re.match(r"[a-z]+:", link)]
    assert local, "the README links to no file of the repository"
    missing = [link for link in local if not (ROOT / link).exists()]
    assert not missing, f"README links to missing files: {missing}"


def test_the_library_example_runs_as_printed(tmp_path, monkeypatch):
    code = _example(README)
    assert code == _example(GETTING_STARTED), "README and docs/getting-started.md print different examples"
    assert len(code.strip().splitlines()) <= 35
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    import matplotlib.pyplot as plt

    try:
        names = runpy.run_path(str(_write(tmp_path / "example.py", code)))
    finally:
        plt.close("all")
    top, node, x, solver, surface = (names[k] for k in ("top", "node", "x", "solver", "surface"))
    assert np.allclose(surface.vertices[node], top, rtol=0, atol=1e-12)   # the vertex picked at that position
    assert x[node, 2] - top[2] > 1e-4                                     # 0.5 N upward lifts it (by mm)
    assert len(solver.positions) > len(surface.vertices)                  # the cut added vertices
    frames = sorted((tmp_path / "liver_frames").glob("*.vtu"))
    assert (tmp_path / "liver.pvd").is_file() and len(frames) >= 2       # a ParaView series, drag and cut
    assert (tmp_path / "liver.png").stat().st_size > 10_000               # a drawn figure, not an empty file


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path
