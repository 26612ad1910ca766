"""What a sliced verdict did: :class:`SlicedStats`, filled by its steps."""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["SlicedStats"]


@dataclass
class SlicedStats:
    """What the sliced verdict did (``SpectrumDecision.timing`` holds the times).

    Attributes
    ----------
    n : int
        Order of A.
    slices : int
        Number of shift-invert slices of S.
    boundaries : int
        Certified boundaries (a strip between two).
    strips : dict
        Number of strips per size m.
    norm_W : float
        Rigorous upper bound of ||W||_2 (1/time^2).
    window : float
        Delta, the half-width of the explicit window (1/time^2).
    max_kappa : float
        Largest kappa(a) among certified boundaries.
    fuzz : float
        Largest inertia fuzz (1/time^2).
    ritz_radius : float
        Largest Ritz radius ||R||_2 of a slice (1/time^2).
    lanczos_runs : int
        Shift-invert eigen-solves (:func:`~.slices.shift_invert`; a slice whose
        shift missed its lower edge takes more than one).
    arpack_runs : int
        Those of them made again by ARPACK, where the Lanczos without restarts
        had not converged (:func:`~.lanczos.nearest_pairs`).
    computed : int
        Eigenpairs computed by those solves (n of them are kept).
    parts : int
        Parts of a scan in parts (``classify_sliced``'s ``part_size``,
        :mod:`.parts`): 1 for a whole scan.
    cuts : tuple of (float, float)
        Their split points and first boundaries (x_j, c_j), j = 1 .. parts - 1.
    moved : int
        Shifts moved down by 1 % of a slice width before the eigen-solver ran, because
        the probe solve of their factorization had a relative residual above
        1e-7 (:func:`~.slices.shift_invert`: a tiny pivot of the elimination).
    reshifted : int
        Slices computed again about a shift moved by 1 % of their span (their
        Kahan radius above the eigen-solver's own bound for their pairs,
        :func:`~.slices.stopping_bound`: it converged to vectors of an
        inexact operator).
    split_misses : int
        Runs made again with half the step because the run above a slice did not
        reach back into it (no split point between the two runs,
        :func:`~.slices.ritz_slices`).
    counted_edges : int
        Points proved by a count at a gap of Ritz values (a factorization of
        their own), not at a run's shift: a slice's upper edge where the run
        above does not prove it, or a run's proved point where its shift is
        too near one of its Ritz values for its count
        (:func:`~.slices.ritz_slices`).
    dw_counts : int
        Sylvester counts made again in double-word arithmetic: their float64
        fuzz above :func:`~.inertia.fuzz_limit`, or a slice edge that only
        that fuzz kept too close to a Ritz value (:mod:`.slices`).
    deferred_counts : int
        Runs whose count was left out, between two counted runs of a chain
        (their float64 count too fuzzy to use, or every count a
        factorization of its own, as with SuperLU's solves;
        :func:`~.slices.ritz_slices`).
    chain_failures : int
        Chains whose end counts did not prove them, made again with every
        run counted (:func:`~.slices.ritz_slices`).
    """

    n: int = 0
    slices: int = 0
    boundaries: int = 0
    strips: dict = field(default_factory=dict)
    norm_W: float = 0.0
    window: float = 0.0
    max_kappa: float = 0.0
    fuzz: float = 0.0
    ritz_radius: float = 0.0
    lanczos_runs: int = 0
    arpack_runs: int = 0
    computed: int = 0
    moved: int = 0
    reshifted: int = 0
    split_misses: int = 0
    counted_edges: int = 0
    dw_counts: int = 0
    deferred_counts: int = 0
    chain_failures: int = 0
    parts: int = 1
    cuts: tuple = ()
