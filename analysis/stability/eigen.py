r"""Eigenvalues of the mass-weighted stiffness M^{-1} K, frequencies and growth rates.

Linear motion about an equilibrium obeys :math:`M\ddot q = -K q`; with
:math:`q \propto e^{i\omega t}` this gives :math:`M^{-1}K v = \lambda v`,
:math:`\omega = \pm\sqrt{\lambda}` (paper Eqs. 5-6). K is real and not
symmetric, so eigenvalues are real or come in complex-conjugate pairs
:math:`\lambda_R \pm i\lambda_I`; then one of :math:`\pm\sqrt{\lambda}` has
a negative imaginary part and the mode grows as
:math:`e^{|\operatorname{Im}\omega| t}` — the growth rate is
:math:`\max |\operatorname{Im}\sqrt{\lambda}|` and the mean-square
displacement grows as :math:`e^{2\max|\operatorname{Im}\omega|\,t}` (Eq. 8).

Two paths:

* :func:`dense_eigen` — LAPACK ``geev`` through :func:`scipy.linalg.eig` with
  left and right eigenvectors and the eigenvalue condition numbers
  :math:`\kappa_i = \|y_i\|\|x_i\|/|y_i^H x_i|`; for systems up to a few
  thousand degrees of freedom.
* :func:`sparse_eigen` — ARPACK in shift-invert mode
  (:func:`scipy.sparse.linalg.eigs` with ``sigma``), the k eigenvalues closest
  to the shift, for large N; :func:`band_scan` repeats it over several shifts.
  Where to put the shifts is discussed in ``docs/analysis.md`` ("Where the
  coalescence happens"): on the N = 100 ramps the pairs that coalesce at and
  above F_x^c lie in the *interior* of the spectrum, lambda ~ 0.05 - 0.3
  lambda_max (rank 15 - 50 % from the bottom), never among the softest modes
  nor at the top; :data:`COALESCENCE_BAND` gives that band in units of the
  largest diagonal entry of M^-1 K, widened to 0.8 because packings relaxed
  with friction (not the default protocol) have pairs up to 0.71.

Mass weighting uses the inertia that the dynamics uses, M = diag(m, m, I/R²)
= diag(m, m, m/2) per disk (docs/model.md section 1, ``fix nve/sphere disc``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from remote_trigger.analysis.errors import is_integer, is_real

__all__ = ["dynamical_matrix", "EigenResult", "dense_eigen", "sparse_eigen", "band_scan",
           "default_shift",
           "eigenvalues", "frequencies", "growth_rate", "condition_numbers",
           "damped_growth_rate", "DENSE_MAX", "COALESCENCE_BAND"]

#: above this many degrees of freedom :func:`eigenvalues` uses the sparse path
DENSE_MAX = 3000

#: where complex pairs are born on the N = 100 ramps, as fractions of the largest
#: diagonal entry of M^-1 K (docs/analysis.md, "Where the coalescence happens")
COALESCENCE_BAND = (0.05, 0.8)


def _check_mass(mass, n):
    mass = np.asarray(mass, dtype=np.float64)
    if mass.shape != (n,):
        raise ValueError(f"mass has shape {mass.shape}, K is {n} x {n}: the diagonal of M "
                         f"must have shape ({n},)")
    if not np.all(np.isfinite(mass)) or np.any(mass <= 0):
        k = int(np.argmax(~np.isfinite(mass) | (mass <= 0)))
        raise ValueError(f"mass diagonal must be finite and > 0, entry {k} is {float(mass[k])!r}")
    return mass


def dynamical_matrix(K, mass):
    """M^{-1} K for a diagonal mass matrix.

    Parameters
    ----------
    K : sparse matrix or ndarray, shape (n, n)
        Stiffness K = -dG/dq (force/length).
    mass : array_like, shape (n,)
        Diagonal of M (m, m, I/R^2 per disk).

    Returns
    -------
    Same kind as K (CSR if sparse), shape (n, n); units 1/time^2.

    Raises
    ------
    ValueError
        If K is not a real square matrix (sparse or array_like), not finite,
        or the masses are not positive.
    """
    if not sp.issparse(K):
        K = np.asarray(K)
    if np.iscomplexobj(K):
        # (it was cast to its real part, with a ComplexWarning)
        raise ValueError("K must be real (K = -dG/dq of a real force), got a complex matrix")
    if K.ndim != 2 or K.shape[0] != K.shape[1]:
        raise ValueError(f"K must be square, got shape {K.shape}")
    n = K.shape[0]
    mass = _check_mass(mass, n)
    if sp.issparse(K):
        Kc = K.tocsr().astype(np.float64)
        if not np.all(np.isfinite(Kc.data)):
            raise ValueError("K has non-finite entries")
        return sp.diags(1.0 / mass).dot(Kc).tocsr()
    K = np.asarray(K, dtype=np.float64)
    if not np.all(np.isfinite(K)):
        raise ValueError("K has non-finite entries")
    return K / mass[:, None]


def frequencies(lam):
    """omega = +-sqrt(lambda) (Eq. 6).

    Parameters
    ----------
    lam : array_like, complex, shape (k,)

    Returns
    -------
    ndarray, complex, shape (k, 2)
        Columns +sqrt(lambda) (principal root, Re >= 0) and -sqrt(lambda).

    Raises
    ------
    ValueError
        If ``lam`` is not 1-D.
    """
    w = np.sqrt(np.asarray(lam, dtype=np.complex128))
    if w.ndim != 1:
        raise ValueError(f"lam must have shape (k,), got shape {w.shape}")
    return np.column_stack([w, -w])


def growth_rate(lam):
    """max |Im omega| over omega = +-sqrt(lambda); 0 for an all-real positive spectrum.

    A negative real lambda (static instability) also gives a growth rate
    sqrt(-lambda).

    Parameters
    ----------
    lam : array_like, complex

    Returns
    -------
    float, 1/time units.
    """
    lam = np.asarray(lam, dtype=np.complex128)
    if lam.size == 0:
        return 0.0
    return float(np.max(np.abs(np.sqrt(lam).imag)))


def condition_numbers(left, right):
    """Eigenvalue condition numbers kappa_i = ||y_i|| ||x_i|| / |y_i^H x_i|.

    Parameters
    ----------
    left, right : ndarray, shape (n, k)
        Left and right eigenvectors (columns), any normalisation.

    Returns
    -------
    ndarray, shape (k,)
        >= 1; inf where y^H x vanishes (a defective eigenvalue, i.e. an
        exceptional point).
    """
    num = np.linalg.norm(left, axis=0) * np.linalg.norm(right, axis=0)
    den = np.abs(np.einsum("ik,ik->k", left.conj(), right))
    with np.errstate(divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.inf)


@dataclass
class EigenResult:
    """Eigenvalues of M^{-1} K with their diagnostics.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (k,)
        Sorted by real part, then imaginary part.
    right, left : ndarray, complex, shape (n, k) or None
        Right (A x = lambda x) and left (y^H A = lambda y^H) eigenvectors of
        A = M^{-1} K, unit 2-norm columns, same order.
    kappa : ndarray, shape (k,) or None
        Eigenvalue condition numbers (see :func:`condition_numbers`).
    method : str
        ``'dense'``, ``'arpack-shift-invert'`` or ``'sliced'`` (the Ritz values of
        the symmetric part and strip block eigenvalues of
        :func:`~remote_trigger.analysis.stability.sliced.classify_sliced`:
        approximations within their certified strips, not enclosures).
    sigma : float or None
        Shift used by the sparse path.
    """

    eigenvalues: np.ndarray
    right: np.ndarray | None = None
    left: np.ndarray | None = None
    kappa: np.ndarray | None = None
    method: str = "dense"
    sigma: float | None = None

    @property
    def omega(self):
        """Frequencies, shape (k, 2): +sqrt(lambda), -sqrt(lambda)."""
        return frequencies(self.eigenvalues)

    @property
    def growth_rate(self):
        """max |Im omega| (1/time)."""
        return growth_rate(self.eigenvalues)

    def complex_mask(self, rtol=0.0):
        """Eigenvalues whose computed imaginary part is nonzero (|Im| > rtol |lambda|).

        This is what LAPACK returned, not a decision: near an exceptional
        point use :mod:`remote_trigger.analysis.stability.exceptional`.
        """
        lam = self.eigenvalues
        return np.abs(lam.imag) > rtol * np.abs(lam)


def _sort(lam, *vecs):
    order = np.lexsort((lam.imag, lam.real))
    return (lam[order],) + tuple(None if v is None else v[:, order] for v in vecs)


def dense_eigen(K, mass, vectors=True):
    """All eigenvalues of M^{-1} K by LAPACK (``dgeev``), with left/right vectors.

    Parameters
    ----------
    K : sparse matrix or ndarray, shape (n, n)
    mass : array_like, shape (n,)
    vectors : bool, optional
        Also return left/right eigenvectors and condition numbers (default).

    Returns
    -------
    EigenResult

    Raises
    ------
    ValueError
        Bad shapes, non-finite K, non-positive masses.
    """
    A = dynamical_matrix(K, mass)
    if sp.issparse(A):
        A = A.toarray()
    if A.shape[0] == 0:
        return EigenResult(np.zeros(0, complex), method="dense")
    if not vectors:
        lam = sla.eigvals(A, check_finite=False)
        return EigenResult(_sort(lam.astype(np.complex128))[0], method="dense")
    lam, vl, vr = sla.eig(A, left=True, right=True, check_finite=False)
    lam = lam.astype(np.complex128)
    lam, vl, vr = _sort(lam, vl.astype(np.complex128), vr.astype(np.complex128))
    vl = vl / np.linalg.norm(vl, axis=0)
    vr = vr / np.linalg.norm(vr, axis=0)
    return EigenResult(lam, vr, vl, condition_numbers(vl, vr), "dense")


def sparse_eigen(K, mass, k=12, sigma=0.0, left=False, tol=0.0, maxiter=None, v0=None):
    """The k eigenvalues of M^{-1} K closest to ``sigma`` (ARPACK shift-invert).

    Parameters
    ----------
    K : sparse matrix, shape (n, n)
    mass : array_like, shape (n,)
    k : int, optional
        Number of eigenvalues (< n - 1).
    sigma : float, optional
        Real shift (1/time^2); ARPACK iterates with (A - sigma I)^{-1} (sparse
        LU), so it returns the eigenvalues nearest sigma in the complex plane.
        Default 0: the soft end of the spectrum. Complex pairs are born in
        the interior (``docs/analysis.md``; :func:`band_scan`). sigma must not
        be an eigenvalue; with rattlers left in, 0 is one.
    left : bool, optional
        Also compute left eigenvectors (a second ARPACK run on A^T) and the
        condition numbers; eigenvalues are matched by nearest value.
    tol : float, optional
        ARPACK relative tolerance (0 = machine precision).
    maxiter : int, optional
    v0 : ndarray, shape (n,), optional
        Starting vector (default: ARPACK's random start).

    Returns
    -------
    EigenResult
        ``method = 'arpack-shift-invert'``.

    Raises
    ------
    ValueError
        Bad shapes or k out of range, or sigma (numerically) an eigenvalue
        (the shifted matrix is singular).
    """
    A = dynamical_matrix(sp.csr_matrix(K) if not sp.issparse(K) else K, mass)
    n = A.shape[0]
    if not is_integer(k) or not (1 <= k < n - 1):
        raise ValueError(f"k must be an integer with 1 <= k < n - 1 = {n - 1}, got {k!r}")
    if not is_real(sigma) \
            or not np.isfinite(sigma):
        raise ValueError(f"sigma must be a finite real number, got sigma = {sigma!r}")
    if v0 is not None:
        # (ARPACK reads n entries whatever v0 holds: a shorter one crashed the process)
        v0 = np.asarray(v0, dtype=np.float64)
        if v0.shape != (n,) or not np.all(np.isfinite(v0)):
            raise ValueError(f"v0 must be a finite array of shape ({n},), got shape "
                             f"{v0.shape}")
    shifted = (A - sigma * sp.identity(n, format="csr")).tocsc()
    try:
        lu = spla.splu(shifted)
    except RuntimeError as exc:
        raise ValueError(f"sigma = {sigma!r} is an eigenvalue of M^-1 K (singular shifted "
                         f"matrix: {exc}); remove rattlers or move the shift") from None
    opinv = spla.LinearOperator((n, n), matvec=lu.solve, dtype=np.float64)
    lam, vr = spla.eigs(A, k=k, sigma=sigma, OPinv=opinv, tol=tol, maxiter=maxiter, v0=v0)
    lam = lam.astype(np.complex128)
    vr = vr / np.linalg.norm(vr, axis=0)
    vl = kappa = None
    if left:
        opinv_t = spla.LinearOperator((n, n), matvec=lambda b: lu.solve(b, trans="T"),
                                      dtype=np.float64)
        lt, vl_ = spla.eigs(A.T.tocsr(), k=k, sigma=sigma, OPinv=opinv_t, tol=tol,
                            maxiter=maxiter)
        # A real: A^T y = lambda y  <=>  y^T A = lambda y^T, so the left
        # eigenvector in the convention w^H A = lambda w^H is w = conj(y)
        match = np.array([np.argmin(np.abs(lt - lv)) for lv in lam])
        vl = np.conj(vl_[:, match])
        vl = vl / np.linalg.norm(vl, axis=0)
    lam, vr, vl = _sort(lam, vr, vl)
    if vl is not None:
        kappa = condition_numbers(vl, vr)
    return EigenResult(lam, vr, vl, kappa, "arpack-shift-invert", float(sigma))


def default_shift(K, mass):
    """A shift inside the coalescence band: 0.25 x the largest diagonal entry of M^-1 K.

    Returns
    -------
    float, 1/time^2
    """
    A = dynamical_matrix(sp.csr_matrix(K) if not sp.issparse(K) else K, mass)
    return 0.25 * float(np.max(A.diagonal()))


def band_scan(K, mass, lo=None, hi=None, windows=6, k=20, tol=0.0):
    """Shift-invert ARPACK over several shifts spread across a band of the spectrum.

    Complex pairs are born in the interior of the spectrum (docs/analysis.md),
    where a large system has many eigenvalues; one shift only sees the k
    nearest. This runs :func:`sparse_eigen` at ``windows`` shifts evenly
    spaced in [lo, hi] and merges the results (duplicates removed).

    Parameters
    ----------
    K : sparse matrix, shape (n, n)
    mass : array_like, shape (n,)
    lo, hi : float, optional
        Band in 1/time^2; default :data:`COALESCENCE_BAND` times the largest
        diagonal entry of M^-1 K.
    windows : int, optional
        Number of shifts (default 6); cost is one sparse LU and one ARPACK run
        per shift.
    k : int, optional
        Eigenvalues per shift.
    tol : float, optional
        ARPACK tolerance.

    Returns
    -------
    EigenResult
        ``method = 'arpack-band-scan'``, ``sigma`` = the first shift; the
        eigenvalues found (no vectors).
    """
    A = dynamical_matrix(sp.csr_matrix(K) if not sp.issparse(K) else K, mass)
    dmax = float(np.max(A.diagonal()))
    lo = COALESCENCE_BAND[0] * dmax if lo is None else float(lo)
    hi = COALESCENCE_BAND[1] * dmax if hi is None else float(hi)
    if not (hi > lo) or windows < 1:
        raise ValueError(f"need lo < hi and windows >= 1, got lo = {lo!r}, hi = {hi!r}, "
                         f"windows = {windows!r}")
    sigmas = np.linspace(lo, hi, int(windows))
    found = []
    for sg in sigmas:
        found.append(sparse_eigen(K, mass, k=k, sigma=float(sg), tol=tol).eigenvalues)
    lam = np.concatenate(found)
    lam = lam[np.lexsort((lam.imag, lam.real))]
    keep = np.ones(lam.size, bool)
    scale = max(np.abs(lam).max(), 1.0) if lam.size else 1.0
    keep[1:] = np.abs(np.diff(lam)) > 1e-9 * scale
    return EigenResult(lam[keep], method="arpack-band-scan", sigma=float(sigmas[0]))


def eigenvalues(K, mass, method="auto", k=12, sigma=0.0):
    """Eigenvalues of M^{-1} K, dense or sparse by size.

    Parameters
    ----------
    K : sparse matrix or ndarray, shape (n, n)
    mass : array_like, shape (n,)
    method : {'auto', 'dense', 'sparse'}
        'auto' uses the dense path up to :data:`DENSE_MAX` dofs.
    k, sigma
        Passed to :func:`sparse_eigen`.

    Returns
    -------
    EigenResult
    """
    if method not in ("auto", "dense", "sparse"):
        raise ValueError(f"method must be 'auto', 'dense' or 'sparse', got {method!r}")
    n = K.shape[0]
    if method == "dense" or (method == "auto" and n <= DENSE_MAX):
        return dense_eigen(K, mass)
    return sparse_eigen(K, mass, k=k, sigma=sigma)


def damped_growth_rate(K, mass, damping):
    """Largest Re s of the damped linear dynamics M q'' + C q' + K q = 0.

    The quadratic eigenvalue problem (s^2 M + s C + K) x = 0 with diagonal
    M and C, solved through its companion form
    ``[[0, I], [-M^-1 K, -M^-1 C]]`` (dense, 2n x 2n). With C = 0 this is
    max |Im sqrt(lambda)| of :func:`growth_rate`; with C = gamma on every
    translational dof it is the undamped rate lowered by about gamma / 2
    when gamma is small against the pair's frequency (paper Sec. IV).

    Parameters
    ----------
    K : sparse matrix or ndarray, shape (n, n)
        Stiffness matrix (after rattler removal).
    mass : array_like, shape (n,)
        Diagonal of M.
    damping : array_like, shape (n,)
        Diagonal of C (force per velocity), >= 0; ``fix viscous gamma``
        gives gamma on the x and y dofs and 0 on R theta.

    Returns
    -------
    float
        max Re s (1/time): > 0 unstable (growth of the amplitude; D(t)
        grows at twice this rate), < 0 every mode decays.

    Raises
    ------
    ValueError
        Bad shapes, negative damping, non-positive masses, non-finite K.
    """
    A = dynamical_matrix(K, mass)
    if sp.issparse(A):
        A = A.toarray()
    n = A.shape[0]
    mass = _check_mass(mass, n)
    c = np.asarray(damping, dtype=np.float64)
    if c.shape != (n,):
        raise ValueError(f"damping must have shape ({n},), got {c.shape}")
    if np.any(c < 0) or not np.all(np.isfinite(c)):
        raise ValueError("damping must be finite and >= 0")
    if n == 0:
        return 0.0
    Z = np.zeros((2 * n, 2 * n))
    Z[:n, n:] = np.eye(n)
    Z[n:, :n] = -A
    Z[n:, n:] = -np.diag(c / mass)
    s = sla.eigvals(Z, check_finite=False)
    return float(np.max(s.real))
