"""The double-word Sylvester count (analysis.stability.sliced.inertia.count_below_dw)
against Arb: shifts one float beside each eigenvalue of a matrix whose
eigenvalues are known in closed form, where the float64 count is often wrong."""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.sliced import inertia
from remote_trigger.analysis.stability.sliced.inertia import (Shifts, count_below,
                                                              count_below_dw)

flint = pytest.importorskip("flint")


def laplacian(n):
    """The 1D Dirichlet Laplacian tridiag(-1, 2, -1): eigenvalues 4 sin^2(k pi / (2 (n + 1)))."""
    return sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsc()


def test_counts_one_float_beside_every_eigenvalue():
    """n = 400: at the float just above and just below each of the 400 eigenvalues
    (Arb, 200 bits), the double-word count is the exact count and its fuzz is
    below the float's distance to the eigenvalue (>= 2.8e-21); the float64
    count is wrong at ~1 shift in 8 (its fuzz, 1e-13, does not claim those)."""
    n = 400
    T = laplacian(n)
    old = flint.ctx.prec
    flint.ctx.prec = 200
    try:
        lam = [4 * (flint.arb.pi() * k / (2 * (n + 1))).sin() ** 2 for k in range(1, n + 1)]
        wrong64 = 0
        for k, ball in enumerate(lam, start=1):
            m = float(ball.mid())
            up = m if ball < m else float(np.nextafter(m, np.inf))
            down = m if ball > m else float(np.nextafter(m, -np.inf))
            assert ball < up and ball > down          # decided by Arb
            for a, want in ((up, k), (down, k - 1)):
                cnt, fuzz = count_below_dw(T, a)
                assert fuzz < float(abs(flint.arb(a) - ball).lower())
                assert cnt == want, (k, a)
                cnt64, fuzz64, _ = count_below(T, a)
                wrong64 += cnt64 != want
                if cnt64 != want:                      # float64 did not claim it
                    assert fuzz64 > float(abs(flint.arb(a) - ball).upper())
    finally:
        flint.ctx.prec = old
    assert wrong64 > 20        # the float64 count cannot resolve these shifts


def test_counts_of_a_random_matrix_and_its_fuzz():
    """Random sparse symmetric matrices, shifts across the spectrum: the count of
    eigvalsh, in the order given or in QDLDL's; the fuzz ~1e-15 x the float64
    one (16 u^2 against u per operation)."""
    rng = np.random.default_rng(3)
    for n in (3, 40, 300):
        C = sp.random(n, n, density=min(1.0, 6.0 / n), random_state=rng)
        S = sp.csc_matrix(C + C.T + sp.diags(np.linspace(-5, 5, n)))
        lam = np.linalg.eigvalsh(S.toarray())
        shifts = Shifts(S)
        for a in rng.uniform(lam[0] - 1, lam[-1] + 1, 6):
            cnt64, fuzz64, _ = count_below(S, a)
            cnt, fuzz = count_below_dw(S, a)
            cnt_p, fuzz_p = shifts.count_below_dw(a)
            assert cnt == cnt_p == np.count_nonzero(lam < a)
            assert 0 < fuzz < 1e-13 * fuzz64 and 0 < fuzz_p < 1e-13 * fuzz64
        assert shifts.dw_counts == 6


def test_a_missing_diagonal_and_bad_input():
    """A diagonal entry not stored is zero (the shift still applies); a zero
    pivot and a bad permutation are refused with the value named."""
    S = sp.csc_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))       # eigenvalues -1, 1
    S.eliminate_zeros()
    assert count_below_dw(S, 0.5) == (1, count_below_dw(S, 0.5)[1])
    assert count_below_dw(S, -1.5)[0] == 0 and count_below_dw(S, 1.5)[0] == 2
    with pytest.raises(ValueError, match="a = 0.0.*zero pivot"):
        count_below_dw(S, 0.0)
    with pytest.raises(ValueError, match="permutation of range\\(2\\)"):
        count_below_dw(S, 0.5, perm=[0, 0])


def test_shifts_count_in_double_word_above_the_fuzz_limit():
    """Shifts.count_below: the float64 count below the limit (bitwise count_below),
    the double-word count and fuzz above it, the factorization for solves the
    float64 one either way."""
    T = laplacian(50)
    a = 1.2345
    c64, f64, _ = count_below(T, a)
    below = Shifts(T, fuzz_limit=10 * f64)
    assert below.count_below(a)[:2] == (c64, f64) and below.dw_counts == 0
    above = Shifts(T, fuzz_limit=0.5 * f64)
    cnt, fuzz = above.count_below(a)
    assert (cnt, fuzz) == count_below_dw(T, a, above.perm) and above.dw_counts == 1
    x = above.solver.solve(np.ones(50))
    assert np.allclose((T - a * sp.identity(50)) @ x, 1.0)
    assert inertia.fuzz_limit(100.0, 2000) == pytest.approx(inertia.DW_FUZZ_FRACTION * 0.1)


def test_the_scan_counts_again_where_only_the_fuzz_blocks_an_edge(monkeypatch):
    """Every float64 count given a fuzz of 2.0 (the planted spectrum's spacing is
    ~0.66) and no fuzz limit: the slices' edges are certified by counting
    again in double-word arithmetic, with the verdict and eigenvalues of the
    plain scan; in parts also the lower edge of each part's first slice (its
    split point); with the double-word count refused, the same scan fails."""
    from remote_trigger.analysis.stability.decision import Decision
    from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced
    from remote_trigger.analysis.stability.sliced import slices

    from .test_sliced import planted

    K, mass = planted(pairs=[(75, 1.5)])
    plain = classify_sliced(K, mass)
    assert plain.decision is Decision.COMPLEX

    real_count = inertia.count_below
    monkeypatch.setattr(inertia, "count_below",
                        lambda S, a, factor=None: (lambda c: (c[0], max(c[1], 2.0), c[2]))(
                            real_count(S, a, factor)))
    monkeypatch.setattr(slices, "fuzz_limit", lambda normS, n: float("inf"))
    st = SlicedStats()
    res = classify_sliced(K, mass, stats=st)
    assert st.dw_counts >= st.slices - 1 > 0
    assert res.decision is plain.decision, res.reason
    assert np.allclose(np.sort_complex(np.asarray(res.eigenvalues)),
                       np.sort_complex(np.asarray(plain.eigenvalues)), rtol=0, atol=1e-9)

    # in parts: the split points' counts blurred too (Shifts.count), so each
    # part's first slice counts its lower edge again (slices._recounted_edge)
    from remote_trigger.analysis.stability.sliced import parts
    monkeypatch.setattr(parts, "fuzz_limit", lambda normS, n: float("inf"))
    st = SlicedStats()
    res = classify_sliced(K, mass, part_size=60, stats=st)
    assert st.parts > 1 and st.dw_counts >= st.slices + st.parts - 2
    assert res.decision is plain.decision, res.reason
    assert np.allclose(np.sort_complex(np.asarray(res.eigenvalues)),
                       np.sort_complex(np.asarray(plain.eigenvalues)), rtol=0, atol=1e-9)

    def refused(self, a):
        raise ValueError(f"no inertia of S - a I at a = {a!r}: refused")
    monkeypatch.setattr(inertia.Shifts, "count_below_dw", refused)
    res = classify_sliced(K, mass)
    assert res.decision is Decision.UNDECIDED
    assert "edge" in res.reason
