"""Linear stability of an equilibrium dump (driver side of the analyzer).

The ramp calls :func:`analyze_dump` on every equilibrium dump it writes. It
reads the dump with ``remote_trigger.analysis.state.read_dump`` (the format of
docs/conventions.md section 3), assembles K = -dG/dq with
``remote_trigger.analysis.jacobian`` (paper Appendix C, Eqs. 44-67), removes
rattlers iteratively (frictional criterion: fewer than 2 contacts), and
computes the eigenvalues lambda of M^-1 K (Eq. 6: omega = +-sqrt(lambda)).

Complex pairs are detected from the **real Schur form** of M^-1 K, as
MODEL.md section 7 asks: LAPACK standardises 2 x 2 diagonal blocks so that a
block remains only for a complex-conjugate pair, which is robust where
eigenvalues coalesce (an exceptional point, where the eigenvalues themselves
are ill-conditioned). A block counts if its imaginary part exceeds
``rtol`` times the spectral scale max |lambda| (default 1e-10), to ignore
round-off pairs among near-zero eigenvalues.

If the analyzer package later provides its own eigenvalue module, this
function is the one place to switch to it.
"""
from dataclasses import dataclass

import numpy as np


@dataclass
class StabilityResult:
    """Eigen-analysis of one equilibrium.

    Attributes
    ----------
    eigenvalues : ndarray of complex128, shape (M,)
        Eigenvalues of M^-1 K over the kept degrees of freedom, sorted by
        real part.
    complex_pair : bool
        True if a complex-conjugate pair exists (oscillatory instability).
    max_imag : float
        Largest |Im lambda| among the pairs (0 if none).
    growth_rate : float
        max Im(omega) = max over eigenvalues of |Im sqrt(lambda)|, the
        exponential growth rate of a linear perturbation (1/time).
    n_rattlers : int
        Disks removed as rattlers.
    rattler_ids : ndarray of int64
    """

    eigenvalues: np.ndarray
    complex_pair: bool
    max_imag: float
    growth_rate: float
    n_rattlers: int
    rattler_ids: np.ndarray


def analyze_state(state, rtol=1e-10):
    """Eigen-analysis of an analysis ``State`` (see module docstring).

    Parameters
    ----------
    state : remote_trigger.analysis.state.State
    rtol : float
        Relative threshold on |Im lambda| for a pair to count.

    Returns
    -------
    StabilityResult
    """
    import scipy.linalg as sla
    from remote_trigger.analysis import jacobian

    K = jacobian.stiffness_matrix(state)
    rat = jacobian.find_rattlers(state)
    Kr, mr = jacobian.remove_dofs(K, state.mass_diagonal(), rat.keep_dofs)
    Kr = Kr.toarray() if hasattr(Kr, "toarray") else np.asarray(Kr)
    if Kr.size == 0:
        return StabilityResult(np.zeros(0, complex), False, 0.0, 0.0, int(rat.ids.size),
                               rat.ids)
    A = Kr / mr[:, None]
    T = sla.schur(A, output="real")[0]
    lam = np.linalg.eigvals(A)
    scale = float(np.max(np.abs(lam))) if lam.size else 1.0
    max_imag = 0.0
    n = T.shape[0]
    k = 0
    while k < n - 1:
        if T[k + 1, k] != 0.0:
            blk = T[k:k + 2, k:k + 2]
            tr, det = blk[0, 0] + blk[1, 1], blk[0, 0] * blk[1, 1] - blk[0, 1] * blk[1, 0]
            disc = tr * tr / 4.0 - det
            if disc < 0:
                max_imag = max(max_imag, float(np.sqrt(-disc)))
            k += 2
        else:
            k += 1
    complex_pair = max_imag > rtol * scale
    growth = float(np.max(np.abs(np.sqrt(lam.astype(complex)).imag))) if complex_pair else 0.0
    order = np.lexsort((lam.imag, lam.real))
    return StabilityResult(lam[order], bool(complex_pair), max_imag, growth,
                           int(rat.ids.size), rat.ids)


def analyze_dump(path, rtol=1e-10):
    """Read an equilibrium dump (+ sidecar JSON) and analyse it.

    Raises
    ------
    ValueError
        If the dump or its sidecar is missing, corrupt or truncated (from
        ``read_dump``; the message names the file).
    """
    from remote_trigger.analysis.state import read_dump

    try:
        state = read_dump(path, require_contacts=False)
    except (OSError, KeyError, IndexError, ValueError) as exc:
        raise ValueError(f"cannot read equilibrium dump {path!r}: {exc}") from exc
    return analyze_state(state, rtol=rtol)
