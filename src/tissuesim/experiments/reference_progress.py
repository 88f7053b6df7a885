"""Progress of a reference's refinement (:mod:`.reference`): a bar over its levels and an estimate of their time.

A level's cost is dominated by its sparse direct factorisation, which on a 3-D mesh of n unknowns takes about n²
operations (nested dissection): the estimate scales the last level's measured time by the square of the ratio of tet
counts, and extrapolates the tet count of levels not yet meshed by the last ratio between two levels. Measured on the
contact protocol's references (2 cores): a fit on the small levels predicted 49 s for the sphere's level 4 (139k tets),
which took about 90 s; the square predicts 127 s. The time to the last level is an upper bound in the sense that the
refinement may stop earlier (converged, or at the surface bound); it is printed as an estimate, ``≈``, never asserted
on.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

#: A level's time grows as its tet count to this power (above).
EXPONENT = 2.0


class LevelProgress:
    """One reference computation's progress: lines to ``say`` and, if ``bar``, a tqdm bar on stderr whose postfix
    gives the current level's estimated time and the estimate to the last level (``max_levels``)."""

    def __init__(self, say: Callable[[str], None] | None, max_levels: int, *, bar: bool = False,
                 label: str = "reference"):
        self._say = say
        self.max_levels = int(max_levels)
        self.tets: list[int] = []       # per level meshed
        self.seconds: list[float] = []  # per level solved
        self._started = None
        self._bar = None
        if bar and say is not None:
            from tqdm import tqdm

            self._bar = tqdm(total=self.max_levels + 1, unit="level", desc=label, file=sys.stderr, leave=False,
                             bar_format="{desc}: {n_fmt}/{total_fmt} levels |{bar:20}| {elapsed}{postfix}")

    def say(self, line: str) -> None:
        if self._say is None:
            return
        if self._bar is not None:
            self._bar.clear()
        self._say(line)
        if self._bar is not None:
            self._bar.refresh()

    def level_meshed(self, level: int, tets: int) -> None:
        """Level ``level``'s volume has ``tets`` tets; its solve starts now."""
        self.tets.append(int(tets))
        self._started = time.perf_counter()
        if self._bar is not None:
            now, rest = self.estimate(level)
            text = f"level {level}: {tets} tets"
            if now is not None:
                text += f", ≈ {_duration(now)} for it, ≈ {_duration(now + rest)} to level {self.max_levels}"
            self._bar.set_postfix_str(text, refresh=True)

    def level_solved(self) -> None:
        """The level last meshed is solved."""
        self.seconds.append(time.perf_counter() - self._started)
        if self._bar is not None:
            self._bar.update(1)

    def estimate(self, level: int) -> tuple[float | None, float]:
        """``(this level [s] or None before one level is timed, the levels after it up to max_levels [s])``."""
        if not self.seconds:
            return None, 0.0
        base = self.seconds[-1] / self.tets[len(self.seconds) - 1] ** EXPONENT
        now = base * self.tets[-1] ** EXPONENT
        ratio = self.tets[-1] / self.tets[-2] if len(self.tets) > 1 else 1.0
        later = [self.tets[-1] * ratio ** k for k in range(1, self.max_levels - level + 1)]
        return now, float(sum(base * t ** EXPONENT for t in later))

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.1f} min"
