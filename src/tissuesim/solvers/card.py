"""A method's card: what it is and what it can do, declared on its solver class (every :class:`~.base.Solver`
is one). Everything the experiments, the viewer, the CLI, the docs and the tests list about a method is read from
these (through :mod:`.registry`), so a new method is one module."""

from __future__ import annotations

from typing import ClassVar


class MethodCard:
    """The class-level declarations of a method; a subclass of :class:`~.base.Solver` sets those that differ."""

    name: ClassVar[str] = "?"
    #: What the method is, in a figure's legend or a panel ("hybrid FEM + PBD").
    label: ClassVar[str] = "?"
    #: Its column in the experiments' tables ("Ours", "PBD"): a few characters.
    short_label: ClassVar[str] = "?"
    #: Its colour in every plot (a Matplotlib colour), and its line style where it is drawn as a line.
    colour: ClassVar[str] = "tab:gray"
    line_style: ClassVar[str] = "-"
    #: One of the methods the paper compares (§8.3: its published figures are in
    #: :mod:`tissuesim.experiments.paper`).
    in_paper: ClassVar[bool] = False
    #: With the linear material, the static answer is linear in the loads (superposition holds); False where the
    #: method is geometrically nonlinear whatever its material (springs between moving vertices).
    linear_in_load: ClassVar[bool] = True
    #: The method's free scalar in each of its forms, which ``tissuesim calibrate`` fits once (DESIGN: one
    #: dimensionless scalar per method, frozen in :mod:`.calibrated`): form -> (option, lower bound, upper bound).
    free_scalars: ClassVar[dict[str, tuple[str, float, float]]] = {}
    #: The ``material`` options this method accepts.
    materials: ClassVar[tuple[str, ...]] = ("linear",)
    #: True for methods whose step is an exact static solve (one step reaches equilibrium).
    static: ClassVar[bool] = False
    #: How the method absorbs a cut: the :class:`~tissuesim.solvers.cut_carry.SolverCut` subclass that carries its
    #: arrays over each move (a class, or ``"module:Class"`` imported when first needed); None: it cannot be cut,
    #: for :attr:`cut_refusal`'s reason.
    cut_carrier: ClassVar[type | str | None] = None
    cut_refusal: ClassVar[str | None] = None
    #: What :class:`~.snapshot.Snapshot` puts back besides the positions, the velocities and the loads: arrays a step
    #: reads, restored in place (other arrays may be views of them), and values, rebound as they were. A subclass
    #: extends its parent's.
    kept_arrays: ClassVar[tuple[str, ...]] = ()
    kept_values: ClassVar[tuple[str, ...]] = ("largest_displacement", "last_solve")
    #: Where the method's weight under ``gravity`` is not the elastic body's: a sentence saying how far off, warned
    #: of (:class:`~tissuesim.errors.TissuesimWarning`) when a solver is built with gravity; None where it is.
    gravity_caveat: ClassVar[str | None] = None
