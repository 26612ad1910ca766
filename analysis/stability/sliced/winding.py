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

The number is the winding number of det T_F(z) along the boundary of B,
walked through nodes z_0, z_1, ..., z_K = z_0. T_c(z) is the computed
complement, err(z) >= ||T_F(z) - T_c(z)||_2 for every F of the set (the
strip's own bound) and s(z) <= sigma_min(T_c(z)). On the ball ||M - I||_2 < 1
every eigenvalue of M lies in the disc |w - 1| < 1, in the right half-plane,
so L(M) = sum Arg eig(M) (principal arguments) is continuous there and
congruent to arg det M modulo 2 pi: L is a continuous branch of arg det on
the ball.

*One segment* [z_a, z_b]. Along it ||T_F(z) - T_c(z_a)|| <= rho :=
err(z_a) + h (||T'_c(z_a)|| + err'(z_a)) + curv h^2 / 2 (h = |z_b - z_a|,
curv the strip's bound of ||T''||). If rho < s(z_a), X(z) = T_c(z_a)^-1
T_F(z) stays in the ball on the segment: det T_F does not vanish there, and
its change of arg is L(R) - L(Q_a), R = X(z_b), Q_a = X(z_a). With P =
T_c(z_a)^-1 T_c(z_b) (what is computed; ||P - I|| <= q_P = (rho + err_b) /
s_a) and Q_b = T_c(z_b)^-1 T_F(z_b) = I + E (||E|| <= q_Q = err_b / s_b),
R = P Q_b. If q_P + (1 + q_P) q_Q < 1, every P (I + t E), 0 <= t <= 1, is in
the ball, so L(P (I + t E)) - L(P) - L(I + t E) is continuous in t, a
multiple of 2 pi, and 0 at t = 0: *L(R) = L(P) + L(Q_b) exactly*. (Segments
are halved until q_P < 0.8 and q_P + (1 + q_P) q_Q < 0.9.)

*The loop*. The change of arg over segment k is then L(P_k) + d_{k+1} - d_k,
with d_k = L(Q_k) a number of the node z_k alone (the same T_c(z_k), kept,
and the same T_F(z_k) whichever segment it ends or starts). Summed around
the closed boundary the d_k cancel: 2 pi x (winding number) = sum_k L(P_k)
exactly, and the only error of the computed sum is the rounding of each
L(P_k) (a few u times the condition of the small solve and its
eigenvalues, bounded generously). The count is the integer nearest sum /
2 pi when that rounding is below pi. The error bounds err(z) enter only
per segment, as ratios to sigma_min, with no factor m and no sum over the
segments: a box walked in hundreds of segments is counted as surely as one
walked in four. A node whose own ratio err / s leaves no segment from it
passable (2 q + (1 + 2 q) q >= 0.9 with q = err / s: q >= 0.26) ends
the count at once (no answer).

*Non-normal T.* det(W T(z) V) = det(W) det(V) det T(z) for fixed W, V, so
the count on W T V is the count on T; its error bounds are ||W|| ||V||
times T's plus the rounding of the products. Near a pair's exceptional
point sigma_min(T(z)) is about the product of the distances from z to the
pair's two members, and a walk on T needs segments shorter than that; with
V the eigenvectors of T at the box's centre (W its computed inverse)
sigma_min(W T V) is about the distance itself. A walk on T that gives no
count is made once more so.
"""
from __future__ import annotations

import math

import numpy as np

from remote_trigger.analysis.stability.enclosure import gamma, sigma_min_lower

__all__ = ["box_zero_count"]

#: most evaluations of the complement one box may take, by default (each a
#: sparse bordered solve on the bordered route: 600 are minutes at n ~ 2e4)
MAX_EVALS = 600

#: a segment's bounds: q_P below the first, q_P + (1 + q_P) q_Q below the
#: second (module docstring: below 1 the identity holds; the rest is margin)
Q_P_MAX, Q_SUM_MAX = 0.8, 0.9


def _norm2_upper(D):
    """sqrt(||D||_1 ||D||_inf) >= ||D||_2, inflated for rounding."""
    aD = np.abs(D)
    return math.sqrt(float(aD.sum(axis=0).max()) * float(aD.sum(axis=1).max())) * (1 + 1e-12)


def box_zero_count(schur, x0, x1, y0, y1, curv, max_evals=MAX_EVALS):
    """Number of zeros of det T_F(z) in the box [x0, x1] x [y0, y1], for every F.

    The box's edge is walked once on T itself and, if that gives no count, once
    more on W T(z) V (V the eigenvectors of T at the box's centre, W its
    computed inverse: the same determinant up to the constant det(W V), so the
    same count), whose norms near a non-normal T (a pair near its exceptional
    point) see the distance to the zeros rather than its square.

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
    max_evals : int, optional
        Most evaluations of ``schur`` one walk of the edge may take (no count
        beyond). A segment is passable once it is shorter than about
        (0.6 - 2 err / s) s / ||T'||, s = sigma_min(T) at its start: near a
        pair close to its exceptional point s is about the product of the
        distances to the pair's members, and a box may need thousands.

    Returns
    -------
    count : int or None
        The number of zeros (eigenvalues of A + F in the box, with
        multiplicity); None if it could not be certified.
    why : str
        Why not ('' when certified; both walks' reasons when neither counts).
    margin : float
        pi over the bound of the error of the summed phase (its distance to
        the nearest multiple of 2 pi plus the rounding bound; > 1 when
        certified, 0 otherwise).

    Notes
    -----
    The proof is the module docstring's: per segment the computed phase is
    exact up to the nodes' own errors, and around the loop those cancel. On
    W T V the error bounds are ||W|| ||V|| times T's plus the rounding of the
    two products (4 gamma_{m+2} ||W||_F ||X||_F ||V||_F for X = T, T'), the
    curvature bound ||W|| ||V|| times T's; a singular W or V would make every
    node fail its sigma_min test, so none is assumed nonsingular.
    """
    cache = {}

    def raw(z):
        if z not in cache:
            cache[z] = schur(z, deriv=True)
        return cache[z]

    corners = [complex(x0, y0), complex(x1, y0), complex(x1, y1), complex(x0, y1)]
    count, why, margin = _walk(raw, corners, curv, None, max_evals)
    if count is not None:
        return count, why, margin
    Tm = raw(complex(0.5 * (x0 + x1), 0.5 * (y0 + y1)))[0]
    if Tm is None or not np.all(np.isfinite(Tm)):
        return None, why, 0.0
    try:
        _, V = np.linalg.eig(Tm)
        W = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return None, why, 0.0
    if not (np.all(np.isfinite(V)) and np.all(np.isfinite(W))):
        return None, why, 0.0
    count, why2, margin = _walk(raw, corners, curv, (W, V), max_evals)
    if count is not None:
        return count, why2, margin
    why2 = why2[len("winding count: "):]
    return None, f"{why}; on T's eigenvector basis at the box's centre: {why2}", 0.0


def _walk(raw, corners, curv, similarity, max_evals):
    """One walk of the box's edge (corners counter-clockwise) on T, or on W T V
    with ``similarity`` = (W, V), in at most ``max_evals`` evaluations: (count
    or None, why, margin)."""
    if similarity is not None:
        W, V = similarity
        nWV = _norm2_upper(W) * _norm2_upper(V)
        fWV = float(np.linalg.norm(W)) * float(np.linalg.norm(V))
        curv = curv * nWV
    cache, seen = {}, set()

    def at(z):
        seen.add(z)
        if z not in cache:
            T, e, D, de = raw(z)
            if T is not None and similarity is not None:
                g = 4 * gamma(T.shape[0] + 2)
                e = e * nWV + g * fWV * float(np.linalg.norm(T))
                de = de * nWV + g * fWV * float(np.linalg.norm(D))
                T, D = W @ T @ V, W @ D @ V
            s = sigma_min_lower(T, norm="spectral") if T is not None else 0.0
            cache[z] = (T, e, D, de, s)
        return cache[z]

    total, rounding = 0.0, 0.0
    for k in range(4):
        todo = [(corners[k], corners[(k + 1) % 4])]
        while todo:
            za, zb = todo.pop()
            if len(seen) > max_evals:
                return None, (f"winding count: more than {max_evals} evaluations of T "
                              f"on the box's edge"), 0.0
            Ta, ea, Da, dea, sa = at(za)
            Tb, eb, _, _, sb = at(zb)
            if Ta is None or Tb is None:
                return None, "winding count: the bordered system is singular on the box", 0.0
            m = Ta.shape[0]
            q0 = ea / sa if sa > 0 else math.inf
            if not (2 * q0 < Q_P_MAX and 2 * q0 + (1 + 2 * q0) * q0 < Q_SUM_MAX):
                return None, (f"winding count: the error bound is {q0:.3g} of sigma_min(T) "
                              f"at {za:.6g}"), 0.0
            h = abs(zb - za)
            rho = ea + h * (_norm2_upper(Da) + dea) + 0.5 * curv * h * h
            qP = (rho + eb) / sa
            qQ = eb / sb if sb > 0 else math.inf
            if not (qP < Q_P_MAX and qP + (1 + qP) * qQ < Q_SUM_MAX):
                if h < 1e-9 * max(abs(za), 1.0):
                    return None, f"winding count: det T not bounded away from 0 near {za:.6g}", 0.0
                zm = 0.5 * (za + zb)
                todo += [(zm, zb), (za, zm)]     # za..zm first (stack)
                continue
            w = np.linalg.eigvals(np.linalg.solve(Ta, Tb))
            if not np.all(np.abs(w - 1.0) < 1.0):
                return None, "winding count: a step leaves the disc |w - 1| < 1", 0.0
            total += float(np.sum(np.angle(w)))
            # the computed T_c(z_a)^-1 T_c(z_b) and its eigenvalues: backward
            # errors of a few u times its condition, far inside this allowance
            cond = float(np.linalg.norm(Ta)) / sa
            rounding += 1e3 * m * 2.0 ** -52 * cond * (1.0 + float(np.linalg.norm(Tb)) / sa)
    rounding *= 1 + 1e-6
    turns = total / (2 * math.pi)
    count = round(turns)
    off = abs(turns - count) * 2 * math.pi
    if not off + rounding < math.pi:
        return None, (f"winding count: the summed phase {total:.6g} is {off:.3g} from a "
                      f"multiple of 2 pi (rounding bound {rounding:.3g})"), 0.0
    return int(count), "", math.pi / max(off + rounding, 1e-300)
