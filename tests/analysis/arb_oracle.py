"""Independent rigorous checks of complex-pair decisions with Arb (python-flint).

Nothing here uses the analyzer's decision code: the checks are interval
computations in Arb's ball arithmetic (Johansson, IEEE Trans. Comput. 66
(2017) 1281) on the same float64 matrix, optionally with every entry
widened to the set of reals that round to it (radius rel |A_ij|).

* :func:`verify_eigenpair` -- Krawczyk / Rump existence test for one
  eigenpair near a float approximation (Rump, BIT 41 (2001) 133): if it
  succeeds, every matrix of the ball has exactly one eigenvalue in the
  returned enclosure (with eigenvector normalised at one component).
* :func:`pair_is` -- 'complex' if an eigenvalue with Im != 0 is verified for
  the pair, 'real' if its two eigenvalues are verified real and distinct,
  None if neither could be verified.
* :func:`full_spectrum` -- Arb's ``acb_mat.eig`` on the whole matrix (small
  matrices only: seconds at n = 40, about a minute at n = 280).
* :func:`discriminant_2x2` -- exact rational discriminant of a 2 x 2 float
  matrix.
"""
from fractions import Fraction

import numpy as np

from flint import acb, acb_mat, arb, arb_mat, ctx   # python-flint, a test extra

PREC = 128


def discriminant_2x2(J):
    """((j11 - j22)/2)^2 + j12 j21 of a float 2 x 2 matrix, exactly (Fraction)."""
    a, b, c, d = (Fraction(float(x)) for x in np.asarray(J, float).ravel())
    return ((a - d) / 2) ** 2 + b * c


def _ball_matrix(A, rel, cplx):
    n = A.shape[0]
    vals = []
    for x in A.ravel().tolist():
        vals.append(arb(x, abs(x) * rel) if (rel and x) else arb(x))
    M = arb_mat(n, n, vals)
    return acb_mat(M) if cplx else M


def verify_eigenpair(A, lam, x, rel=0.0, Aball=None):
    """Enclose an eigenvalue of every matrix in the ball A (+- rel |A|) near (lam, x).

    Parameters
    ----------
    A : ndarray, shape (n, n), float64
    lam : complex
        Approximate eigenvalue (real arithmetic if its imaginary part is 0).
    x : ndarray, shape (n,)
        Approximate eigenvector.
    rel : float
        Relative entrywise radius of the input balls.
    Aball : arb_mat or acb_mat, optional
        The ball matrix, if already built.

    Returns
    -------
    (centre, radius) : (complex, float) or None
        lam_true in the disc |z - centre| <= radius (real interval if real),
        or None if the test failed.
    """
    old = ctx.prec
    ctx.prec = PREC
    try:
        n = A.shape[0]
        cplx = complex(lam).imag != 0.0
        x = np.asarray(x, complex if cplx else float)
        k = int(np.argmax(np.abs(x)))
        x = x / x[k]
        lam = complex(lam) if cplx else float(np.real(lam))
        Ab = Aball if Aball is not None else _ball_matrix(A, rel, cplx)
        V = acb_mat if cplx else arb_mat
        S = acb if cplx else arb
        xb = V(n, 1, [S(v) for v in x.tolist()])
        lb = S(lam)
        r = Ab * xb - xb * lb                                    # A x - lam x
        Gm = A.astype(complex if cplx else float) - lam * np.eye(n)
        Gm[:, k] = -x
        R = np.linalg.inv(Gm)
        Rb = V(n, n, [S(v) for v in R.ravel().tolist()])
        G = Ab - V(n, n, [S(lam) if i == j else S(0) for i in range(n) for j in range(n)])
        for i in range(n):
            G[i, k] = S(-x[i])
        C = V(n, n, [S(1) if i == j else S(0) for i in range(n) for j in range(n)]) - Rb * G
        z = -(Rb * r)
        zabs = np.array([float(z[i, 0].abs_upper() if cplx else abs(z[i, 0]).upper())
                         for i in range(n)])
        delta = 4.0 * zabs + 1e-300
        for _ in range(6):
            Y = V(n, 1, [S(0) + (acb(arb(0, d), arb(0, d)) if cplx else arb(0, d))
                         for d in delta.tolist()])
            Yhat = V(n, 1, [Y[i, 0] if i != k else S(0) for i in range(n)])
            f = z + C * Y + Rb * (Yhat * Y[k, 0])
            fabs = np.array([float(f[i, 0].abs_upper() if cplx else abs(f[i, 0]).upper())
                             for i in range(n)])
            if np.all(fabs < delta):
                return lam, float(delta[k]) * (np.sqrt(2.0) if cplx else 1.0)
            delta = np.maximum(2.0 * fabs, delta * 2.0)
        return None
    finally:
        ctx.prec = old


def pair_is(A, pair, rel=0.0):
    """Rigorous pair-local answer for the two eigenvalues of A nearest ``pair``.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    pair : sequence of two complex
        Approximate eigenvalues of the pair (e.g. from LAPACK).
    rel : float
        Relative entrywise radius of the input balls (2^-53: every matrix
        that rounds to A).

    Returns
    -------
    'complex', 'real' or None
    """
    lam, V = np.linalg.eig(A)
    idx = [int(np.argmin(np.abs(lam - p))) for p in pair]
    l0 = lam[idx[0]]
    if abs(l0.imag) > 0:
        j = idx[0] if l0.imag > 0 else idx[1]
        enc = verify_eigenpair(A, lam[j], V[:, j], rel)
        if enc is not None and enc[1] < abs(complex(enc[0]).imag):
            return "complex"
        return None
    if idx[0] == idx[1]:
        return None
    encs = [verify_eigenpair(A, lam[j].real, V[:, j].real, rel) for j in idx]
    if any(e is None for e in encs):
        return None
    (c1, r1), (c2, r2) = encs
    return "real" if abs(c1 - c2) > r1 + r2 else None


def full_spectrum(A, rel=0.0, prec=PREC):
    """Arb's enclosure of every eigenvalue; 'complex', 'real' or None.

    'complex': some enclosure excludes the real axis. 'real': the
    enclosures are pairwise disjoint and each meets only its own mirror
    image (so each holds one eigenvalue equal to its conjugate). None:
    eigenvalues not isolated at this precision.
    """
    old = ctx.prec
    ctx.prec = prec
    try:
        E = _ball_matrix(A, rel, True).eig(nonstop=True)
    finally:
        ctx.prec = old
    mids = np.array([complex(float(e.real.mid()), float(e.imag.mid())) for e in E])
    rads = np.array([float(abs(e - acb(complex(m))).upper()) for e, m in zip(E, mids)])
    if not np.all(np.isfinite(rads)) or not np.all(np.isfinite(mids)):
        return None
    if np.any(np.abs(mids.imag) > rads):
        return "complex"
    for i in range(mids.size):
        for j in range(mids.size):
            if i != j and abs(np.conj(mids[i]) - mids[j]) <= rads[i] + rads[j]:
                return None
            if i != j and abs(mids[i] - mids[j]) <= rads[i] + rads[j]:
                return None
    return "real"
