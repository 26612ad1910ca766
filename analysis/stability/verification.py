"""Steps 1-5 of the certified decision for one basis (the proof is the
docstring of :mod:`remote_trigger.analysis.stability.exceptional`).

Step 1: the spectrum cut into units (:func:`split_units`) and each pair's real
basis, refined near an exceptional point (:func:`_pair_basis`). Step 2: the
row enclosure of S = X^{-1} A~ X (:class:`Verified`). Steps 4-5: each
pair's 2 x 2 block, crude and sharp, with its Riccati coupling to the rest
(:class:`_Block`). Step 3: the isolation of neighbouring discs
(:func:`_isolation`). :func:`analyse` builds X from LAPACK's eigenvectors;
:func:`verify` runs steps 2-5 for any nonsingular X (also a previous
decision's basis, :mod:`remote_trigger.analysis.stability.basis`).
"""
from __future__ import annotations

from dataclasses import dataclass
import math
import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from remote_trigger.analysis.stability.decision import PairDecision, SpectrumBasis
from remote_trigger.analysis.stability.enclosure import (
    EPS, TINY, U, cover_radius, disc_test, accurate_residual, frac, gamma, margin, pair_eigs,
    rounded_up, sep_2x2_lower, sigma_min_2x2_lower)

_PARALLEL = 1.0 - 1e-4          # |cos| of two real eigenvectors above which they form a pair
_ILL = 100.0                    # pair basis condition above which the subspace is refined
_SHARP_BELOW = 1e4              # crude margin below which a pair is also computed sharply
_RESIDUAL_CHUNK = 32            # pairs whose sharp residuals are computed in one call


# --------------------------------------------------------------------------- units and bases
@dataclass
class Unit:
    """One unit of the spectrum (step 1): a real eigenvalue alone, or a pair."""

    idx: tuple                 # eigenvalue indices (1 or 2)
    complex_pair: bool = False
    merged: bool = False       # real pair formed because the eigenvectors are parallel


def split_units(lam, V):
    """Split the spectrum into real units and pairs (complex pairs, parallel real pairs)."""
    n = lam.size
    units = []
    nonreal = np.flatnonzero(lam.imag != 0.0).tolist()
    k = 0
    while k < len(nonreal):             # LAPACK stores a complex pair as neighbours
        j = nonreal[k]
        if j + 1 < n and lam[j + 1] == np.conj(lam[j]):
            units.append(Unit((j, j + 1), complex_pair=True))
            k += 2
            continue
        raise ValueError("eigenvalue solver returned an unpaired complex eigenvalue")
    reals = np.flatnonzero(lam.imag == 0.0)
    reals = reals[np.argsort(lam.real[reals], kind="stable")]
    # |cos| of the angle between the eigenvectors of sorted neighbours (one
    # array operation; only compared with _PARALLEL)
    Vr = V[:, reals].real
    nrm = np.sqrt(np.einsum("ij,ij->j", Vr, Vr))
    parallel = (np.abs(np.einsum("ij,ij->j", Vr[:, :-1], Vr[:, 1:]))
                / (nrm[:-1] * nrm[1:]) > _PARALLEL).tolist()
    reals = reals.tolist()
    k = 0
    while k < len(reals):
        if k + 1 < len(reals) and parallel[k]:
            units.append(Unit((reals[k], reals[k + 1]), merged=True))
            k += 2
            continue
        units.append(Unit((reals[k],)))
        k += 1
    return units


class SparseCopy(sp.csr_matrix):
    """A CSR copy of a dense A (the same float64 entries, for the products A X)
    that also gives A - sigma I in CSC form for the refinement's sparse LUs
    (:meth:`shifted`), the positions of its diagonal found once."""

    def shifted(self, sigma):
        """A - sigma I as a CSC matrix: the same entries and structure as
        ``csc_matrix(A - sigma * identity)`` (a diagonal entry that becomes
        exactly 0 is dropped, as that difference drops it)."""
        n = self.shape[0]
        t = self.__dict__.get("_shift_template")
        if t is None:
            C = sp.csc_matrix(self)
            C.sort_indices()
            cols = np.repeat(np.arange(n), np.diff(C.indptr))
            pos = np.nonzero(C.indices == cols)[0]
            t = (C, pos, C.data[pos].copy()) if pos.size == n else (None, None, None)
            self._shift_template = t
        C, pos, diag = t
        new = None if C is None else diag - sigma
        if new is None or not np.all(new != 0):
            return sp.csc_matrix(sp.csr_matrix(self) - sigma * sp.identity(n, format="csr"))
        M = C.copy()
        M.data[pos] = new
        return M


def _refine(A, sigma, Q, iters=4, Ap=None):
    """Orthonormal basis of the 2-dimensional invariant subspace nearest sigma.

    Subspace iteration with (A - sigma I)^{-1} from Q; returns Q unchanged if
    the shifted matrix cannot be factorised or the iteration breaks down.
    ``Ap``: A's sparse copy (:class:`SparseCopy`), factorised by a sparse LU
    (SuperLU) instead of the dense one (O(n^3) per pair: most of the
    decision's time where many pairs are refined, as in a spectrum of
    near-double eigenvalues). Only a proposal: the basis is verified
    afterwards (step 2).
    """
    n = A.shape[0]
    solve = None
    for _ in range(3):
        if Ap is not None:
            import scipy.sparse.linalg as spla

            try:
                # A's pattern is symmetric (K's): a minimum-degree ordering of
                # A + A^T, diagonal pivots preferred (half the time of COLAMD's
                # LU at 837 dofs; the basis is only a proposal, verified below)
                lu = spla.splu(Ap.shifted(sigma), permc_spec="MMD_AT_PLUS_A",
                               diag_pivot_thresh=0.01, options=dict(SymmetricMode=True))
                if np.all(lu.U.diagonal() != 0):
                    solve = lu.solve
                    break
            except RuntimeError:            # exactly singular
                pass
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                lu, piv = sla.lu_factor(A - sigma * np.eye(n), check_finite=False)
            if np.all(np.diag(lu) != 0):
                solve = lambda W, f=(lu, piv): sla.lu_solve(f, W, check_finite=False)  # noqa: E731
                break
        sigma = sigma * (1 + 64 * EPS) + 64 * TINY
    if solve is None:
        return Q
    W = Q
    for _ in range(iters):
        Y = solve(W)
        if not np.all(np.isfinite(Y)):
            return Q
        W, _ = np.linalg.qr(Y)
    return W


def _pair_basis(A, lam, V, unit, Ap=None, floor=None):
    """Real orthonormal basis (n x 2) of a pair's invariant subspace (refined near an EP).

    A merged or ill-conditioned pair is refined (:func:`_refine`) unless its
    orthonormalised eigenvector basis Q already spans an invariant subspace
    to ``floor`` (||A Q - Q Q^T A Q||_F <= ``floor``, n u ||A||_F from
    :func:`analyse`: the rounding of the product itself, which no refinement
    goes below): the near-double pairs of an almost normal A (a periodic or
    ordered packing at F_x = 0), where the refinement's sparse LUs were most
    of the decision's time. Either basis is only a proposal: step 2 verifies
    it, and it is marked for the sharp check (True) as a refined one."""
    i, j = unit.idx
    if unit.complex_pair:
        V0 = np.column_stack([V[:, i].real, V[:, i].imag])
    else:
        V0 = np.column_stack([V[:, i].real, V[:, j].real])
    V0 = V0 / np.maximum(np.linalg.norm(V0, axis=0), TINY)
    sv = np.linalg.svd(V0, compute_uv=False)
    Q, _ = np.linalg.qr(V0)
    cond = sv[0] / sv[1] if sv[1] > 0 else math.inf
    if unit.merged or cond > _ILL:
        if floor is not None:
            AQ = (A if Ap is None else Ap) @ Q
            if float(np.linalg.norm(AQ - Q @ (Q.T @ AQ))) <= floor:
                return Q, True
        sigma = 0.5 * (lam[i].real + lam[j].real)
        return _refine(A, sigma, Q, Ap=Ap), True
    return Q, False


# --------------------------------------------------------------------------- verification
class Verified:
    """Enclosure of S = X^{-1} A~ X, row by row (step 2 of the proof)."""

    def __init__(self, A, X, blocks, rel_error, input_error, Ap=None):
        n = A.shape[0]
        self.n = n
        self.ok = False
        self.reason = ""
        g = gamma(n + 2)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                R = np.linalg.inv(X)
            except np.linalg.LinAlgError:
                self.reason = "eigenvector basis is singular"
                return
        if not np.all(np.isfinite(R)):
            self.reason = "eigenvector basis is singular"
            return
        aA, aX, aR = np.abs(A), np.abs(X), np.abs(R)
        G = (A if Ap is None else Ap) @ X
        C = R @ G
        H = R @ X
        xs = aX.sum(axis=1)
        axs = aA @ xs
        raxs = aR @ axs
        rgs = aR @ np.abs(G).sum(axis=1)
        rxs = aR @ xs
        Fh = H
        Fh[np.diag_indices(n)] -= 1.0
        f = rounded_up(np.abs(Fh).sum(axis=1) + g * rxs, n)
        fmax = float(f.max())
        if not fmax < 0.5:
            self.reason = f"eigenvector basis too ill-conditioned (||R X - I|| = {fmax:.2g})"
            return
        e1 = g * (rgs + raxs)
        absC = np.abs(C)
        nrax = rounded_up(float((absC.sum(axis=1) + e1).max()), n)
        dev = e1 + f * (nrax / (1.0 - fmax))
        ynorm_inf = rounded_up(float(aR.sum(axis=1).max()), n) / (1.0 - fmax)
        if rel_error > 0:
            w = rel_error * raxs
            dev = dev + w + f * (float(w.max()) / (1.0 - fmax))
        if input_error > 0:
            Rn = np.linalg.norm(R, axis=1)
            Yn = Rn + f * (float(Rn.max()) / (1.0 - fmax))
            dev = dev + Yn * input_error * float(np.linalg.norm(X, axis=0).sum())
        self.dev = rounded_up(dev, n)
        one = [s for s, k in blocks if k == 1]
        absC[one, one] = 0.0
        for s, k in blocks:
            if k > 1:
                absC[s:s + k, s:s + k] = 0.0
        self.off = rounded_up(absC.sum(axis=1), n)       # row sums outside the own block
        self.absC = absC
        self.C, self.R, self.f, self.fmax = C, R, f, fmax
        self.ynorm_inf = ynorm_inf
        self.raxs = raxs
        self.ok = True

    def crude_block(self, s):
        """Centre (float) and entrywise radius of S_cc from the row enclosure."""
        S = self.C[s:s + 2, s:s + 2].copy()
        d = self.dev[s:s + 2]
        return S, np.column_stack([d, d])

    def sharp_residuals(self, A, X, starts):
        """The accurate residuals r = A Q - Q M~ of the pairs at ``starts`` (Q =
        X[:, s:s + 2], M~ = C[s:s + 2, s:s + 2]), ``_RESIDUAL_CHUNK`` pairs per
        call (each column the bits of its pair's own call); a dict s -> (r, its
        bound), for :meth:`sharp_block`."""
        starts, out = list(starts), {}
        for c0 in range(0, len(starts), _RESIDUAL_CHUNK):
            chunk = starts[c0:c0 + _RESIDUAL_CHUNK]
            cols = np.ravel([[s, s + 1] for s in chunk])
            blocks = np.stack([self.C[s:s + 2, s:s + 2] for s in chunk])
            r, er = accurate_residual(A, X[:, cols], blocks)
            out.update({s: (r[:, 2 * j:2 * j + 2], er[:, 2 * j:2 * j + 2])
                        for j, s in enumerate(chunk)})
        return out

    def sharp_block(self, A, Q, s, rel_error, input_error, residual=None):
        """S_cc = M~ + Y_c r with the accurate residual r = A Q - Q M~ (step 4);
        ``residual``: (r, its bound) if already computed (:meth:`sharp_residuals`)."""
        n = self.n
        Mt = self.C[s:s + 2, s:s + 2].copy()
        r, er = accurate_residual(A, Q, Mt) if residual is None else residual
        Rc = self.R[s:s + 2]
        aRc = np.abs(Rc)
        t = Rc @ r
        rad = gamma(n + 2) * (aRc @ np.abs(r)) + aRc @ er
        # Y_c = R_c - (F Y)_c:  |(F Y r)_ik| <= f_i ||Y||_inf ||r_k + er_k||_inf
        rcol = (np.abs(r) + er).max(axis=0)
        rad = rad + np.outer(self.f[s:s + 2], self.ynorm_inf * rcol)
        if rel_error > 0:
            aAQ = abs(A) @ np.abs(Q)        # (A dense, or its sparse copy)
            rad = rad + rel_error * (aRc @ aAQ
                                     + np.outer(self.f[s:s + 2], self.ynorm_inf
                                                * aAQ.max(axis=0)))
        if input_error > 0:
            yc = float(np.linalg.norm(Rc)) + math.sqrt(2.0 * n) * float(self.f[s:s + 2].max()) \
                * self.ynorm_inf
            rad = rad + yc * input_error * float(np.linalg.norm(Q))
        Sf = frac(Mt)
        Tf = frac(t)
        S = [[Sf[a][b] + Tf[a][b] for b in range(2)] for a in range(2)]
        return S, rounded_up(rad, n)


@dataclass
class _Block:
    """What the decision of one pair c needs from the rest of S (step 4)."""

    rest: bool                 # the matrix has more than the pair
    gam: float                 # >= ||S_rc||_F
    eta: float                 # >= ||S_cr||_F
    err_rr: float              # >= ||S_rr - blockdiag||_F
    r_c: float                 # block Gershgorin radius of the pair's rows
    lam1: np.ndarray           # centres of the real units
    others: np.ndarray         # centres (p, 2, 2) of the other pairs

    def decide(self, S, rad, sharp):
        """PairDecision and cover radius for centre S (Fractions) and radius rad (2 x 2)."""
        Sfl = np.array([[float(S[0][0]), float(S[0][1])], [float(S[1][0]), float(S[1][1])]])
        rad = rad + U * np.abs(Sfl)          # float copy of the exact centre
        D0 = ((S[0][0] - S[1][1]) / 2) ** 2 + S[0][1] * S[1][0]
        if not np.all(np.isfinite(rad)):
            return PairDecision(pair_eigs(S), D0 < 0, False, 0.0, float(D0), eta=math.inf,
                                reason="no finite bound on the block", sharp=sharp), math.inf
        radn = rounded_up(float(np.linalg.norm(rad)), 4)
        sep = math.inf
        if self.lam1.size:
            sep = float(sigma_min_2x2_lower(self.lam1 - Sfl[0, 0], -Sfl[1, 0], -Sfl[0, 1],
                                             self.lam1 - Sfl[1, 1]).min())
        sep = min(sep, sep_2x2_lower(Sfl, self.others))
        delta = sep - self.err_rr - radn
        ric = 0.0
        if self.rest:
            if not (delta > 0 and 4.0 * self.gam * self.eta < delta * delta * (1 - 8 * U)):
                return PairDecision(
                    pair_eigs(S), D0 < 0, False, 0.0, float(D0), sep=float(sep), eta=radn,
                    reason=f"pair not separated from the rest: sep >= {sep:.3g}, coupling "
                           f"{self.gam:.3g} x {self.eta:.3g}", sharp=sharp), math.inf
            ric = rounded_up(2.0 * self.gam * self.eta / delta, 4)
        D, bound = disc_test(S, rad + ric)
        cert = abs(D) > bound
        dec = PairDecision(pair_eigs(S), D < 0, bool(cert), margin(D, bound), float(D),
                           float(bound), rounded_up(radn + 2 * ric, 4),
                           float(delta if self.rest else math.inf), None, "riccati-2x2",
                           "" if cert else "discriminant within its error bound", sharp)
        # eig(M_c) lies in the block region only if the coupling term is below r_c
        cover = math.inf if ric > self.r_c else cover_radius(S, self.r_c + radn)
        return dec, cover


def analyse(A, lam, V, units, rel_error, input_error, Ap=None):
    """One verification pass over the given units. Returns (entries, summary data)."""
    n = A.shape[0]
    # column layout: units sorted by the real part of their eigenvalues
    lr = lam.real.tolist()
    key = [lr[un.idx[0]] if len(un.idx) == 1 else (lr[un.idx[0]] + lr[un.idx[1]]) / 2
           for un in units]
    order = sorted(range(len(units)), key=key.__getitem__)
    units = [units[k] for k in order]
    blocks, refined, single = [], [], []
    s = 0
    for un in units:
        k = len(un.idx)
        blocks.append((s, k))
        if k == 1:
            single.append((s, un.idx[0]))
        s += k
    X = np.empty((n, s))
    if single:
        at, idx = (np.array(c) for c in zip(*single))
        Vs = V[:, idx].real
        X[:, at] = Vs / np.sqrt(np.einsum("ij,ij->j", Vs, Vs))
    floor = n * U * float(np.linalg.norm(A))
    for un, (s, k) in zip(units, blocks):
        if k == 2:
            X[:, s:s + 2], ref = _pair_basis(A, lam, V, un, Ap, floor)
        refined.append(k == 2 and ref)
    return verify(A, X, blocks, units, refined, rel_error, input_error, Ap)


def verify(A, X, blocks, units, refined, rel_error, input_error, Ap=None, ver=None):
    """Steps 2-5 for the basis X (units' columns at ``blocks``): (entries, Verified).

    ``Ap``: A in a form for the product A X (a sparse copy; None: A). ``ver``:
    the step-2 enclosure of this X and ``blocks`` if already made."""
    n = A.shape[0]
    if ver is None:
        ver = Verified(A, X, blocks, rel_error, input_error, Ap)
    if not ver.ok:
        return None, ver
    ver.basis = SpectrumBasis(X, ver.R, blocks)
    dev, off, C = ver.dev, ver.off, ver.C
    one = np.array([b for b, (s, k) in enumerate(blocks) if k == 1], dtype=np.intp)
    s_one = np.array([blocks[b][0] for b in one.tolist()], dtype=np.intp)
    lam1 = C[s_one, s_one]
    offdev = off + dev
    # discs (centre, radius, block index): the real units', then the pairs'
    discs = [lam1.tolist(), offdev[s_one].tolist(), one.tolist()]
    pending = []                     # (block, start, _Block, crude decision, cover, centre)
    pair_out = []
    pair_start = np.array([s for s, k in blocks if k == 2], dtype=np.intp)
    pair_blocks = np.empty((pair_start.size, 2, 2))
    for j, d in ((0, 0), (0, 1), (1, 0), (1, 1)):
        pair_blocks[:, j, d] = C[pair_start + j, pair_start + d]
    for b, (s, k) in enumerate(blocks):
        if k == 1:
            continue
        c = [s, s + 1]
        rest = np.ones(n, bool)
        rest[c] = False
        blk = _Block(
            rest=bool(rest.any()),
            gam=rounded_up(math.sqrt(float(np.sum((ver.absC[:, c].sum(axis=1)[rest]
                                            + dev[rest]) ** 2))), n),
            eta=rounded_up(math.sqrt(float(np.sum(offdev[c] ** 2))), 2),
            err_rr=rounded_up(math.sqrt(float(np.sum(offdev[rest] ** 2))), n),
            r_c=rounded_up(float(offdev[c].sum()), 4),
            lam1=lam1,
            others=pair_blocks[pair_start != s])
        S0 = frac(ver.crude_block(s)[0])
        dec, cover = blk.decide(S0, ver.crude_block(s)[1], False)
        pending.append((b, s, blk, dec, cover, S0))
    # sharp enclosure: the pair nearest an exceptional point (smallest crude
    # margin), refined pairs, and every pair the crude enclosure leaves unsure
    crit = min(range(len(pending)), key=lambda q: pending[q][3].margin) if pending else -1
    sharp = [q == crit or refined[b] or not dec.certified or dec.margin < _SHARP_BELOW
             for q, (b, s, blk, dec, cover, S) in enumerate(pending)]
    try:
        resid = ver.sharp_residuals(A if Ap is None else Ap, X,
                                    [pending[q][1] for q in range(len(pending)) if sharp[q]])
    except ValueError:          # (an entry too large to split: no sharp block)
        resid = None
    for q, (b, s, blk, dec, cover, S) in enumerate(pending):
        if sharp[q]:
            Sx = None
            if resid is not None:
                try:
                    Sx, radx = ver.sharp_block(A if Ap is None else Ap, X[:, s:s + 2], s,
                                               rel_error, input_error, resid[s])
                except ValueError:
                    Sx = None
            if Sx is not None:
                dec2, cover2 = blk.decide(Sx, radx, True)
                if dec2.certified or not dec.certified:
                    dec, cover, S = dec2, cover2, Sx
        centre = float((S[0][0] + S[1][1]) / 2)
        for lst, v in zip(discs, (centre, cover + U * abs(centre), b)):
            lst.append(v)
        pair_out.append(dec)
    iso, ver.conflicts = _isolation(discs, blocks, units)
    return pair_out + iso, ver


def _isolation(discs, blocks, units):
    """Isolation of neighbouring discs (all centred on the real axis).

    ``discs`` holds three lists: centres, radii and block indices. Returns
    the PairDecision of each neighbouring pair of discs and the eigenvalue
    index pairs of two real units whose discs overlap.
    """
    c, r, b = (np.asarray(v) for v in discs)
    order = np.argsort(c, kind="stable")
    c, r, b = c[order], r[order], b[order].tolist()
    gap = (c[1:] - c[:-1]) * (1 - 2 * U)
    rr = (r[:-1] + r[1:]) * (1 + 2 * U)
    pos = rr > 0
    m = np.full(gap.shape, math.inf)
    m[pos] = gap[pos] / rr[pos]
    ok = (gap > rr).tolist()
    c, m, rr = c.tolist(), m.tolist(), rr.tolist()
    iso = [PairDecision(np.array([c[k], c[k + 1]], complex), False, ok[k], m[k],
                        method="gershgorin", reason="" if ok[k] else "discs overlap",
                        bound=rr[k])
           for k in range(len(ok))]
    conflicts = [(units[b[k]].idx[0], units[b[k + 1]].idx[0]) for k in range(len(ok))
                 if not ok[k] and blocks[b[k]][1] == 1 and blocks[b[k + 1]][1] == 1]
    return iso, conflicts
