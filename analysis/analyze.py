"""One call from an equilibrium to its spectrum: K, rattlers, eigenvalues, decision.

This is the entry point for the ramp and the command line::

    from remote_trigger.analysis.analyze import analyze, analyze_dump
    res = analyze_dump("eq.dump")            # sidecar eq.dump.json gives k_n, k_t, mu, wall_y
    res.decision.complex_present, res.growth_rate, res.rattlers.ids

Steps: assemble K = -dG/dq (``jacobian.stiffness_matrix``, paper Appendix C),
remove rattlers iteratively (``jacobian.find_rattlers``, frictional criterion
of fewer than 2 contacts), form M^-1 K with M = diag(m, m, I/R^2), compute
its eigenvalues (dense LAPACK up to ``eigen.DENSE_MAX`` dofs, else ARPACK
shift-invert) and decide whether a complex pair is present with the
certified test of ``exceptional`` (dense path: the whole spectrum; sparse
path: the projected subspace).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import eigen as _eigen
from . import exceptional as _exc
from . import jacobian as _jac
from .state import read_dump

__all__ = ["Analysis", "analyze", "analyze_dump"]


@dataclass
class Analysis:
    """Result of :func:`analyze`.

    Attributes
    ----------
    state : State
    K : scipy.sparse.csr_matrix, shape (3N, 3N)
        Full stiffness (rattlers kept).
    mass : ndarray, shape (3N,)
        Diagonal of M.
    rattlers : RattlerResult
        Removed disks (ids, indices) and the kept dofs.
    eigen : EigenResult or None
        Eigenvalues of M^-1 K restricted to the kept dofs.
    decision : SpectrumDecision or None
        Certified complex-pair decision (None if not requested).
    residual : ndarray, shape (3N,)
        G = contact + external forces (zero at equilibrium).
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
        """max |Im sqrt(lambda)| (1/time); 0 if all eigenvalues are real and positive."""
        return None if self.eigen is None else self.eigen.growth_rate

    @property
    def max_residual(self):
        """max over disks of max(|F_i|, |T_i|/R_i) including the loads."""
        G = self.residual.reshape(-1, 3)
        return float(max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2]))))


def analyze(state, eigenvalues=True, decide=True, method="auto", k=12, sigma=None,
            min_contacts=2):
    """Stiffness, rattlers, spectrum and complex-pair decision of one state.

    Parameters
    ----------
    state : State
    eigenvalues : bool, optional
        Compute the eigenvalues (default True).
    decide : bool, optional
        Run the certified complex-pair test (default True; dense path: all
        pairs; sparse path: the ``k`` eigenvalues nearest ``sigma``).
    method : {'auto', 'dense', 'sparse'}
    k : int
        Sparse path: number of eigenvalues.
    sigma : float, optional
        Sparse path: shift (1/time^2); default
        :func:`~remote_trigger.analysis.eigen.default_shift`, inside the band
        where pairs coalesce (``docs/analysis.md``).
    min_contacts : int
        Rattler criterion (default 2, frictional disks).

    Returns
    -------
    Analysis
    """
    K = _jac.stiffness_matrix(state)
    mass = state.mass_diagonal()
    rat = _jac.find_rattlers(state, min_contacts=min_contacts)
    G = _jac.generalized_forces(state)
    eig = dec = None
    if eigenvalues and rat.keep_dofs.size:
        Kr, mr = _jac.remove_dofs(K, mass, rat.keep_dofs)
        n = Kr.shape[0]
        dense = method == "dense" or (method == "auto" and n <= _eigen.DENSE_MAX)
        if dense:
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
                dec, _ = _exc.classify_projected(_eigen.dynamical_matrix(Kr, mr), sigma,
                                                 k=max(k, 2))
                eig = _eigen.EigenResult(dec.eigenvalues, method="arpack-shift-invert",
                                         sigma=float(sigma))
            else:
                eig = _eigen.sparse_eigen(Kr, mr, k=k, sigma=sigma)
    return Analysis(state, K, mass, rat, eig, dec, G)


def analyze_dump(path, **kwargs):
    """:func:`analyze` of a dump; model-parameter keywords go to ``read_dump``.

    Parameters
    ----------
    path : str
    **kwargs
        ``k_n, k_t, mu, wall_y, F_x, F_y, dt, frame`` for
        :func:`~remote_trigger.analysis.state.read_dump`; the rest for
        :func:`analyze`.
    """
    read_keys = ("k_n", "k_t", "mu", "wall_y", "F_x", "F_y", "dt", "frame", "no_wall")
    rk = {key: kwargs.pop(key) for key in list(kwargs) if key in read_keys}
    return analyze(read_dump(path, **rk), **kwargs)
