import subprocess
import sys

import tissuesim


def test_every_public_name_resolves():
    for name in tissuesim.__all__:
        assert getattr(tissuesim, name) is not None, name


def test_import_stays_light():
    """``import tissuesim`` must not pull in Numba or the solvers: they load on first use."""
    code = "import sys, tissuesim; print(any(m in sys.modules for m in ('numba', 'tissuesim.solvers', 'scipy')))"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"
