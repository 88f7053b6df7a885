"""Frozen calibrated values of the free scalar of each method and form (written by ``tissuesim calibrate --write``).

Calibration case: the cube model (default resolution), 1 N of pressure on the load node, metric eq 26 over the 50
M_S nodes nearest the load node, against the ``fem`` reference; 1-D bounded minimisation. The values are frozen
here (Python constants, so packaging cannot lose them) and used for every model and load.
"""

# method -> form -> (option name, value, calibration RMSE [m], reference RMS displacement [m])
CALIBRATED = {
    "hybrid": {
        "xpbd": ("thickness", 0.002, float("nan"), float("nan")),
        "pbd": ("stiffness", 0.5, float("nan"), float("nan")),
    },
    "pbd": {
        "xpbd": ("thickness", 0.005, float("nan"), float("nan")),
        "pbd": ("stiffness", 0.5, float("nan"), float("nan")),
    },
    "mass-spring": {
        "springs": ("thickness", 0.005, float("nan"), float("nan")),
    },
}

MASS_SPRING_THICKNESS = CALIBRATED["mass-spring"]["springs"][1]


def value(method: str, form: str) -> float:
    """The calibrated free scalar of ``method`` in ``form``."""
    return CALIBRATED[method][form][1]
