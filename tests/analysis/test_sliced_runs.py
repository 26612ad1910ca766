"""The slices proved by the counts at the runs' shifts (sliced.slices.ritz_slices):
against LAPACK's spectrum, against slices whose every edge is counted, where the
next run does not reach back, and resumed from a position with a run pending."""
import copy

import numpy as np
import pytest

from remote_trigger.analysis.stability.sliced import SlicedStats, scaled_parts, slices
from remote_trigger.analysis.stability.sliced.scan import _bottom
from remote_trigger.analysis.stability.sliced.strips import StripContext


@pytest.fixture(scope="module")
def packing(tmp_path_factory):
    """S, W, the strips' context and the bottom of the free-rotation N = 400
    state (n = 1176), with LAPACK's eigenvalues of S."""
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from tests.data import unpack

    tmp = str(tmp_path_factory.mktemp("runs"))
    unpack("free_rotation_N400_s5_step_00002.dump.json", tmp)
    system = reduced_system(read_equilibrium(unpack("free_rotation_N400_s5_step_00002", tmp)))
    A, S, W = scaled_parts(system.K, system.mass)
    ctx = StripContext.of(A, S, W, 2.0 ** -53, 10.0)
    return S, W, ctx, _bottom(S, ctx, 2.0 ** -53), np.linalg.eigvalsh(S.toarray())


def _slicing(S, W, ctx, lo0, k=60):
    st = SlicedStats()
    got = list(slices.ritz_slices(S, W, k, ctx.normS, slices.start_position(S, lo0, st), st))
    return got, st


def _checked(got, lam, normS):
    """The slices tile the spectrum: contiguous edges, each Ritz value inside its
    slice and within 1e-9 ||S|| of LAPACK's eigenvalue of the same rank."""
    for a, b in zip(got, got[1:]):
        assert a.hi == b.lo
    for sl in got:
        assert np.all((sl.theta > sl.lo) & (sl.theta < sl.hi))
    theta = np.concatenate([sl.theta for sl in got])
    assert theta.size == lam.size
    assert np.max(np.abs(theta - lam)) < 1e-9 * normS
    return theta


def test_counts_at_the_shifts_prove_almost_every_slice(packing):
    """One run a slice: the count below each shift from its own factorization;
    a count at a gap only where a run's shift is too near a Ritz value of it or
    at the top (here: fewer than a quarter of the slices). Every eigenvalue of
    S found once, LAPACK's to 1e-9 ||S||."""
    S, W, ctx, lo0, lam = packing
    got, st = _slicing(S, W, ctx, lo0)
    _checked(got, lam, ctx.normS)
    assert st.slices == len(got)
    assert st.counted_edges < st.slices / 4
    assert st.lanczos_runs <= st.slices + st.split_misses + st.counted_edges + 1


def test_every_edge_counted_gives_the_same_spectrum(packing, monkeypatch):
    """With no split point between two runs (every slice's upper edge then
    counted, as at the top of the spectrum), the same eigenvalues to 1e-9 ||S||
    and more factorizations: one count at every slice edge."""
    S, W, ctx, lo0, lam = packing
    got, st = _slicing(S, W, ctx, lo0)
    monkeypatch.setattr(slices, "_split", lambda cur, nxt: None)
    got2, st2 = _slicing(S, W, ctx, lo0)
    _checked(got2, lam, ctx.normS)
    assert st2.counted_edges == st2.slices > st.counted_edges
    assert st2.split_misses == (slices._NEXT_TRIES) * (st2.slices - 1)


def test_a_next_run_that_does_not_reach_back_is_made_again(packing, monkeypatch):
    """A step far past the run's reach: the next run is made again with half
    the step until it overlaps (``split_misses``); the same spectrum."""
    S, W, ctx, lo0, lam = packing
    monkeypatch.setattr(slices, "_NEXT_STEP", 6.0)
    got, st = _slicing(S, W, ctx, lo0)
    _checked(got, lam, ctx.normS)
    assert st.split_misses > 0


def test_a_slicing_resumed_with_a_run_pending_gives_the_same_bits(packing):
    """From a copy of the position after any of the first slices (a run then
    pending: made again from its shift and the saved start-vector stream), the
    same slices, bit for bit, as the slicing that went on."""
    S, W, ctx, lo0, lam = packing
    st = SlicedStats()
    pos = slices.start_position(S, lo0, st)
    gen = slices.ritz_slices(S, W, 60, ctx.normS, pos, st)
    first = [next(gen)]
    saved = []
    for _ in range(4):
        saved.append(copy.deepcopy(pos))
        first.append(next(gen))
    assert all(p.pending is not None for p in saved)
    for i, p in enumerate(saved):
        again = slices.ritz_slices(S, W, 60, ctx.normS, copy.deepcopy(p), SlicedStats())
        for sl in first[i + 1:]:
            got = next(again)
            assert (got.lo, got.hi) == (sl.lo, sl.hi)
            assert got.theta.tobytes() == sl.theta.tobytes()
            assert got.Q.tobytes() == sl.Q.tobytes()


def _chained(S, W, ctx, lo0, k=60, pos=None, st=None):
    """ritz_slices where every float64 count counts as too fuzzy (``fuzz_limit``
    0): each count made is double-word, and the runs between form chains."""
    from remote_trigger.analysis.stability.sliced.inertia import Shifts

    st = SlicedStats() if st is None else st
    shifts = Shifts(S, 0.0, st)
    pos = slices.start_position(S, lo0, st, shifts) if pos is None else pos
    return slices.ritz_slices(S, W, k, ctx.normS, pos, st, shifts), st


@pytest.fixture(scope="module")
def chained(packing):
    """The whole chained slicing of the packing (:func:`_chained`): slices, stats."""
    S, W, ctx, lo0, lam = packing
    gen, st = _chained(S, W, ctx, lo0)
    return list(gen), st


def test_chains_of_runs_between_double_word_counts(packing, chained, monkeypatch):
    """Where the float64 counts are too fuzzy, CHAIN_RUNS - 1 runs of every
    CHAIN_RUNS leave their counts out and the counts at a chain's ends prove
    its slices: the same spectrum as one double-word count a run, with about
    1 / CHAIN_RUNS of the double-word counts."""
    S, W, ctx, lo0, lam = packing
    got, st = chained
    _checked(got, lam, ctx.normS)
    monkeypatch.setattr(slices, "CHAIN_RUNS", 1)
    gen1, st1 = _chained(S, W, ctx, lo0)
    got1 = list(gen1)
    theta1 = _checked(got1, lam, ctx.normS)
    assert st1.deferred_counts == 0 and st.deferred_counts > 0
    assert st.chain_failures == st1.chain_failures == 0
    assert st.lanczos_runs == st1.lanczos_runs
    assert st.dw_counts < 0.5 * st1.dw_counts
    assert np.concatenate([sl.theta for sl in got]).tobytes() == theta1.tobytes()


def test_no_run_above_stop_above_leaves_its_count_out(packing, chained):
    """``stop_above`` at the middle of the spectrum: every run whose shift lies
    above it is counted (fewer counts left out than without it); the same
    spectrum."""
    S, W, ctx, lo0, lam = packing
    from remote_trigger.analysis.stability.sliced.inertia import Shifts

    mid = float(np.median(lam))
    st = SlicedStats()
    shifts = Shifts(S, 0.0, st)
    got = list(slices.ritz_slices(S, W, 60, ctx.normS, slices.start_position(S, lo0, st, shifts),
                                  st, shifts, stop_above=mid))
    _checked(got, lam, ctx.normS)
    st_all = chained[1]
    assert 0 < st.deferred_counts < st_all.deferred_counts
    assert st.dw_counts > st_all.dw_counts


def test_a_chain_resumed_from_any_of_its_slices_gives_the_same_bits(packing):
    """From a copy of the position after each of the first slices of chained
    slicing (its pending run's count left out or not), the same slices, bit
    for bit."""
    S, W, ctx, lo0, lam = packing
    gen, st = _chained(S, W, ctx, lo0)
    first, saved = [next(gen)], []
    for _ in range(6):
        saved.append(copy.deepcopy(gen.gi_frame.f_locals["pos"]))
        first.append(next(gen))
    assert {p.deferred for p in saved} >= {0, 1}
    for i, p in enumerate(saved):
        again, _ = _chained(S, W, ctx, lo0, pos=copy.deepcopy(p))
        for sl in first[i + 1:]:
            got = next(again)
            assert (got.lo, got.hi) == (sl.lo, sl.hi)
            assert got.theta.tobytes() == sl.theta.tobytes()
            assert got.Q.tobytes() == sl.Q.tobytes()


def test_a_chain_whose_counts_disagree_is_made_again_run_by_run(packing, monkeypatch):
    """A run inside a chain that misses an eigenvalue (one pair dropped from
    its eigen-solve): the counts at the chain's ends disagree with its Ritz
    values, and the chain is made again from its start with every run
    counted (``chain_failures``); the same spectrum."""
    S, W, ctx, lo0, lam = packing
    real = slices.shift_invert
    calls = []

    def dropping(*args, **kw):
        lam_, V, sigma = real(*args, **kw)
        calls.append(sigma)
        if len(calls) == 3:
            j = int(np.argmin(np.abs(lam_ - sigma)))
            return np.delete(lam_, j), np.delete(V, j, axis=1), sigma
        return lam_, V, sigma

    monkeypatch.setattr(slices, "shift_invert", dropping)
    gen, st = _chained(S, W, ctx, lo0)
    _checked(list(gen), lam, ctx.normS)
    assert st.chain_failures >= 1
