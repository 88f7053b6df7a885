"""A MkDocs hook: the API reference's methods page gets, for each registered method, the table of its keyword
options (name, meaning, unit, default, range) and what it takes (materials, cuts).

Which options a method has and their defaults come from the code (``solver_options``, the classes' signatures), so
the table cannot drift from it; what each option means, its unit and its range are written here once. A method
with an option this file does not describe fails the strict build, so a new option is documented with it.
"""

from __future__ import annotations

import re

MARKER = "<!-- method options -->"

#: option -> (meaning, unit, range)
OPTIONS = {
    "youngs_modulus": ("Young's modulus E", "Pa", "> 0"),
    "poisson_ratio": ("Poisson's ratio ν", "–", "(-1, 0.49]"),
    "fixed": ("the M_S vertices held at rest (indices or a bool mask); None: the bottom tenth", "–", "free vertices"),
    "density": ("mass density ρ (dynamics and the weight)", "kg/m³", "> 0"),
    "dt": ("time step of `step()`", "s", "> 0"),
    "damping": ("velocity damping per step (the path, not the equilibrium)", "–", "[0, 1)"),
    "material": ("constitutive model", "–", "the method's materials (below)"),
    "gravity": ("gravitational acceleration, or None", "m/s²", "3 finite numbers, magnitude ≤ 1e4"),
    "attachments": ("ligaments: `Attachment`s (springs to anchors)", "N/m", "positive stiffness"),
    "form": ("the surface layer: `xpbd` (elastic, material-derived) or `pbd` (the paper's coefficients)", "–",
             "xpbd, pbd"),
    "iterations": ("Gauss–Seidel sweeps per step of the projection forms", "–", "≥ 1"),
    "thickness_ratio": ("the surface layer's thickness over its edge length β (calibrated)", "–", "> 0"),
    "stiffness": ("the paper's PBD stiffness coefficient k (form pbd)", "–", "(0, 1]"),
    "mass_scale": ("factor on the pbd form's masses (calibrated)", "–", "> 0"),
    "signed_bending": ("bend constraints on the signed dihedral angle", "–", "True, False"),
    "integrator": ("the layer's step: `implicit` (rests at the static answer) or `xpbd` (projection)", "–",
                   "implicit, xpbd"),
    "prestrain": ("in-plane prestrain of the surface, so that a cut gapes", "–", "[0, 0.3]"),
    "warm_start": ("move free vertices with the embedded FEM displacement when the load changes", "–",
                   "True, False"),
    "near_field": ("W: M_S vertices within it of the contact follow quadratic tets on the fine volume", "m",
                   "None or > 0"),
    "element": ("M_V's elements: `linear` (the paper's) or `quadratic` (every vertex follows them)", "–",
                "linear, quadratic"),
}


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Put each method's table where the page has :data:`MARKER`."""
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, "\n\n".join(_method(name) for name in _methods()))


def _methods() -> list[str]:
    from tissuesim.solvers.registry import available_solvers

    return list(available_solvers())


def _method(name: str) -> str:
    from tissuesim.solvers.registry import solver_class, solver_options

    import sys

    cls = solver_class(name)
    summary = (sys.modules[cls.__module__].__doc__ or "").strip().split("\n\n")[0].replace("\n", " ")
    summary = re.sub(r":(?:mod|class|func|meth|data|attr):`~?\.?([^`]+)`", r"`\1`", summary)   # Sphinx roles
    missing = [option for option in solver_options(name) if option not in OPTIONS]
    if missing:
        raise ValueError(f"docs/hooks/method_options.py does not describe option(s) {', '.join(missing)} of "
                         f"{name}: add them to OPTIONS")
    rows = [f"| `{option}` | {OPTIONS[option][0]} | {OPTIONS[option][1]} | `{default!r}` | {OPTIONS[option][2]} |"
            for option, default in solver_options(name).items()]
    cuts = "cuts" if cls.cut_carrier is not None else "does not cut (" + (cls.cut_refusal or "").split(":")[0] + ")"
    return "\n".join([f"### `{name}`", "", summary, "",
                      f"Materials: {', '.join(f'`{m}`' for m in cls.materials)}; {cuts}. Class: "
                      f"`{cls.__module__}.{cls.__qualname__}`.", "",
                      "| option | meaning | unit | default | range |", "|---|---|---|---|---|", *rows])
