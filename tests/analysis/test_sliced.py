"""The whole-spectrum verdict by slicing (analysis.stability.sliced) against the
dense certified decision and against Arb, on hand-built matrices with planted
pairs and on frictional packings."""
import dataclasses
import pickle

import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability import eigen, exceptional
from remote_trigger.analysis.stability.sliced import (
    SlicedStats, classify_sliced, count_below, saved_scans, scan, strips)

from remote_trigger.analysis.stability.sliced.strips import arpack_hint

from .arb_oracle import full_spectrum
from remote_trigger.analysis.stability.decision import Decision


def planted(n=150, pairs=(), seed=0, coupling=0.3):
    """K and M whose M^-1/2 K M^-1/2 = S + W: S = diagonal spectrum in [1, 100] plus a
    sparse symmetric coupling, W a sparse skew coupling; ``pairs`` = (i, ratio):
    eigenvalues i and i + 1 of S 0.2 apart, coupled by w = ratio * 0.1 (in the
    2 x 2 block alone: complex iff ratio > 1)."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(1.0, 100.0, n) + rng.uniform(-0.1, 0.1, n)
    W = sp.random(n, n, density=4.0 / n, random_state=rng, data_rvs=rng.standard_normal)
    W = (W - W.T) * (coupling * 0.1)
    C = sp.random(n, n, density=3.0 / n, random_state=rng, data_rvs=rng.standard_normal)
    S = sp.diags(theta) + (C + C.T) * 0.01
    W = W.tolil()
    S = S.tolil()
    for i, ratio in pairs:
        S[i + 1, i + 1] = S[i, i] + 0.2
        for j in (i, i + 1):             # the pair coupled to nothing else
            for k in range(n):
                if k not in (i, i + 1):
                    W[j, k] = W[k, j] = 0.0
                    S[j, k] = S[k, j] = 0.0
        W[i, i + 1], W[i + 1, i] = ratio * 0.1, -ratio * 0.1
    A = (S + W).tocsr()
    mass = rng.uniform(0.5, 2.0, n)
    r = np.sqrt(mass)
    K = sp.diags(r) @ A @ sp.diags(r)
    return sp.csr_matrix(K), mass


def dense_decision(K, mass):
    return exceptional.classify_spectrum(eigen.dynamical_matrix(K, mass).toarray())


def test_count_below_is_the_number_of_eigenvalues_below():
    rng = np.random.default_rng(3)
    C = sp.random(200, 200, density=0.03, random_state=rng)
    S = sp.csc_matrix(C + C.T + sp.diags(np.linspace(-5, 5, 200)))
    lam = np.linalg.eigvalsh(S.toarray())
    for a in (-6.0, -1.3, 0.01, 2.7, 9.0):
        cnt, fuzz, _ = count_below(S, a)
        assert fuzz < 1e-8
        assert cnt == np.count_nonzero(lam < a)
    with pytest.raises(ValueError, match="a = 1.0"):
        count_below(sp.csc_matrix(np.eye(3)), 1.0)


def test_count_below_inside_a_packing_spectrum():
    """S of a frictional packing (810 kept dofs), shifts in 25 gaps across its
    spectrum (indefinite S - a I, factorized without pivoting): the count is
    the dense one and the fuzz stays far below the gap."""
    from remote_trigger.analysis.stability import jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.sliced import scaled_parts

    from .builders import random_packing

    res = analyze(random_packing(5, nx=20, ny=15), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    S = scaled_parts(Kr, mr)[1]
    lam = np.linalg.eigvalsh(S.toarray())
    for i in np.linspace(5, lam.size - 6, 25).astype(int):
        a = 0.5 * (lam[i] + lam[i + 1])
        cnt, fuzz, factor = count_below(S, a)
        assert cnt == i + 1
        assert fuzz < 1e-2 * (lam[i + 1] - lam[i])
        # the premise of the fuzz: the factors reproduce P^T (S - a I) P to within
        # it (a factorization that regularized or pivoted would not)
        L, d, p = factor.factors()
        IL = sp.identity(S.shape[0], format="csc") + sp.csc_matrix(L)
        H = (S - a * sp.identity(S.shape[0], format="csc")).tocsr()[p][:, p]
        Z = (IL @ sp.diags(d) @ IL.T - H).toarray()
        assert np.max(np.abs(Z).sum(axis=1)) <= fuzz


def test_refactorized_counts_are_bitwise_new_factorizations():
    """The slices count at many shifts a with one ordering (sliced.inertia.Shifts,
    QDLDL's update): permutation, L, D, counts, fuzz and solves bitwise those
    of a new factorization at each shift; a zero pivot, which update() does
    not report, is refused as a new factorization refuses it, and the next
    count is again bitwise."""
    import qdldl

    from remote_trigger.analysis.stability import jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.sliced import scaled_parts
    from remote_trigger.analysis.stability.sliced.inertia import Shifts, shifted

    from .builders import random_packing

    res = analyze(random_packing(5, nx=20, ny=15), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    S = scaled_parts(Kr, mr)[1]
    shifts = Shifts(S)
    b = np.random.default_rng(1).standard_normal(S.shape[0])
    lam = np.linalg.eigvalsh(S.toarray())
    # the first pivot of the ordering is S_pp - a: zero at a = S_pp
    shifts.count_below(lam[3])
    p0 = int(shifts.solver.factors()[2][0])
    tried = failed = 0
    for a in [lam[3], float(S.diagonal()[p0]), *np.linspace(lam[3], lam[-3], 7)]:
        try:
            got = shifts.count_below(a)
        except ValueError as exc:
            assert "zero pivot" in str(exc)
            with pytest.raises(RuntimeError):
                qdldl.Solver(shifted(S, a))
            with pytest.raises(ValueError):
                count_below(S, a)
            failed += 1
            continue
        fac, new = shifts.solver, qdldl.Solver(shifted(S, a))
        (L1, d1, p1), (L2, d2, p2) = fac.factors(), new.factors()
        assert np.array_equal(p1, p2) and np.array_equal(d1, d2)
        assert np.array_equal(L1.indptr, L2.indptr) and np.array_equal(L1.indices, L2.indices)
        assert np.array_equal(L1.data, L2.data)
        assert np.array_equal(fac.solve(b), new.solve(b))
        assert got[:2] == count_below(S, a)[:2]
        tried += 1
    assert (tried, failed) == (8, 1)


@pytest.mark.parametrize("where", [2, 75, 146])
@pytest.mark.parametrize("ratio", [1.5, 1.02, 0.97, 0.7])
def test_planted_pair_bottom_middle_top(where, ratio):
    """A complex pair (ratio 1.5, 1.02) or a real pair near its exceptional
    point (0.97, 0.7) planted at the bottom, the middle or the top of the
    spectrum; a complex pair is decided as a strip of two eigenvalues, a real
    one by a boundary between them (0.7) or as a strip (0.97, if no boundary
    can be certified there)."""
    K, mass = planted(pairs=[(where, ratio)])
    st = SlicedStats()
    res = classify_sliced(K, mass, stats=st)
    assert res.coverage == "whole" and res.start == "sliced"
    assert res.decision is Decision.certified(ratio > 1), res.reason
    assert dense_decision(K, mass).decision is Decision.certified(ratio > 1)
    assert sum(st.strips.values()) + st.strips.get(2, 0) == 150
    if ratio > 1:
        assert st.strips.get(2, 0) >= 1
        assert any(p.certified and p.is_complex for p in res.pairs)
    assert all(p.certified for p in res.pairs)


def test_two_nearly_coalescing_real_pairs_are_real():
    K, mass = planted(pairs=[(40, 0.9), (41 + 60, 0.95)], seed=1)
    res = classify_sliced(K, mass)
    assert res.decision is Decision.REAL, res.reason
    assert dense_decision(K, mass).decision is Decision.REAL
    assert all(p.certified for p in res.pairs)


@pytest.mark.parametrize("ratio", [1.2, 0.8])
def test_agrees_with_arb(ratio):
    """n = 40: Arb's enclosure of the whole spectrum of M^-1 K says the same."""
    K, mass = planted(n=40, pairs=[(20, ratio)], seed=2)
    res = classify_sliced(K, mass)
    want = "complex" if ratio > 1 else "real"
    assert res.decision is Decision.certified(ratio > 1), res.reason
    assert full_spectrum(eigen.dynamical_matrix(K, mass).toarray()) == want


def test_strong_coupling_is_never_called_real():
    """A skew part as large as the spacing: many complex pairs; the verdict is
    'complex' or 'undecided', never 'real' (the check can fail)."""
    K, mass = planted(n=120, seed=4, coupling=30.0)
    dense = dense_decision(K, mass)
    assert dense.decision is Decision.COMPLEX
    res = classify_sliced(K, mass)
    assert res.decision in (Decision.COMPLEX, Decision.UNDECIDED)
    if res.decision is Decision.UNDECIDED:
        assert res.reason


def test_a_slice_with_inexact_vectors_is_computed_again(monkeypatch):
    """A slice whose Ritz vectors are inexact in every direction (as ARPACK
    leaves them when the solves are: a shift at a tiny pivot of the
    factorization, docs/results/analysis.md "A shift at a tiny pivot"; here
    simulated by perturbing the third slice's vectors by 1e-6) is computed
    again about a shift 1 % of its span lower: the scan's largest Kahan
    radius is then that of the clean slices and every eigenvalue is in a
    strip of its own. Without the second computation (_RECOMPUTE_ABOVE = inf) the
    same scan keeps the large radius and strips of 2. Both verdicts are the
    dense one. (The rule: a Kahan radius above the eigen-solver's own bound
    for the slice's pairs, slices.stopping_bound.)"""
    from remote_trigger.analysis.stability.sliced import slices

    K, M = planted(n=400, pairs=[(200, 0.7)])
    pairs = slices.nearest_pairs
    calls = []

    def noisy(*args):
        lam, V, steps = pairs(*args)
        calls.append(1)
        if len(calls) == 3:         # the third slice's vectors, perturbed by 1e-6
            V = V + 1e-6 * np.random.default_rng(0).standard_normal(V.shape)
        return lam, V, steps

    monkeypatch.setattr(slices, "nearest_pairs", noisy)
    got, default = {}, slices._RECOMPUTE_ABOVE
    for refine in (default, np.inf):
        monkeypatch.setattr(slices, "_RECOMPUTE_ABOVE", refine)
        calls.clear()
        st = SlicedStats()
        got[refine] = (classify_sliced(K, M, stats=st), st)
    (dec, st), (dec0, st0) = got[default], got[np.inf]
    assert st.reshifted == 1 and st0.reshifted == 0
    assert st.lanczos_runs == st0.lanczos_runs + 1
    assert st.ritz_radius < st0.ritz_radius / 100
    assert st.strips == {1: 400} and st0.strips.get(2, 0) > 0
    want = dense_decision(K, M).decision
    assert dec.decision is want is Decision.REAL and dec0.decision is Decision.REAL


def test_a_poor_slice_weakens_only_the_boundaries_near_it(monkeypatch):
    """The radius that a boundary's test subtracts is the largest of the
    slices still in the buffer, not of every slice so far: one slice with
    residuals 1e-5 (not computed again) leaves strips of several eigenvalues in its
    own range and its neighbour's, and every eigenvalue of S above them in a
    strip of its own. (With the largest radius so far, the same scan made
    strips of 2-6 up to the top of the spectrum.)"""
    from remote_trigger.analysis.stability.sliced import slices

    K, M = planted(n=400, pairs=[(200, 0.7)])
    pairs = slices.nearest_pairs
    seen = []

    def noisy(*args):
        lam, V, steps = pairs(*args)
        seen.append(lam)
        if len(seen) == 2:
            V = V + 1e-5 * np.random.default_rng(0).standard_normal(V.shape)
        return lam, V, steps

    monkeypatch.setattr(slices, "nearest_pairs", noisy)
    monkeypatch.setattr(slices, "_RECOMPUTE_ABOVE", np.inf)
    st = SlicedStats()
    dec = classify_sliced(K, M, stats=st)
    top = float(np.max(seen[1]))            # the poor slice reaches up to here
    groups = [p.eigenvalues.real for p in dec.pairs]
    assert groups and min(g.min() for g in groups) < top     # the poor slice's strips
    assert max(g.max() for g in groups) < top + 2 * st.window
    assert sum(st.strips.get(m, 0) * m for m in st.strips if m > 1) < 80


def test_too_narrow_window_is_undecided_with_a_reason():
    K, mass = planted(pairs=[(75, 1.5)])
    res = classify_sliced(K, mass, window=1e-3)
    assert res.decision in (Decision.COMPLEX, Decision.UNDECIDED)
    if res.decision is Decision.UNDECIDED:
        assert res.reason


def test_bad_input():
    with pytest.raises(ValueError, match="square"):
        classify_sliced(sp.csr_matrix(np.ones((3, 4))), np.ones(3))
    with pytest.raises(ValueError, match="-1.0"):
        classify_sliced(sp.identity(3, format="csr"), np.array([1.0, -1.0, 1.0]))
    bad = sp.csr_matrix(np.array([[1.0, np.nan], [0.0, 1.0]]))
    with pytest.raises(ValueError, match="non-finite"):
        classify_sliced(bad, np.ones(2))


def _cluster(w_chain, w_pair, n=150, m=10, spacing=0.004, clusters=((70, 50.0),)):
    """S diagonal with clusters of m eigenvalues ``spacing`` apart (from index c0
    at value x0 for each (c0, x0) of ``clusters``), W a skew chain ``w_chain``
    along each and ``w_pair`` between its members 5 and 6 (a sequence: one per
    cluster)."""
    theta = np.linspace(1.0, 100.0, n)
    W = sp.lil_matrix((n, n))
    pair_w = np.broadcast_to(np.asarray(w_pair, float), (len(clusters),))
    for (c0, x0), wp in zip(clusters, pair_w):
        theta[c0:c0 + m] = x0 + spacing * np.arange(m)
        for a in range(c0, c0 + m - 1):
            W[a, a + 1], W[a + 1, a] = w_chain, -w_chain
        W[c0 + 4, c0 + 5], W[c0 + 5, c0 + 4] = wp, -wp
    return sp.csr_matrix(sp.diags(theta) + W), np.ones(n)


@pytest.mark.parametrize("w_chain, w_pair, m", [
    (0.0025, 0.01, 10),     # one pair in a strip of 10
    (0.0019, 0.02, 4),      # 2 real + 1 pair: a mixed strip, no real-axis route decides it
    (0.003, 0.01, 10),      # 5 pairs in a strip of 10
])
def test_strip_with_a_pair_is_certified_complex_by_winding(w_chain, w_pair, m):
    """Before the box route these strips were undecided (their reasons: "strip of
    10 eigenvalues (> 8)", "strip of 4: no sign change of det between roots"):
    a box about ARPACK's estimate, off the real axis, holds an eigenvalue."""
    K, mass = _cluster(w_chain, w_pair)
    lam = np.linalg.eigvals(K.toarray())
    assert np.count_nonzero(lam.imag > 0) >= 1
    st = SlicedStats()
    res = classify_sliced(K, mass, stats=st)
    assert res.decision is Decision.COMPLEX, res.reason
    assert st.strips.get(m) == 1
    # the strip's approximations carry the pair (for the growth rate and the
    # pair's place downstream), as LAPACK has it
    got = np.asarray(res.eigenvalues)
    for z in lam[lam.imag > 0]:
        assert np.min(np.abs(got - z)) < 1e-8 * abs(z)
    assert full_spectrum(eigen.dynamical_matrix(K, mass).toarray()) == "complex"


def test_real_cluster_of_26_is_certified_real_by_the_deflated_route():
    """A real cluster of 26 (> 24: the routes of a sparse LU per evaluation try
    it off the real axis only, and left it undecided): the deflated route (one
    LU, det of the polynomial complement changing sign 26 times between its
    estimated roots) certifies it real, as LAPACK and the arbitrary-precision
    oracle have it. ARPACK's note for such a strip, were it undecided, sees
    its 26 eigenvalues, none complex."""
    K, mass = _cluster(0.0022, 0.0022, n=200, m=26)
    assert np.all(np.linalg.eigvals(K.toarray()).imag == 0)
    st = SlicedStats()
    res = classify_sliced(K, mass, stats=st)
    assert res.decision is Decision.REAL, res.reason
    assert st.strips.get(26) == 1
    assert full_spectrum(eigen.dynamical_matrix(K, mass).toarray()) == "real"
    note, inside = arpack_hint(K, 49.9, 50.2, 26)     # (mass 1: A = K)
    assert "26 of its 26 eigenvalues seen, none complex" in note and inside.size == 26


def test_every_undecided_strip_is_named():
    """Two undecided strips, each a real pair at an exceptional point of the
    cluster's skew chain (S = 20 and 50 + 0.004 k, W = 0.002 between members 4
    and 5: a double root, defective, coupled to the cluster's rest): no route
    can certify it real, nor exclude a real root. The reason names both, with
    ARPACK's note for each."""
    K, mass = _cluster(0.0, 0.002, n=200, m=6, spacing=0.004,
                       clusters=((30, 20.0), (100, 50.0)))
    res = classify_sliced(K, mass)
    assert res.decision is Decision.UNDECIDED
    assert res.reason.startswith("2 undecided strips: strip of 2: ")
    low, high = res.reason.split(" | ")
    assert "near x = 20.018;" in low and "near x = 50.018" in high
    assert low.endswith("none complex") and high.endswith("none complex")
    assert "2 of its 2 eigenvalues seen" in high


def test_strips_equal_to_within_their_rounding_need_no_lu(monkeypatch):
    """Exact double real eigenvalues with W = 0 (20 and 50): their projected
    cluster is exact to its rounding, and no route can separate the pair
    (:func:`strips.unresolved`). Each strip is undecided at once, named with
    its estimates and the error floor; no deflated complement (the strip's
    first sparse LU), no ARPACK (both made to fail here), and the
    whole-spectrum verdict is undecided."""
    K, mass = _cluster(0.0, 0.0, n=200, m=2, spacing=0.0, clusters=((30, 20.0), (100, 50.0)))
    assert np.all(np.linalg.eigvals(K.toarray()).imag == 0)

    def no_lu(*a, **k):
        raise AssertionError("a strip equal to within its rounding took a sparse LU")
    monkeypatch.setattr(strips, "decide_deflated", no_lu)
    monkeypatch.setattr(scan, "arpack_hint", no_lu)
    res = classify_sliced(K, mass)
    assert res.decision is Decision.UNDECIDED
    low, high = res.reason.split(" | ")
    for part, x in ((low, "20"), (high, "50")):
        assert "equal to within the rounding of its block" in part
        assert f"the projected cluster: {x}+0j .. {x}+0j" in part and "ARPACK" not in part
    # a pair split by much more than the floor is not skipped
    assert not strips.unresolved([20.0, 20.0 + 1e-6], 1.0, 1e-11)
    assert strips.unresolved([20.0, 20.0 + 1e-13], 1.0, 1e-11)
    assert not strips.unresolved([20.0 + 1e-6j, 20.0 - 1e-6j], 1.0, 1e-11)
    assert strips.unresolved([20.0 + 1e-13j, 20.0 - 1e-13j], 1.0, 1e-11)


@pytest.mark.parametrize("m, clusters", [
    (10, ((70, 50.0),)),
    (10, ((30, 20.0), (70, 50.0))),
    (14, ((70, 50.0),)),
    (24, ((70, 50.0),)),
])
def test_real_clusters_of_up_to_24_are_certified_real(m, clusters):
    """Real clusters of 10-24 strongly coupled eigenvalues (left undecided
    while only strips of up to 8 were tried on the real axis): m sign
    changes of det T, certified real, as the Arb oracle says."""
    K, mass = _cluster(0.0022, 0.0022, n=200, m=m, clusters=clusters)
    st = SlicedStats()
    res = classify_sliced(K, mass, stats=st)
    assert res.decision is Decision.REAL, res.reason
    assert st.strips.get(m) == len(clusters)
    assert full_spectrum(eigen.dynamical_matrix(K, mass).toarray()) == "real"


def test_stop_at_complex_lists_the_spectrum_below_the_first_complex_strip():
    """Two complex pairs planted (modes 30 and 120 of 150): the full scan
    certifies both strips; the stopped scan gives the same verdict from the
    first, with exactly the full scan's eigenvalues below its upper boundary
    (as many as LAPACK has there), ARPACK's top eigenvalue, and fewer slices."""
    K, mass = planted(pairs=[(30, 1.5), (120, 1.5)], seed=5)
    full_st, stop_st = SlicedStats(), SlicedStats()
    full = classify_sliced(K, mass, stats=full_st)
    stop = classify_sliced(K, mass, stats=stop_st, stop_at_complex=True)
    assert full.decision is Decision.COMPLEX and stop.decision is Decision.COMPLEX, stop.reason
    assert np.isinf(full.scanned_below) and np.isnan(full.lambda_max)
    assert sum(p.is_complex and p.certified for p in full.pairs) == 2
    assert sum(p.is_complex and p.certified for p in stop.pairs) == 1
    lam = np.linalg.eigvals(eigen.dynamical_matrix(K, mass).toarray())
    pairs_re = np.sort(lam[lam.imag > 0].real)
    assert pairs_re[0] < stop.scanned_below < pairs_re[1]
    below = full.eigenvalues[full.eigenvalues.real < stop.scanned_below]
    np.testing.assert_array_equal(stop.eigenvalues, below)
    assert stop.eigenvalues.size == np.count_nonzero(lam.real < stop.scanned_below)
    assert abs(stop.lambda_max - np.max(full.eigenvalues.real)) < 1e-9 * stop.lambda_max
    assert stop_st.slices < full_st.slices
    assert "only" in stop.describe() and "only" not in full.describe()


def test_progress_counts_the_scan_and_changes_nothing():
    """``progress(done, n)`` after each slice: done rises with every slice to n
    for a whole scan (real) and stops below n for a scan stopped at a complex
    strip; the verdicts and eigenvalues are those of the same calls without it."""
    n = 150
    for pairs, stop, want in (((), False, Decision.REAL), (((40, 1.5),), True, Decision.COMPLEX)):
        K, mass = planted(n=n, pairs=pairs, seed=7)
        calls, st = [], SlicedStats()
        got = classify_sliced(K, mass, stop_at_complex=stop, slice_size=20, stats=st,
                              progress=lambda done, m: calls.append((done, m)))
        ref = classify_sliced(K, mass, stop_at_complex=stop, slice_size=20)
        assert got.decision is want and ref.decision is want, got.reason
        np.testing.assert_array_equal(got.eigenvalues, ref.eigenvalues)
        done = [d for d, _ in calls]
        assert all(m == n for _, m in calls) and len(calls) == st.slices > 1
        assert all(a < b for a, b in zip(done, done[1:])) and done[0] > 0
        assert (done[-1] == n) is (not stop)


@pytest.mark.parametrize("pair, want", [(20, Decision.COMPLEX), (None, Decision.UNDECIDED)])
def test_slicing_that_fails_above_a_complex_strip_is_complex(monkeypatch, pair, want):
    """The slices stop after the third (a planted failure): with a complex
    strip below, the verdict is complex (the strip decides the whole matrix)
    with the failure as its note; without one, undecided."""
    from remote_trigger.analysis.stability.sliced import scan
    from remote_trigger.analysis.stability.sliced.numerics import SliceFailure

    real_slices = scan.ritz_slices

    def failing(*args, **kwargs):
        for k, sl in enumerate(real_slices(*args, **kwargs)):
            if k == 3:
                raise SliceFailure("planted failure")
            yield sl

    monkeypatch.setattr(scan, "ritz_slices", failing)
    K, mass = planted(pairs=[(pair, 1.5)] if pair is not None else [], seed=6)
    res = classify_sliced(K, mass, slice_size=20)
    assert res.decision is want
    assert "planted failure" in res.reason
    assert bool(np.isfinite(res.scanned_below)) is (want is Decision.COMPLEX)


class _Killed(Exception):
    """Stands for a kill in the middle of a scan."""


def _fields(res, st):
    """Every number of a verdict and its statistics, as text (floats exact, NaN == NaN)."""
    return repr((res.decision, res.confidence, res.reason, res.scanned_below,
            res.lambda_max, res.eigenvalues.tobytes(), res.backward_error,
            [(p.eigenvalues.tobytes(), repr(dataclasses.replace(p, eigenvalues=None)))
             for p in res.pairs],
            {k: v for k, v in vars(st).items()}))


@pytest.mark.parametrize("pairs, stop", [((), False), (((100, 1.5),), True)])
def test_a_scan_killed_after_any_slice_resumes_to_the_same_bits(tmp_path, pairs, stop):
    """``checkpoint_dir``: a scan saved after every slice and killed after
    slice k (k = 2, 4, ...; the state saved after slice k - 1) resumes, in a fresh call, to the verdict, pairs,
    margins, eigenvalues and statistics of the uninterrupted scan, bit for
    bit; a second call returns the saved verdict without scanning; the scan's
    state is removed when the verdict is saved; a different matrix (one bit
    of one entry) does not find it. The state holds no array of n rows (the
    buffer's Ritz vectors are computed again on resume)."""
    K, mass = planted(n=150, pairs=pairs, seed=11)
    ref_st = SlicedStats()
    ref = classify_sliced(K, mass, slice_size=20, stats=ref_st, stop_at_complex=stop)
    assert ref.decision is Decision.certified(pairs), ref.reason
    assert ref_st.slices >= 4
    want = _fields(ref, ref_st)
    for k in range(2, ref_st.slices + 1, 2):
        folder = tmp_path / f"k{k}"
        seen = []

        def kill(done, n):
            seen.append(done)
            if len(seen) == k:
                raise _Killed

        with pytest.raises(_Killed):
            classify_sliced(K, mass, slice_size=20, stop_at_complex=stop, progress=kill,
                            checkpoint_dir=folder, checkpoint_seconds=0)
        assert [p.name.endswith(".scan.pkl") for p in folder.iterdir()] == [True]
        # how far the saved scan had come: the count after slice k - 1
        (path, done, n_saved, _), = saved_scans(folder)
        assert (done, n_saved) == (seen[-2], K.shape[0]) and path.endswith(".scan.pkl")
        # the state keeps no array of n rows: neither W Q nor the Ritz vectors
        # (computed again on resume)
        with open(path, "rb") as fh:
            _, sc = pickle.load(fh)
        assert sc.buf.Q is None and sc.buf.q_shape[0] == K.shape[0]
        assert not [name for obj in (sc, sc.buf) for name, v in vars(obj).items()
                    if isinstance(v, np.ndarray) and v.ndim == 2 and v.shape[0] == K.shape[0]]
        more, st = [], SlicedStats()
        got = classify_sliced(K, mass, slice_size=20, stats=st, stop_at_complex=stop,
                              progress=lambda done, n: more.append(done),
                              checkpoint_dir=folder, checkpoint_seconds=0)
        assert _fields(got, st) == want
        assert len(more) == ref_st.slices - (k - 1)  # the killed slice again, then the rest
        assert [p.name.endswith(".done.pkl") for p in folder.iterdir()] == [True]
        assert saved_scans(folder) == []
    st = SlicedStats()
    again = classify_sliced(K, mass, slice_size=20, stats=st, stop_at_complex=stop,
                            checkpoint_dir=folder,
                            progress=lambda *a: pytest.fail("scanned again"))
    assert _fields(again, st) == want
    K2 = K.copy()
    K2.data[0] = np.nextafter(K2.data[0], np.inf)
    seen2 = []
    classify_sliced(K2, mass, slice_size=20, stop_at_complex=stop, checkpoint_dir=folder,
                    progress=lambda done, n: seen2.append(done))
    assert len(seen2) > 0
    assert len(list(folder.iterdir())) == 2


def test_a_scan_whose_slices_do_not_come_again_starts_over(tmp_path):
    """A resumed scan computes its buffer's slices again from the saved
    position and checks them against the saved hash of the Ritz vectors: a
    state whose hash, or whose position, does not match what comes out is not
    resumed but scanned from the beginning, to the same bits. (A window of
    40 ||W|| keeps three slices in the buffer at the kill.)"""
    K, mass = planted(n=150, seed=11)
    ref_st = SlicedStats()
    ref = classify_sliced(K, mass, slice_size=20, stats=ref_st, window=40.0)
    want = _fields(ref, ref_st)
    for spoil in ("hash", "position", None):
        folder = tmp_path / str(spoil)
        seen = []

        def kill(done, n):
            seen.append(done)
            if len(seen) == 4:
                raise _Killed

        with pytest.raises(_Killed):
            classify_sliced(K, mass, slice_size=20, progress=kill, checkpoint_dir=folder,
                            checkpoint_seconds=0, window=40.0)
        (path, *_), = saved_scans(folder)
        with open(path, "rb") as fh:
            key, sc = pickle.load(fh)
        assert len(sc.buf.edges) == 3 and set(sc.starts) == {e[0] for e in sc.buf.edges}
        if spoil == "hash":
            sc.buf.q_sha = "0" * 64
        elif spoil == "position":
            sc.starts[sc.buf.edges[0][0]].rng = np.random.default_rng(1)
        with open(path, "wb") as fh:
            pickle.dump((key, sc), fh)
        more, st = [], SlicedStats()
        got = classify_sliced(K, mass, slice_size=20, stats=st, checkpoint_dir=folder,
                              checkpoint_seconds=0, progress=lambda d, n: more.append(d),
                              window=40.0)
        assert _fields(got, st) == want
        assert len(more) == (ref_st.slices - 3 if spoil is None else ref_st.slices)


def test_a_verdict_saved_under_another_strip_limit_is_not_taken(tmp_path, monkeypatch):
    """The saved state is keyed by the largest strip decided on the real axis
    too: a verdict (or a scan) saved under another limit is scanned over, so
    no verdict mixes strips decided by two rules."""
    from remote_trigger.analysis.stability.sliced import scan

    K, mass = planted(n=60, seed=2)
    monkeypatch.setattr(scan, "_MAX_STRIP", 8)
    classify_sliced(K, mass, slice_size=20, checkpoint_dir=tmp_path)
    monkeypatch.setattr(scan, "_MAX_STRIP", 24)
    seen = []
    classify_sliced(K, mass, slice_size=20, checkpoint_dir=tmp_path,
                    progress=lambda done, n: seen.append(done))
    assert seen, "the verdict saved under the limit 8 was taken"
    seen.clear()
    classify_sliced(K, mass, slice_size=20, checkpoint_dir=tmp_path,
                    progress=lambda done, n: seen.append(done))
    assert not seen                     # its own saved verdict is taken


def test_a_stale_scan_state_is_removed_and_bad_input_refused(tmp_path):
    """A saved scan of another matrix is left alone until a verdict is saved
    in the folder, then removed; an unreadable state is scanned over; a
    negative or NaN ``checkpoint_seconds`` is refused by name."""
    K, mass = planted(n=60, seed=2)
    (tmp_path / "sliced-0123.scan.pkl").write_bytes(b"not a pickle")
    (tmp_path / "notes.txt").write_text("kept")
    assert saved_scans(tmp_path) == []          # the unreadable state is left out
    res = classify_sliced(K, mass, slice_size=20, checkpoint_dir=tmp_path)
    assert res.decision is Decision.REAL
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names[0] == "notes.txt" and len(names) == 2 and names[1].endswith(".done.pkl")
    assert saved_scans(tmp_path / "missing") == []
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="checkpoint_seconds"):
            classify_sliced(K, mass, checkpoint_dir=tmp_path, checkpoint_seconds=bad)


def test_a_state_of_other_code_under_the_calls_key_is_scanned_over(tmp_path):
    """A saved scan and verdict under this call's own key that do not load (as
    the files of the code before the package ``sliced`` would not: pickle
    finds their classes by module path, and ``sliced._Scan`` and
    ``ritz_buffer.RitzBuffer`` are gone; or a truncated file) are scanned
    over from the beginning, to the bits of a call without them, and replaced
    by this call's verdict."""
    K, mass = planted(n=60, seed=2)
    ref_st = SlicedStats()
    want = _fields(classify_sliced(K, mass, slice_size=20, stats=ref_st), ref_st)
    classify_sliced(K, mass, slice_size=20, checkpoint_dir=tmp_path)
    done, = tmp_path.iterdir()
    key = done.name[len("sliced-"):-len(".done.pkl")]
    good = done.read_bytes()
    payloads = {
        # (key, sliced._Scan()) and (key, ritz_buffer.RitzBuffer()) as protocol 0
        "old scan": b"(V%s\ncremote_trigger.analysis.stability.sliced\n_Scan\n)Rt." % key.encode(),
        "old buffer": (b"(V%s\ncremote_trigger.analysis.stability.ritz_buffer\nRitzBuffer\n)Rt."
                       % key.encode()),
        "truncated": good[:len(good) // 2],
    }
    for name, payload in payloads.items():
        with pytest.raises(Exception):
            pickle.loads(payload)
        for suffix in (".scan.pkl", ".done.pkl"):
            (tmp_path / f"sliced-{key}{suffix}").write_bytes(payload)
        seen, st = [], SlicedStats()
        got = classify_sliced(K, mass, slice_size=20, stats=st, checkpoint_dir=tmp_path,
                              progress=lambda done, n: seen.append(done))
        assert _fields(got, st) == want, name
        assert len(seen) == ref_st.slices, name
        assert [p.name for p in tmp_path.iterdir()] == [done.name], name
        assert done.read_bytes() != payload


def test_soft_pairs_do_not_stop_the_scan_and_collective_decision():
    """A pair planted at the bottom (Re ~ 1.2 of lambda_max ~ 100) and one at mode
    120: with soft_rel = 0.05 the first is soft, so the stopped scan goes on past
    it and stops at the second (scanned_below between them in LAPACK's
    spectrum); ``collective_decision`` calls that complex with one soft pair.
    With the bottom pair alone the scan with soft_rel covers the whole spectrum
    and the decision on the pairs that are not soft is real (one soft pair), as
    the dense decision's; with soft_rel = 0 both pairs count. A bad soft_rel is
    refused by name."""
    from remote_trigger.analysis.stability.verdict import collective_decision

    K, mass = planted(pairs=[(0, 1.5), (120, 1.5)], seed=5)
    lam = np.linalg.eigvals(eigen.dynamical_matrix(K, mass).toarray())
    pairs_re = np.sort(lam[lam.imag > 0].real)
    top = float(np.max(lam.real))
    assert pairs_re[0] < 0.05 * top < pairs_re[1]
    plain = classify_sliced(K, mass, stop_at_complex=True)
    soft = classify_sliced(K, mass, stop_at_complex=True, soft_rel=0.05)
    assert plain.decision is soft.decision is Decision.COMPLEX
    assert plain.scanned_below < pairs_re[1] < soft.scanned_below
    assert pairs_re[1] < soft.scanned_below < top
    assert sum(p.is_complex and p.certified for p in soft.pairs) == 2
    assert collective_decision(soft, soft.lambda_max, 0.05) == (Decision.COMPLEX, 1)
    assert collective_decision(plain, plain.lambda_max, 0.05) == (Decision.UNDECIDED, 1)
    assert collective_decision(soft, soft.lambda_max, 0.0) == (Decision.COMPLEX, 0)

    K1, mass1 = planted(pairs=[(0, 1.5)], seed=5)
    one = classify_sliced(K1, mass1, stop_at_complex=True, soft_rel=0.05)
    assert one.decision is Decision.COMPLEX and np.isinf(one.scanned_below), one.reason
    top1 = float(np.max(one.eigenvalues.real))
    assert collective_decision(one, top1, 0.05) == (Decision.REAL, 1)
    dense = dense_decision(K1, mass1)
    assert collective_decision(dense, float(np.max(dense.eigenvalues.real)), 0.05) \
        == (Decision.REAL, 1)
    assert collective_decision(dense, float(np.max(dense.eigenvalues.real)), 0.0) \
        == (Decision.COMPLEX, 0)
    K0, mass0 = planted(seed=5)
    assert collective_decision(dense_decision(K0, mass0), 100.0, 0.05) == (Decision.REAL, 0)
    for bad in (-0.1, 1.0, "x", True):
        with pytest.raises(ValueError, match="soft_rel"):
            classify_sliced(K1, mass1, stop_at_complex=True, soft_rel=bad)


def test_collective_decision_leaves_soft_units_aside():
    """The rule itself on hand-made decisions (lambda_max = 1, threshold 1e-4):
    a certified soft pair and an undecided soft unit (its disc overlapping the
    pair's, as on an N = 400 ramp) beside certified units that are not soft
    is real with one soft pair; the undecided unit not soft, the decision
    stopped, or the whole decision undecided: undecided; a certified pair
    that is not soft: complex."""
    from remote_trigger.analysis.stability.decision import PairDecision, SpectrumDecision
    from remote_trigger.analysis.stability.verdict import collective_decision

    soft_pair = PairDecision(np.array([2e-6 - 1e-6j, 2e-6 + 1e-6j]), True, True, 10.0)
    soft_open = PairDecision(np.array([2e-6, 3e-6]), False, False, 0.9, method="gershgorin",
                             reason="discs overlap")
    stiff = PairDecision(np.array([0.3, 0.5]), False, True, 5.0, method="gershgorin")

    def dec(pairs, present=True, below=np.inf):
        return SpectrumDecision(present, 2.0, pairs, 0.0, np.zeros(0, complex),
                                scanned_below=below)

    assert collective_decision(dec([soft_pair, soft_open, stiff]), 1.0) == (Decision.REAL, 1)
    stiff_open = PairDecision(np.array([0.3, 0.31]), False, False, 0.9, method="gershgorin")
    assert collective_decision(dec([soft_pair, stiff_open]), 1.0) == (Decision.UNDECIDED, 1)
    assert collective_decision(dec([soft_pair, stiff], below=0.2), 1.0) == \
        (Decision.UNDECIDED, 1)
    assert collective_decision(dec([soft_pair, stiff], present=None), 1.0) == \
        (Decision.UNDECIDED, 1)
    pair = PairDecision(np.array([0.4 - 0.01j, 0.4 + 0.01j]), True, True, 3.0)
    assert collective_decision(dec([soft_pair, stiff_open, pair]), 1.0) == (Decision.COMPLEX, 1)
    assert collective_decision(dec([soft_pair, stiff]), 1.0, soft_rel=1e-7) == (Decision.COMPLEX, 0)


@pytest.mark.parametrize("w_pair, want", [(0.0022, Decision.REAL), (0.01, Decision.COMPLEX)])
def test_a_cluster_of_40_is_decided_in_pieces_as_lapack_has_it(monkeypatch, w_pair, want):
    """A strip of 40 nearly equal eigenvalues (a skew chain along the cluster,
    one member pair coupled by ``w_pair``) is cut into pieces of about 16
    (strips.PIECE), each with its own deflated complement: real (sign changes
    counted piece by piece) or complex (a box on one piece), as LAPACK has it;
    the strip's 40 estimates are LAPACK's eigenvalues, one to one."""
    from remote_trigger.analysis.stability.sliced import strips

    widths = []
    of = strips.DeflatedComplement.of.__func__

    def spy(cls, ctx, buf, I, *args):
        widths.append(I.size)
        return of(cls, ctx, buf, I, *args)

    monkeypatch.setattr(strips.DeflatedComplement, "of", classmethod(spy))
    K, mass = _cluster(0.0022, w_pair, n=200, m=40)
    lam = np.linalg.eigvals(K.toarray())          # (mass 1: A = K)
    st = SlicedStats()
    res = classify_sliced(K, mass, stats=st)
    assert res.decision is want, res.reason
    assert st.strips.get(40) == 1
    assert any(0 < w < 40 for w in widths)
    strip = [p for p in res.pairs if p.eigenvalues.size == 40]
    assert len(strip) == 1 and strip[0].certified
    est = np.asarray(strip[0].eigenvalues)
    inside = lam[(lam.real > 49.9) & (lam.real < 50.3)]
    assert inside.size == 40
    d = np.abs(est[:, None] - inside[None])
    assert np.max(np.min(d, axis=1)) < 1e-8 * 50 and np.max(np.min(d, axis=0)) < 1e-8 * 50
    assert (np.count_nonzero(est.imag != 0) > 0) == (want is Decision.COMPLEX)
    assert full_spectrum(eigen.dynamical_matrix(K, mass).toarray()) == want.label


@pytest.mark.parametrize("w_pair", [0.0016, 0.0019, 0.0021, 0.0023, 0.0026, 0.003])
def test_a_cluster_of_40_near_its_exceptional_point_is_never_decided_wrongly(w_pair):
    """Across the coupling where a pair of the cluster of 40 becomes complex:
    wherever the scan in pieces decides, it agrees with the arbitrary-precision
    oracle (a piece's route that certified a false verdict would fail here)."""
    K, mass = _cluster(0.0022, w_pair, n=200, m=40)
    res = classify_sliced(K, mass)
    truth = full_spectrum(eigen.dynamical_matrix(K, mass).toarray())
    lam = np.linalg.eigvals(K.toarray())
    lapack = "complex" if np.any(lam.imag != 0) else "real"
    assert truth in (None, lapack)
    assert res.decision is Decision.UNDECIDED or res.decision.label == lapack, (res.reason, truth)
