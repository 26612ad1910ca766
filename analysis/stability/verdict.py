"""The stability verdict of an equilibrium: certified decision, codes, growth rate.

The ramp calls :func:`stability_of_dump` on every equilibrium dump it writes.
The work is done by the analyzer, :func:`remote_trigger.analysis.stability.analyze.analyze`
(docs/analysis.md): K = -dG/dq (paper Appendix C), rattlers removed
iteratively (frictional criterion: fewer than 2 contacts), eigenvalues of
M^-1 K (Eq. 6: omega = +-sqrt(lambda)) and the **certified** complex-pair
decision (``remote_trigger.analysis.stability.exceptional``: a verified similarity,
Gershgorin isolation, and the pair's 2 x 2 block enclosed to the precision
of the float64 matrix; above ``eigen.DENSE_MAX`` dofs the whole-spectrum
verdict by slicing, ``remote_trigger.analysis.stability.sliced``). No threshold on Im lambda is used:
the decision is ``'complex'`` (a pair certified complex), ``'real'`` (every
eigenvalue certified real) or ``'undecided'`` (a pair is so close to an
exceptional point that the float64 matrix cannot tell), each with its
margin (``confidence``, > 1 = certified).

Ramp policy (docs/driver.md): only certified answers move the bracket of
F_x^c. An ``'undecided'`` point is neither stable nor unstable; it is
recorded (``decision`` = -1 with its margin) in ramp.h5, and the bisection
works around it (``pywrap.stages.ramp_bracket``, ``next_bisection_point``).
"""
from dataclasses import dataclass
import math
import enum
import os

import numpy as np

from remote_trigger.analysis.errors import TooLargeError

#: peak memory of the dense verdict (:func:`stability_of`), in float64 n x n
#: matrices: 12.1 measured (tracemalloc) at n = 1158, the matrix itself not
#: counted; with it and a margin, 14
DENSE_PEAK_MATRICES = 14
#: environment variable: the memory (GiB) a dense verdict may use, instead
#: of what the machine has available
MEMORY_ENV = "REMOTE_TRIGGER_MEMORY_GB"
#: a certified complex pair is *soft* when every eigenvalue of its unit has
#: |Re lambda| below this fraction of lambda_max: two near-floppy modes of one
#: or two weakly held disks, not two stiff ones. Measured on the default
#: ensemble: stiff onsets at Re lambda_c / lambda_max >= 0.013, soft ones
#: <= 1.2e-5; on the N = 400 fine ramps soft ones 4e-7 to 3.4e-5 (a factor
#: >= 3 from this threshold; docs/results/ensemble.md)
SOFT_MODE_REL = 1e-4


class Decision(enum.IntEnum):
    """The certified decision on an equilibrium's spectrum, with its stored code.

    The integer values are the codes stored in the ``decision`` columns of
    ramp.h5, trigger_map.h5 and ensemble.h5 (docs/driver.md); an
    ``IntEnum`` compares equal to them, so ``codes == Decision.COMPLEX``
    works on a NumPy array of codes.

    Attributes
    ----------
    COMPLEX : 1
        A complex-conjugate pair of M^-1 K is certified (oscillatory instability).
    REAL : 0
        Every eigenvalue is certified real.
    UNDECIDED : -1
        A pair so close to an exceptional point that the float64 matrix
        cannot tell (the margin says how close).
    """

    COMPLEX = 1
    REAL = 0
    UNDECIDED = -1

    @property
    def label(self):
        """``'complex'``, ``'real'`` or ``'undecided'`` (the analyzer's words)."""
        return self.name.lower()

    @classmethod
    def of(cls, value):
        """The decision of a stored code (int or float) or of a label.

        Raises
        ------
        ValueError
            Neither a code (1, 0, -1) nor a label.
        """
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


#: numeric codes of the decision labels, as stored in ramp.h5
DECISION_CODES = {d.label: int(d) for d in Decision}


@dataclass
class StabilityResult:
    """Eigen-analysis of one equilibrium.

    Attributes
    ----------
    eigenvalues : ndarray of complex128, shape (M,)
        Eigenvalues of M^-1 K over the kept degrees of freedom, sorted by
        real part.
    complex_pair : bool
        True iff a complex-conjugate pair is *certified* (``decision ==
        'complex'``): an oscillatory instability.
    max_imag : float
        Largest |Im lambda| over the eigenvalues if ``complex_pair``, else 0.
    growth_rate : float
        max |Im omega| over omega = +-sqrt(lambda) (1/time); 0 for a real
        positive spectrum.
    n_rattlers : int
        Disks removed as rattlers.
    rattler_ids : ndarray of int64
    decision : str
        ``'complex'``, ``'real'`` or ``'undecided'``.
    confidence : float
        Margin of the decision (docs/analysis.md): > 1 certified; for
        ``'undecided'`` the margin (< 1) of the least certain pair.
    residual : float
        max over disks of max(|F_i|, |T_i|/R_i) recomputed by the analyzer
        from the dump (loads included).
    timing : dict
        Wall times (s) of the eigen-solve (``eigen``) and of the certified
        decision (``decision``).
    basis : remote_trigger.analysis.stability.decision.SpectrumBasis or None
        The decision's verified basis (start of the next point's decision).
    start : str
        ``'dgeev'``, ``'basis'`` (decided from a previous point's basis) or
        ``'sliced'`` (the verdict by slicing, above ``eigen.DENSE_MAX`` dofs).
    reason : str
        Why the decision is ``'undecided'`` (the decision's own words, e.g.
        which strip and where), or with ``collective`` why that decision is
        (the units left undecided); empty otherwise.
    n_dof : int
        Order of the matrix decided (the kept dofs; -1 if not recorded).
    scanned_below : float
        ``eigenvalues`` holds every eigenvalue with real part below this and
        none above (+inf: all of them; finite for a sliced verdict *complex*
        that stopped at its first complex strip, ``stop_at_complex``).
        ``max_imag`` and ``growth_rate`` are then those of the pairs below.
    lambda_max : float
        Largest real part of the spectrum: of ``eigenvalues``, or with a
        finite ``scanned_below`` ARPACK's largest eigenvalue of the symmetric
        part (an approximation); NaN for an empty spectrum.
    collective : str
        With ``stability_of(..., collective=True)``: the decision on the pairs
        that are not soft (:func:`collective_decision`): ``'complex'`` (a
        certified complex pair with an eigenvalue at |Re lambda| >=
        ``SOFT_MODE_REL`` lambda_max), ``'real'`` (every eigenvalue certified
        real, or in a certified complex pair below that) or ``'undecided'``;
        ``''`` when not asked for.
    soft_pairs : int
        With ``collective=True``: the certified complex units that are soft
        (a sliced strip counts as one); -1 when not asked for.
    """

    eigenvalues: np.ndarray
    complex_pair: bool
    max_imag: float
    growth_rate: float
    n_rattlers: int
    rattler_ids: np.ndarray
    decision: str = "real"
    confidence: float = float("inf")
    residual: float = float("nan")
    timing: dict = None
    basis: object = None
    start: str = "dgeev"
    reason: str = ""
    n_dof: int = -1
    scanned_below: float = float("inf")
    lambda_max: float = float("nan")
    collective: str = ""
    soft_pairs: int = -1

    @property
    def decision_code(self):
        """The :class:`Decision` (1 complex, 0 real, -1 undecided, as stored in ramp.h5)."""
        return Decision.of(self.decision)


def collective_decision(dec, lambda_max, soft_rel=None):
    """The decision on the pairs that are not soft, and the soft pairs' count.

    A certified complex unit (a dense 2 x 2 pair, or a sliced strip) is
    *soft* when every eigenvalue of its computed block has |Re lambda| <
    ``soft_rel`` x ``lambda_max``: the label uses the computed eigenvalues
    (inside the unit's enclosure, which is far narrower than the threshold
    in the packings measured), the decision that the unit is complex is
    certified.

    Parameters
    ----------
    dec : remote_trigger.analysis.stability.decision.SpectrumDecision
        A whole-spectrum decision (dense, or sliced with or without a stop).
    lambda_max : float
        Largest real part of the spectrum (NaN: no unit is soft).
    soft_rel : float, optional
        Default None: :data:`SOFT_MODE_REL`.

    Returns
    -------
    decision : str
        ``'complex'``: a certified complex unit that is not soft.
        ``'real'``: the whole decision is *real*; or it is *complex*, covers
        the whole spectrum (no stop), its certified complex units are all
        soft and every unit that is not soft is certified (a soft unit may
        be undecided: e.g. the isolation disc of a soft pair overlapping
        that of a soft neighbour). ``'undecided'`` otherwise (a whole
        decision *undecided* stays so).
    soft : int
        The certified complex units that are soft.
    """
    thr = (SOFT_MODE_REL if soft_rel is None else soft_rel) * lambda_max

    def is_soft(p):
        return p.eigenvalues is not None and len(p.eigenvalues) > 0 and \
            np.max(np.abs(np.real(p.eigenvalues))) < thr

    cert = [p for p in dec.pairs if p.method != "gershgorin" and p.is_complex and p.certified]
    soft = sum(1 for p in cert if is_soft(p))
    if soft < len(cert):
        return "complex", soft
    if dec.complex_present is False:
        return "real", 0
    # complex, on soft units only: real if the decision covers the whole spectrum
    # and every unit that is not soft is certified (a soft unit may be left
    # undecided, e.g. its isolation disc overlapping a soft neighbour's)
    if dec.complex_present and math.isinf(dec.scanned_below) and \
            all(p.certified or is_soft(p) for p in dec.pairs):
        return "real", soft
    return "undecided", soft


def classify_dense(A, basis=None, soft_rel=None):
    """The dense certified decision of A, from ``basis`` where it certifies.

    ``classify_spectrum(A, basis=basis)``; with ``soft_rel`` (a decision on
    the pairs that are not soft, :func:`collective_decision`) a decision from
    the basis that leaves that decision undecided is made again from dgeev
    (a decision from a basis leaves more coupling, so wider discs: see
    ``classify_spectrum``). Returns the
    :class:`~remote_trigger.analysis.stability.decision.SpectrumDecision`.
    """
    from remote_trigger.analysis.stability import exceptional

    dec = exceptional.classify_spectrum(A, basis=basis)
    if soft_rel is not None and dec.start == "basis" and \
            collective_decision(dec, _top(dec), soft_rel)[0] == "undecided":
        dec = exceptional.classify_spectrum(A)
    return dec


def collective_reason(dec):
    """Why :func:`collective_decision` is undecided where the decision is complex:
    the units left undecided (their reasons, the first three), or the
    decision's own note (a stopped or failed scan). One line."""
    bad = [p.reason for p in dec.pairs if not p.certified]
    if bad:
        return (f"only soft complex pairs certified; {len(bad)} undecided: "
                + " | ".join(bad[:3]) + (f" | and {len(bad) - 3} more" if len(bad) > 3 else ""))
    return f"only soft complex pairs certified; {dec.reason or 'the scan stopped'}"


def available_memory():
    """Bytes a calculation may allocate here, or None if unknown.

    ``$REMOTE_TRIGGER_MEMORY_GB`` if set; else the smaller of the machine's
    ``MemAvailable`` (``/proc/meminfo``) and what the cgroup v2 limit
    (``/sys/fs/cgroup/memory.max``, a batch job's limit) leaves.

    Raises
    ------
    InputError
        If the environment variable is not a positive number.
    """
    from remote_trigger.analysis.errors import InputError

    env = os.environ.get(MEMORY_ENV)
    if env is not None:
        try:
            gb = float(env)
        except ValueError:
            gb = -1.0
        if not gb > 0:
            raise InputError(f"{MEMORY_ENV} = {env!r}: not a positive number of GiB")
        return int(gb * 2**30)
    found = []
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        with open("/sys/fs/cgroup/memory.current") as fh:
            used = int(fh.read().strip())
        if limit != "max":
            found.append(int(limit) - used)
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def check_dense_fits(n, available=None):
    """Refuse a dense verdict of order ``n`` that would not fit in memory.

    Parameters
    ----------
    n : int
        Order of M^-1 K after rattler removal (dofs).
    available : int, optional
        Bytes available (default :func:`available_memory`; unknown: no check).

    Raises
    ------
    TooLargeError
        If :data:`DENSE_PEAK_MATRICES` x 8 n^2 bytes exceed ``available``; the
        message names n, both amounts, and that no verdict was reached.
    """
    avail = available_memory() if available is None else available
    need = DENSE_PEAK_MATRICES * 8.0 * n * n
    if avail is not None and need > avail:
        raise TooLargeError(
            f"no stability verdict: the dense verdict for n = {n} dofs needs about "
            f"{_amount(need)} ({DENSE_PEAK_MATRICES} float64 n x n matrices), "
            f"{_amount(avail)} available ({MEMORY_ENV} or the machine's)")


def _amount(nbytes):
    """``'1.5 GiB'``, or MiB / KiB below a tenth of the larger unit."""
    for unit, size in (("GiB", 2**30), ("MiB", 2**20)):
        if nbytes >= 0.1 * size:
            return f"{nbytes / size:.1f} {unit}"
    return f"{nbytes / 2**10:.1f} KiB"


def stability_of(state, basis=None, stop_at_complex=False, progress=None,
                 checkpoint_dir=None, collective=False):
    """Eigen-analysis of an analysis ``State`` with the analyzer.

    Up to ``eigen.DENSE_MAX`` dofs the dense certified decision (from
    ``basis`` if given); above, the whole-spectrum verdict by slicing
    (:func:`~remote_trigger.analysis.stability.sliced.classify_sliced`; no
    basis, ``start`` 'sliced', eigenvalues approximate).

    Parameters
    ----------
    state : remote_trigger.analysis.state.state.State
    basis : remote_trigger.analysis.stability.decision.SpectrumBasis, optional
        The previous point's ``basis``: tried first
        (:func:`remote_trigger.analysis.stability.exceptional.classify_spectrum`);
        if its ``dofs`` differ from this state's kept dofs (a disk became or
        stopped being a rattler), it is carried over by
        :meth:`~remote_trigger.analysis.stability.decision.SpectrumBasis.on_dofs`.
        The returned basis records this state's kept dofs.
    stop_at_complex : bool, optional
        Sliced path only: stop the scan at the first strip certified complex
        (the same certified verdict; the eigenvalues above it are not
        computed, see ``StabilityResult.scanned_below``). Default False.
    progress : callable, optional
        Sliced path only: ``progress(done, n)`` after each slice (see
        :func:`~remote_trigger.analysis.stability.sliced.classify_sliced`).
    checkpoint_dir : str, optional
        Sliced path only: the folder where the scan saves its state and its
        verdict, so that a killed scan resumes and a repeated one is not redone
        (``classify_sliced``'s ``checkpoint_dir``). Default None: nothing saved.
    collective : bool, optional
        Also decide on the pairs that are not soft (``StabilityResult.collective``
        and ``soft_pairs``, :func:`collective_decision`); a sliced scan with
        ``stop_at_complex`` then goes on past soft complex strips. A dense
        decision from ``basis`` that leaves the collective decision undecided
        is made again from dgeev. Default False.

    Returns
    -------
    StabilityResult

    Raises
    ------
    TooLargeError
        If the dense verdict (at most ``eigen.DENSE_MAX`` dofs) would not fit in
        memory (:func:`check_dense_fits`).
    ValueError
        If ``basis`` is not a SpectrumBasis or None.
    """
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability import eigen, jacobian
    from remote_trigger.analysis.stability.decision import SpectrumBasis
    from remote_trigger.analysis.stability.sliced import classify_sliced

    if basis is not None and not isinstance(basis, SpectrumBasis):
        raise ValueError(f"basis must be a SpectrumBasis (a previous result's .basis) or None, "
                         f"got {type(basis).__name__}")

    # K, rattlers and residual from analyze(); the dense spectrum and the
    # certified decision from one classify_spectrum call (its eigen-solve gives
    # the eigenvalues too: analyze(..., eigenvalues=True) would run a second,
    # separate eigenvalue solve -- 20-30 % of the time of a ramp step)
    res = analyze(state, eigenvalues=False, decide=False)
    rat = res.rattlers
    if rat.keep_dofs.size == 0:      # every disk a rattler: nothing to decide
        return StabilityResult(np.zeros(0, complex), False, 0.0, 0.0, int(rat.ids.size),
                               np.asarray(rat.ids, np.int64), "real", float("inf"),
                               res.max_residual, n_dof=0)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, rat.keep_dofs)
    if Kr.shape[0] > eigen.DENSE_MAX:
        # the whole-spectrum verdict by slicing: no dense matrix, no basis
        dec = classify_sliced(Kr, mr, stop_at_complex=stop_at_complex, progress=progress,
                              checkpoint_dir=checkpoint_dir,
                              soft_rel=SOFT_MODE_REL if collective else None)
    else:
        check_dense_fits(Kr.shape[0])
        if basis is not None and basis.dofs is not None:
            # other rattlers than at the basis's point: carried over (or None)
            basis = basis.on_dofs(rat.keep_dofs)
        dec = classify_dense(eigen.dynamical_matrix(Kr, mr).toarray(), basis,
                             SOFT_MODE_REL if collective else None)
        if dec.basis is not None:
            dec.basis.dofs = np.asarray(rat.keep_dofs, np.int64).copy()
    if dec.complex_present is None:
        decision = "undecided"
    else:
        decision = "complex" if dec.complex_present else "real"
    lam = np.asarray(dec.eigenvalues, np.complex128)
    lam = lam[np.lexsort((lam.imag, lam.real))]
    cplx = decision == "complex"
    max_imag = float(np.max(np.abs(lam.imag))) if (cplx and lam.size) else 0.0
    lam_max = _top(dec)
    coll, soft = collective_decision(dec, lam_max, SOFT_MODE_REL) if collective else ("", -1)
    why = str(dec.reason or "") if decision == "undecided" else ""
    if coll == "undecided" and not why:
        why = collective_reason(dec)
    return StabilityResult(lam, cplx, max_imag, float(eigen.growth_rate(lam)),
                           int(rat.ids.size), np.asarray(rat.ids, np.int64), decision,
                           float(dec.confidence), res.max_residual, dict(dec.timing),
                           dec.basis, dec.start, why,
                           int(Kr.shape[0]), float(dec.scanned_below), float(lam_max),
                           coll, soft)


def _top(dec):
    """Largest real part of a decision's spectrum: of its eigenvalues if they are
    all there, else its ``lambda_max`` (ARPACK's); NaN for none."""
    lam = np.asarray(dec.eigenvalues)
    if math.isinf(dec.scanned_below):
        return float(np.max(lam.real)) if lam.size else math.nan
    return float(dec.lambda_max)


def stability_of_dump(path, basis=None, stop_at_complex=False, progress=None,
                      checkpoint_dir=None, collective=False, allow_residual=False):
    """Read an equilibrium dump (+ sidecar JSON) and return :func:`stability_of` it.

    A dump of spheres (``dump_dimension``) is read by ``read_dump3d``.

    ``basis``, ``stop_at_complex``, ``progress``, ``checkpoint_dir``,
    ``collective``: as in :func:`stability_of`. ``allow_residual`` (default
    False): refuse a state that is not an equilibrium of its parameters, as
    ``remote-trigger jacobian`` does without ``--allow-residual``
    (:func:`~remote_trigger.analysis.stability.analyze.check_equilibrium`);
    True decides any state (:func:`stability_of` does not check; the
    driver, whose equilibria pass its own Newton test, passes True).

    Raises
    ------
    ValueError
        If the dump or its sidecar is missing, corrupt or truncated (from
        ``read_dump``; the message names the file).
    NotEquilibriumError
        Without ``allow_residual``, a residual above 1e3 x the round-off floor (a
        ``ValueError`` too; e.g. a dump written with too few digits).
    """
    from remote_trigger.analysis.stability.analyze import check_equilibrium
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    try:
        state = read_equilibrium(path)      # spheres: 6 dofs each, rattlers below 3 contacts
    except (OSError, KeyError, IndexError, ValueError) as exc:
        raise ValueError(f"cannot read equilibrium dump {path!r}: {exc}") from exc
    if not allow_residual:
        check_equilibrium(state, what=path)
    return stability_of(state, basis, stop_at_complex, progress, checkpoint_dir, collective)
