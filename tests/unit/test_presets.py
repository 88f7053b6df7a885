"""Material presets: each value within the range its source reports, usable by every solver, and the paper's
material still the default."""

import warnings

import pytest

from tissuesim.errors import MaterialError, TissuesimWarning
from tissuesim.fem.material import LOCKING_WARNING_POISSON_RATIO, Material
from tissuesim.fem.presets import PRESETS, preset, preset_options

TISSUES = ("liver", "kidney", "brain", "muscle", "fat", "skin")


def test_the_six_tissues_are_there():
    assert set(TISSUES) <= set(PRESETS)


@pytest.mark.parametrize("name", TISSUES)
def test_a_preset_lies_in_the_range_its_source_reports(name):
    p = preset(name)
    assert p.low < p.youngs_modulus < p.high
    assert 100.0 <= p.low and p.high <= 1e6          # soft tissue in the small-strain tests cited: kPa, not MPa
    assert 900.0 <= p.density <= 1100.0              # ICRU 44: fat 950 .. skin 1090 kg/m³
    assert p.source and any(char.isdigit() for char in p.source)    # a source with its year and numbers


@pytest.mark.parametrize("name", TISSUES)
def test_a_preset_is_a_material_linear_tetrahedra_take_without_warning(name):
    options = preset_options(name)
    assert options["poisson_ratio"] <= LOCKING_WARNING_POISSON_RATIO
    with warnings.catch_warnings():
        warnings.simplefilter("error", TissuesimWarning)
        Material(youngs_modulus=options["youngs_modulus"], poisson_ratio=options["poisson_ratio"])


def test_an_unknown_preset_names_the_ones_there_are():
    with pytest.raises(MaterialError, match="choose one of liver, kidney, brain, muscle, fat, skin"):
        preset("spleen")


def test_the_default_material_stays_the_papers():
    assert Material().youngs_modulus == 5500.0 and Material().poisson_ratio == 0.3
