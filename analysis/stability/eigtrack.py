r"""Follow the pair of eigenvalues that coalesces at F_x^c through a ramp (Fig. 3).

The ramp (``ramp.h5``, docs/driver.md) stores the spectrum of M^-1 K at every
equilibrium: ramp steps, bisection points and, in the paper job, a short
continuation above F_x^c (read by ``pywrap.ramp_file.read_spectra``).
:func:`track_pair` identifies the pair that is
born at F_x^c and follows it down and up the load:

1. **Birth.** At the first unstable load of the bracket (the smallest F_x
   with a complex pair) the pair with the largest |Im lambda| is taken
   (at the end of a bisection it is the only pair, born within ``tol``).
2. **Ancestors.** At the last stable load, its two real ancestors are the
   two eigenvalues closest to Re lambda of the pair.
3. **Down the ramp** each tracked real eigenvalue is matched to the
   eigenvalue of the next lower load that is nearest to it (the two matches
   distinct). Real eigenvalues of a one-parameter family of real matrices
   cannot cross without coalescing, so nearest-neighbour matching with
   steps much smaller than the level spacing keeps their identity; the
   matching distance relative to the local level spacing is recorded
   (``ambiguity``) so that a doubtful track is visible.
4. **Up the ramp** the complex pair is matched the same way (lambda with
   Im > 0 and its conjugate).

.. math::

   \lambda_{a,b}(F_x) = \lambda_c \mp c_-\sqrt{F_x^c - F_x}\quad (F_x < F_x^c),
   \qquad
   \lambda_\pm = \lambda_c \pm i\,c_+\sqrt{F_x - F_x^c}\quad (F_x > F_x^c)

near an exceptional point; the figure shows exactly these two branches.
"""
from dataclasses import dataclass
import math

import numpy as np

from remote_trigger.analysis.stability.decision import Decision


@dataclass
class PairTrack:
    """The coalescing pair along the ramp.

    Attributes
    ----------
    F_x : ndarray, shape (n,)
        Loads, increasing.
    lam_a, lam_b : ndarray of complex, shape (n,)
        The two tracked eigenvalues: below F_x^c real with Re a < Re b;
        above, lam_b = conj(lam_a) with Im lam_b > 0.
    complex_pair : ndarray of bool, shape (n,)
        True where the tracked pair is complex.
    rank : int
        Position of the lower ancestor in the ascending spectrum at the last
        stable load (0 = softest).
    n_modes : int
        Size of the spectrum there.
    lam_c : float
        Re lambda of the pair at its birth.
    ambiguity : float
        Largest ratio, over all matches, of the matching distance to the
        distance of the second-best candidate (< 1; close to 1 means the
        identity of the track is doubtful).
    """

    F_x: np.ndarray
    lam_a: np.ndarray
    lam_b: np.ndarray
    complex_pair: np.ndarray
    rank: int
    n_modes: int
    lam_c: float
    ambiguity: float


def complex_mask(lam, rtol=1e-10):
    """Eigenvalues with |Im| above rtol * max|lambda| (the ramp's criterion)."""
    lam = np.asarray(lam, complex)
    if lam.size == 0:
        return np.zeros(0, bool)
    return np.abs(lam.imag) > rtol * float(np.max(np.abs(lam)))


def _nearest_two(values, targets):
    """Indices of distinct nearest matches of two targets; returns (idx, ambiguity)."""
    best, best_cost = None, np.inf
    d0 = np.abs(values - targets[0])
    d1 = np.abs(values - targets[1])
    c0 = np.argsort(d0)[:3]
    c1 = np.argsort(d1)[:3]
    for i in c0:
        for j in c1:
            if i != j and d0[i] + d1[j] < best_cost:
                best, best_cost = (int(i), int(j)), d0[i] + d1[j]
    amb = 0.0
    for k, (d, idx) in enumerate(((d0, best[0]), (d1, best[1]))):
        others = np.delete(d, list(best))
        if others.size:
            amb = max(amb, float(d[idx] / max(np.min(others), 1e-300)))
    return best, amb


def track_pair(points, rtol=1e-10):
    """Track the coalescing pair through a set of equilibria.

    Parameters
    ----------
    points : sequence of (float, ndarray, Decision)
        (F_x, eigenvalues, decision) of every equilibrium, in any order;
        ``decision`` is the ramp's certified
        :class:`~remote_trigger.analysis.stability.decision.Decision`:
        COMPLEX, REAL or UNDECIDED (too close to the exceptional point for
        the certified test; such points are skipped, since their computed
        eigenvalues are not reliable there). Points with an empty spectrum
        are ignored.
    rtol : float
        Relative threshold on |Im lambda| for the "complex" flag of the
        tracked pair above F_x^c.

    Returns
    -------
    PairTrack or None
        None if no point has a complex pair or no point below it is real.

    Raises
    ------
    ValueError
        If ``points`` holds no spectrum at all, or a point is not a triple
        whose decision is a Decision (a label such as ``'complex'`` or a
        bool is refused, not read as one: ``Decision.of`` converts a stored
        code or label).
    """
    points = list(points)
    for i, p in enumerate(points):
        if not (isinstance(p, (tuple, list)) and len(p) == 3):
            raise ValueError(f"track_pair: point {i} must be (F_x, eigenvalues, decision), "
                             f"got {p!r:.80}")
        if not isinstance(p[2], Decision):
            raise ValueError(f"track_pair: the decision of point {i} (F_x = {p[0]!r}) must be "
                             f"a Decision, got {p[2]!r}")
    pts, cplx = [], []
    for F, lam, dec in sorted(points, key=lambda p: float(p[0])):
        lam = np.asarray(lam, complex)
        if lam.size and dec is not Decision.UNDECIDED:
            pts.append((float(F), lam))
            cplx.append(dec is Decision.COMPLEX)
    if not pts:
        raise ValueError("track_pair needs at least one spectrum, got none")
    if not any(cplx):
        return None
    first = cplx.index(True)
    if first == 0:
        return None
    # birth: the pair with the largest |Im| at the first unstable load
    F_hi, lam_hi = pts[first]
    cand = lam_hi[lam_hi.imag > 0]
    if cand.size == 0:
        return None
    born = cand[np.argmax(cand.imag)]
    # ancestors at the last stable load
    F_lo, lam_lo = pts[first - 1]
    re = lam_lo.real
    (ia, ib), amb = _nearest_two(re, np.array([born.real, born.real]))
    a, b = sorted((re[ia], re[ib]))
    rank = int(np.searchsorted(np.sort(re), a))
    out = {F_hi: (np.conj(born), born, True), F_lo: (complex(a), complex(b), False)}
    # down the ramp
    cur = np.array([a, b])
    for F, lam in reversed(pts[:first - 1]):
        (i, j), am = _nearest_two(lam.real, cur)
        amb = max(amb, am)
        cur = np.sort(lam.real[[i, j]])
        out[F] = (complex(cur[0]), complex(cur[1]), False)
    # up the ramp
    cur_c = born
    for F, lam in pts[first + 1:]:
        mask = complex_mask(lam, rtol)
        up = np.flatnonzero(lam.imag >= 0)
        d = np.abs(lam[up] - cur_c)
        order = np.argsort(d)
        if d.size > 1:
            amb = max(amb, float(d[order[0]] / max(d[order[1]], 1e-300)))
        k = int(up[order[0]])
        cur_c = lam[k]
        out[F] = (np.conj(cur_c), cur_c, bool(mask[k]))
    Fs = np.array(sorted(out))
    la = np.array([out[F][0] for F in Fs], complex)
    lb = np.array([out[F][1] for F in Fs], complex)
    cp = np.array([out[F][2] for F in Fs], bool)
    return PairTrack(F_x=Fs, lam_a=la, lam_b=lb, complex_pair=cp, rank=rank,
                     n_modes=int(lam_lo.size), lam_c=float(born.real), ambiguity=float(amb))


def predict_coalescence(F_prev, lam_prev, F, lam):
    r"""Load distance to the nearest coalescence of two neighbouring real eigenvalues.

    Near an exceptional point the gap of the coalescing pair closes like
    :math:`g \propto \sqrt{F_x^c - F_x}`, so :math:`g^2` is linear in F_x.
    For every pair of neighbouring eigenvalues (sorted by real part) whose
    gap shrinks from ``F_prev`` to ``F``, :math:`g^2` is extrapolated
    linearly to zero,

    .. math::

        d = g^2(F) \, \frac{F - F_\mathrm{prev}}{g^2(F_\mathrm{prev}) - g^2(F)},

    and the smallest d is returned. The extrapolation is exact for the
    square-root law and underestimates the distance for a gap closing like
    :math:`(F_x^c - F_x)^p` with p > 1/2 (d = (F_x^c - F_x) / (2p)); it cannot
    foresee a coalescence caused by a contact event between the two loads.
    Used by the adaptive ramp (``pywrap.ramp``) to choose its next step.

    Parameters
    ----------
    F_prev, F : float
        Two loads, ``F > F_prev``.
    lam_prev, lam : array_like of complex, shape (n,)
        Eigenvalues of M^-1 K at the two loads (any order).

    Returns
    -------
    distance : float
        Predicted F_x^c - F, >= 0; 0 if a computed eigenvalue is already
        complex (its real-part gap is 0), ``inf`` if no gap is closing.
    index : int
        Position of the closing pair's lower eigenvalue in the sorted
        spectrum at ``F`` (-1 if none).

    Raises
    ------
    ValueError
        If ``F <= F_prev`` or the two spectra have different sizes (a
        contact or rattler change: the neighbours cannot be matched).
    """
    if not F > F_prev:
        raise ValueError(f"need F > F_prev, got F = {F!r}, F_prev = {F_prev!r}")
    e0 = np.sort(np.asarray(lam_prev, complex).real)
    e1 = np.sort(np.asarray(lam, complex).real)
    if e0.size != e1.size:
        raise ValueError(f"spectra of different sizes ({e0.size} and {e1.size}): the "
                         f"neighbours cannot be matched")
    if e1.size < 2:
        return math.inf, -1
    g0, g1 = np.diff(e0) ** 2, np.diff(e1) ** 2
    closing = g1 < g0
    if not np.any(closing):
        return math.inf, -1
    d = np.full(g1.size, np.inf)
    d[closing] = g1[closing] * (F - F_prev) / (g0[closing] - g1[closing])
    i = int(np.argmin(d))
    return float(d[i]), i


def sqrt_law(F_x, lam_a, lam_b, F_lo, F_hi, rel_span=0.05, min_points=3):
    """Exponents of the gap closing and of Im lambda opening at an exceptional point.

    Near a generic exceptional point at F_c the two coalescing eigenvalues
    obey lambda_b - lambda_a ~ sqrt(F_c - F) below F_c (real, a gap that
    closes) and Im lambda ~ sqrt(F - F_c) above it (paper Sec. III.C.2, the
    normal form's A ~ eps^-1/2). This fits both exponents by least squares
    in log-log, with F_c the midpoint of the certified bracket [F_lo, F_hi].

    Parameters
    ----------
    F_x : array_like, shape (n,)
        Loads of the tracked pair.
    lam_a, lam_b : array_like of complex, shape (n,)
        The pair (below F_c real, Re a < Re b; above, lam_b = conj(lam_a)
        with Im lam_b > 0), e.g. a :class:`PairTrack`.
    F_lo, F_hi : float
        Certified bracket of F_c (real at F_lo, complex at F_hi).
    rel_span : float
        Points with 10 (F_hi - F_lo) <= |F - F_c| <= rel_span F_c are used
        (distances comparable to the bracket's width are not resolved).
    min_points : int
        Fewer points on a side give NaN for that side.

    Returns
    -------
    dict
        ``below`` and ``above``: exponent (NaN if too few points),
        ``n_below``, ``n_above``, ``range_below``, ``range_above``
        ((min, max) of |F - F_c| used).
    """
    F = np.asarray(F_x, float)
    a = np.asarray(lam_a, complex)
    b = np.asarray(lam_b, complex)
    Fc = 0.5 * (F_lo + F_hi)
    dmin, dmax = 10.0 * (F_hi - F_lo), rel_span * abs(Fc)
    out = {}
    for side, sel, y in (("below", F <= F_lo, np.abs(b - a)),
                         ("above", F >= F_hi, np.abs(b.imag))):
        d = np.abs(F - Fc)
        m = sel & (d >= dmin) & (d <= dmax) & (y > 0)
        out[f"n_{side}"] = int(m.sum())
        if m.sum() < min_points:
            out[side] = float("nan")
            out[f"range_{side}"] = (float("nan"), float("nan"))
            continue
        p = np.polyfit(np.log(d[m]), np.log(y[m]), 1)
        out[side] = float(p[0])
        out[f"range_{side}"] = (float(d[m].min()), float(d[m].max()))
    return out
