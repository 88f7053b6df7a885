"""A haptic servo process's device must travel to the process it runs in: one that cannot be pickled is refused
where it is given, with a message that says so and why, and nothing is left running."""

import multiprocessing
import threading

import pytest

from tissuesim import make_solver
from tissuesim.errors import SolverError
from tissuesim.haptics import HapticProcess

STIFFNESS = 200.0   # N/m


class LockedDevice:
    """A callable device holding a lock, which no pickle carries to another process."""

    def __init__(self):
        self.lock = threading.Lock()

    def __call__(self):
        return (lambda: [0.0, 0.0, 0.0]), (lambda force: None)


def _local_device():
    def device():
        return (lambda: [0.0, 0.0, 0.0]), (lambda force: None)
    return device


@pytest.fixture(scope="module")
def solver(small_cube):
    return make_solver("hybrid", small_cube)


@pytest.mark.parametrize("device", [lambda: None, _local_device(), LockedDevice()],
                         ids=["lambda", "local-function", "holding-a-lock"])
def test_a_device_that_cannot_be_pickled_is_refused_where_it_is_given(solver, device):
    before = set(multiprocessing.active_children())
    with pytest.raises(SolverError) as error:
        HapticProcess(solver, device=device, stiffness=STIFFNESS)
    message = str(error.value)
    assert "the haptic device must be picklable" in message and "its own process" in message
    assert "module-level function or class" in message
    assert set(multiprocessing.active_children()) == before


def test_a_device_made_unpicklable_after_construction_is_refused_before_the_process_starts(solver):
    loop = HapticProcess(solver, device=_PlainDevice(), stiffness=STIFFNESS)
    loop.device.lock = threading.Lock()
    before = set(multiprocessing.active_children())
    with pytest.raises(SolverError, match="the haptic device must be picklable"):
        loop.start()
    assert not loop.running and loop.ticks == 0
    assert set(multiprocessing.active_children()) == before


class _PlainDevice:
    def __call__(self):
        return (lambda: [0.0, 0.0, 0.0]), (lambda force: None)
