r"""The shape of the coalescing pair's mode: collective or carried by a few particles.

At the first load certified complex, the pair lambda_c, conj(lambda_c) has a
right eigenvector q of M^-1 K (displacements and rotations of the kept
particles, rattlers at zero). Its translations u_i (2 per disk, 3 per
sphere; rotations left out) give the participation ratio

.. math::

    \mathrm{PR} = \frac{\left(\sum_i |u_i|^2\right)^2}{N \sum_i |u_i|^4},

1 when every particle moves equally, 1/N when one particle carries the mode
(Bell & Dean, Discuss. Faraday Soc. 50, 55 (1970), the measure of mode
localization in glasses). N PR is the effective number of particles that
move. A pair carried by one weakly held particle (a disk with two contacts
whose own 3 x 3 block is near its exceptional point) is a *local* onset:
it tells nothing about the collective mechanism of the paper, and its load
is an extreme value over the particles of the packing.

The eigenvector is computed by ARPACK shift-invert about lambda_c (complex
shift, sparse LU of M^-1/2 K M^-1/2 - lambda_c), or densely for tiny
systems; it is an approximation (its residual is returned), used to
describe the mode, never to decide.

Whether the mode is a long plane wave is measured by its *long-wave
fraction*: the part of sum |u_i|^2 that lies, component by component, in
the span of the plane waves exp(i k x_i), k = 2 pi m / L_x, |m| <= m_max
(default 3: the longest waves the box, periodic in x, holds). For a
random vector on N particles it is (2 m_max + 1) / N on average (the
dimension of the span over that of the space); a mode made of those waves
has 1. A candidate mechanism for F_x^c falling with N is the near
degeneracy of long-wavelength modes (exact in tiled packings,
docs/results/ensemble.md); this fraction tells whether the first pair is
such a mode.
"""
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from remote_trigger.analysis.errors import is_integer

__all__ = ["PairMode", "pair_mode", "participation_ratio", "long_wave_fraction"]

#: the longest plane waves of the long-wave fraction: |m| <= LONG_WAVE_M
LONG_WAVE_M = 3

#: below this many kept dofs the eigenvector comes from a dense eig
_DENSE_BELOW = 64


@dataclass
class PairMode:
    """The mode of a complex pair (:func:`pair_mode`).

    Attributes
    ----------
    eigenvalue : complex
        The eigenvalue of M^-1 K nearest the requested one (1/time^2).
    translations : ndarray of complex, shape (N, 2) or (N, 3)
        u_i of every particle (rattlers 0), normalised to sum |u_i|^2 = 1.
    participation_ratio : float
        PR of the translations (module docstring), in [1/N, 1].
    n_particles : float
        N PR: the effective number of particles that move.
    residual : float
        ||A v - lambda v|| / (||A||_1 ||v||) of the mass-weighted eigenvector v.
    long_wave : float
        :func:`long_wave_fraction` of the translations (|m| <= LONG_WAVE_M),
        in [0, 1]; a random vector has (2 LONG_WAVE_M + 1) / N on average.
    """

    eigenvalue: complex
    translations: np.ndarray
    participation_ratio: float
    n_particles: float
    residual: float
    long_wave: float = float("nan")


def participation_ratio(u):
    """PR = (sum |u_i|^2)^2 / (N sum |u_i|^4) of per-particle vectors.

    Parameters
    ----------
    u : array_like, shape (N, d)
        One vector (real or complex) per particle.

    Returns
    -------
    float
        In [1/N, 1]; NaN for a zero vector.

    Raises
    ------
    ValueError
        If ``u`` is not two-dimensional or has no rows.
    """
    u = np.asarray(u)
    if u.ndim != 2 or u.shape[0] == 0:
        raise ValueError(f"participation_ratio needs an (N, d) array with N >= 1, "
                         f"got shape {u.shape}")
    w = np.sum(np.abs(u) ** 2, axis=1)
    s4 = float(np.sum(w * w))
    return float(np.sum(w) ** 2 / (u.shape[0] * s4)) if s4 > 0 else float("nan")


def long_wave_fraction(u, x, L_x, m_max=LONG_WAVE_M):
    """Fraction of sum |u_i|^2 in the span of the plane waves exp(i k x_i).

    Parameters
    ----------
    u : array_like, shape (N, d)
        One vector (real or complex) per particle.
    x : array_like, shape (N,)
        The particles' x coordinates (length).
    L_x : float
        The periodic box length along x (length), > 0: one number, e.g.
        ``state.box_length[0]`` (not the whole ``box_length``).
    m_max : int, optional
        Waves k = 2 pi m / L_x with |m| <= m_max (default 3); an integer >= 0
        (Python or numpy).

    Returns
    -------
    float
        sum over the d components of ||P u_a||^2 / sum |u_i|^2, P the
        orthogonal projector onto the span of the 2 m_max + 1 vectors
        (exp(i k x_i))_i: in [0, 1], 1 for a combination of those waves,
        (2 m_max + 1) / N on average for a random vector. NaN for a zero
        ``u``.

    Raises
    ------
    ValueError
        If the shapes disagree, ``L_x`` is not one positive finite number (a
        box length of several entries is named), ``m_max`` is not an integer
        >= 0, or 2 m_max + 1 > N (the waves span everything).
    """
    u = np.asarray(u)
    x = np.asarray(x, np.float64).reshape(-1)
    if u.ndim != 2 or u.shape[0] != x.size:
        raise ValueError(f"long_wave_fraction needs u of shape (N, d) and x of N values, "
                         f"got {u.shape} and {x.size}")
    L = np.asarray(L_x)
    if L.size > 1:
        # (box_length (L_x, L_y) was "the truth value of an array is ambiguous")
        raise ValueError(f"long_wave_fraction needs L_x, one number, got an array of shape "
                         f"{L.shape} ({L_x!r}): give L_x = box_length[0]")
    if (L.size != 1 or L.dtype.kind not in "iuf" or isinstance(L_x, (bool, np.bool_))
            or not (np.isfinite(L) and L > 0)):
        raise ValueError(f"long_wave_fraction needs a positive box length, got L_x = {L_x!r}")
    L_x = float(L.reshape(()))
    if not is_integer(m_max) or m_max < 0:
        # (m_max = -1 gave 0.0, m_max = 1.5 the value of m_max = 1)
        raise ValueError(f"long_wave_fraction needs m_max, an integer >= 0, got "
                         f"m_max = {m_max!r}")
    m = np.arange(-int(m_max), int(m_max) + 1)
    if m.size > x.size:
        raise ValueError(f"long_wave_fraction: {m.size} waves for {x.size} particles")
    norm2 = float(np.sum(np.abs(u) ** 2))
    if norm2 == 0.0:
        return float("nan")
    Q, _ = np.linalg.qr(np.exp(1j * np.outer(x, 2.0 * np.pi * m / L_x)))
    return float(np.sum(np.abs(Q.conj().T @ u) ** 2) / norm2)


def pair_mode(state, eigenvalue):
    """Right eigenvector of M^-1 K at ``eigenvalue`` and its participation ratio.

    Parameters
    ----------
    state : State or State3D
        An equilibrium (disks: 3 dofs each; spheres: 6); rattlers removed as
        by :func:`~remote_trigger.analysis.stability.system.reduced_system`.
    eigenvalue : complex or sequence of two floats
        lambda_c (1/time^2): one eigenvalue of a complex pair, so Im != 0
        (either sign); a complex number, or ``[Re, Im]`` as the ensemble
        stores ``lambda_c``.

    Returns
    -------
    PairMode
        The mode of the eigenvalue nearest ``eigenvalue``.

    Raises
    ------
    ValueError
        If every particle is a rattler, ``eigenvalue`` is not a number or a
        pair of real numbers, is not finite, or is real (Im = 0: no pair;
        the mode of a real eigenvalue is not what this describes).

    Warns
    -----
    UserWarning
        If the eigenvalue found nearest is real to round-off (|Im| <= 64 eps
        ||A||_1): no complex pair lies nearest the value given, and the
        result is the mode of a real eigenvalue.
    """
    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.state3d import State3D

    val = np.asarray(eigenvalue)
    if val.shape == (2,) and np.isrealobj(val) and val.dtype.kind in "fiu":
        sigma = complex(float(val[0]), float(val[1]))          # [Re, Im]
    elif val.shape == () and val.dtype.kind in "fiuc":
        sigma = complex(val)
    else:
        raise ValueError(f"pair_mode needs a complex number or [Re, Im], got "
                         f"eigenvalue = {eigenvalue!r}")
    if not np.isfinite(sigma):
        raise ValueError(f"pair_mode needs a finite eigenvalue, got {eigenvalue!r}")
    if sigma.imag == 0.0:
        # (it returned the mode of the nearest eigenvalue, a real one, as a pair's)
        raise ValueError(f"pair_mode needs an eigenvalue of a complex pair (Im != 0), got "
                         f"eigenvalue = {eigenvalue!r}")
    res = reduced_system(state)
    keep = np.asarray(res.keep_dofs, np.int64)
    if keep.size == 0:
        raise ValueError("pair_mode: every particle is a rattler")
    Kr, mr = res.K, res.mass
    A = sp.csc_matrix(eigen.dynamical_matrix(Kr, mr))
    n = A.shape[0]
    if n < _DENSE_BELOW:
        lam, V = np.linalg.eig(A.toarray())
        j = int(np.argmin(np.abs(lam - sigma)))
        lam_j, v = complex(lam[j]), V[:, j]
    else:
        lu = spla.splu((A - sigma * sp.identity(n, format="csc")).astype(complex).tocsc())
        op = spla.LinearOperator((n, n), matvec=lu.solve, dtype=complex)
        # a fixed start vector: ARPACK's own is random, and the mode's
        # participation ratio then moved in its last digits from run to run
        # (an ensemble's table differed between a run and its resume)
        v0 = np.random.default_rng(0).standard_normal(n).astype(complex)
        nu, V = spla.eigs(op, k=min(4, n - 2), which="LM", v0=v0)
        lam_all = sigma + 1.0 / nu
        j = int(np.argmin(np.abs(lam_all - sigma)))
        lam_j, v = complex(lam_all[j]), V[:, j]
    v = v / np.linalg.norm(v)
    a1 = float(spla.norm(A, 1))
    resid = float(np.linalg.norm(A @ v - lam_j * v) / max(a1, 1e-300))
    if abs(lam_j.imag) <= 64.0 * np.finfo(float).eps * a1:
        warnings.warn(f"pair_mode: the eigenvalue nearest {sigma!r} is real ({lam_j.real!r}): "
                      f"no complex pair there; the mode returned is a real eigenvalue's",
                      UserWarning, stacklevel=2)
    spheres = isinstance(state, State3D)
    per = 6 if spheres else 3
    full = res.expand(v / np.sqrt(mr))    # q = M^-1/2 v (a rigid layer: its translation on each)
    u = full.reshape(state.n, per)[:, :(3 if spheres else 2)]
    u = u / np.linalg.norm(u)
    pr = participation_ratio(u)
    lw = long_wave_fraction(u, state.positions[:, 0], float(state.box_length[0]))
    return PairMode(lam_j, u, pr, pr * state.n, resid, lw)
