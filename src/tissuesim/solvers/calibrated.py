"""Frozen calibrated values of the free scalar of each method and form (written by ``tissuesim calibrate --write``).

Calibration case: the cube model (default resolution), 1 N of pressure on the load node, metric eq 26 over the 50
M_S nodes nearest the load node, against the ``fem`` reference; 1-D bounded minimisation. The values are frozen
here (Python constants, so packaging cannot lose them) and used for every model and load. An entry whose RMSE is
NaN was not calibrated (a provisional value; the xpbd forms, see docs/solvers.md).
"""

# method -> form -> (option name, value, calibration RMSE [m], reference RMS displacement [m])
CALIBRATED = {
    'hybrid': {
        'xpbd': ('thickness_ratio', 1.0441388350867442, 0.0021418311069962555, 0.005736974807995306),
        'pbd': ('stiffness', 0.7846353417495806, 0.0029940996196070524, 0.006356496460080796),
    },
    'pbd': {
        'xpbd': ('thickness_ratio', 4.030807175417886, 0.0034312340793708393, 0.005736974807995306),
        'pbd': ('mass_scale', 142.98011876119094, 0.0040085301029780755, 0.006356496460080796),
    },
    'mass-spring': {
        'springs': ('thickness_ratio', 343.3938967688446, 0.0032083885913306628, 0.005736974807995306),
    },
}

MASS_SPRING_THICKNESS = CALIBRATED["mass-spring"]["springs"][1]


def value(method: str, form: str) -> float:
    """The calibrated free scalar of ``method`` in ``form``."""
    return CALIBRATED[method][form][1]


def option(method: str, form: str) -> tuple[str, float]:
    """``(option name, calibrated value)`` of ``method`` in ``form``."""
    name, number = CALIBRATED[method][form][:2]
    return name, number
