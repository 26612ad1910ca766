"""What the certified complex-pair decision returns.

:class:`Decision` (the three-way answer, with its stored code: the one form
of a decision everywhere, from a pair to a ramp row), :class:`PairDecision`
(one pair of eigenvalues, or the isolation of two neighbouring units),
:class:`SpectrumDecision` (the answer for the whole spectrum) and
:class:`SpectrumBasis` (the verified basis of a decision, the start of the
next one; a ramp saves and loads it). The decision and what each answer
certifies: :mod:`remote_trigger.analysis.stability.exceptional` (dense) and
:mod:`remote_trigger.analysis.stability.sliced` (sliced).
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
import warnings

import numpy as np

__all__ = ["Decision", "DECISION_CODES", "PairDecision", "SpectrumDecision", "SpectrumBasis"]


class Decision(enum.IntEnum):
    """The certified decision on a spectrum (or a pair, or a strip), with its stored code.

    The integer values are the codes stored in the ``decision`` columns of
    ramp.h5, trigger_map.h5 and ensemble.h5 and in the ``.npz`` of
    ``remote-trigger jacobian`` (docs/driver.md): the one mapping between a
    decision and a number. An ``IntEnum`` compares equal to them, so
    ``codes == Decision.COMPLEX`` works on a NumPy array of codes, and
    ``float(d)`` is the code a float column stores.

    Attributes
    ----------
    COMPLEX : 1
        A complex-conjugate pair of M^-1 K is certified (oscillatory instability).
    REAL : 0
        Every eigenvalue the decision covers is certified real.
    UNDECIDED : -1
        A pair so close to an exceptional point that the float64 matrix
        cannot tell (the margin says how close), or a step of the
        verification that could not be certified (the reason says which).
    """

    COMPLEX = 1
    REAL = 0
    UNDECIDED = -1

    @property
    def label(self):
        """``'complex'``, ``'real'`` or ``'undecided'`` (the word printed on lines and reports)."""
        return self.name.lower()

    def __str__(self):
        return self.label

    @classmethod
    def of(cls, value):
        """The decision of a stored code (int or float, e.g. a ramp.h5 row) or of a label.

        Raises
        ------
        ValueError
            Neither a code (1, 0, -1) nor a label; the message names the value.
        """
        if isinstance(value, cls):
            return value
        if isinstance(value, str):
            try:
                return cls[value.upper()]
            except KeyError:
                raise ValueError(f"not a decision label: {value!r}") from None
        try:
            code = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"not a decision code: {value!r}") from None
        if not (np.isfinite(code) and code == int(code) and int(code) in (-1, 0, 1)):
            raise ValueError(f"not a decision code: {value!r}")
        return cls(int(code))

    @classmethod
    def certified(cls, is_complex):
        """COMPLEX if ``is_complex`` else REAL: the decision of a certified sign."""
        return cls.COMPLEX if is_complex else cls.REAL


#: numeric codes of the decision labels, as stored in ramp.h5 (``Decision``'s values)
DECISION_CODES = {d.label: int(d) for d in Decision}


@dataclass
class PairDecision:
    """Decision for one pair of eigenvalues (or the isolation of two neighbours).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (2,)
        The pair (eigenvalues of the centre of its 2 x 2 block; for an
        isolation entry the two neighbouring centres).
    is_complex : bool
        Sign of the discriminant at the centre: True if D < 0.
    certified : bool
        True if margin > 1: the sign of D (pair) or the separation of the
        two discs (isolation) holds for every matrix of the set.
    margin : float
        |D| / (bound on the change of D) for a pair; distance of the centres
        / sum of the radii for an isolation entry.
    discriminant : float
        D of the pair's 2 x 2 block (1/time^4 for M^-1 K), rounded to float.
    bound : float
        Largest change of D compatible with the errors.
    eta : float
        Frobenius radius of the pair's 2 x 2 block (all errors, coupling
        included).
    sep : float
        Lower bound of sep(S_rr, S_cc) (inf for a 2 x 2 matrix).
    kappa : tuple of float or None
        Unused (kept for compatibility); None.
    method : str
        ``'exact-2x2'`` (the matrix is 2 x 2), ``'riccati-2x2'`` (a pair of a
        larger matrix) or ``'gershgorin'`` (isolation of two neighbouring
        units).
    reason : str
        Why an entry is not certified (empty otherwise).
    sharp : bool
        The pair's block was computed with the exact residual (step 4 of
        :mod:`remote_trigger.analysis.stability.exceptional`), not only from
        the float64 similarity.
    """

    eigenvalues: np.ndarray
    is_complex: bool
    certified: bool
    margin: float
    discriminant: float = float("nan")
    bound: float = float("nan")
    eta: float = float("nan")
    sep: float = float("inf")
    kappa: tuple | None = None
    method: str = "riccati-2x2"
    reason: str = ""
    sharp: bool = False

    @property
    def decision(self):
        """The :class:`Decision` of this entry: UNDECIDED unless certified."""
        if not self.certified:
            return Decision.UNDECIDED
        return Decision.certified(self.is_complex)


@dataclass
class SpectrumDecision:
    """Is a complex pair present in the spectrum?

    Attributes
    ----------
    decision : Decision
        COMPLEX: a pair is certified complex. REAL: every eigenvalue the
        decision covers is certified real -- the whole spectrum where
        ``coverage`` is ``'whole'``, only ``eigenvalues`` where it is
        ``'partial'`` (then it is no stability verdict: check
        :attr:`is_verdict`). UNDECIDED: a pair is too close to an
        exceptional point for the precision of the matrix, or a unit is not
        isolated. The constructor also takes True / False / None for
        COMPLEX / REAL / UNDECIDED (the decision of a certified sign).
    confidence : float
        For COMPLEX, the largest margin among certified complex pairs; for
        REAL, the smallest margin (pairs and isolation); for UNDECIDED, the
        smallest margin (< 1) among the entries that failed.
    pairs : list of PairDecision
        Every pair and every isolation entry between neighbouring units.
    backward_error : float
        Largest row deviation bound dev_i of the similarity (units of A).
    eigenvalues : ndarray, complex
        All eigenvalues, sorted by real part: LAPACK's (``start`` 'dgeev'),
        or the verified basis's block centres with their second-order
        coupling term (``start`` 'basis').
    timing : dict
        Wall times in seconds: ``eigen`` (eigenvalues and vectors; 0 for a
        decision from a previous basis) and ``decision`` (everything else).
    reason : str
        For an undecided spectrum, why.
    basis : SpectrumBasis or None
        The verified basis, to start the decision of a nearby matrix from
        (``classify_spectrum(..., basis=)``); None if verification failed.
    start : str
        ``'dgeev'`` (eigenvectors computed for this matrix) or ``'basis'``
        (the basis of a previous decision, corrected; see
        :func:`remote_trigger.analysis.stability.exceptional.classify_spectrum`).
    coverage : str
        ``'whole'``: the decision covers every eigenvalue of the matrix (a
        stability verdict). ``'partial'``: it covers only ``eigenvalues``
        (:func:`remote_trigger.analysis.stability.projected.classify_projected`:
        the k nearest a shift, certified for a matrix within the projection
        residual); a pair elsewhere is not seen, so it is not a verdict.
    n_total : int
        Order of the whole matrix (0 if not recorded); with ``coverage``
        ``'partial'``, ``eigenvalues.size`` of ``n_total`` are covered.
    sigma : float
        The shift of a partial decision (NaN for a whole one).
    scanned_below : float
        ``eigenvalues`` lists every eigenvalue with real part below this
        (1/time^2) and none above it; +inf when it lists all of them. Finite
        only for a sliced verdict *complex* whose scan stopped above its first
        certified complex strip
        (:func:`~remote_trigger.analysis.stability.sliced.classify_sliced`,
        ``stop_at_complex``, or a slicing that failed higher up): the verdict
        still covers the whole matrix (a certified complex pair exists), but
        the growth rate of ``eigenvalues`` is that of the pairs below, not
        necessarily the spectrum's largest.
    lambda_max : float
        With a finite ``scanned_below``: ARPACK's largest eigenvalue of the
        symmetric part (an approximation, for Re lambda / lambda_max); NaN
        otherwise.
    """

    decision: Decision
    confidence: float
    pairs: list = field(default_factory=list)
    backward_error: float = 0.0
    eigenvalues: np.ndarray | None = None
    timing: dict = field(default_factory=dict)
    reason: str = ""
    basis: "SpectrumBasis | None" = None
    start: str = "dgeev"
    coverage: str = "whole"
    n_total: int = 0
    sigma: float = float("nan")
    scanned_below: float = float("inf")
    lambda_max: float = float("nan")

    def __post_init__(self):
        if self.decision is None:
            self.decision = Decision.UNDECIDED
        elif isinstance(self.decision, (bool, np.bool_)):
            self.decision = Decision.certified(bool(self.decision))
        else:
            self.decision = Decision.of(self.decision)

    @property
    def is_verdict(self):
        """True iff the decision covers the whole spectrum (``coverage == 'whole'``)."""
        return self.coverage == "whole"

    def describe(self):
        """One line: the decision and what it covers.

        A whole-spectrum decision reads ``'complex pair: yes'`` / ``'no'`` /
        ``'undecided'``; a partial one names its coverage and says that it is
        no verdict, e.g. ``'partial decision (12 of 4800 eigenvalues, those
        nearest sigma = 1.2e+04), not a stability verdict: no complex pair
        among them'``.
        """
        if self.is_verdict:
            what = {Decision.COMPLEX: "yes", Decision.REAL: "no",
                    Decision.UNDECIDED: "undecided"}[self.decision]
            scan = ("" if math.isinf(self.scanned_below) else
                    f"; eigenvalues computed below Re lambda = {self.scanned_below:.6g} only")
            return f"complex pair: {what} (confidence margin {self.confidence:.3g}{scan})"
        k = 0 if self.eigenvalues is None else len(self.eigenvalues)
        what = {Decision.COMPLEX: "a complex pair among them",
                Decision.REAL: "no complex pair among them",
                Decision.UNDECIDED: "undecided among them"}[self.decision]
        return (f"partial decision ({k} of {self.n_total or '?'} eigenvalues, those nearest "
                f"sigma = {self.sigma:.6g}), not a stability verdict: {what} (margin "
                f"{self.confidence:.3g})")

    @property
    def critical_pair(self):
        """The pair that decided (largest-margin complex pair if present, else least certain)."""
        cands = [p for p in self.pairs if p.method != "gershgorin"] or self.pairs
        if not cands:
            return None
        if self.decision is Decision.COMPLEX:
            return max((p for p in cands if p.is_complex and p.certified),
                       key=lambda p: p.margin)
        return min(cands, key=lambda p: p.margin)


@dataclass
class SpectrumBasis:
    """A verified basis of a decision: the start of the next one.

    Attributes
    ----------
    X : ndarray, shape (n, n)
        Columns: the units' bases (a real eigenvector, or two columns
        spanning a pair's invariant subspace), unit ``b`` in columns
        ``blocks[b][0] : blocks[b][0] + blocks[b][1]``.
    R : ndarray, shape (n, n)
        The float64 inverse of X used in the verification.
    blocks : list of (int, int)
        (first column, size 1 or 2) of each unit.
    dofs : ndarray of int, shape (n,), or None
        The degrees of freedom of the whole system that X's rows stand for
        (the kept dofs after rattler removal, as ``remove_dofs`` takes them);
        None if not recorded. With it, :meth:`on_dofs` carries the basis over
        to a point whose rattlers differ.
    """

    X: np.ndarray
    R: np.ndarray
    blocks: list
    dofs: np.ndarray | None = None

    @property
    def pairs(self):
        """ndarray of bool, shape (len(blocks),): the unit is a pair (a complex
        pair or two near-parallel real eigenvectors), i.e. has two columns."""
        return np.array([k == 2 for _, k in self.blocks], dtype=bool)

    def on_dofs(self, dofs):
        """The basis carried over to another set of kept dofs (other rattlers).

        A start for :func:`~remote_trigger.analysis.stability.exceptional.classify_spectrum`
        at a point whose rattlers differ from this basis's (a disk that
        gained or lost its last contacts between two ramp points): rows of
        dofs that are kept in both are kept; for each dof no longer kept, the
        real unit whose column lies most on the dropped dofs is dropped; for
        each new dof a unit vector on it is added as a real unit (its mode is
        then found by the correction of the verification). The verification
        is the same rigorous one for any nonsingular X, so this changes only
        whether the start succeeds, never what a decision certifies.

        Parameters
        ----------
        dofs : array_like of int, shape (n_new,)
            The new kept dofs (indices into the whole system's 3N or 6N).

        Returns
        -------
        SpectrumBasis or None
            ``self`` if the dofs are the same; None if this basis has no
            recorded ``dofs``, if a dropped dof would take a pair's column, or
            if the carried-over X is singular.
        """
        dofs = np.asarray(dofs, np.int64)
        if self.dofs is None:
            return None
        old = np.asarray(self.dofs, np.int64)
        if old.shape == dofs.shape and np.array_equal(old, dofs):
            return self
        in_new = np.isin(old, dofs)
        in_old = np.isin(dofs, old)
        n_drop, n_add = int(np.count_nonzero(~in_new)), int(np.count_nonzero(~in_old))
        X = self.X
        col_unit = np.repeat(np.arange(len(self.blocks)), [k for _, k in self.blocks])
        drop_cols = np.zeros(X.shape[1], bool)
        if n_drop:
            weight = np.einsum("ij,ij->j", X[~in_new], X[~in_new]) \
                / np.einsum("ij,ij->j", X, X)
            sizes = np.array([k for _, k in self.blocks])[col_unit]
            weight[sizes != 1] = -1.0
            order = np.argsort(-weight, kind="stable")[:n_drop]
            if np.any(weight[order] < 0):
                return None
            drop_cols[order] = True
        # rows: the new dofs in their order; old rows where the dof was kept
        pos_old = {int(d): i for i, d in enumerate(old)}
        Xn = np.zeros((dofs.size, X.shape[1] - n_drop + n_add))
        keep_cols = np.flatnonzero(~drop_cols)
        rows_new = np.flatnonzero(in_old)
        rows_old = np.array([pos_old[int(d)] for d in dofs[in_old]], np.int64)
        Xn[np.ix_(rows_new, np.arange(keep_cols.size))] = X[np.ix_(rows_old, keep_cols)]
        for c, r in enumerate(np.flatnonzero(~in_old)):
            Xn[r, keep_cols.size + c] = 1.0
        norms = np.sqrt(np.einsum("ij,ij->j", Xn, Xn))
        if not np.all(norms > 0):
            return None
        Xn /= norms
        blocks, s0 = [], 0
        for start, k in self.blocks:
            if k == 1 and drop_cols[start]:
                continue
            blocks.append((s0, k))
            s0 += k
        blocks += [(s0 + c, 1) for c in range(n_add)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                R = np.linalg.inv(Xn)
            except np.linalg.LinAlgError:
                return None
        if not np.all(np.isfinite(R)):
            return None
        return SpectrumBasis(Xn, R, blocks, dofs.copy())

    def save(self, path):
        """Write X, the block layout and the dofs to ``path`` (``.npz``; R is
        recomputed on load)."""
        b = np.asarray(self.blocks, np.int64).reshape(-1, 2)
        extra = {} if self.dofs is None else {"dofs": np.asarray(self.dofs, np.int64)}
        with open(path, "wb") as fh:
            np.savez(fh, X=self.X, blocks=b, **extra)

    @classmethod
    def load(cls, path):
        """Read a basis written by :meth:`save` (R = inv(X), as the verification computes it).

        Raises
        ------
        ValueError
            If the file is not a saved basis (the message names it).
        """
        try:
            with np.load(path) as z:
                X, b = z["X"], z["blocks"]
                dofs = z["dofs"] if "dofs" in z.files else None
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"cannot read spectrum basis {path!r}: {exc}") from exc
        n = X.shape[0]
        if (X.ndim != 2 or X.shape != (n, n) or b.ndim != 2 or b.shape[1] != 2
                or int(b[:, 1].sum()) != n):
            raise ValueError(f"cannot read spectrum basis {path!r}: inconsistent shapes")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            R = np.linalg.inv(X)
        if dofs is not None and dofs.shape != (n,):
            raise ValueError(f"cannot read spectrum basis {path!r}: inconsistent shapes")
        return cls(X, R, [(int(s), int(k)) for s, k in b], dofs)
