"""Sweep item 3: near-incompressible ν, where linear tetrahedra lock, is refused or warned about, with the reason."""

import pytest

from tissuesim import MaterialError, make_solver


@pytest.mark.parametrize("nu", [0.49999, 0.4999, 0.495])
def test_a_locking_poisson_ratio_is_refused_saying_why(small_cube, nu):
    with pytest.raises(MaterialError, match="lock"):
        make_solver("fem", small_cube, poisson_ratio=nu)


def test_a_nearly_incompressible_poisson_ratio_warns_of_locking(small_cube):
    with pytest.warns(UserWarning, match="lock"):
        make_solver("embedded", small_cube, poisson_ratio=0.48)
