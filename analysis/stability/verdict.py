"""The stability verdict of an equilibrium: one engine, one entry point.

Everything that decides whether an equilibrium has a complex pair goes
through :func:`decide` (docs/analysis.md, "The engine"):

1. :func:`~remote_trigger.analysis.stability.system.reduced_system` builds
   the reduced system once: K = -dG/dq (paper Appendix C), the rattlers
   removed iteratively (fewer than 2 contacts for frictional disks, 3 for
   spheres), K and M restricted to the dofs kept.
2. :func:`decide` takes that system and a :class:`VerdictOptions` and
   returns one :class:`StabilityResult`. The path is chosen once
   (:func:`choose_method`, with the memory check of the dense path): the
   dense certified decision of M^-1 K (paper Eq. 6: omega = +-sqrt(lambda);
   :mod:`~remote_trigger.analysis.stability.exceptional`: a verified
   similarity, Gershgorin isolation, each pair's 2 x 2 block enclosed to
   the precision of the float64 matrix) up to ``eigen.DENSE_MAX`` dofs, the
   whole-spectrum verdict by spectrum slicing above it
   (:mod:`~remote_trigger.analysis.stability.sliced`).

No threshold on Im lambda is used: the answer is a
:class:`~remote_trigger.analysis.stability.decision.Decision` --
COMPLEX (a pair certified complex), REAL (every eigenvalue certified real)
or UNDECIDED (a pair so close to an exceptional point that the float64
matrix cannot tell, or a step that could not be certified) -- with its
margin (``confidence``, > 1 = certified).

Ramp policy (docs/driver.md): only certified answers move the bracket of
F_x^c. An UNDECIDED point is neither stable nor unstable; it is recorded
(code -1 with its margin) in ramp.h5, and the bisection works around it.
"""
from dataclasses import dataclass, field
import math
import os

import numpy as np

from remote_trigger.analysis.errors import TooLargeError, is_integer
from remote_trigger.analysis.stability.decision import Decision, SpectrumBasis
from remote_trigger.analysis.stability.system import reduced_system

__all__ = ["VerdictOptions", "StabilityResult", "decide", "spectrum_decision",
           "choose_method", "stability_of", "stability_of_dump", "collective_decision",
           "collective_reason", "classify_dense", "available_memory", "check_dense_fits",
           "SOFT_MODE_REL", "DENSE_PEAK_MATRICES", "MEMORY_ENV", "PAIR_POLICIES"]

#: peak memory of the dense verdict (:func:`decide`), in float64 n x n
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
#: the soft-pair policies (:attr:`VerdictOptions.pairs`, the ramp's ``pairs``)
PAIR_POLICIES = ("all", "collective")
#: the methods (:attr:`VerdictOptions.method`)
METHODS = ("auto", "dense", "sliced")


@dataclass(frozen=True)
class VerdictOptions:
    """How :func:`decide` decides: path, soft-pair policy, scope, tolerances, checkpoint.

    Attributes
    ----------
    method : {'auto', 'dense', 'sliced'}
        'auto' (default): dense up to ``eigen.DENSE_MAX`` dofs, sliced above
        (:func:`choose_method`).
    pairs : {'all', 'collective'}
        The soft-pair policy. 'all' (default): the decision on every pair.
        'collective': also the decision on the pairs that are not soft
        (:func:`collective_decision`, :data:`SOFT_MODE_REL`;
        ``StabilityResult.collective``); a scan that stops at its first
        complex strip then goes on past soft ones.
    stop_at_complex : bool
        False (default): the whole spectrum is computed. True: only the
        verdict is asked for; the sliced scan stops at its first strip
        certified complex (the same certified verdict; the eigenvalues above
        it are not computed, ``StabilityResult.scanned_below``). The dense
        path computes every eigenvalue either way (one LAPACK call).
    rel_error : float or None
        Sliced path: entrywise relative uncertainty of K the verdict covers
        (default None: the unit roundoff, as the dense path).
    window : float
        Sliced path: half-width of the explicit window about a boundary, in
        units of ||W||_2 (default 10).
    slice_size : int or None
        Sliced path: Ritz pairs per slice (default None: the scan's own).
    checkpoint_dir : str or None
        Sliced path: the folder where the scan saves its state and its
        verdict, so that a killed scan resumes and a repeated one is not redone
        (``classify_sliced``'s ``checkpoint_dir``). Default None: nothing saved.
    checkpoint_seconds : float or None
        Sliced path: seconds between two saves (default None: the scan's own).
    part_size : int or None
        Sliced path: scan in parts of about this many eigenvalues of the
        symmetric part (``classify_sliced``'s ``part_size``), which a
        ``map_tasks`` given to :func:`decide` runs side by side (e.g. on MPI
        ranks). The partition depends on the matrix and ``part_size`` only,
        never on what runs the parts: the same verdict, eigenvalues and
        margins, bit for bit, on one rank or many. At least the slice size
        (``slice_size``, or ``sliced.scan.SLICE_SIZE`` = 60 when None).
        Default None: one part, the whole scan.

    Raises
    ------
    ValueError
        On construction, for a value outside its set; the message names it.
    """

    method: str = "auto"
    pairs: str = "all"
    stop_at_complex: bool = False
    rel_error: float | None = None
    window: float = 10.0
    slice_size: int | None = None
    checkpoint_dir: str | None = None
    checkpoint_seconds: float | None = None
    part_size: int | None = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got "
                             f"method = {self.method!r}")
        if self.pairs not in PAIR_POLICIES:
            raise ValueError(f"pairs must be one of {', '.join(PAIR_POLICIES)}, got "
                             f"pairs = {self.pairs!r}")
        if not isinstance(self.stop_at_complex, (bool, np.bool_)):
            raise ValueError(f"stop_at_complex must be True or False, got "
                             f"stop_at_complex = {self.stop_at_complex!r}")
        if self.slice_size is not None and (not is_integer(self.slice_size)
                                            or self.slice_size < 2):
            raise ValueError(f"slice_size must be an integer >= 2, got "
                             f"slice_size = {self.slice_size!r}")
        if self.part_size is not None:
            from remote_trigger.analysis.stability.sliced.scan import SLICE_SIZE

            least = SLICE_SIZE if self.slice_size is None else self.slice_size
            if not is_integer(self.part_size) or self.part_size < least:
                raise ValueError(f"part_size must be None or an integer >= the slice size "
                                 f"({least}), got part_size = {self.part_size!r}")

    @property
    def soft_rel(self):
        """The soft-pair threshold (a fraction of lambda_max) the policy uses:
        :data:`SOFT_MODE_REL` for 'collective', None for 'all'."""
        return SOFT_MODE_REL if self.pairs == "collective" else None


@dataclass
class StabilityResult:
    """The verdict on one equilibrium (:func:`decide`).

    Attributes
    ----------
    eigenvalues : ndarray of complex128, shape (M,)
        Eigenvalues of M^-1 K over the kept degrees of freedom, sorted by
        real part (1/time^2); on the sliced path approximations (the
        symmetric part's Ritz values for one-eigenvalue strips).
    decision : Decision
        COMPLEX, REAL or UNDECIDED (stored as 1, 0, -1).
    max_imag : float
        Largest |Im lambda| over the eigenvalues if the decision is COMPLEX, else 0.
    growth_rate : float
        max |Im omega| over omega = +-sqrt(lambda) (1/time); 0 for a real
        positive spectrum.
    n_rattlers : int
        Particles removed as rattlers.
    rattler_ids : ndarray of int64
    confidence : float
        Margin of the decision (docs/analysis.md): > 1 certified; for
        UNDECIDED the margin (< 1) of the least certain pair.
    residual : float
        max over particles of max(|F_i|, |T_i|/R_i) of the state (loads
        included; force units).
    timing : dict
        Wall times (s) of the eigen-solve (``eigen``) and of the certified
        decision (``decision``).
    basis : remote_trigger.analysis.stability.decision.SpectrumBasis or None
        The decision's verified basis (start of the next point's decision;
        dense path only).
    start : str
        ``'dgeev'``, ``'basis'`` (decided from a previous point's basis) or
        ``'sliced'`` (the verdict by slicing).
    reason : str
        Why the decision is UNDECIDED (the decision's own words, e.g. which
        strip and where), or with the 'collective' policy why that decision
        is (the units left undecided); empty otherwise.
    n_dof : int
        Order of the matrix decided (the kept dofs; -1 if not recorded).
    scanned_below : float
        ``eigenvalues`` holds every eigenvalue with real part below this and
        none above (+inf: all of them; finite for a sliced verdict COMPLEX
        that stopped at its first complex strip, ``stop_at_complex``).
        ``max_imag`` and ``growth_rate`` are then those of the pairs below.
    lambda_max : float
        Largest real part of the spectrum: of ``eigenvalues``, or with a
        finite ``scanned_below`` ARPACK's largest eigenvalue of the symmetric
        part (an approximation); NaN for an empty spectrum.
    collective : Decision or None
        With the 'collective' policy, the decision on the pairs that are not
        soft (:func:`collective_decision`): COMPLEX (a certified complex pair
        with an eigenvalue at |Re lambda| >= ``SOFT_MODE_REL`` lambda_max),
        REAL (every eigenvalue certified real, or in a certified complex pair
        below that) or UNDECIDED; None with the 'all' policy.
    soft_pairs : int
        With the 'collective' policy: the certified complex units that are
        soft (a sliced strip counts as one); -1 otherwise.
    method : str
        The path taken: ``'dense'`` or ``'sliced'`` (``''`` when every
        particle is a rattler and nothing was decided).
    complex_units : int
        The units certified complex: dense 2 x 2 pairs, or sliced strips
        (a strip of several pairs counts as one; a stopped scan counts those
        below its stop).
    """

    eigenvalues: np.ndarray
    decision: Decision
    max_imag: float
    growth_rate: float
    n_rattlers: int
    rattler_ids: np.ndarray
    confidence: float = float("inf")
    residual: float = float("nan")
    timing: dict = field(default_factory=dict)
    basis: object = None
    start: str = "dgeev"
    reason: str = ""
    n_dof: int = -1
    scanned_below: float = float("inf")
    lambda_max: float = float("nan")
    collective: Decision | None = None
    soft_pairs: int = -1
    method: str = ""
    complex_units: int = 0

    @property
    def complex_pair(self):
        """True iff a complex-conjugate pair is certified (``decision`` is
        COMPLEX): an oscillatory instability."""
        return self.decision is Decision.COMPLEX

    @property
    def policy_decision(self):
        """The decision the policy asked for: ``collective`` under the
        'collective' policy, else ``decision`` (what a ramp row stores)."""
        return self.decision if self.collective is None else self.collective


def choose_method(n, options=None, available=None):
    """The path of the verdict for a system of ``n`` dofs: 'dense' or 'sliced'.

    'auto' takes the dense path up to ``eigen.DENSE_MAX`` dofs and the sliced
    one above; a dense path (chosen or asked for) is checked against the
    memory (:func:`check_dense_fits`). The one place where the choice is made.

    Parameters
    ----------
    n : int
        Order of the reduced system.
    options : VerdictOptions, optional
    available : int, optional
        Bytes available (default: :func:`available_memory`).

    Returns
    -------
    str

    Raises
    ------
    TooLargeError
        If the dense path would not fit in memory.
    """
    from remote_trigger.analysis.stability.eigen import DENSE_MAX

    method = (options or VerdictOptions()).method
    if method == "auto":
        method = "dense" if n <= DENSE_MAX else "sliced"
    if method == "dense":
        check_dense_fits(n, available)
    return method


def spectrum_decision(system, options=None, basis=None, progress=None, map_tasks=None):
    """The certified decision of a reduced system, as the path returns it.

    The path is :func:`choose_method`'s. Dense: the decision of M^-1 K
    (:func:`classify_dense`, from ``basis`` where it certifies, carried over
    to this system's kept dofs; the returned basis records them). Sliced:
    :func:`~remote_trigger.analysis.stability.sliced.classify_sliced` with
    the options' scope, tolerances and checkpoint (no basis).

    Parameters
    ----------
    system : remote_trigger.analysis.stability.system.ReducedSystem
        With at least one dof kept.
    options : VerdictOptions, optional
    basis : SpectrumBasis, optional
    progress : callable, optional
        Sliced path: ``progress(done, n)`` after each slice.
    map_tasks : callable, optional
        Sliced path with ``options.part_size``: what runs the parts (as
        :func:`decide`).

    Returns
    -------
    dec : remote_trigger.analysis.stability.decision.SpectrumDecision
    method : str
        'dense' or 'sliced'.
    """
    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.sliced import classify_sliced

    options = options or VerdictOptions()
    method = choose_method(system.n, options)
    if method == "sliced":
        kw = {} if options.rel_error is None else {"rel_error": options.rel_error}
        dec = classify_sliced(system.K, system.mass, window=options.window,
                              slice_size=options.slice_size,
                              stop_at_complex=options.stop_at_complex, progress=progress,
                              checkpoint_dir=options.checkpoint_dir,
                              checkpoint_seconds=options.checkpoint_seconds,
                              soft_rel=options.soft_rel, part_size=options.part_size,
                              map_tasks=map_tasks, **kw)
        return dec, method
    if basis is not None and basis.dofs is not None:
        # other rattlers than at the basis's point: carried over (or None)
        basis = basis.on_dofs(system.keep_dofs)
    dec = classify_dense(eigen.dynamical_matrix(system.K, system.mass).toarray(), basis,
                         options.soft_rel)
    if dec.basis is not None:
        dec.basis.dofs = np.asarray(system.keep_dofs, np.int64).copy()
    return dec, method


def decide(system, options=None, basis=None, progress=None, map_tasks=None):
    """The stability verdict of a reduced system: the engine's one entry point.

    Parameters
    ----------
    system : remote_trigger.analysis.stability.system.ReducedSystem
        From :func:`~remote_trigger.analysis.stability.system.reduced_system`.
    options : VerdictOptions, optional
        Path, soft-pair policy, scope, tolerances, checkpoint (default
        ``VerdictOptions()``: auto path, all pairs, the whole spectrum).
    basis : SpectrumBasis, optional
        Dense path: the previous point's ``basis``, tried first
        (:func:`remote_trigger.analysis.stability.exceptional.classify_spectrum`);
        if its ``dofs`` differ from this system's kept dofs (a disk became or
        stopped being a rattler), it is carried over by
        :meth:`~remote_trigger.analysis.stability.decision.SpectrumBasis.on_dofs`.
        Ignored on the sliced path.
    progress : callable, optional
        Sliced path: ``progress(done, n)`` after each slice (see
        :func:`~remote_trigger.analysis.stability.sliced.classify_sliced`).
    map_tasks : callable, optional
        Sliced path with ``options.part_size``: ``map_tasks(fn, tasks)``
        returning ``fn``'s results in the order of ``tasks``, an iterable
        that may be closed before its end (``stop_at_complex``); ``fn``, the
        tasks and results are picklable. An executor's ``map`` or an MPI map
        (``remote_trigger.pywrap.runtime.rankmap``). Default None: the
        builtin :func:`map`, one part after the other. It changes where the
        parts run, never the answer.

    Returns
    -------
    StabilityResult

    Raises
    ------
    TooLargeError
        If the dense path would not fit in memory (:func:`check_dense_fits`).
    ValueError
        If ``options`` is not a VerdictOptions or ``basis`` not a
        SpectrumBasis or None, or ``map_tasks`` is not callable.
    """
    from remote_trigger.analysis.stability import eigen

    options = _check_inputs(options, basis, map_tasks)
    rat = system.rattlers
    if system.n == 0:          # every particle a rattler: nothing to decide
        return StabilityResult(np.zeros(0, complex), Decision.REAL, 0.0, 0.0,
                               int(rat.ids.size), np.asarray(rat.ids, np.int64),
                               float("inf"), system.max_residual, n_dof=0)
    dec, method = spectrum_decision(system, options, basis, progress, map_tasks)
    decision = dec.decision
    lam = np.asarray(dec.eigenvalues, np.complex128)
    lam = lam[np.lexsort((lam.imag, lam.real))]
    cplx = decision is Decision.COMPLEX
    max_imag = float(np.max(np.abs(lam.imag))) if (cplx and lam.size) else 0.0
    lam_max = _top(dec)
    coll, soft = (collective_decision(dec, lam_max, options.soft_rel)
                  if options.soft_rel is not None else (None, -1))
    why = str(dec.reason or "") if decision is Decision.UNDECIDED else ""
    if coll is Decision.UNDECIDED and not why:
        why = collective_reason(dec)
    units = sum(1 for p in dec.pairs if p.method != "gershgorin" and p.is_complex
                and p.certified)
    return StabilityResult(lam, decision, max_imag, float(eigen.growth_rate(lam)),
                           int(rat.ids.size), np.asarray(rat.ids, np.int64),
                           float(dec.confidence), system.max_residual, dict(dec.timing),
                           dec.basis, dec.start, why, system.n, float(dec.scanned_below),
                           float(lam_max), coll, soft, method, units)


def _check_inputs(options, basis, map_tasks=None):
    """``options`` (None: the defaults), checked with ``basis`` and ``map_tasks``."""
    options = VerdictOptions() if options is None else options
    if not isinstance(options, VerdictOptions):
        raise ValueError(f"options must be a VerdictOptions, got {type(options).__name__}")
    if basis is not None and not isinstance(basis, SpectrumBasis):
        raise ValueError(f"basis must be a SpectrumBasis (a previous result's .basis) or None, "
                         f"got {type(basis).__name__}")
    if map_tasks is not None and not callable(map_tasks):
        raise ValueError(f"map_tasks must be callable or None, got map_tasks = {map_tasks!r}")
    return options


def stability_of(state, options=None, basis=None, progress=None, map_tasks=None):
    """:func:`decide` of a state: ``decide(reduced_system(state), ...)``.

    Parameters
    ----------
    state : State or State3D
    options, basis, progress, map_tasks
        As in :func:`decide`.

    Returns
    -------
    StabilityResult

    Raises
    ------
    ValueError, TooLargeError
        As :func:`decide` (a bad ``options`` or ``basis`` before K is built).
    """
    _check_inputs(options, basis, map_tasks)
    return decide(reduced_system(state), options, basis, progress, map_tasks)


def stability_of_dump(path, options=None, basis=None, progress=None, allow_residual=False,
                      map_tasks=None):
    """Read an equilibrium dump (+ sidecar JSON) and return :func:`stability_of` it.

    A dump of spheres (``dump_dimension``) is read by ``read_dump3d``.

    ``options``, ``basis``, ``progress``, ``map_tasks``: as in :func:`decide`.
    ``allow_residual`` (default False): refuse a state that is not an
    equilibrium of its parameters, as ``remote-trigger jacobian`` does
    without ``--allow-residual``
    (:func:`~remote_trigger.analysis.stability.residual.check_equilibrium`);
    True decides any state (:func:`decide` does not check).

    Raises
    ------
    ValueError
        If the dump or its sidecar is missing, corrupt or truncated (from
        ``read_dump``; the message names the file).
    NotEquilibriumError
        Without ``allow_residual``, a residual above 1e3 x the round-off floor (a
        ``ValueError`` too; e.g. a dump written with too few digits).
    """
    from remote_trigger.analysis.stability.residual import check_equilibrium
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    try:
        state = read_equilibrium(path)      # spheres: 6 dofs each, rattlers below 3 contacts
    except (OSError, KeyError, IndexError, ValueError) as exc:
        raise ValueError(f"cannot read equilibrium dump {path!r}: {exc}") from exc
    if not allow_residual:
        check_equilibrium(state, what=path)
    return stability_of(state, options, basis, progress, map_tasks)


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
    decision : Decision
        COMPLEX: a certified complex unit that is not soft.
        REAL: the whole decision is REAL; or it is COMPLEX, covers the whole
        spectrum (no stop), its certified complex units are all soft and
        every unit that is not soft is certified (a soft unit may be
        undecided: e.g. the isolation disc of a soft pair overlapping that
        of a soft neighbour). UNDECIDED otherwise (a whole decision
        UNDECIDED stays so).
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
        return Decision.COMPLEX, soft
    if dec.decision is Decision.REAL:
        return Decision.REAL, 0
    # complex, on soft units only: real if the decision covers the whole spectrum
    # and every unit that is not soft is certified (a soft unit may be left
    # undecided, e.g. its isolation disc overlapping a soft neighbour's)
    if dec.decision is Decision.COMPLEX and math.isinf(dec.scanned_below) and \
            all(p.certified or is_soft(p) for p in dec.pairs):
        return Decision.REAL, soft
    return Decision.UNDECIDED, soft


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
            collective_decision(dec, _top(dec), soft_rel)[0] is Decision.UNDECIDED:
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




def _top(dec):
    """Largest real part of a decision's spectrum: of its eigenvalues if they are
    all there, else its ``lambda_max`` (ARPACK's); NaN for none."""
    lam = np.asarray(dec.eigenvalues)
    if math.isinf(dec.scanned_below):
        return float(np.max(lam.real)) if lam.size else math.nan
    return float(dec.lambda_max)


