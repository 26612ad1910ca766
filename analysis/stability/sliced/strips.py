"""The strips of the sliced verdict: the coupling across an interval and the
decision of a strip of m >= 2 eigenvalues from its Schur complement.

:class:`StripContext` holds what every boundary and strip test uses (the
scaled matrix, its skew part, their norms and error bounds);
:func:`coupling` bounds kappa across an interval (a boundary is certified
where kappa < 1); :func:`decide_strip` decides a strip between two certified
boundaries, first by :func:`decide_deflated` (one sparse LU per piece of
the strip, :class:`DeflatedComplement`), then by the routes of a sparse LU
per evaluation; :func:`arpack_hint` says what ARPACK sees in a strip left
undecided (a note, not certified). The proof: the module docstring of
:mod:`remote_trigger.analysis.stability.sliced` (*Boundary lemma*,
*Strips* and *Deflated strips*); the winding count of a box off the real
axis: :mod:`.winding`.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np
import scipy.sparse as sp
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from remote_trigger.analysis.stability.decision import Decision, SpectrumDecision
from remote_trigger.analysis.stability.enclosure import (
    U, gamma, sigma_min_lower, sigma_min_lower_many)
from remote_trigger.analysis.stability.sliced.inertia import norm1, norm2_skew
from remote_trigger.analysis.stability.sliced.numerics import INFLATE, SliceFailure
from remote_trigger.analysis.stability.sliced.slices import top_eigenvalue
from remote_trigger.analysis.stability.sliced.winding import MAX_EVALS, box_zero_count

__all__ = ["StripContext", "coupling", "decide_strip", "decide_deflated", "DeflatedComplement",
           "arpack_hint", "strips_decision", "unresolved", "poly_budget"]


def _norm22(x11, x12, x22):
    """2-norm of the symmetric 2 x 2 matrix of block norms."""
    m = 0.5 * (x11 + x22)
    return (m + math.sqrt(0.25 * (x11 - x22) ** 2 + x12 * x12)) * INFLATE


@dataclass(frozen=True, kw_only=True)
class StripContext:
    """What every boundary and strip test of a scan uses (built by :meth:`of`).

    Attributes
    ----------
    A : scipy.sparse.csr_matrix, shape (n, n)
        A = M^-1/2 K M^-1/2.
    W : scipy.sparse.csr_matrix, shape (n, n)
        Its skew part (A - A^T) / 2.
    normW : float
        Rigorous upper bound of ||W||_2.
    normS : float
        Upper bound of ||S||_1 >= ||S||_2 (S the symmetric part).
    normA1 : float
        Upper bound of ||A||_2, from ||A||_1 and ||A||_inf.
    eps : float
        Bound of ||F||_2 for every F of the set (|F| <= rel_error |A|) plus
        the rounding of the scaling.
    Delta : float
        Half-width of the explicit window about a boundary (``window``
        ||W||_2; 1e-3 max(||S||_1, 1) if W = 0).
    rnd : float
        Rounding of the products with W (absolute, 2-norm, per vector).
    """

    A: object
    W: object
    normW: float
    normS: float
    normA1: float
    eps: float
    Delta: float
    rnd: float

    @classmethod
    def of(cls, A, S, W, rel_error, window):
        """The context of A = S + W (:func:`~.scan.scaled_parts`) for the set
        |F| <= ``rel_error`` |A| and a window of ``window`` ||W||_2."""
        absA = abs(A)
        normA1 = math.sqrt(norm1(absA) * norm1(absA.T))
        nSW = norm1(abs(S) + abs(W))
        eps = ((rel_error + 12 * U) * normA1 + U * nSW) * INFLATE
        normW = norm2_skew(W)
        normS = norm1(S)
        n = A.shape[0]
        rows = int(np.max(np.diff(A.indptr))) if n else 0
        rnd = gamma(n + rows + 4) * norm1(abs(W)) * 4
        Delta = window * normW if normW > 0 else 1e-3 * max(normS, 1.0)
        return cls(A=A, W=W, normW=normW, normS=normS, normA1=normA1, eps=eps, Delta=Delta,
                   rnd=rnd)


def coupling(ctx, buf, lower, upper, lo_edge, hi_edge, exclude=()):
    """kappa of the rest (all but ``exclude``) across the interval [lower, upper].

    ``lo_edge``/``hi_edge``: below/above them Ritz values are not in the buffer
    (None: no eigenvalue there). Returns kappa, g_min, Delta_eff, near indices,
    their g (distance to the interval), the Xi bound and phi of the near set.
    """
    th, rs, wqn = buf.th, buf.rs, buf.wqn
    dist = np.where(th < lower, lower - th, np.where(th > upper, th - upper, 0.0))
    ex = np.zeros(th.size, bool)
    ex[list(exclude)] = True
    if np.any((dist == 0) & ~ex):
        raise SliceFailure("a Ritz value of the rest inside the interval")
    near = np.nonzero((dist < ctx.Delta) & ~ex)[0]
    far_d = [lower - lo_edge if lo_edge is not None else math.inf,
             hi_edge - upper if hi_edge is not None else math.inf]
    out = np.nonzero((dist >= ctx.Delta) & ~ex)[0]
    d_out = min(far_d + ([float(dist[out].min())] if out.size else []))
    used = np.concatenate([near, np.asarray(list(exclude), int)])
    phi = buf.phi(used) if used.size else 0.0
    rhat = (math.sqrt(float(np.sum(rs[used] ** 2))) * (1 + phi)
            + 2 * phi * float(np.max(np.abs(th[used])) if used.size else 0.0)) * INFLATE
    r = buf.radius              # largest Kahan radius of the buffer's slices
    d_eff = d_out - r - 4 * rhat
    if not d_eff > 0:
        raise SliceFailure("the window's complement is not separated from the interval")
    g = dist[near]
    g_min = min(float(g.min()) if g.size else math.inf, d_eff)
    if not g_min > 2 * (r + 4 * rhat):
        # the count of S below the interval must equal that of the block-diagonal H
        raise SliceFailure("a Ritz value within its radius of the interval")
    xi = ctx.eps + 2 * rhat + (2 * phi + phi * phi) * ctx.normW + ctx.rnd * max(used.size, 1)
    below = lo_edge is None and not np.any((th < lower) & ~ex)
    above = hi_edge is None and not np.any((th > upper) & ~ex)
    if below or above:
        # one side empty: J = +-I, herm(J W') = 0 for the skew W
        return xi / g_min, g_min, d_eff, near, dist[near], xi, phi
    Ls, Us = near[th[near] < lower], near[th[near] > upper]
    if Ls.size and Us.size:
        B = buf.Wn[np.ix_(Ls, Us)]
        x11 = float(np.linalg.norm((np.abs(B) + ctx.rnd) / np.sqrt(
            np.outer(dist[Ls], dist[Us])))) * INFLATE
    else:
        x11 = 0.0
    x12 = ((math.sqrt(float(np.sum(wqn[near] ** 2 / g))) * (1 + phi) + ctx.rnd
            * math.sqrt(near.size / g_min)) / math.sqrt(d_eff)) * INFLATE if near.size else 0.0
    x22 = ctx.normW / d_eff
    kappa = _norm22(x11, x12, x22) + xi / g_min
    return kappa, g_min, d_eff, near, g, xi, phi


#: a piece's explicit block holds the strip's Ritz vectors and those of the
#: rest within REACH x the piece's width of it, so that the rest's resolvent
#: is analytic on a disc about the piece's centre of radius ~ (1/2 + REACH)
#: x its width, and its Taylor series converges across the piece
#: (docs/results/analysis.md, "Deflated strips")
REACH = 1.0
#: the series is truncated where its last term's share of the error bound is
#: below max(rho, tol), tol first TAYLOR_LOOSE ||A||_2, at least TAYLOR_TOL ||A||_2
TAYLOR_LOOSE = 1e-6
TAYLOR_TOL = 1e-10
#: most Taylor terms of a piece (a piece whose series is longer is halved)
TAYLOR_TERMS = 60
#: most halvings of a strip into pieces
_DEPTH = 6
#: most steps of a piece's walk along the real axis
_WALK = 500
#: strips of more than this many are tried by a box before the walk
_BOX_FIRST = 8
#: a strip of more than PIECE Ritz values is first cut into pieces of about
#: PIECE (each grown, by doubling, until its far rest is coupled weakly across
#: it): a piece's explicit block then holds ~3 PIECE columns where the whole
#: strip's would hold ~3 m (docs/results/analysis.md, "Large clusters in pieces")
PIECE = 16
#: a strip cut into pieces whose routes leave it undecided is tried once more
#: as one piece (halved as before) only up to this many Ritz values: beyond,
#: one piece's bordered LU has more dense columns than it is worth
WHOLE_MAX = 200
#: a strip is left undecided at once (:func:`unresolved`) where its eigenvalue
#: estimates are resolved to less than UNRESOLVED times the error floor of
#: every route
UNRESOLVED = 0.1


def unresolved(est, lip, floor):
    """Whether the routes cannot decide a strip whose m eigenvalues are
    estimated by ``est``: each route's test is below ``UNRESOLVED`` times
    ``floor``, the error that every route's bound holds at least (rho of the
    strip's block).

    A route passes where sigma_min of the computed complement T exceeds its
    error bound (>= ``floor``) at the points the estimates place. As
    sigma_min is 1-Lipschitz and ||T(x) - T(x0)|| <= ``lip`` |x - x0|,
    sigma_min(T(x)) <= ``lip`` |x - z| at an eigenvalue z: so the sign test
    between two real roots sees at most ``lip`` x half their gap, the cover of
    the real axis at most ``lip`` |Im z| at Re z, and a box of half-width
    r = min(Im z, the distance to the others) / 2 about a complex estimate at
    most ``lip`` r on its nearest edge (sqrt2 r taken). True when all three
    are below ``UNRESOLVED floor``: eigenvalues equal to within the rounding
    of their own block (a near-double pair of a periodic or ordered packing
    at F_x = 0). Nothing is decided from it, and a skipped route could only
    have passed if the estimates were off by about ``floor`` / ``lip``: it is
    used only with estimates that accurate (:func:`decide_strip`: a skew
    part too small to move the cluster).

    Parameters
    ----------
    est : array_like of complex, shape (m,)
        Estimates of the strip's eigenvalues (units of A: K / M).
    lip : float
        Bound of ||T'(x)||_2 on the strip (>= 1).
    floor : float
        The least error bound of any route (units of A).

    Returns
    -------
    bool
    """
    est = np.asarray(est, complex)
    if est.size < 2:
        return False
    tol = UNRESOLVED * floor / lip
    if not 0.5 * float(np.min(np.diff(np.sort(est.real)))) < tol:
        return False                        # distinct real roots: the sign changes
    if not float(np.min(np.abs(est.imag))) < tol:
        return False                        # no real root: the cover
    for i in np.nonzero(est.imag > 0)[0]:
        others = np.abs(np.delete(est, i) - est[i])
        r = 0.5 * min(float(est[i].imag), float(np.min(others)))
        if not math.sqrt(2.0) * r < tol:
            return False                    # a box about it
    return True


def _explicit_block(ctx, buf, idx, WQ, coupled):
    """What a Schur complement onto the Ritz vectors ``idx`` needs: b (the
    block's scaled coupling to the rest), Q (the vectors orthonormalised), phi_Q
    (their departure from orthonormality), A Q, Q^T A Q and rho (the error of
    Q^T A Q and of the set F). ``WQ``: W times the block's vectors (as the
    caller lays it out); ``coupled``: :func:`coupling`'s answer with ``exclude
    = idx``."""
    kap, g_min, d_eff, near, g, xi, phi = coupled
    p = idx.size
    A = ctx.A
    n = A.shape[0]
    cross = buf.Wn[np.ix_(near, idx)]
    bn = float(np.linalg.norm((np.abs(cross) + ctx.rnd) / np.sqrt(g)[:, None])) if near.size else 0.0
    b = (math.sqrt(bn ** 2 + float(np.sum(WQ ** 2)) / d_eff) * (1 + phi)
         + xi * math.sqrt(p) / math.sqrt(g_min)) * INFLATE
    Q, _ = np.linalg.qr(buf.Q[:, idx])
    phiQ = (float(np.linalg.norm(Q.T @ Q - np.eye(p))) + gamma(n) * p) * INFLATE
    AQ = A @ Q
    Tc = Q.T @ AQ
    # errors of Tc and of the set: rounding, the non-orthonormality of Q, F
    rho = ((gamma(n + 8) * p * ctx.normA1 + (2 * phiQ + phiQ ** 2) * ctx.normA1)
           + ctx.eps + 2 * b * ctx.eps / math.sqrt(g_min) / (1 - kap)) * INFLATE
    return b, Q, phiQ, AQ, Tc, rho


class DeflatedComplement:
    """The Schur complement of a piece [lo, hi] of a strip onto an enlarged
    block, as a polynomial in z (package docstring, *Deflated strips*).

    The explicit block E is the strip's Ritz vectors and those of the rest
    within ``REACH`` (hi - lo) of the piece (p columns, orthonormalised: Q);
    the far rest (the orthogonal complement) is coupled across the piece by
    kappa < 1 (:func:`coupling` with E excluded), so for Re z in [lo, hi]
    A + F - z is singular iff its complement T_F(z) onto span(Q) is. With one
    sparse LU of the bordered matrix [[A - c, Q], [Q^T, 0]] at the centre c,
    Y_0 solves P_r (A - c) Y_0 = P_r A Q and Y_k the same system with Y_{k-1}
    on the right (Y_k in range(Q_r)); Y(z) = sum_{k<K} (z - c)^k Y_k has the
    residual Z(z) = P_r (A - z) Y(z) - P_r A Q = sum_{k<K} (z - c)^k Z_k
    - (z - c)^K Y_{K-1}, each Z_k computed, so ||Z(z)|| <= sum |z - c|^k
    ||Z_k|| + |z - c|^K ||Y_{K-1}|| for every z. The polynomial
    T~(z) = Q^T A Q - z - sum (z - c)^k Q^T A Y_k then differs from T_F(z) by
    at most :meth:`err` (|z - c|): b ||Z|| / (sqrt(g_min) (1 - kappa)) (the
    bound of the dense route, which holds for every Y in range(Q_r)), the
    rounding of the coefficients and rho (rounding of Q^T A Q, the
    non-orthonormality of Q, F).

    Built by :meth:`of`; raises :class:`SliceFailure` where the far rest is not
    weakly coupled or the series does not reach its tolerance.

    Attributes
    ----------
    lo, hi, c, r : float
        The piece, its centre and half-width (units of A: K / M).
    E : ndarray of int, shape (p,)
        The buffer's indices of the explicit block (the strip's Ritz values
        among them: ``inI``).
    Tc : ndarray, shape (p, p)
        Q^T A Q.
    P : ndarray, shape (K, p, p)
        The Taylor coefficients Q^T A Y_k.
    target : float
        The tolerance the series was truncated at (:meth:`extend`).
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @classmethod
    def of(cls, ctx, buf, I, lo, hi, lo_edge, hi_edge, target):
        """The complement of the piece [lo, hi] of the strip of Ritz values I,
        its series truncated at ``target`` (:meth:`extend`)."""
        A = ctx.A
        n = A.shape[0]
        c, r = 0.5 * (lo + hi), 0.5 * (hi - lo)
        th = buf.th
        dist = np.where(th < lo, lo - th, np.where(th > hi, th - hi, 0.0))
        inE = dist < REACH * (hi - lo)
        inE[I] = True
        E = np.nonzero(inE)[0]
        p = E.size
        kap, g_min, d_eff, near, g, xi, phi = coupling(ctx, buf, lo, hi, lo_edge, hi_edge,
                                                       exclude=E)
        if not kap < 1:
            raise SliceFailure(f"the far rest is coupled across the piece (kappa {kap:.3g})")
        b, Q, phiE, AQ, Tc, rho = _explicit_block(
            ctx, buf, E, ctx.W @ buf.Q[:, E], (kap, g_min, d_eff, near, g, xi, phi))
        Qs = sp.csr_matrix(Q)
        M = sp.bmat([[A - c * sp.identity(n, format="csr"), Qs], [Qs.T, None]], format="csc")
        try:
            lu = spla.splu(M)
        except RuntimeError:
            raise SliceFailure("the bordered system of a piece is singular") from None
        pc = cls(lo=lo, hi=hi, c=c, r=r, E=E, p=p, th=th[E], inI=np.isin(E, I), Tc=Tc,
                 rho=rho, A=A, Q=Q, lu=lu, phiE=phiE,
                 normA1=ctx.normA1, scale=b / math.sqrt(g_min) / (1 - kap),
                 Tn=float(np.linalg.norm(Tc)) * INFLATE, rhs=AQ, terms=[], target=math.inf)
        pc.extend(max(rho, target))
        return pc

    def extend(self, target):
        """Add Taylor terms until the last one's share of :meth:`err` (r), the
        truncation r^K ||Y_{K-1}||, is at most ``target``: each term a solve
        with the piece's LU and its residual (raises :class:`SliceFailure`
        beyond ``TAYLOR_TERMS`` terms)."""
        if not target < self.target:
            return
        A, Q, n, p, c = self.A, self.Q, self.A.shape[0], self.p, self.c
        # rounding of one coefficient: A Y_k, Q^T (A Y_k), the projections, as
        # gamma |Q|^T |A| |Y_k| <= gamma sqrt(p) (1 + phi) ||A|| ||Y_k||_F
        gz = gamma(2 * n + 8)
        zeros = np.zeros((p, p))
        terms = self.terms
        while True:
            if terms and self.scale * self.r ** len(terms) * (terms[-1][3] + terms[-1][2]) \
                    <= target:
                break
            if len(terms) >= TAYLOR_TERMS:
                raise SliceFailure("the Taylor series of a piece does not reach its tolerance")
            rhs = self.rhs
            Yk = self.lu.solve(np.vstack([rhs, zeros]))[:n]
            Yk = Yk - Q @ (Q.T @ Yk)
            AY = A @ Yk
            Z = (AY - c * Yk) - rhs
            Z = Z - Q @ (Q.T @ Z)
            ny = float(np.linalg.norm(Yk))
            rr = gz * self.normA1 * math.sqrt(p) * (1 + self.phiE) * ny
            zn = float(np.linalg.norm(Z)) + 4 * rr + gz * float(np.linalg.norm(rhs))
            if not (math.isfinite(ny) and math.isfinite(zn)):
                raise SliceFailure("the Taylor series of a piece is not finite")
            # (Q^T A Y_k, ||Z_k|| bound, rounding, ||Y_k||)
            terms.append((Q.T @ AY, zn * INFLATE, rr, ny * INFLATE))
            self.rhs = Yk
        self.target = target
        self.K = len(terms)
        self.P = np.array([t[0] for t in terms])
        self.zk = np.array([t[1] for t in terms])
        self.rk = np.array([t[2] for t in terms])
        self.ztail = (terms[-1][3] + terms[-1][2]) * INFLATE
        self.Pn = np.linalg.norm(self.P, axis=(1, 2)) * INFLATE

    def err(self, tau):
        """Bound of ||T_F(z) - T~(z)||_2 for |z - c| <= tau, every F of the set."""
        pw = tau ** np.arange(self.K + 1)
        zn = float(np.dot(pw[:-1], self.zk)) + pw[-1] * self.ztail
        return (self.scale * zn + 3 * float(np.dot(pw[:-1], self.rk)) + self.rho) * INFLATE

    def rounding(self, tau, zabs, cplx=False):
        """Bound of the rounding of evaluating T~(z) (Horner) for |z - c| <= tau,
        |z| <= zabs."""
        s = self.Tn + zabs * math.sqrt(self.p) + float(np.dot(tau ** np.arange(self.K), self.Pn))
        # (+2: a product with a constant row scaling, :meth:`schur`)
        return (2.0 if cplx else 1.0) * gamma(2 * self.K + 6) * s * INFLATE

    def __call__(self, z):
        """T~(z), computed (z real or complex)."""
        t = z - self.c
        S = self.P[-1].astype(complex) if isinstance(z, complex) else self.P[-1].copy()
        for k in range(self.K - 2, -1, -1):
            S = S * t + self.P[k]
        return self.Tc - z * np.eye(self.p) - S

    def deriv(self, z):
        """T~'(z), computed."""
        t = z - self.c
        S = -np.eye(self.p) + 0 * t
        for k in range(self.K - 1, 0, -1):
            S = S - k * self.P[k] * t ** (k - 1)
        return S

    def lipschitz(self, tau):
        """Bound of ||T~'(z)||_2 for |z - c| <= tau."""
        k = np.arange(1, self.K)
        return (1 + float(np.sum(k * tau ** (k - 1) * self.Pn[1:]))) * INFLATE

    def curvature(self, tau):
        """Bound of ||T~''(z)||_2 for |z - c| <= tau."""
        k = np.arange(2, self.K)
        return float(np.sum(k * (k - 1) * tau ** (k - 2) * self.Pn[2:])) * INFLATE

    def walk(self, lo, hi):
        """Certify that T_F(x) is nonsingular for every real x in [lo, hi] and F
        of the set: from x = lo, sigma_min(T~(x)) = s > slack (the error bound
        over the piece, the evaluation's rounding and a floor) excludes a root
        from [x, x + (s - slack) / (2 L)] (L the Lipschitz bound of T~ on the
        piece), on which sigma_min(T_F) >= (s + slack) / 2 - ... > 0; the
        next x is its end. Returns (True, margin, None) or (False, margin, x)
        at the first x where s <= slack."""
        tau = max(self.c - lo, hi - self.c)
        L = self.lipschitz(tau)
        err = self.err(tau)
        x, margin = lo, math.inf
        for _ in range(_WALK):
            T = self(x)
            floor = 1e3 * gamma(self.p + 2) * float(np.linalg.norm(T))
            slack = err + self.rounding(tau, max(abs(lo), abs(hi))) + floor
            s = sigma_min_lower(T)
            if not s > slack:
                return False, max(s, 0.0) / slack, x
            margin = min(margin, 0.5 * (s + slack) / slack)
            x = x + (s - slack) / (2 * L) * (1 - 1e-8)
            if x >= hi:
                return True, margin, None
        return False, 0.0, x

    def schur(self, tau, zabs, z0):
        """``schur(z, deriv=True)`` for :func:`~.winding.box_zero_count` on a box
        about z0 within |z - c| <= tau, |z| <= zabs: (d T~(z), err, d T~'(z),
        derr), err bounding ||T_F(z) - T~(z)|| on the whole box (so the
        derivative's error is its rounding only, derr, and the curvature that
        of T~). d is a constant diagonal scaling of the rows, 0 < d <= 1 (so
        ||d (T_F - T~)|| <= err and det(d T) winds as det T): 1 on the strip's
        rows, the rows of the rest's Ritz values far from z0 scaled down to
        the norm of the strip's rows of T~(z0), so that the box's evaluations
        are not conditioned by directions far away."""
        err = self.err(tau) + self.rounding(tau, zabs, cplx=True)
        derr = 2 * gamma(2 * self.K + 6) * (math.sqrt(self.p) + self.lipschitz(tau)) * INFLATE
        x0 = float(np.real(z0))
        size = float(np.linalg.norm(self(complex(z0))[self.inI]))
        d = np.where(self.inI, 1.0, np.minimum(1.0, size / np.maximum(
            np.abs(self.th - x0), 1e-300)))[:, None]

        def f(z, deriv=True):
            return d * self(z), err, d * self.deriv(z), derr
        return f

    def roots(self, x0):
        """Estimates of the zeros of det T~ (not certified): the eigenvalues of
        T~ linearised about x0."""
        T0, D0 = self(x0), self.deriv(x0)
        try:
            z = sla.eigvals(T0 - x0 * D0, -D0)
        except (np.linalg.LinAlgError, ValueError):
            return np.zeros(0, complex)
        return z[np.isfinite(z)]

    def refined(self, z, steps=3):
        """Estimate z moved to the nearest eigenvalue of T~ linearised about
        it, ``steps`` times (Newton's method on the polynomial; not certified)."""
        for _ in range(steps):
            z0 = complex(z) if abs(np.imag(z)) > 0 else float(np.real(z))
            T0, D0 = self(z0), self.deriv(z0)
            try:
                w = sla.eigvals(T0 - z0 * D0, -D0)
            except (np.linalg.LinAlgError, ValueError):
                break
            w = w[np.isfinite(w)]
            if not w.size:
                break
            z = w[int(np.argmin(np.abs(w - z0)))]
        return complex(z)


def _strip_estimates(pieces, m, a_lo, a_hi, steps):
    """m estimates of the strip's eigenvalues from its pieces' complements (not
    certified): each piece's zeros with real part in it, refined ``steps``
    times (not refined in a strip of more than ``_BOX_FIRST``: one generalized
    eigenproblem of p x p per estimate); if that is not m of them, the m
    zeros nearest the strip (None if fewer)."""
    found, every = [], []
    steps = steps if m <= _BOX_FIRST else 0     # (a box refines its own estimate)
    for pc in pieces:
        z = pc.roots(pc.c)
        every.extend(z)
        for w in z[(z.real >= pc.lo) & (z.real <= pc.hi) & (z.imag >= 0)]:
            w = pc.refined(w, steps)
            if not (pc.lo <= w.real <= pc.hi) or w.imag < 0:
                continue
            found.append(w)
            if w.imag > 0:
                found.append(np.conj(w))
    if len(found) != m:
        every = np.asarray(every, complex)
        d = np.maximum(np.maximum(a_lo - every.real, every.real - a_hi), 0.0)
        found = list(every[np.lexsort((np.abs(every.real - 0.5 * (a_lo + a_hi)), d))][:m])
        if len(found) < m:
            return None
    return np.sort_complex(np.asarray(found, complex))


#: most evaluations of a deflated complement of p <= 16 one walk of a box's
#: edge may take: each is a p x p polynomial (~0.15 ms at p <= 16, 1.1 ms at
#: 64, 5 ms at 128, K = 20 terms), where the bordered route's are sparse LUs
#: (``winding.MAX_EVALS``). A pair near its exceptional point took 1077
#: (N = 6400, seed 2, p = 6; docs/results/analysis.md). Above p = 16 the
#: budget falls as p^-3 (:func:`poly_budget`), never below MAX_EVALS.
POLY_MAX_EVALS = 10_000


def poly_budget(p):
    """The evaluation budget of a box's walk on a deflated complement of order
    p: ``POLY_MAX_EVALS`` up to p = 16, then in proportion to p^-3 (the cost
    of one evaluation), not below ``winding.MAX_EVALS``."""
    return max(MAX_EVALS, int(POLY_MAX_EVALS * min(1.0, (16.0 / p) ** 3)))


def _box(pieces, est, m, whys):
    """A box about a complex estimate (the two of largest Im), off the real axis
    (winding on the complement T~ of the piece that holds its real part):
    (COMPLEX, margin, the m estimates with the counted pair's replaced by its
    approximation: :func:`_pair_in_box`) or None (why not appended to
    ``whys``)."""
    cx = sorted((z for z in est if z.imag > 0), key=lambda z: -z.imag)
    for z0 in cx[:2]:
        pc = next((q for q in pieces if q.lo <= z0.real <= q.hi), None)
        if pc is None:
            continue
        others = [abs(z0 - z) for z in est if z != z0]
        if m > _BOX_FIRST:
            z0 = pc.refined(z0, 1)
            if not (z0.imag > 0 and pc.lo <= z0.real <= pc.hi):
                continue
        r = 0.5 * min([z0.imag, z0.real - pc.lo, pc.hi - z0.real] + others)
        if not r > 0:
            continue
        tau = abs(z0.real - pc.c) + r + (z0.imag + r)
        zabs = abs(z0) + 2 * r
        cnt, w, mg = box_zero_count(pc.schur(tau, zabs, z0), z0.real - r, z0.real + r,
                                    z0.imag - r, z0.imag + r, pc.curvature(tau),
                                    max_evals=poly_budget(pc.p))
        if cnt is not None and cnt >= 1:
            z = _pair_in_box(pc, z0, r)
            out = est.copy()
            i, k = (int(np.argmin(np.abs(out - w))) for w in (z0, np.conj(z0)))
            if i != k:
                out[[i, k]] = [z, np.conj(z)]
            return Decision.COMPLEX, mg, np.sort_complex(out)
        whys.append(w if w else f"no eigenvalue in the box about {z0:.6g}")
    return None


def _pair_in_box(pc, z0, r):
    """The approximation (not certified) of an eigenvalue counted in the box
    of half-width r about z0: Newton's method on the piece's complement, its
    series extended to ``TAYLOR_TOL`` ||A|| where it reaches that (the box's
    estimate was made at a looser tolerance, off by up to ~5 % of its Im); z0
    if the iterate leaves the box."""
    try:
        pc.extend(TAYLOR_TOL * pc.normA1)
    except SliceFailure:
        pass
    z = pc.refined(z0, 3)
    inside = abs(z.real - z0.real) <= r and abs(z.imag - z0.imag) <= r
    return z if inside and np.isfinite(z) else complex(z0)


def _deflated_routes(pieces, est, m, a_lo, a_hi):
    """The routes of :func:`decide_deflated` on its pieces, given the estimates."""
    whys = []
    roots = np.sort(est.real)
    real_est = bool(np.all(est.imag == 0)) and bool(np.all(np.diff(roots) > 0))
    # a strip estimated mixed (real and complex zeros) goes to the box at once:
    # the walk would stop at its real root only after ~log(width / err) steps
    mixed = not real_est and bool(np.any(est.imag == 0))

    def box():
        return _box(pieces, est, m, whys)

    # a strip of more than _BOX_FIRST: one box (its pairs would each be a dip
    # of the walk, every step an inversion of p x p)
    boxed = m > _BOX_FIRST and not real_est
    if boxed and (found := box()):
        return (*found, "")
    if not real_est and not mixed:
        margin = math.inf
        for pc in pieces:
            ok, mg, where = pc.walk(pc.lo, pc.hi)
            if not ok:
                whys.append(f"a real root cannot be excluded near x = {where:.9g}")
                break
            margin = min(margin, mg)
        else:
            return Decision.COMPLEX, margin, est, ""
    elif real_est:
        # in each piece, the sign changes of det T~ at points where T_F is
        # nonsingular (the piece's far rest keeps the sign of its determinant
        # on the piece): each is a real eigenvalue of A + F in the piece; m of
        # them over the pieces are the strip's m eigenvalues
        changes, margin = 0, math.inf
        for pc in pieces:
            r = roots[(roots > pc.lo) & (roots < pc.hi)]
            pts = np.concatenate([[pc.lo], 0.5 * (r[1:] + r[:-1]), [pc.hi]])
            tau = max(pc.c - pc.lo, pc.hi - pc.c)
            err = pc.err(tau) + pc.rounding(tau, max(abs(pc.lo), abs(pc.hi)))
            signs = []
            for x in pts:
                T = pc(float(x))
                slack = err + 1e3 * gamma(pc.p + 2) * float(np.linalg.norm(T))
                s = sigma_min_lower(T)
                if not s > slack:
                    whys.append(f"strip of {m}: det of its complement not certified at "
                                f"x = {x:.9g}")
                    break
                margin = min(margin, s / slack)
                signs.append(np.linalg.slogdet(T)[0])
            else:
                changes += sum(signs[i] != signs[i + 1] for i in range(len(signs) - 1))
                continue
            break
        else:
            if changes == m:
                return Decision.REAL, margin, roots.astype(complex), ""
            whys.append(f"strip of {m}: {changes} sign changes of det between roots")
    if not boxed and (found := box()):
        return (*found, "")
    return Decision.UNDECIDED, 0.0, est, "; ".join(whys)


def decide_deflated(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge):
    """Decide a strip of m >= 2 by its deflated complements (one sparse LU per
    piece, :class:`DeflatedComplement`): complex if no real x in the strip is
    a root (:meth:`~DeflatedComplement.walk`), real if det changes sign m
    times between estimated roots in one piece, complex if a box about a
    complex estimate holds an eigenvalue (winding on the polynomial).

    The series is first truncated at ``TAYLOR_LOOSE`` ||A||; the estimates
    of the strip's eigenvalues then set the tolerance to 0.1 of their
    smallest |Im| or spacing (not below ``TAYLOR_TOL`` ||A||), and once more
    to ``TAYLOR_TOL`` ||A|| if the strip is left undecided.

    Returns
    -------
    (Decision, float, ndarray of complex or None, str)
        The decision, its margin, the m eigenvalue estimates and, when
        UNDECIDED, why.
    """
    m = I.size
    if m > PIECE:
        pieces = _cut(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge)
        if pieces is not None:
            result = _decide_pieces(ctx, pieces, m, a_lo, a_hi)
            if result[0] is not Decision.UNDECIDED or m > WHOLE_MAX:
                return result
        elif m > WHOLE_MAX:
            return (Decision.UNDECIDED, 0.0, None,
                    f"deflated route: the strip of {m} could not be cut into pieces")
    pieces, todo = [], [(a_lo, a_hi, 0)]
    while todo:
        lo, hi, depth = todo.pop()
        try:
            pieces.append(DeflatedComplement.of(ctx, buf, I, lo, hi, lo_edge, hi_edge,
                                                TAYLOR_LOOSE * ctx.normA1))
        except SliceFailure as exc:
            if depth >= _DEPTH:
                return Decision.UNDECIDED, 0.0, None, f"deflated route: {exc}"
            mid = 0.5 * (lo + hi)
            todo += [(mid, hi, depth + 1), (lo, mid, depth + 1)]
    pieces.sort(key=lambda pc: pc.lo)
    return _decide_pieces(ctx, pieces, m, a_lo, a_hi)


def _cut(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge):
    """The strip of Ritz values I (more than ``PIECE``) cut into pieces, from
    its lower edge up: a piece holds the next ``PIECE`` Ritz values of the strip,
    doubled until its complement can be built (the far rest coupled weakly
    across it, the series reaching its tolerance), and ends midway between two
    Ritz values (at ``a_hi`` for the last). None if a piece cannot be built
    below the top of the strip."""
    th = buf.th
    pieces, s, m = [], 0, I.size
    while s < m:
        k = PIECE
        while True:
            e = min(s + k, m)
            lo = a_lo if s == 0 else 0.5 * (th[I[s - 1]] + th[I[s]])
            hi = a_hi if e == m else 0.5 * (th[I[e - 1]] + th[I[e]])
            try:
                pieces.append(DeflatedComplement.of(ctx, buf, I[s:e], lo, hi, lo_edge, hi_edge,
                                                    TAYLOR_LOOSE * ctx.normA1))
                break
            except SliceFailure:
                if e == m:
                    return None
                k *= 2
        s = e
    return pieces


def _decide_pieces(ctx, pieces, m, a_lo, a_hi):
    """The routes of :func:`decide_deflated` on the pieces that cover the strip
    [a_lo, a_hi] of m eigenvalues (series extended as it says)."""
    tight = TAYLOR_TOL * ctx.normA1
    est = _strip_estimates(pieces, m, a_lo, a_hi, 0)
    if est is None:
        return Decision.UNDECIDED, 0.0, None, "deflated route: no estimates"
    im = np.abs(est.imag[est.imag != 0])
    re = np.sort(est.real[est.imag == 0])
    spread = min([float(im.min()) if im.size else math.inf]
                 + ([float(np.diff(re).min())] if re.size > 1 else []))
    result = (Decision.UNDECIDED, 0.0, est, "")
    if len(pieces) > 1 and m > _BOX_FIRST and np.any(est.imag > 0):
        # a strip in pieces: first the box, its piece's series alone extended
        # to a tenth of the estimate's distance to the real axis and to the
        # other estimates (the other pieces' estimates stay at the loose
        # tolerance)
        for z0 in sorted((z for z in est if z.imag > 0), key=lambda z: -z.imag)[:2]:
            pc = next((q for q in pieces if q.lo <= z0.real <= q.hi), None)
            near = min([abs(z0 - z) for z in est if z != z0] + [2 * z0.imag])
            try:
                if pc is not None:
                    pc.extend(max(tight, min(TAYLOR_LOOSE * ctx.normA1, 0.1 * near)))
            except SliceFailure:
                continue
        if (found := _box(pieces, est, m, [])) is not None:
            return (*found, "")
    first = max(tight, min(TAYLOR_LOOSE * ctx.normA1, 0.1 * spread))
    for target in dict.fromkeys((first, tight)):
        try:
            for pc in pieces:
                pc.extend(target)
        except SliceFailure as exc:
            return Decision.UNDECIDED, 0.0, est, f"deflated route: {exc}"
        est = _strip_estimates(pieces, m, a_lo, a_hi, 1)
        if est is None:
            break
        result = _deflated_routes(pieces, est, m, a_lo, a_hi)
        if result[0] is not Decision.UNDECIDED:
            return result
    return result[0], result[1], result[2], f"deflated route: {result[3]}"


def decide_strip(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge, estimates=None,
                  real_routes=True):
    """Decide one strip of m >= 2 eigenvalues (module docstring, *Strips*).

    With Q_I the strip's Ritz vectors (orthonormalised) and Q_r the rest, for
    real x in [a_lo, a_hi] the Schur complement of A - x onto span(Q_I) is
    T(x) = Q_I^T A Q_I - x - Q_I^T A Y(x), Y(x) the solution in range(Q_r) of
    P_r (A - x) Y = P_r A Q_I: a bordered sparse system. Its computed Y has a
    residual Z; the true complement differs by at most b ||Z|| /
    (sqrt(g_min) (1 - kappa_r)), and T is Lipschitz in x with constant
    1 + b^2 / (g_min (1 - kappa_r)^2) (b, kappa_r, g_min bounded on the
    whole strip by :func:`coupling`).

    The order: the projected cluster (Y = 0, no solve; real x only), then
    :func:`decide_deflated` (one sparse LU per piece; also where the rest is
    coupled across the strip, kappa_r >= 1, and for strips of any size),
    then the routes of a bordered solve per evaluation, where those leave
    the strip undecided.

    ``estimates``: a callable returning (note, ARPACK's estimates of the
    eigenvalues with real part in the strip), asked only when the real-axis
    routes fail (or are skipped: ``real_routes`` False); a box about each of
    the (at most two) complex estimates of largest Im, off the real axis,
    is then counted by winding
    (:func:`~.winding.box_zero_count`): one
    eigenvalue or more in it certifies the strip complex. An undecided
    strip's reason ends with the note.

    A strip whose projected cluster is as accurate as its block's rounding
    (err0 <= 2 rho: a skew part too small to move it) and whose estimates
    are :func:`unresolved` by that rounding is left undecided before any
    sparse LU, its estimates named in place of ARPACK's note.

    Returns
    -------
    (Decision, float, ndarray of complex, str)
        The strip's decision, its margin, the approximations of its m
        eigenvalues and, when UNDECIDED, why.
    """
    verdict, margin, lam, why, noted = _strip_routes(
        ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge, estimates, real_routes)
    if verdict is Decision.UNDECIDED and not noted and estimates is not None:
        why = "; ".join(w for w in (why, estimates()[0]) if w)
    return verdict, margin, lam, why


def _strip_routes(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge, estimates, real_routes):
    """The routes of :func:`decide_strip`: (decision, margin, eigenvalue
    approximations, why, whether why already names the estimates)."""
    m = I.size
    kap, g_min, d_eff, near, g, xi, phi = coupling(
        ctx, buf, a_lo, a_hi, lo_edge, hi_edge, exclude=I)
    lam0 = buf.th[I].astype(complex)
    if not kap < 1:
        deflated = decide_deflated(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge)
        if deflated[0] is not Decision.UNDECIDED:
            return deflated + (False,)
        return (Decision.UNDECIDED, 0.0, lam0,
                f"the rest is coupled across the strip (kappa {kap:.3g})", False)
    if not real_routes:
        # the deflated route first: the strip's own block (below; n x m, and
        # m^2 n for Q^T A Q) is needed only by the box on ARPACK's estimates
        # after it, which a strip of more than WHOLE_MAX does not get
        deflated = decide_deflated(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge)
        if deflated[0] is not Decision.UNDECIDED:
            return deflated + (False,)
        if m > WHOLE_MAX:        # (an undecided strip says why)
            return (Decision.UNDECIDED, 0.0, lam0,
                    deflated[3] or f"strip of {m} (> {WHOLE_MAX}): undecided in pieces", False)
    # column-major, as a column selection of W Q is (np.sum's last bit depends on it)
    b, Q, phiI, AQ, Tc, rho = _explicit_block(
        ctx, buf, I, np.asfortranarray(ctx.W @ buf.Q[:, I]),
        (kap, g_min, d_eff, near, g, xi, phi))
    # |T''(x)| <= 2 b^2 / (g_min^2 (1 - kappa_r)^3) on the strip
    curv = 2 * b * b / (g_min ** 2 * (1 - kap) ** 3) * INFLATE
    A = ctx.A
    n = A.shape[0]
    bordered = []               # [M0, E], assembled at the first solve

    def bordered_at(x):
        """The bordered matrix [[A - x, Q], [Q^T, 0]] = M0 - x E (M0 and E
        assembled once)."""
        if not bordered:
            Qs = sp.csr_matrix(Q)
            bordered.extend([sp.bmat([[A, Qs], [Qs.T, None]], format="csc"),
                             sp.diags(np.r_[np.ones(n), np.zeros(m)], format="csc")])
        return (bordered[0] - x * bordered[1]).tocsc()

    evaluated = {}              # x -> (T, D) of the solved routes (for the estimates)
    # the projected cluster: Y = 0 in range(Q_r) is a solution like any other
    # (the bound b ||Z|| / (sqrt(g_min) (1 - kappa_r)) holds for every Y in
    # range(Q_r)), with the residual Z0 = -P_r A Q; T(x) = Tc - x, T' = -I, no
    # sparse solve. The rounding of Z0 (the product A Q, the projection) is
    # added to its norm. Tried first: a strip whose coupling to the rest is
    # small against its own spread is decided from its m x m block alone.
    Z0 = AQ - Q @ (Q.T @ AQ)
    zn0 = (float(np.linalg.norm(Z0)) * (1 + 2 * gamma(n + m + 8))
           + 2 * gamma(n + m + 8) * ctx.normA1 * math.sqrt(m) * (1 + phiI)) * INFLATE
    err0 = (b * zn0 / math.sqrt(g_min) / (1 - kap) + rho) * INFLATE
    projected = [False]
    # eigenvalues equal to within the block's own rounding: no route can
    # separate them (:func:`unresolved`). Where the skew part is too small to
    # move the cluster (err0 <= 2 rho), the projected cluster's estimates and
    # (after its LU) the deflated complement's are as accurate as any route's.
    lam_p = np.linalg.eigvals(Tc)
    lip = 1 + b * b / (g_min * (1 - kap) ** 2)
    floor_bound = err0 <= 2 * rho

    def floor_undecided(est, source):
        est = np.sort_complex(np.asarray(est, complex))
        return (Decision.UNDECIDED, 0.0, est,
                f"strip of {m}: its eigenvalues are equal to within the rounding of its "
                f"block ({source}: {est[0]:.9g} .. {est[-1]:.9g}, not certified; every "
                f"route's error >= {rho:.2g})", True)

    if floor_bound and unresolved(lam_p, lip, rho):
        return floor_undecided(lam_p, "the projected cluster")

    def schur(x, deriv=False):
        # x real, or complex with Re x in the strip (the box route): the same
        # bounds (module winding), the rounding terms doubled for complex
        cplx = 2.0 if isinstance(x, complex) else 1.0
        if projected[0]:          # (real x only: the real-axis routes)
            return Tc - x * np.eye(m), err0
        M = bordered_at(x)
        try:
            lu = spla.splu(M)
        except RuntimeError:
            return (None, math.inf) + ((None, math.inf) if deriv else ())
        Y = lu.solve(np.vstack([AQ, np.zeros((m, m))]))[:n]
        Y = Y - Q @ (Q.T @ Y)
        Z = (A @ Y - x * Y) - AQ
        Z = Z - Q @ (Q.T @ Z)
        T = Tc - x * np.eye(m) - Q.T @ (A @ Y)
        rY = cplx * gamma(n + 8) * ctx.normA1 * float(np.linalg.norm(Y))
        zn = float(np.linalg.norm(Z)) + 4 * rY
        err = (b * zn / math.sqrt(g_min) / (1 - kap) + 2 * rY + rho) * INFLATE
        if not deriv:
            return T, err
        # T'(x) = -I - Q^T A (C_r - x)^-1 Y(x), from the same factorization
        Y2 = lu.solve(np.vstack([Y, np.zeros((m, m))]))[:n]
        Y2 = Y2 - Q @ (Q.T @ Y2)
        Z2 = (A @ Y2 - x * Y2) - Y
        Z2 = Z2 - Q @ (Q.T @ Z2)
        D = -np.eye(m) - Q.T @ (A @ Y2)
        rY2 = cplx * gamma(n + 8) * ctx.normA1 * float(np.linalg.norm(Y2))
        derr = (b * (float(np.linalg.norm(Z2)) + 4 * rY2 + zn / (g_min * (1 - kap)))
                / math.sqrt(g_min) / (1 - kap) + 2 * rY2) * INFLATE
        if not isinstance(x, complex):
            evaluated[x] = (T, D)
        return T, err, D, derr

    def test(x):
        T, err = schur(x)
        if T is None:
            return 0.0, 0.0, T
        floor = 1e3 * gamma(m + 2) * float(np.linalg.norm(T))
        return sigma_min_lower(T) - err, max(err, floor), T

    def in_a_box(approx):
        """Complex if a box about an estimate, off the real axis, holds an
        eigenvalue (winding count); returns (verdict, margin, why, the strip's
        eigenvalue approximations: ARPACK's if it saw all m, else ``approx``
        with the two nearest the pair replaced by it)."""
        _, inside = estimates() if estimates is not None else ("", np.zeros(0, complex))
        est = sorted(inside[inside.imag > 0], key=lambda z: -z.imag)
        why = ""
        for z0 in est[:2]:
            others = [abs(z0 - z) for z in est if z != z0]
            r = 0.5 * min([z0.imag, z0.real - a_lo, a_hi - z0.real] + others)
            if not r > 0:
                continue
            # a box about an eigenvalue has sigma_min(T) <= ~ sqrt2 r ||T'|| on its
            # edge, and every evaluation's error is at least rho: a box that
            # small cannot be counted (its halvings would run to MAX_EVALS)
            if math.sqrt(2.0) * r * lip < rho:
                why = f"winding count: the box about {z0:.6g} is within the error bound"
                continue
            cnt, why, margin = box_zero_count(
                schur, z0.real - r, z0.real + r, z0.imag - r, z0.imag + r, curv)
            if cnt is not None and cnt >= 1:
                if inside.size == m:
                    return Decision.COMPLEX, margin, "", inside.astype(complex)
                out = np.asarray(approx, complex).copy()
                j = np.argsort(np.abs(out.real - z0.real))[:2]
                out[j] = [z0, np.conj(z0)]
                return Decision.COMPLEX, margin, "", out
            if cnt == 0:
                why = f"winding count: no eigenvalue in the box about {z0:.6g}"
        return Decision.UNDECIDED, 0.0, why, approx

    if not real_routes:         # (the deflated route tried above)
        verdict, margin, why, lam_b = in_a_box(lam0)
        return verdict, margin, lam_b, why, False

    def all_real(roots):
        """m real roots: det T changes sign between consecutive estimated roots."""
        pts = np.concatenate([[a_lo], 0.5 * (roots[1:] + roots[:-1]), [a_hi]])
        signs, margin = [], math.inf
        for p in pts:
            s, floor, T = test(float(p))
            if not s > floor:
                return Decision.UNDECIDED, max(s, 0.0) / floor if floor else 0.0, (
                    f"strip of {m}: det of its Schur complement not certified at x = {p:.9g}")
            margin = min(margin, (s + floor) / floor if floor else math.inf)
            signs.append(np.linalg.slogdet(T)[0])
        if all(signs[i] != signs[i + 1] for i in range(m)):
            return Decision.REAL, margin, ""
        return Decision.UNDECIDED, 0.0, f"strip of {m}: no sign change of det between roots"

    def no_real_root_projected(limit=200):
        """The cover of no_real_root for the projected cluster: T(x) = Tc - x
        + E(x), ||E(x)|| <= err0 on the whole strip, and sigma_min(Tc - x) is
        1-Lipschitz in x, so sigma_min(Tc - mid) - h > err0 (+ the rounding
        floor of forming Tc - mid) excludes a root from [mid - h, mid + h]."""
        todo, margin, evals = [(a_lo, a_hi)], math.inf, 0
        while todo:
            lo, hi = todo.pop()
            mid, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
            T = Tc - mid * np.eye(m)
            evals += 1
            low = sigma_min_lower(T) - h * (1 + 1e-8)
            slack = err0 + 1e3 * gamma(m + 2) * float(np.linalg.norm(T))
            if low > slack:
                margin = min(margin, low / slack)
                continue
            hopeless = float(np.linalg.svd(T, compute_uv=False)[-1]) < 0.5 * slack
            if hopeless or evals > limit or h < 1e-12 * max(abs(mid), 1.0):
                return Decision.UNDECIDED, max(low, 0.0) / slack, (
                    f"strip of {m}: a real root cannot be excluded near x = {mid:.9g} "
                    f"(projected cluster)")
            todo += [(lo, mid), (mid, hi)]
        return Decision.COMPLEX, margin, ""

    def no_real_root(probe=()):
        """Cover [a_lo, a_hi] by intervals [x - h, x + h] on which T(x + t) = T(x) +
        t T'(x) + O(curv t^2 / 2) stays nonsingular; sigma_min of the explicit
        linear part is sampled (Lipschitz constant ||T'||). ``probe``: points
        (estimated real roots) where T is looked at first: one within its
        error bound of a singular matrix ends the cover (no interval about it
        can pass; the halvings down to it would take ~log2(width / err) solves)."""
        for x in probe:
            T, err = schur(float(np.clip(x, a_lo, a_hi)))
            if T is None:
                break
            floor = 1e3 * gamma(m + 2) * float(np.linalg.norm(T))
            if float(np.linalg.svd(T, compute_uv=False)[-1]) < 0.5 * (err + floor):
                return Decision.UNDECIDED, 0.0, (
                    f"strip of {m}: a real root cannot be excluded near x = {x:.9g}")
        todo, margin, evals = [(a_lo, a_hi)], math.inf, 0
        while todo:
            lo, hi = todo.pop()
            mid, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
            T, err, D, derr = schur(mid, deriv=True)
            evals += 1
            if T is None:
                return Decision.UNDECIDED, 0.0, "the bordered system of the strip is singular"
            ts = np.linspace(-h, h, 33)
            smin = float(np.min(sigma_min_lower_many(T[None] + ts[:, None, None] * D[None])))
            low = smin - float(np.linalg.norm(D, 2)) * (ts[1] - ts[0]) / 2 * (1 + 1e-8)
            floor = 1e3 * gamma(m + 2) * float(np.linalg.norm(T))
            slack = err + h * derr + 0.5 * curv * h * h + floor
            if low > slack:
                margin = min(margin, low / slack)
                continue
            # T(mid) itself within its error bound of a singular matrix: every
            # interval about mid fails too (no halving can exclude a root there)
            hopeless = float(np.linalg.svd(T, compute_uv=False)[-1]) < 0.5 * (err + floor)
            if hopeless or evals > 400 or h < 1e-12 * max(abs(mid), 1.0):
                return Decision.UNDECIDED, max(low, 0.0) / slack, (
                    f"strip of {m}: a real root cannot be excluded near x = {mid:.9g}")
            todo += [(lo, mid), (mid, hi)]
        return Decision.COMPLEX, margin, ""

    # first the projected cluster alone (no sparse solve): its eigenvalues are
    # the root estimates; tried only where its error leaves room (a float
    # estimate of min sigma_min(Tc - x) over the estimates' real parts)
    xs = np.clip(lam_p.real, a_lo, a_hi)
    room = min(float(np.linalg.svd(Tc - x * np.eye(m), compute_uv=False)[-1]) for x in xs)
    if room > 2 * err0:
        projected[0] = True
        roots_p = np.sort(lam_p.real)
        if np.all(lam_p.imag == 0) and np.all(np.diff(roots_p) > 0):
            result = all_real(roots_p)
        else:
            result = no_real_root_projected()
        projected[0] = False
        if result[0] is Decision.COMPLEX:
            return result[0], result[1], lam_p, result[2], False
        if result[0] is Decision.REAL:
            return result[0], result[1], roots_p.astype(complex), result[2], False

    # the deflated route: one sparse LU per piece of the strip; the routes
    # below (a sparse LU per evaluation) only where it leaves the strip undecided
    deflated = decide_deflated(ctx, buf, I, a_lo, a_hi, lo_edge, hi_edge)
    if deflated[0] is not Decision.UNDECIDED:
        return deflated + (False,)
    if floor_bound and deflated[2] is not None and unresolved(deflated[2], lip, rho):
        return floor_undecided(deflated[2], "its deflated complement")

    def linearised(xc, T1, D1):
        """Roots of det(T(xc) + (x - xc) T'(xc)) = 0 (None if not finite)."""
        try:
            est = sla.eigvals(T1 - xc * D1, -D1)
        except (np.linalg.LinAlgError, ValueError):
            return None
        return est if np.all(np.isfinite(est)) else None

    cover_done = None
    if not np.all(lam_p.imag == 0):
        # the projected cluster has a complex pair: the cover first, and the
        # estimates from its solves (T and T' at the evaluated point nearest
        # the pair, re-linearised once), not from four solves of their own
        cover_done = no_real_root()
        if cover_done[0] is Decision.COMPLEX and evaluated:
            x0 = float(np.mean(lam_p.real))
            xc = min(evaluated, key=lambda x: abs(x - x0))
            est = linearised(xc, *evaluated[xc])
            if est is not None:
                x1 = float(np.clip(np.mean(est.real), a_lo, a_hi))
                T1, _, D1, _ = schur(x1, deriv=True)
                est1 = linearised(x1, T1, D1) if T1 is not None else None
                est = est1 if est1 is not None else est
            return cover_done[0], cover_done[1], est if est is not None else lam_p, "", False

    # the strip's eigenvalues: fixed point of x = eig(T(x) + x) from the Ritz values
    # (the projected cluster's when its coupling to the rest is below the
    # error of any solve, err0 <= 2 rho: a solve would not move them)
    negligible = err0 <= 2 * rho
    T0, _ = (Tc - 0.5 * (a_lo + a_hi) * np.eye(m), None) if negligible else \
        schur(0.5 * (a_lo + a_hi))
    if T0 is None:
        return (Decision.UNDECIDED, 0.0, lam0, "the bordered system of the strip is singular",
                False)
    lam_c = np.linalg.eigvals(T0 + 0.5 * (a_lo + a_hi) * np.eye(m))
    # the roots of det T(x) = 0, estimated from T linearised about the cluster's
    # centre xc: det(T(xc) + (x - xc) T'(xc)) = 0, a generalized eigenproblem
    for _ in range(0 if negligible else 4):
        xc = float(np.clip(np.mean(lam_c.real), a_lo, a_hi))
        T1, _, D1, _ = schur(xc, deriv=True)
        if T1 is None:
            break
        try:
            est = sla.eigvals(T1 - xc * D1, -D1)
        except (np.linalg.LinAlgError, ValueError):
            break
        if not np.all(np.isfinite(est)):
            break
        lam_c = est

    # the route the estimates suggest first, then the other one
    roots = np.sort(lam_c.real)
    distinct = bool(np.all(np.diff(roots) > 0))
    first_real = bool(np.all(lam_c.imag == 0))
    tries = ([all_real] if first_real else []) + [no_real_root] + \
        ([all_real] if distinct and not first_real else [])
    result = (Decision.UNDECIDED, 0.0, f"strip of {m}: no distinct root estimates")
    for route in tries:
        if route is no_real_root and cover_done is not None:
            result = cover_done          # (tried above, undecided)
        else:
            result = route(roots) if route is all_real else route(roots if first_real else ())
        if result[0] is not Decision.UNDECIDED:
            break
    if result[0] is Decision.REAL:
        lam_c = roots.astype(complex)       # certified real: the estimates' real parts
    if result[0] is Decision.UNDECIDED and estimates is not None:
        box = in_a_box(lam_c)
        if box[0] is Decision.COMPLEX:
            return box[0], box[1], box[3], "", False
        if box[2]:
            result = (result[0], result[1], f"{result[2]}; {box[2]}")
    return result[0], result[1], lam_c, result[2], False


def arpack_hint(A, a_lo, a_hi, m):
    """What ARPACK sees in an undecided strip [a_lo, a_hi] of m eigenvalues: a
    note for its reason, marked not certified ('' if ARPACK fails), and the
    estimates with real part in the strip (ndarray of complex, by real part).

    The 2 m + 6 eigenvalues of A nearest the strip's centre (shift-invert;
    not asked for a strip of more than ``WHOLE_MAX``);
    those with real part in the strip are counted (a complex pair far from the
    real axis may be missed: the note says how many of the m were seen) and
    the complex ones named. Nothing is decided from it.
    """
    n = A.shape[0]
    k = min(2 * m + 6, n - 2)
    none = np.zeros(0, complex)
    if k < 1:
        return "", none
    if m > WHOLE_MAX:
        # (thousands of eigenvalues by shift-invert: more than the scan costs)
        return f"ARPACK not asked (a strip of more than {WHOLE_MAX})", none
    c = 0.5 * (a_lo + a_hi)
    try:
        lu = spla.splu(sp.csc_matrix(A - c * sp.identity(n, format="csr")))
        op = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
        # a fixed start vector: the note does not depend on earlier ARPACK calls
        nu = spla.eigs(op, k=k, which="LM", return_eigenvectors=False, maxiter=50 * n,
                       v0=np.random.default_rng(0).standard_normal(n))
    except (RuntimeError, spla.ArpackError):
        return "", none
    lam = c + 1.0 / nu
    inside = lam[(lam.real >= a_lo) & (lam.real <= a_hi)]
    cx = inside[inside.imag > 0]
    note = f"ARPACK, not certified: {inside.size} of its {m} eigenvalues seen, "
    inside = inside[np.lexsort((inside.imag, inside.real))]
    if not cx.size:
        return note + "none complex", inside
    z = cx[int(np.argmax(cx.imag))]
    return note + f"{cx.size} complex pair(s), e.g. {z.real:.6g} +- {z.imag:.4g}i", inside


def strips_decision(S, eps, pairs, lam, margins, complex_margins, undecided_margins, reason,
                      scanned_below, timing):
    """The SpectrumDecision of a finished (stopped, or failed) scan of S from what
    its strips and boundaries found (:meth:`.scan.SlicedScan.decision`; the merge of a
    partitioned scan's parts, :func:`.parts.merged_decision`)."""
    n = S.shape[0]
    lam = np.asarray(lam, complex)
    lam = lam[np.lexsort((lam.imag, lam.real))] if lam.size else lam
    if complex_margins and math.isfinite(scanned_below):
        note = ("the scan stopped at the first strip certified complex" if not reason
                else f"the slicing failed above a strip certified complex: {reason}")
        return SpectrumDecision(True, max(complex_margins), pairs, eps, lam, timing, note,
                                start="sliced", n_total=n,
                                scanned_below=float(scanned_below),
                                lambda_max=top_eigenvalue(S))
    if reason:
        return SpectrumDecision(None, 0.0, pairs, 0.0, lam, timing, reason, start="sliced",
                                n_total=n)
    if complex_margins:
        return SpectrumDecision(True, max(complex_margins), pairs, eps, lam, timing,
                                start="sliced", n_total=n)
    if undecided_margins:
        bad = [p.reason for p in pairs if not p.certified]
        why = bad[0] if len(bad) == 1 else (
            f"{len(bad)} undecided strips: " + " | ".join(bad[:3])
            + (f" | and {len(bad) - 3} more" if len(bad) > 3 else ""))
        return SpectrumDecision(None, min(undecided_margins), pairs, eps, lam, timing,
                                why, start="sliced", n_total=n)
    return SpectrumDecision(False, min(margins) if margins else math.inf, pairs,
                            eps, lam, timing, start="sliced", n_total=n)
