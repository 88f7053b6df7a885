"""A device-agnostic haptic loop (docs/haptics.md): a servo thread turns the tool position into a force at 1 kHz
from the grabbed region's 3×3 compliance and a virtual coupling spring, while the visual loop steps the full solver
at its own rate and syncs the force into it.

    loop = HapticLoop(solver, position=device.position, apply_force=device.set_force, stiffness=200.0, radius=0.004)
    loop.grab()                 # the node nearest the tool (read here: no tick yet); four static solves
    with loop:                  # the servo thread runs inside the block
        while running:
            loop.sync()         # the latest force becomes the solver's load
            solver.step()       # the visual loop, e.g. 60 Hz

``tool="grasper"`` holds the patch within ``radius`` in a :class:`~tissuesim.Grasper`'s jaws instead: ``sync()``
settles the jaws where the coupling puts them.
"""

from .coupling import HapticStatistics
from .loop import HapticLoop
from .process import HapticProcess
from .response import LocalResponse, local_response

__all__ = ["HapticLoop", "HapticProcess", "HapticStatistics", "LocalResponse", "local_response"]
