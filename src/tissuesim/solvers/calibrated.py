"""Frozen calibrated values of the free scalar of each method and form (written by ``tissuesim calibrate --write``).

Calibration case: the cube model (default resolution), 1 N of pressure on the load node, metric eq 26 over the 50
M_S nodes nearest the load node, against the ``fem`` reference; 1-D bounded minimisation. The values are frozen
here (Python constants, so packaging cannot lose them) and used for every model and load. An entry whose RMSE is
NaN was not calibrated (a provisional value; the xpbd forms, see docs/solvers.md).
"""

# method -> form -> (option name, value, calibration RMSE [m], reference RMS displacement [m])
CALIBRATED = {
    'hybrid': {
        'xpbd': ('thickness_ratio', 1.0020630069335938, 0.0023499127960647523, 0.006000020090671506),
        'pbd': ('stiffness', 0.812811518909585, 0.0026255696649983627, 0.006000020090671506),
    },
    'pbd': {
        'xpbd': ('thickness_ratio', 3.9832797808338585, 0.0037242339185013323, 0.006000020090671506),
        'pbd': ('mass_scale', 145.72235084624504, 0.0035012667160415293, 0.006000020090671506),
    },
    'mass-spring': {
        'springs': ('thickness_ratio', 320.7073644682394, 0.0034962758087217017, 0.006000020090671506),
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
