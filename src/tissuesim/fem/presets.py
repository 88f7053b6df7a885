"""Material presets for common soft tissues: Young's modulus, Poisson's ratio and density, each with its source.

    options = preset_options("liver")   # {"youngs_modulus": 4100.0, "poisson_ratio": 0.45, "density": 1060.0}
    solver = make_solver("hybrid", hybrid, **options)

The default material stays the paper's (E = 5.5 kPa, ν = 0.3, :mod:`tissuesim.fem.material`); a preset is chosen.

Choices (``docs/materials.md`` gives the table with the sources and the ranges they report):

* E is the small-strain modulus a source reports as its central value (a mean over subjects or samples), and
  ``low``..``high`` the spread it reports (mean ± one standard deviation, or a reference range where it gives one).
  Soft-tissue moduli depend on the test (indentation, tension, shear-wave elastography), the strain, the rate and
  the species by an order of magnitude or more: a preset is a plausible value of one kind of measurement, not the
  tissue's constant. Shear-wave elastography reports E = 3 ρ c_s², which assumes incompressibility.
* ν = 0.45 for every tissue. Tissue is nearly incompressible (ν close to 0.5), but linear tetrahedra lock as ν → 0.5
  (:data:`tissuesim.fem.material.LOCKING_WARNING_POISSON_RATIO`): 0.45 is the highest ν they take without a
  warning, and they are then about 0.8 of elasticity's compliance (the measurement in :mod:`tissuesim.fem.material`).
* Densities are those of ICRU Report 44 (1989), *Tissue substitutes in radiation dosimetry and measurement*.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import MaterialError

#: Poisson's ratio of every preset (see the module's docstring).
PRESET_POISSON_RATIO = 0.45


@dataclass(frozen=True)
class Preset:
    """One tissue's material.

    Attributes:
        name: the tissue, e.g. ``"liver"``.
        youngs_modulus: E [Pa], the source's central value.
        poisson_ratio: ν [-].
        density: ρ [kg/m³] (ICRU Report 44).
        low, high: the spread of E the source reports [Pa].
        source: the literature source of E, and how it measured.
    """

    name: str
    youngs_modulus: float
    poisson_ratio: float
    density: float
    low: float
    high: float
    source: str

    def options(self) -> dict[str, float]:
        """The solver options of this material: ``youngs_modulus`` [Pa], ``poisson_ratio`` [-], ``density`` [kg/m³]."""
        return {"youngs_modulus": self.youngs_modulus, "poisson_ratio": self.poisson_ratio, "density": self.density}


PRESETS: dict[str, Preset] = {p.name: p for p in (
    Preset("liver", 4100.0, PRESET_POISSON_RATIO, 1060.0, 2300.0, 5900.0,
           "Fung et al. 2013, PLoS ONE 8(12):e85067: transient elastography of 530 healthy livers in vivo, "
           "mean 4.1 kPa, reference range 2.3-5.9 kPa"),
    Preset("kidney", 5000.0, PRESET_POISSON_RATIO, 1050.0, 2100.0, 7900.0,
           "Arda et al. 2011, AJR Am J Roentgenol 197(3):532-536: shear-wave elastography of 127 healthy "
           "volunteers, renal cortex 5.0 +/- 2.9 kPa"),
    Preset("brain", 1400.0, PRESET_POISSON_RATIO, 1040.0, 1100.0, 2500.0,
           "Budday et al. 2015, J Mech Behav Biomed Mater 46:318-330: flat-punch indentation of bovine brain, "
           "gray matter 1.39 +/- 0.29 kPa, white matter 1.90 +/- 0.59 kPa"),
    Preset("muscle", 11100.0, PRESET_POISSON_RATIO, 1050.0, 7000.0, 15200.0,
           "Arda et al. 2011, AJR Am J Roentgenol 197(3):532-536: shear-wave elastography of 127 healthy "
           "volunteers, gastrocnemius 11.1 +/- 4.1 kPa (masseter 10.4 +/- 3.7 kPa)"),
    Preset("fat", 3250.0, PRESET_POISSON_RATIO, 950.0, 2340.0, 4160.0,
           "Samani et al. 2007, Phys Med Biol 52(6):1565-1576: indentation of 169 fresh ex vivo breast samples, "
           "normal fat 3.25 +/- 0.91 kPa at small strain"),
    Preset("skin", 56300.0, PRESET_POISSON_RATIO, 1090.0, 39900.0, 72700.0,
           "In vivo measurement of breast tissues stiffness using a light aspiration device (pilot study, 7 "
           "volunteers): skin 56.3 +/- 16.4 kPa; tensile tests ex vivo report MPa (McKee et al. 2011, Tissue Eng "
           "Part B 17(3):155-164)"),
)}


def preset(name: str) -> Preset:
    """The :class:`Preset` of tissue ``name`` (one of :data:`PRESETS`), or a MaterialError listing them."""
    if not isinstance(name, str) or name not in PRESETS:
        raise MaterialError(f"unknown material preset {name!r}; choose one of {', '.join(PRESETS)}, or give "
                            "youngs_modulus [Pa], poisson_ratio and density [kg/m³]")
    return PRESETS[name]


def preset_options(name: str) -> dict[str, float]:
    """The solver options ``youngs_modulus`` [Pa], ``poisson_ratio`` [-] and ``density`` [kg/m³] of tissue
    ``name``."""
    return preset(name).options()
