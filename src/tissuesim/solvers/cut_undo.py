"""Taking a cutting move back: what a move may change, kept before it writes (:class:`CutUndo`), so that a move that
fails halfway leaves the solver exactly as it was (:meth:`~.cut_carry.SolverCut.apply`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..cutting.rows import EdgeRows, Rows

if TYPE_CHECKING:
    from ..cutting.result import CutPlan
    from .cut_carry import SolverCut


class CutUndo:
    """What a move may change, kept before it writes so a failure halfway can be taken back: the attributes of the
    solver, its state and the updater (a cut rebinds most arrays: extended views, new hybrid mesh), the surface's
    rewritten rows and fans, the constraint rows and edge maps (journals of their changes), and copies of the few
    per-vertex arrays a cut edits in place (their rows at the changed triangles, or whole where a cut writes farther:
    the mass-spring's bound rows, the hybrid's M_V slots)."""

    #: per-vertex arrays a cut writes in place at old vertices of its changed rows only: (owner, attribute)
    AT_ROWS = (("solver", "mass"), ("solver", "inv_mass"), ("updater", "lumped"), ("updater", "prescribed_mask"),
               ("updater", "held_mask"))
    #: arrays it writes in place elsewhere too (the bound rows of spring neighbours, the hybrid's M_V slots)
    WHOLE = (("solver", "output_slot"), ("updater", "gershgorin"))

    def __init__(self, updater: SolverCut, plan: CutPlan):
        s = updater.solver
        self.updater, self.plan = updater, plan
        self.attributes = [(o, dict(vars(o))) for o in (s, s.state, updater)]
        self.spare, self.surface = updater.spare.mark(), updater.surface.mark(plan)
        self.journals = [v for v in vars(updater).values() if isinstance(v, (Rows, EdgeRows))]
        for journal in self.journals:
            journal.begin()
        owners = {"solver": s, "updater": updater}
        rows = plan.vertices()
        rows = rows[rows < plan.old_count]
        arrays = [(getattr(owners[o], name, None), rows) for o, name in self.AT_ROWS]
        arrays += [(getattr(owners[o], name, None), slice(None)) for o, name in self.WHOLE]
        self.copies = [(a, at, a[at].copy()) for a, at in arrays if isinstance(a, np.ndarray)]
        self.loads = (s.kept_loads(), s.forces, s.load_nodes, s.forces[s.load_nodes].copy())
        self.patches = dict(s.patch_cache)

    def restore(self) -> None:
        """Everything as when this was made."""
        s, updater = self.updater.solver, self.updater
        updater.surface.restore(self.surface, self.plan)
        updater.spare.restore(self.spare)
        for owner, attributes in self.attributes:
            vars(owner).clear()
            vars(owner).update(attributes)
        for journal in self.journals:
            journal.undo()
        for array, at, copy in self.copies:
            array[at] = copy
        kept, forces, nodes, values = self.loads
        for load, *fields in kept:       # the same handles, as they were
            load.node, load.force, load.radius, load.nodes, load.shares = fields
        forces[nodes] = values
        s.patch_cache.clear()
        s.patch_cache.update(self.patches)

    def commit(self) -> None:
        """Keep the move: the journals stop recording."""
        for journal in self.journals:
            journal.commit()
