"""The contact patches of a solver's loads: which M_S nodes a load at a node with a tip of radius R reaches, with
their area-weighted shares (:func:`tissuesim.loads.contact_patch`), cached per (node, R), and the refusal of a patch
that reaches the fixed region. A mixin of :class:`~tissuesim.solvers.base.Solver`, which holds ``rest_positions``,
``hybrid``, ``fixed`` and the caches ``patch_cache`` and ``lumped_area_cache``."""

from __future__ import annotations

import numpy as np

from ..errors import BoundaryConditionError, SolverError, first_indices


class LoadPatches:
    """Where a solver's load goes (see the module docstring)."""

    def contact_patch(self, node: int, radius: float | None) -> tuple[np.ndarray, np.ndarray]:
        """``(nodes (k,) int64, shares (k,) float64)`` that a load at ``node`` with tip ``radius`` [m] goes to.

        Cached per (node, radius), so an interactive drag that re-sets the load every frame costs nothing here.
        Raises SolverError if the radius is not positive and finite or the patch reaches the fixed region, and
        BoundaryConditionError if ``node`` itself is fixed (the load would vanish into the support).
        """
        key = self._patch_key(node, radius)
        patch = self.patch_cache.get(key)
        if patch is None:
            patch = self._new_patch(*key)
            self._refuse_held(*key, patch[0])
            self.remember_patch(key, patch)
        return patch

    def support_reached(self, node: int, radius: float | None = None) -> np.ndarray:
        """``(k,) int64`` the fixed M_S nodes that a load at ``node`` with tip ``radius`` [m] would reach; empty
        when :meth:`set_load` accepts that load (what :meth:`PinHead.grab <tissuesim.PinHead.grab>` looks for)."""
        key = self._patch_key(node, radius)
        if key in self.patch_cache:
            return np.zeros(0, dtype=np.int64)
        patch = self._new_patch(*key)
        held = self._held_in(patch[0])
        if not held.size:
            self.remember_patch(key, patch)  # the grab that asked loads it next
        return held

    def remember_patch(self, key: tuple[int, float | None], patch: tuple[np.ndarray, np.ndarray]) -> None:
        if len(self.patch_cache) > 256:  # a long interactive session grabs many nodes: keep the cache bounded
            self.patch_cache.clear()
        for array in patch:             # loads hand these out: nobody may change the cache through them
            array.flags.writeable = False
        self.patch_cache[key] = patch

    def _held_in(self, nodes: np.ndarray) -> np.ndarray:
        """``(k,) int64`` the fixed nodes among ``nodes``."""
        return np.intersect1d(nodes, self.fixed).astype(np.int64)

    @staticmethod
    def _patch_key(node: int, radius: float | None) -> tuple[int, float | None]:
        from ..loads import contact_radius

        return int(node), None if radius is None else contact_radius(radius)

    def lumped_areas(self) -> np.ndarray:
        """``(n,) float64`` M_S rest area [m²] each vertex stands for (a third of its triangles')."""
        from ..loads import lumped_areas

        if self.lumped_area_cache is None:
            self.lumped_area_cache = lumped_areas(self.rest_positions, self.hybrid.surface.triangles)
        return self.lumped_area_cache

    def _new_patch(self, node: int, radius: float | None) -> tuple[np.ndarray, np.ndarray]:
        from ..loads import contact_patch

        return contact_patch(self.rest_positions, self.hybrid.surface.triangles, node, radius,
                             areas=self.lumped_areas())

    def _refuse_held(self, node: int, radius: float | None, patch: np.ndarray) -> None:
        """Refuse a load at ``node`` whose ``patch`` ``(k,)`` holds fixed nodes: part of it would vanish into the
        support, all of it when ``node`` itself is fixed."""
        held = self._held_in(patch)
        if np.any(held == node):
            raise BoundaryConditionError(
                f"node {node} is fixed (held at rest by the support), so a load on it would vanish and nothing "
                "would move; load a free node (PinHead.grab snaps to the nearest one), or leave it out of `fixed`"
            )
        if held.size:
            raise SolverError(
                f"the contact patch of radius {radius:g} m around node {node} reaches the fixed region "
                f"({held.size} of its {patch.size} nodes are held, first: {first_indices(held)}); "
                "use a smaller radius or load a node farther from the support"
            )
