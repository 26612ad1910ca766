r"""A certified count of eigenvalues in a box of the complex plane, by winding.

A strip of the sliced verdict (:mod:`~remote_trigger.analysis.stability.sliced`)
that holds real eigenvalues *and* a complex pair is decided by neither of its
real-axis routes. Its Schur complement T(z) (m x m, analytic in z) is defined
off the real axis too: for Re z in the strip the rest of A + F - z is
invertible with the same scaled bound as on the axis (the boundary lemma's
Re <Jv, (J + B' - iy Gamma^-1) v> >= (1 - kappa) ||v||^2 holds for every y),
so det(A + F - z) = det(rest) det T_F(z) there and the eigenvalues of A + F
in a box B = [x_0, x_1] x [y_0, y_1] are the zeros of det T_F in B, with
multiplicity. If y_0 > 0 and that number is at least one, A + F has a
non-real eigenvalue: **complex, certified**.

The number is the winding number of det T_F(z) along the boundary of B. With
T_c(z) the computed complement and err(z) >= ||T_F(z) - T_c(z)||_2 for every
F of the set (the strip's own bound), walk the boundary in segments
[z_a, z_b]. On a segment ||T_F(z) - T_c(z_a)|| <= rho := err(z_a) +
h (||T'_c(z_a)|| + err'(z_a)) + curv h^2 / 2 (h = |z_b - z_a|, curv the
strip's bound of ||T''||). If rho < sigma_min(T_c(z_a)) =: s, then
T_c(z_a)^-1 T_F(z) = I + X(z) with ||X|| < 1 along the segment: det T_F does
not vanish there, every eigenvalue of I + X stays in the disc |w - 1| < 1
(the right half-plane), and the continuous change of arg det T_F over the
segment is sum Arg eig(I + X(z_b)) - sum Arg eig(I + X(z_a)). The computed
phi = sum Arg eig(T_c(z_a)^-1 T_c(z_b)) differs from it by at most
m asin(err(z_a) / s) + m asin(tau), tau = (err(z_b) / s) / (1 - (rho +
err(z_b)) / s)
(the sum of the arguments of the eigenvalues of I + Y, ||Y|| <= t < 1, is
at most m asin(t) in modulus). If the errors summed over the boundary stay
below pi, the winding number is the integer nearest sum(phi) / 2 pi: for
every F of the set. Segments that fail the test are halved.
"""
from __future__ import annotations

import math

import numpy as np

from remote_trigger.analysis.stability.enclosure import sigma_min_lower

__all__ = ["box_zero_count"]

#: most evaluations of the complement (sparse bordered solves) one box may take
MAX_EVALS = 600


def _norm2_upper(D):
    """sqrt(||D||_1 ||D||_inf) >= ||D||_2, inflated for rounding."""
    aD = np.abs(D)
    return math.sqrt(float(aD.sum(axis=0).max()) * float(aD.sum(axis=1).max())) * (1 + 1e-12)


def box_zero_count(schur, x0, x1, y0, y1, curv):
    """Number of zeros of det T_F(z) in the box [x0, x1] x [y0, y1], for every F.

    Parameters
    ----------
    schur : callable
        ``schur(z, deriv=True)`` -> (T_c, err, D_c, derr): the computed
        complement at z, the bound of ||T_F(z) - T_c|| for every F, the
        computed derivative and the bound of its error (``T_c`` None if the
        bordered system is singular).
    x0, x1, y0, y1 : float
        The box (x0 < x1, y0 < y1).
    curv : float
        Bound of ||T''(z)||_2 in the box.

    Returns
    -------
    count : int or None
        The number of zeros (eigenvalues of A + F in the box, with
        multiplicity); None if it could not be certified.
    why : str
        Why not ('' when certified).
    margin : float
        pi over the phase error bound (> 1 when certified; 0 otherwise).
    """
    corners = [complex(x0, y0), complex(x1, y0), complex(x1, y1), complex(x0, y1)]
    cache = {}

    def at(z):
        if z not in cache:
            cache[z] = schur(z, deriv=True)
        return cache[z]

    total, slack = 0.0, 0.0
    for k in range(4):
        todo = [(corners[k], corners[(k + 1) % 4])]
        while todo:
            za, zb = todo.pop()
            if len(cache) > MAX_EVALS:
                return None, (f"winding count: more than {MAX_EVALS} evaluations of T "
                              f"on the box's edge"), 0.0
            Ta, ea, Da, dea = at(za)
            Tb, eb, _, _ = at(zb)
            if Ta is None or Tb is None:
                return None, "winding count: the bordered system is singular on the box", 0.0
            s = sigma_min_lower(Ta, norm="spectral")
            h = abs(zb - za)
            rho = ea + h * (_norm2_upper(Da) + dea) + 0.5 * curv * h * h
            if not (rho + eb < 0.8 * s and ea < 0.25 * s):
                if h < 1e-9 * max(abs(za), 1.0):
                    return None, f"winding count: det T not bounded away from 0 near {za:.6g}", 0.0
                zm = 0.5 * (za + zb)
                todo += [(zm, zb), (za, zm)]     # za..zm first (stack)
                continue
            w = np.linalg.eigvals(np.linalg.solve(Ta, Tb))
            if not np.all(np.abs(w - 1.0) < 1.0):
                return None, "winding count: a step leaves the disc |w - 1| < 1", 0.0
            m = Ta.shape[0]
            tau = (eb / s) / (1.0 - (rho + eb) / s)
            total += float(np.sum(np.angle(w)))
            # the computed T_c(z_a)^-1 T_c(z_b) and its eigenvalues: backward
            # errors of a few u times its condition, far inside this allowance
            cond = float(np.linalg.norm(Ta)) / s
            rnd = 1e3 * m * 2.0 ** -52 * cond * (1.0 + float(np.linalg.norm(Tb)) / s)
            slack += m * (math.asin(min(1.0, ea / s)) + math.asin(min(1.0, tau))) + rnd
    slack *= 1 + 1e-6
    turns = total / (2 * math.pi)
    count = round(turns)
    off = abs(turns - count) * 2 * math.pi
    if not (slack < math.pi and off + slack < math.pi):
        return None, f"winding count: phase error {slack:.3g} too large", 0.0
    return int(count), "", math.pi / max(off + slack, 1e-300)
