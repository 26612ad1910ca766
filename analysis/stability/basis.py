"""The certified decision started from a previous decision's basis (no eigen-solve).

A ramp's next step (``classify_spectrum(A, basis=)``): steps 2-5 of
:mod:`remote_trigger.analysis.stability.exceptional` hold for any
nonsingular X, so the verified basis of a nearby matrix
(:class:`~remote_trigger.analysis.stability.decision.SpectrumBasis`),
corrected to first order, replaces LAPACK's eigenvectors (:func:`from_basis`);
real units that the correction cannot separate become a pair
(:func:`_merge_coupled`).
"""
from __future__ import annotations

import numpy as np

from remote_trigger.analysis.stability.verification import Unit, Verified, verify

_BASIS_CORRECTED = 0.001         # a corrected basis is used once its verified coupling max|W| <= this
_BASIS_ITERATIONS = 3           # ... after at most this many corrections
_BASIS_DIVERGED = 1.0           # a correction |W| above this: give up, start from dgeev
_BASIS_MERGE = 0.5              # |W_ij| above which two real units of a basis become a pair


def from_basis(A, basis, rel_error, input_error, Ap=None):
    """Steps 2-5 from a previous decision's basis, corrected (no eigen-solve).

    With C = R A X (block diagonal up to the change of A since X was
    verified), X <- X (I + W), W_ij = C_ij / (C_jj - C_ii) for i, j in
    different units, removes the off-block part of C to first order. The
    corrected X is enclosed (step 2, R = X^{-1} anew); the enclosure's C gives
    the next W, and the correction is repeated (a Newton-type iteration whose
    |W| fell quadratically on the ramps tried) until the enclosed X's own
    max |W| <= ``_BASIS_CORRECTED``, at most ``_BASIS_ITERATIONS`` times (one
    correction was enough for 293 of the 297 N = 100 ramp steps tried). The
    verification of X is the same rigorous one as for dgeev's vectors (it
    holds for any nonsingular X). Returns (entries, Verified, eigenvalues)
    or None if the basis does not fit (size), the correction diverges or it
    has not converged after ``_BASIS_ITERATIONS`` corrections.
    """
    X, R, blocks = basis.X, basis.R, basis.blocks
    n = A.shape[0]
    if X.shape != (n, n):
        return None
    def layout(blocks):
        unit = np.repeat(np.arange(len(blocks)), [k for _, k in blocks])
        return unit[:, None] == unit[None, :]

    def correction(C0, same):
        d = C0.diagonal()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            W = C0 / (d[None, :] - d[:, None])
        W[same] = 0.0
        return W

    same = layout(blocks)
    C0 = R @ ((A if Ap is None else Ap) @ X)
    ver = None
    for it in range(_BASIS_ITERATIONS + 1):
        W = correction(C0, same)
        if it == 0:
            new = _merge_coupled(W, blocks)
            if new is None:
                return None
            if new is not blocks:       # strongly coupled real units become pairs
                perm = np.concatenate([np.arange(s0, s0 + k) for s0, k in new[1]])
                X, R, C0 = X[:, perm], R[perm], C0[np.ix_(perm, perm)]
                blocks = new[0]
                same = layout(blocks)
                W = correction(C0, same)
        wmax = float(np.abs(W).max()) if W.size else 0.0
        if not wmax <= _BASIS_DIVERGED:          # also NaN / inf
            return None
        if it and wmax <= _BASIS_CORRECTED:      # the verified X's coupling is small
            break
        if it == _BASIS_ITERATIONS:  # not converged: the eigenvalue estimates would be poor
            return None
        X = X + X @ W
        X /= np.sqrt(np.einsum("ij,ij->j", X, X))
        # the enclosure's C = X^-1 A X is the next iteration's C0
        ver = Verified(A, X, blocks, rel_error, input_error, Ap)
        if not ver.ok:
            return None
        C0 = ver.C
    units = [Unit(tuple(range(s0, s0 + k)), merged=k == 2) for s0, k in blocks]
    entries, ver = verify(A, X, blocks, units, [False] * len(blocks), rel_error,
                           input_error, Ap, ver)
    if entries is None or ver.conflicts:
        return None
    # eigenvalues: a unit's diagonal entry of C, plus the second-order
    # coupling sum_j C_ij C_ji / (C_ii - C_jj) (measured on ramps, relative to
    # max |lambda|: dgeev's to 2e-14-4e-11; 1e-13-4e-8 without the coupling
    # term); a pair's 2 x 2 block
    C = ver.C
    d = C.diagonal()
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        T = C * C.T / (d[:, None] - d[None, :])
    T[same] = 0.0
    for s0, k in blocks:            # a pair's coupling through its 2 x 2 resolvent
        if k == 2:
            p, q, r, t = C[s0, s0], C[s0, s0 + 1], C[s0 + 1, s0], C[s0 + 1, s0 + 1]
            a, b = C[:, s0], C[:, s0 + 1]            # C_ic
            e, f = C[s0, :], C[s0 + 1, :]            # C_ci
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                det = (d - p) * (d - t) - q * r
                T[:, s0] = (a * ((d - t) * e + q * f) + b * (r * e + (d - p) * f)) / det
            T[:, s0 + 1] = 0.0
            T[s0:s0 + 2, s0] = 0.0
    lam = (d + T.sum(axis=1)).astype(complex)
    if not np.all(np.isfinite(lam)):
        lam = d.astype(complex)
    for s0, k in blocks:
        if k == 2:
            # the pair's eigenvalues mu with the same second-order coupling:
            # those of C_cc + C_cr (mu I - D_r)^-1 C_rc (two fixed-point sweeps
            # from the block's own eigenvalues); a complex pair stays an exact
            # conjugate pair, a real one real (else the block's own are kept)
            c = slice(s0, s0 + 2)
            own = np.linalg.eigvals(C[c, c]).astype(complex)
            mus = own.copy()
            for h in range(2):
                mu = mus[h]
                for _ in range(2):
                    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                        w = 1.0 / (mu - d)
                    w[c] = 0.0
                    M = C[c, c] + (C[c, :] * w) @ C[:, c]
                    if not np.all(np.isfinite(M)):
                        break
                    ev = np.linalg.eigvals(M)
                    mu = ev[np.argmin(np.abs(ev - mu))]
                mus[h] = mu
            if own.imag.any():
                z = mus[int(np.argmax(mus.imag))]
                mus = np.array([z.conjugate(), z]) if z.imag > 0 else own
            elif mus.imag.any():
                mus = own
            lam[c] = mus
    return entries, ver, lam[np.lexsort((lam.imag, lam.real))]


def _merge_coupled(W, blocks):
    """Pair up the real units that a first-order correction cannot separate.

    Two single units i, j with max(|W_ij|, |W_ji|) > ``_BASIS_MERGE`` (their
    eigenvalues close compared with their coupling: the two sides of an
    exceptional point) become one 2 x 2 unit, decided by step 4. Returns
    ``blocks`` itself if nothing is merged, else (new blocks, the old blocks
    in the new column order); None if a unit is strongly coupled to more than
    one other, or a pair to anything (no 2 x 2 layout separates them).
    """
    strong = np.argwhere(np.maximum(np.abs(W), np.abs(W.T)) > _BASIS_MERGE)
    strong = strong[strong[:, 0] < strong[:, 1]]
    if strong.size == 0:
        return blocks
    start = {s0: b for b, (s0, k) in enumerate(blocks)}
    partner = {}
    for i, j in strong.tolist():
        if i not in start or j not in start or blocks[start[i]][1] != 1 \
                or blocks[start[j]][1] != 1 or i in partner or j in partner:
            return None
        partner[i], partner[j] = j, i
    order, done = [], set()
    for s0, k in blocks:
        if s0 in done:
            continue
        order.append((s0, k))
        if s0 in partner:
            order.append((partner[s0], 1))
            done.add(partner[s0])
    new, col, b = [], 0, 0
    while b < len(order):
        s0, k = order[b]
        if k == 1 and s0 in partner:
            new.append((col, 2))
            col, b = col + 2, b + 2
        else:
            new.append((col, k))
            col, b = col + k, b + 1
    return new, order
