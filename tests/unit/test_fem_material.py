"""Material: parameter checks and the elastic matrix D of eq (4)."""

import numpy as np
import pytest

from tissuesim.errors import MaterialError
from tissuesim.fem.material import Material


def test_defaults_are_the_papers_tissue():
    m = Material()
    assert (m.youngs_modulus, m.poisson_ratio) == (5500.0, 0.3)


@pytest.mark.parametrize(
    "e, nu, words",
    [
        (5500.0, 0.5, "poisson_ratio"),
        (5500.0, 0.7, "poisson_ratio"),
        (5500.0, -1.0, "poisson_ratio"),
        (0.0, 0.3, "youngs_modulus"),
        (-1.0, 0.3, "youngs_modulus"),
        (float("nan"), 0.3, "finite"),
        (float("inf"), 0.3, "finite"),
        (5500.0, float("nan"), "finite"),
        ("soft", 0.3, "real number"),
    ],
)
def test_refuses_out_of_range_parameters(e, nu, words):
    with pytest.raises(MaterialError, match=words):
        Material(e, nu)


def test_elasticity_matrix_matches_hookes_law():
    m = Material(1000.0, 0.25)
    d = m.elasticity_matrix()
    # Uniaxial stress σ_xx = 1 Pa: strains ε_xx = 1/E, ε_yy = ε_zz = −ν/E give D ε = (1, 0, 0, 0, 0, 0).
    eps = np.array([1.0, -0.25, -0.25, 0, 0, 0]) / 1000.0
    np.testing.assert_allclose(d @ eps, [1, 0, 0, 0, 0, 0], atol=1e-15)
    # Pure shear: τ = G γ.
    assert d[3, 3] == pytest.approx(1000.0 / 2.5)
    assert m.bulk_modulus == pytest.approx(1000.0 / 1.5)
    assert np.all(np.linalg.eigvalsh(d) > 0)
