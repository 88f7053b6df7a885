"""Sweep item 1: the pin-head keeps its own copy of the grab point."""

import numpy as np

from tissuesim import PinHead, make_solver


def test_moving_the_callers_cursor_array_does_not_move_the_anchor(small_cube, small_cube_top):
    solver = make_solver("pbd", small_cube)
    pin = PinHead(solver, stiffness=20.0)
    cursor = small_cube.surface.vertices[small_cube_top].copy()
    pin.grab(cursor)
    cursor += [0.0, 0.0, 0.05]          # the caller reuses its array for the next cursor position
    assert np.allclose(pin.drag(cursor), [0.0, 0.0, 1.0])


def test_grabbing_a_live_node_row_does_not_make_the_anchor_follow_the_node(small_cube, small_cube_top):
    solver = make_solver("hybrid", small_cube)
    pin = PinHead(solver, stiffness=20.0)
    pin.grab(solver.positions[small_cube_top])      # a view into the solver's live positions
    anchor = small_cube.surface.vertices[small_cube_top].copy()
    target = anchor + [0.0, 0.0, 0.01]
    for _ in range(100):
        pin.drag(target)
        solver.step()
    assert np.array_equal(pin.anchor, anchor)  # exact: a copy
    assert np.allclose(pin.force(target), [0.0, 0.0, 0.2])
    assert np.all(np.isfinite(solver.positions))
