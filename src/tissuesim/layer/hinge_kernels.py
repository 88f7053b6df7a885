"""Numba closed forms of one hinge (P1, P2 | P3, P4): eq 10's bending angle θ, the signed angle β, and the gradient
of each per node, without eq 12's division by sinθ.

The step kernels (:mod:`tissuesim.layer.kernels`), the linearised statics (:mod:`tissuesim.layer.static`), the rest
measures and the finite-strain layer all read a hinge through these functions, so they agree to the last bit. Each
is inlined into its caller (``inline="always"``): it returns its numbers as a tuple, which then costs nothing.
Numba's on-disk cache of a caller is keyed by the caller's own file, so after an edit here its compiled callers are
stale: ``make clean-numba`` removes the caches.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Same thresholds as the reference (tissuesim.layer.constraints).
TINY_LENGTH = 1e-300
TINY_SINE = 1e-12


@njit(cache=True, inline="always")
def _hinge_vectors(x, i1, i2, i3, i4):
    """``(a, b, c)`` = P2 − P1, P3 − P1, P4 − P1 of hinge (P1, P2 | P3, P4) of ``x``, as 9 floats."""
    ox = x[i1, 0]
    oy = x[i1, 1]
    oz = x[i1, 2]
    px2 = x[i2, 0]
    py2 = x[i2, 1]
    pz2 = x[i2, 2]
    px3 = x[i3, 0]
    py3 = x[i3, 1]
    pz3 = x[i3, 2]
    px4 = x[i4, 0]
    py4 = x[i4, 1]
    pz4 = x[i4, 2]
    return px2 - ox, py2 - oy, pz2 - oz, px3 - ox, py3 - oy, pz3 - oz, px4 - ox, py4 - oy, pz4 - oz


@njit(cache=True, inline="always")
def _lever_rule(ta, tb, g3x, g3y, g3z, g4x, g4y, g4z):
    """``(∇_1, ∇_2)`` as 6 floats from ∇_3, ∇_4 and the projections ``ta`` = b·a/|a|², ``tb`` = c·a/|a|²:
    ∇_2 = −ta ∇_3 − tb ∇_4 (the lever rule), ∇_1 = −∇_2 − ∇_3 − ∇_4 (the angle does not change under translation)."""
    g2x = -ta * g3x - tb * g4x
    g2y = -ta * g3y - tb * g4y
    g2z = -ta * g3z - tb * g4z
    return -g2x - g3x - g4x, -g2y - g3y - g4y, -g2z - g3z - g4z, g2x, g2y, g2z


@njit(cache=True, inline="always")
def bend_gradient(
    x: np.ndarray, i1: int, i2: int, i3: int, i4: int,
) -> tuple[bool, float, float, float, float, float, float, float, float, float, float, float, float, float, float]:
    """Eq 10's θ on hinge (P1, P2 | P3, P4) of ``x`` and its gradient ∇θ per node, in closed form.

    Returns ``(valid, θ, |P2 − P1|, ∇_1θ, ∇_2θ, ∇_3θ, ∇_4θ)`` (each gradient as 3 floats); ``valid`` is False for a
    degenerate hinge (the caller skips it). See :func:`tissuesim.layer.kernels._project_bend` for the expressions.
    """
    ax, ay, az, bx, by, bz, cx, cy, cz = _hinge_vectors(x, i1, i2, i3, i4)
    # n1 ∥ a×b, n2 ∥ a×c
    c1x = ay * bz - az * by
    c1y = az * bx - ax * bz
    c1z = ax * by - ay * bx
    c2x = ay * cz - az * cy
    c2y = az * cx - ax * cz
    c2z = ax * cy - ay * cx
    det = c1x * cx + c1y * cy + c1z * cz
    length2 = ax * ax + ay * ay + az * az
    length = math.sqrt(length2)
    theta = math.atan2(length * abs(det), c1x * c2x + c1y * c2y + c1z * c2z)
    l1sq = c1x * c1x + c1y * c1y + c1z * c1z
    l2sq = c2x * c2x + c2y * c2y + c2z * c2z
    # Degenerate: |a×b| or |a×c| ≤ TINY_LENGTH (squared, TINY_LENGTH² underflows to 0: the same test), or
    # sinθ = |a| |det| / (|a×b| |a×c|) ≤ TINY_SINE (squared, no root).
    if (l1sq <= TINY_LENGTH * TINY_LENGTH or l2sq <= TINY_LENGTH * TINY_LENGTH
            or length2 * (det * det) <= (TINY_SINE * TINY_SINE) * (l1sq * l2sq)):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    f3 = -math.copysign(length, det) / l1sq
    f4 = math.copysign(length, det) / l2sq
    g3x = f3 * c1x
    g3y = f3 * c1y
    g3z = f3 * c1z
    g4x = f4 * c2x
    g4y = f4 * c2y
    g4z = f4 * c2z
    inv_length2 = 1.0 / length2
    ta = (bx * ax + by * ay + bz * az) * inv_length2
    tb = (cx * ax + cy * ay + cz * az) * inv_length2
    g1x, g1y, g1z, g2x, g2y, g2z = _lever_rule(ta, tb, g3x, g3y, g3z, g4x, g4y, g4z)
    return True, theta, length, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z


@njit(cache=True, inline="always")
def bend_gradient_signed(
    x: np.ndarray, i1: int, i2: int, i3: int, i4: int,
) -> tuple[bool, float, float, float, float, float, float, float, float, float, float, float, float, float]:
    """The signed angle β on hinge (P1, P2 | P3, P4) of ``x`` and its gradient per node, in closed form.

    Returns ``(valid, β, ∇_1β, ∇_2β, ∇_3β, ∇_4β)`` (each gradient as 3 floats); ``valid`` is False for a degenerate
    hinge. See :func:`tissuesim.layer.kernels._project_bend_signed`.
    """
    ax, ay, az, bx, by, bz, cx, cy, cz = _hinge_vectors(x, i1, i2, i3, i4)
    # N_A = a×b, N_B = c×a (outward normals of (P1, P2, P3) and (P2, P1, P4))
    nax = ay * bz - az * by
    nay = az * bx - ax * bz
    naz = ax * by - ay * bx
    nbx = cy * az - cz * ay
    nby = cz * ax - cx * az
    nbz = cx * ay - cy * ax
    la2 = nax * nax + nay * nay + naz * naz
    lb2 = nbx * nbx + nby * nby + nbz * nbz
    length2 = ax * ax + ay * ay + az * az
    if la2 <= TINY_LENGTH or lb2 <= TINY_LENGTH or length2 <= TINY_LENGTH:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    length = math.sqrt(length2)
    # β = atan2((N_A × N_B)·a/|a|, N_A·N_B)
    crx = nay * nbz - naz * nby
    cry = naz * nbx - nax * nbz
    crz = nax * nby - nay * nbx
    beta = math.atan2((crx * ax + cry * ay + crz * az) / length, nax * nbx + nay * nby + naz * nbz)
    fa = -length / la2
    fb = -length / lb2
    g3x = fa * nax
    g3y = fa * nay
    g3z = fa * naz
    g4x = fb * nbx
    g4y = fb * nby
    g4z = fb * nbz
    ta = (bx * ax + by * ay + bz * az) / length2
    tb = (cx * ax + cy * ay + cz * az) / length2
    g1x, g1y, g1z, g2x, g2y, g2z = _lever_rule(ta, tb, g3x, g3y, g3z, g4x, g4y, g4z)
    return True, beta, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z
