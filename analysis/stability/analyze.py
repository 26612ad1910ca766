"""One call from an equilibrium to its spectrum: K, rattlers, eigenvalues, decision.

This is the entry point for the ramp and the command line::

    from remote_trigger.analysis.stability.analyze import analyze, analyze_dump
    res = analyze_dump("eq.dump")            # sidecar eq.dump.json gives k_n, k_t, mu, wall_y
    res.decision.complex_present, res.growth_rate, res.rattlers.ids

Steps: assemble K = -dG/dq (``jacobian.stiffness_matrix``, paper Appendix C),
remove rattlers iteratively (``jacobian.find_rattlers``, frictional criterion
of fewer than 2 contacts), form M^-1 K with M = diag(m, m, I/R^2), compute
its eigenvalues and decide whether a complex pair is present, on the whole
spectrum: dense LAPACK with the certified test of ``exceptional`` up to
``eigen.DENSE_MAX`` dofs, above it the certified verdict by spectrum
slicing of ``sliced``. ``method='sparse'`` asks instead for the *partial*
decision of ``projected`` on the k eigenvalues nearest a shift (labelled
partial, not a verdict).

A :class:`~remote_trigger.analysis.state.state3d.State3D` (spheres) takes
the same steps with the 3D Jacobian (``jacobian3d``: 6 dofs per sphere,
rattlers below 3 contacts, M = diag(m, m, m, 2m/5, 2m/5, 2m/5));
:func:`analyze_dump` reads a dump of spheres with ``read_dump3d``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from remote_trigger.analysis.errors import is_integer, is_real
from remote_trigger.analysis.stability import eigen as _eigen
from remote_trigger.analysis.stability import exceptional as _exc
from remote_trigger.analysis.stability import jacobian as _jac
from remote_trigger.analysis.stability import jacobian3d as _jac3
from remote_trigger.analysis.stability import projected as _proj
from remote_trigger.analysis.stability import sliced as _sliced
from remote_trigger.analysis.state.dumpfile import dump_dimension, read_dump, read_dump3d
from remote_trigger.analysis.state.state3d import State3D

__all__ = ["Analysis", "analyze", "analyze_dump", "roundoff_floor", "check_equilibrium",
           "max_residual", "negative_modes", "NEGATIVE_REL"]

#: a residual this many times the round-off floor is "far above" it: the state
#: is not the equilibrium of the parameters it is analysed with
FAR_ABOVE_FLOOR = 1e3
#: smallest floor used (the driver's smallest acceptance level, 1e-10)
FLOOR_MIN = 1e-10
#: floor = ROUNDOFF_FACTOR eps X k_eff (the driver's acceptance level, docs/driver.md)
ROUNDOFF_FACTOR = 4.0


@dataclass
class Analysis:
    """Result of :func:`analyze`.

    Attributes
    ----------
    state : State or State3D
    K : scipy.sparse.csr_matrix, shape (n, n)
        Full stiffness (rattlers kept); n = 3N for disks, 6N for spheres.
    mass : ndarray, shape (n,)
        Diagonal of M.
    rattlers : RattlerResult
        Removed disks or spheres (ids, indices) and the kept dofs.
    eigen : EigenResult or None
        Eigenvalues of M^-1 K restricted to the kept dofs.
    decision : SpectrumDecision or None
        Certified complex-pair decision (None if not requested).
    residual : ndarray, shape (n,)
        G = contact + external forces (zero at equilibrium). :func:`analyze`
        does not check it: a state far from equilibrium gets a spectrum and
        a verdict all the same; check first with :func:`check_equilibrium`
        (what the command line does).
    """

    state: object
    K: object
    mass: np.ndarray
    rattlers: object
    eigen: object
    decision: object
    residual: np.ndarray

    @property
    def eigenvalues(self):
        """Eigenvalues of M^-1 K after rattler removal (complex, sorted by real part)."""
        return None if self.eigen is None else self.eigen.eigenvalues

    @property
    def growth_rate(self):
        """max |Im sqrt(lambda)| (1/time) of the eigenvalues computed; 0 if they are all
        real and positive. On the sparse path (``method='sparse'``) only the k
        nearest ``sigma`` are computed: then it is theirs, not the spectrum's."""
        return None if self.eigen is None else self.eigen.growth_rate

    @property
    def max_residual(self):
        """max over disks of max(|F_i|, |T_i|/R_i) including the loads."""
        return max_residual(self.residual, isinstance(self.state, State3D))


def max_residual(G, spheres=False):
    """r = max_i max(|F_i|, |T_i|/R_i) of generalized forces G.

    Parameters
    ----------
    G : ndarray, shape (3N,) or (6N,)
        (F_x, F_y, T/R) per disk, or (F, T/R) per sphere (force units),
        flat in dof order (as ``generalized_forces`` / ``generalized_forces3d``
        give it), N >= 1, every value finite.
    spheres : bool
        G is that of spheres.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If ``G`` is not a flat array whose length is a positive multiple of
        3 (disks) or 6 (spheres), or holds a non-finite value.
    """
    per, what = (6, "(F, T/R) per sphere") if spheres else (3, "(F_x, F_y, T/R) per disk")
    try:
        G = np.asarray(G, np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"max_residual needs G, an array of numbers, got "
                         f"{type(G).__name__}") from None
    if G.ndim != 1 or G.size == 0 or G.size % per:
        # (a length-5 G was a raw reshape error, an empty one numpy's "zero-size
        # array to reduction", a (2, 3) array was taken as two disks)
        raise ValueError(f"max_residual needs G of shape ({per}N,) with N >= 1, {what} in "
                         f"dof order, got shape {G.shape}")
    bad = np.flatnonzero(~np.isfinite(G))
    if bad.size:
        # (a NaN gave a residual of nan)
        raise ValueError(f"max_residual needs a finite G, got {bad.size} non-finite "
                         f"value(s), the first {G[bad[0]].item()!r} at dof {int(bad[0])}")
    if spheres:
        G = np.asarray(G).reshape(-1, 6)
        return float(max(np.max(np.linalg.norm(G[:, :3], axis=1)),
                         np.max(np.linalg.norm(G[:, 3:], axis=1))))
    G = np.asarray(G).reshape(-1, 3)
    return float(max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2]))))


def roundoff_floor(state):
    r"""Residual that double precision allows for a state, as the driver accepts it.

    .. math::

        r_\mathrm{floor} = \max(10^{-10},\; 4\,\varepsilon\,X\,k_\mathrm{eff}),
        \quad k_\mathrm{eff} = \tfrac32 k_n^{2/3} F^{1/3},

    X the largest coordinate or box length, F the largest external load per
    disk (or, without loads, the largest contact force of the dump, or 1):
    the driver's acceptance level of a stagnating Newton iteration
    (``remote_trigger.pywrap.stages.equilibrium.accept_level``, docs/driver.md).

    Parameters
    ----------
    state : State or State3D

    Returns
    -------
    float
        Force units.
    """
    X = max(float(np.max(np.abs(state.positions))), float(np.max(state.box_hi - state.box_lo)))
    if isinstance(state, State3D):
        F = float(np.max(np.linalg.norm(state.external, axis=1))) if state.n else 0.0
    else:
        F = float(np.max(np.hypot(state.external[:, 0], state.external[:, 1]))) \
            if state.external.size else 0.0
    cf = getattr(state, "contact_forces", None)
    if not F > 0 and cf is not None and cf.size:
        F = float(np.max(np.hypot(state.contact_forces[:, 0], state.contact_forces[:, 1])))
    if not F > 0:
        F = 1.0
    keff = 1.5 * float(state.params.k_n) ** (2.0 / 3.0) * F ** (1.0 / 3.0)
    return max(FLOOR_MIN, ROUNDOFF_FACTOR * np.finfo(float).eps * X * keff)


def check_equilibrium(state, factor=FAR_ABOVE_FLOOR, what=None):
    """Refuse a state whose residual is far above the round-off floor.

    A Jacobian and its spectrum describe the linear motion about an
    equilibrium; at a state that is not one (wrong k_n, mu or loads in the
    sidecar, a dump written with too few digits, a state in motion) they
    describe nothing, and a "complex pair" found there is meaningless.

    Parameters
    ----------
    state : State or State3D
    factor : float
        Refuse above ``factor`` x :func:`roundoff_floor` (default 1e3).
    what : str, optional
        Name of the state in the message (default its source file).

    Returns
    -------
    ratio : float
        Residual / floor.

    Raises
    ------
    NotEquilibriumError
        An ``InputError`` (``ValueError``), naming the residual, the floor
        and what to check.
    ValueError
        If ``factor`` is not a number > 0.
    """
    from remote_trigger.analysis.errors import NotEquilibriumError

    if not is_real(factor) or not factor > 0:
        raise ValueError(f"factor must be a number > 0, got factor = {factor!r}")

    spheres = isinstance(state, State3D)
    G = (_jac3.generalized_forces3d if spheres else _jac.generalized_forces)(state)
    r = max_residual(G, spheres)
    floor = roundoff_floor(state)
    ratio = r / floor
    if not ratio <= factor:
        name = what or state.source or "the state"
        raise NotEquilibriumError(
            f"{name} is not an equilibrium of its parameters: residual max |G| = {r:.3g} "
            f"is {ratio:.3g} x the round-off floor {floor:.3g} (k_n = {state.params.k_n!r},"
            f" k_t = {state.params.k_t!r}, mu = {state.params.mu!r}, F_x = "
            f"{state.F_x!r}, F_y = {state.F_y!r}); check the sidecar and the "
            f"dump's precision (%.17g)")
    return ratio


def analyze(state, eigenvalues=True, decide=True, method="auto", k=12, sigma=None,
            min_contacts=None, progress=None):
    """Stiffness, rattlers, spectrum and complex-pair decision of one state.

    Parameters
    ----------
    state : State or State3D
        Disks, or spheres (then K from ``jacobian3d``).
    eigenvalues : bool, optional
        Compute the eigenvalues (default True).
    decide : bool, optional
        Run the certified complex-pair test (default True; dense and sliced
        paths: the whole spectrum; sparse path: the ``k`` eigenvalues nearest
        ``sigma``, a partial decision).
    method : {'auto', 'dense', 'sliced', 'sparse'}
        'auto': dense up to ``eigen.DENSE_MAX`` dofs, else sliced
        (:func:`~remote_trigger.analysis.stability.sliced.classify_sliced`;
        without ``decide``, ARPACK's k eigenvalues nearest ``sigma``).
    k : int
        Sparse path: number of eigenvalues, >= 1 (the decision takes at
        least 2).
    sigma : float, optional
        Sparse path: shift (1/time^2), finite; default
        :func:`~remote_trigger.analysis.stability.eigen.default_shift`, inside the band
        where pairs coalesce (``docs/analysis.md``).
    min_contacts : int, optional
        Rattler criterion: fewer contacts than this (default 2 for frictional
        disks, 3 for spheres, docs/model.md section 9.1).
    progress : callable, optional
        Sliced path only: ``progress(done, n)`` after each slice (see
        :func:`~remote_trigger.analysis.stability.sliced.classify_sliced`).

    Returns
    -------
    Analysis

    Raises
    ------
    ValueError
        An unknown ``method``, ``k`` not an integer >= 1, ``sigma`` not a
        finite number (checked where eigenvalues are computed), or a shift
        at an eigenvalue (sparse path).
    """
    if isinstance(state, State3D):
        K = _jac3.stiffness_matrix3d(state)
        rat = _jac3.find_rattlers3d(state, min_contacts=3 if min_contacts is None
                                    else min_contacts)
        G = _jac3.generalized_forces3d(state)
    else:
        K = _jac.stiffness_matrix(state)
        rat = _jac.find_rattlers(state, min_contacts=2 if min_contacts is None
                                 else min_contacts)
        G = _jac.generalized_forces(state)
    mass = state.mass_diagonal()
    eig = dec = None
    if eigenvalues and rat.keep_dofs.size:
        Kr, mr = _jac.remove_dofs(K, mass, rat.keep_dofs)
        n = Kr.shape[0]
        if method not in ("auto", "dense", "sliced", "sparse"):
            raise ValueError(f"method must be 'auto', 'dense', 'sliced' or 'sparse', got {method!r}")
        if not is_integer(k) or k < 1:
            raise ValueError(f"k must be an integer >= 1, got k = {k!r}")
        if sigma is not None and not (isinstance(sigma, (int, float, np.floating))
                                      and np.isfinite(sigma)):
            raise ValueError(f"sigma must be a finite number, got sigma = {sigma!r}")
        dense = method == "dense" or (method == "auto" and n <= _eigen.DENSE_MAX)
        sliced = method == "sliced" or (method == "auto" and not dense and decide)
        if sliced:
            # the whole-spectrum verdict by slicing; its eigenvalues are the Ritz
            # values of the symmetric part and the strips' block eigenvalues
            dec = _sliced.classify_sliced(Kr, mr, progress=progress)
            eig = _eigen.EigenResult(np.asarray(dec.eigenvalues, np.complex128), method="sliced")
        elif dense:
            if decide:
                # one LAPACK eigen-solve: the decision's eigenvalues are the spectrum
                dec = _exc.classify_spectrum(_eigen.dynamical_matrix(Kr, mr).toarray())
                eig = _eigen.EigenResult(np.asarray(dec.eigenvalues, np.complex128),
                                         method="dense")
            else:
                eig = _eigen.dense_eigen(Kr, mr, vectors=False)
        else:
            if sigma is None:
                sigma = _eigen.default_shift(Kr, mr)
            if decide:
                # one ARPACK run: the decision's Rayleigh-Ritz values are the k
                # eigenvalues nearest sigma
                dec, _ = _proj.classify_projected(_eigen.dynamical_matrix(Kr, mr), sigma,
                                                  k=max(k, 2))
                eig = _eigen.EigenResult(dec.eigenvalues, method="arpack-shift-invert",
                                         sigma=float(sigma))
            else:
                eig = _eigen.sparse_eigen(Kr, mr, k=k, sigma=sigma)
    return Analysis(state, K, mass, rat, eig, dec, G)


def analyze_dump(path, allow_residual=False, **kwargs):
    """:func:`analyze` of an equilibrium dump; model-parameter keywords go to ``read_dump``.

    A dump of spheres (:func:`~remote_trigger.analysis.state.dumpfile.dump_dimension`)
    is read by ``read_dump3d``.

    Parameters
    ----------
    path : str
    allow_residual : bool, optional
        Default False: refuse a state that is not an equilibrium of its
        parameters (:func:`check_equilibrium`), as ``remote-trigger
        jacobian`` does without ``--allow-residual``: its spectrum and
        verdict would describe nothing. True analyzes any state
        (:func:`analyze` does not check).
    **kwargs
        ``k_n, k_t, mu, wall_y, F_x, F_y, dt, frame, no_wall, mirror_rtol,
        require_contacts, inertia_factor`` for
        :func:`~remote_trigger.analysis.state.dumpfile.read_dump` /
        ``read_dump3d`` (their defaults differ: contacts required for disks,
        I0 = 1/2 for disks, 2/5 for spheres); the rest for :func:`analyze`.

    Raises
    ------
    NotEquilibriumError
        Without ``allow_residual``, a residual above 1e3 x the round-off floor
        (:func:`check_equilibrium`; e.g. a dump written with too few digits,
        or ``k_n`` other than the dump's).
    """
    read_keys = ("k_n", "k_t", "mu", "wall_y", "F_x", "F_y", "dt", "frame", "no_wall",
                 "mirror_rtol", "require_contacts", "inertia_factor")
    rk = {key: kwargs.pop(key) for key in list(kwargs) if key in read_keys}
    reader = read_dump3d if dump_dimension(path, rk.get("frame", -1)) == 3 else read_dump
    state = reader(path, **rk)
    if not allow_residual:
        check_equilibrium(state, what=path)
    return analyze(state, **kwargs)


#: an eigenvalue below -NEGATIVE_REL lambda_max counts as negative (a saddle's);
#: above it round-off and exact zero modes (the screen :func:`negative_modes`,
#: the ramp's ``n_negative``, the ensemble's ``n_saddle``)
NEGATIVE_REL = 1e-9


def negative_modes(state, rel_threshold=NEGATIVE_REL):
    """Number of statically unstable directions of an equilibrium: a saddle has one or more.

    The eigenvalues of A = M^-1/2 K M^-1/2 (similar to M^-1 K; rattlers
    removed as in :func:`analyze`) with Re lambda < -t, t =
    ``rel_threshold`` lambda_max. First Sylvester's count of the eigenvalues
    of the symmetric part S of A below -t0, t0 = ``rel_threshold`` max S_ii
    <= t, from one sparse LDL^T factorization
    (:func:`~remote_trigger.analysis.stability.sliced.count_below`, ~0.1 s
    at n = 28 836): Re lambda = x^* S x for a unit eigenvector x of A, so a
    count of 0 proves that A has none. Otherwise S alone says nothing (a
    disk whose contacts all slide has a free rotation: a zero column of K,
    an eigenvalue 0 of A and a negative one of S), and A's eigenvalues
    nearest -t0 are computed and counted: LAPACK's (lambda_max their
    largest real part) up to ``eigen.DENSE_MAX`` dofs, above it ARPACK
    shift-invert (the 2 c + 6 nearest, c the count of S; lambda_max
    ARPACK's top eigenvalue of S, as the sliced verdict reports it). A
    screen for the ramp, not a certificate.

    Parameters
    ----------
    state : State or State3D
        An equilibrium.
    rel_threshold : float, optional
        Eigenvalues above -t are not counted (default :data:`NEGATIVE_REL`:
        round-off and exact zero modes).

    Returns
    -------
    int
        The count; 0 if every particle is a rattler, -1 if the factorization
        or the eigen-solve failed (no count).
    """
    from scipy.sparse.linalg import ArpackError, eigs

    from remote_trigger.analysis.stability.sliced import count_below

    if not (isinstance(rel_threshold, (int, float, np.floating)) and rel_threshold >= 0
            and np.isfinite(rel_threshold)):
        # (a negative one counted every eigenvalue; nan returned -1, "failed")
        raise ValueError(f"rel_threshold must be a finite number >= 0, got "
                         f"rel_threshold = {rel_threshold!r}")
    res = analyze(state, eigenvalues=False, decide=False)
    keep = res.rattlers.keep_dofs
    if keep.size == 0:
        return 0
    Kr, mr = _jac.remove_dofs(res.K, res.mass, keep)
    A, S, _ = _sliced.scaled_parts(Kr, mr)
    t0 = rel_threshold * float(np.max(S.diagonal()))        # lambda_max(S) >= max S_ii
    try:
        c = count_below(S, -t0)[0]
    except ValueError:
        return -1
    n = A.shape[0]
    if c == 0:
        return 0
    if n <= _eigen.DENSE_MAX:
        lam = np.linalg.eigvals(A.toarray())
        top = float(np.max(lam.real))
    else:
        try:
            lam = eigs(A.tocsc(), k=min(n - 2, 2 * c + 6), sigma=-t0, which="LM",
                       return_eigenvectors=False,
                       v0=np.random.default_rng(0).standard_normal(n))
        except (ArpackError, RuntimeError):
            return -1
        top = _sliced.top_eigenvalue(S)
        if not np.isfinite(top):
            return -1
    return int(np.count_nonzero(lam.real < -rel_threshold * top))
