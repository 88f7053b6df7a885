"""Which methods the experiments run and how they show them, read from each method's card
(:class:`~tissuesim.solvers.base.Solver`: ``label``, ``short_label``, ``colour``, ``line_style``, ``in_paper``) and,
for the contact protocol's variants of a method (:data:`.contact_protocol.VARIANTS`), from :data:`VARIANT_CARDS`.

A method registered anywhere (``@tissuesim.register``) joins every list here: the paper's protocol, its tables and
figures, the contact protocol and the studies.
"""

from __future__ import annotations

from collections.abc import Iterable

from .protocol import REFERENCE

#: The paper's method, "Ours" in its tables.
OURS = "hybrid"
#: The contact protocol's variants of a method (its name with options): their cards, as a method's.
VARIANT_CARDS = {"hybrid-near": {"short_label": "Ours+NF", "label": "hybrid + near field", "colour": "darkred"},
                 "hybrid-quadratic": {"short_label": "Ours-Q", "label": "hybrid, quadratic M_V",
                                      "colour": "tab:purple"}}


# The registry is read inside each function: importing it imports the solvers (and Numba), which the reports and
# figures that read these labels do not otherwise need.


def protocol_methods() -> tuple[str, ...]:
    """Every registered method, the reference last: what the paper's protocol runs by default."""
    return (*compared_methods(), REFERENCE)


def compared_methods() -> tuple[str, ...]:
    """Every registered method but the reference, in registration order."""
    from ..solvers.registry import available_solvers

    return tuple(name for name in available_solvers() if name != REFERENCE)


def paper_methods() -> tuple[str, ...]:
    """The methods the paper compares, the reference excluded (its published figures: :mod:`.paper`)."""
    from ..solvers.registry import method_names

    return tuple(name for name in method_names(in_paper=True) if name != REFERENCE)


def ordered(names: Iterable[str]) -> list[str]:
    """``names`` in the tables' order: the registered methods (reference last), then the variants, then the rest."""
    names = set(names)
    order = [*protocol_methods(), *VARIANT_CARDS]
    return [n for n in order if n in names] + sorted(names - set(order))


def _shown(name: str, field: str, default: str) -> str:
    """A method's or variant's ``field`` of its card, or ``default`` where it has none (a name nobody registered)."""
    from ..solvers.registry import available_solvers, solver_class

    if name in VARIANT_CARDS:
        return VARIANT_CARDS[name].get(field, default)
    return getattr(solver_class(name), field) if name in available_solvers() else default


def short_label(name: str) -> str:
    """A method's or variant's column in the tables ("Ours", "PBD", "Ours-Q"); an unknown name stands for itself."""
    return _shown(name, "short_label", name)


def label(name: str) -> str:
    """What a method or variant is, in a legend ("hybrid FEM + PBD")."""
    return _shown(name, "label", name)


def colour(name: str) -> str:
    """A method's or variant's colour in every plot (grey for a name nobody registered)."""
    return _shown(name, "colour", "tab:gray")


def line_style(name: str) -> str:
    """A method's line style ("-" for a variant or a name nobody registered)."""
    return _shown(name, "line_style", "-")
