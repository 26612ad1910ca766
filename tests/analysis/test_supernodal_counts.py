"""Sylvester counts from the multifrontal LDL^T (analysis.stability.sliced.supernodal):
the count of eigenvalues below a shift against LAPACK's eigenvalues, the
factorization against QDLDL's in the same order, every front shape (narrow
fronts, a wide one split in halves, extend-add by runs and by index), zero
pivots and bad input refused."""
import numpy as np
import pytest
import qdldl
import scipy.sparse as sp

from remote_trigger.analysis.stability.sliced import supernodal
from remote_trigger.analysis.stability.sliced.inertia import SymmetricLU, count_below, shifted
from remote_trigger.analysis.stability.sliced.supernodal import SupernodalLDL


def random_symmetric(n, seed, dense_block=0):
    """A sparse symmetric indefinite matrix; with ``dense_block`` > 0 its last
    rows also hold a dense block of that size (a wide front)."""
    rng = np.random.default_rng(seed)
    C = sp.random(n, n, density=6.0 / n, random_state=rng)
    S = C + C.T + sp.diags(np.linspace(-5, 5, n))
    if dense_block:
        B = np.zeros((n, n))
        B[-dense_block:, -dense_block:] = rng.standard_normal((dense_block, dense_block))
        S = S + sp.csc_matrix(B + B.T)
    return sp.csc_matrix(S)


def particles(m, dofs, seed):
    """A contact network of m particles with ``dofs`` dofs each (dense diagonal
    and contact blocks), neighbours within a distance in a 3D box."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, (m / 0.6) ** (1 / 3), (m, 3))
    blocks = {}
    for i in range(m):
        B = rng.standard_normal((dofs, dofs))
        blocks[i, i] = B + B.T + 4.0 * dofs * np.eye(dofs)
        for j in range(i + 1, m):
            if np.linalg.norm(x[i] - x[j]) < 1.3:
                blocks[i, j] = rng.standard_normal((dofs, dofs))
    rows, cols, vals = [], [], []
    for (i, j), B in blocks.items():
        for p, q, M in ((i, j, B), (j, i, B.T)) if i != j else ((i, i, B),):
            r, c = np.meshgrid(np.arange(dofs) + dofs * p, np.arange(dofs) + dofs * q,
                               indexing="ij")
            rows.append(r.ravel()), cols.append(c.ravel()), vals.append(M.ravel())
    n = m * dofs
    return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n, n))


def shifts_between(lam, k, rng):
    """k shifts, each halfway between two neighbouring eigenvalues (and one
    below and above the spectrum)."""
    mids = 0.5 * (lam[1:] + lam[:-1])
    return [lam[0] - 1.0, lam[-1] + 1.0, *rng.choice(mids, size=k, replace=False)]


@pytest.mark.parametrize("S", [random_symmetric(300, 3), random_symmetric(250, 5, dense_block=90),
                               particles(60, 6, 1)], ids=["random", "wide-front", "particles"])
def test_counts_are_the_eigenvalues_below_the_shift(S):
    """In SuperLU's order and in a random one: the count is LAPACK's number of
    eigenvalues below the shift, the fuzz below the gap to the nearest one."""
    lam = np.linalg.eigvalsh(S.toarray())
    n = S.shape[0]
    rng = np.random.default_rng(0)
    orders = [SymmetricLU(shifted(S, 0.1)).perm, rng.permutation(n)]
    for perm in orders:
        sn = SupernodalLDL(S, perm)
        for a in shifts_between(lam, 8, rng):
            cnt, fuzz = sn.count_below(a)
            assert cnt == int(np.count_nonzero(lam < a)), a
            assert 0 < fuzz < np.min(np.abs(lam - a))


def test_the_wide_front_is_split():
    """In the natural order the dense block makes a front wider than the
    column-by-column limit (the halves of _ldl_dense and the triangular solve
    of _front run): the counts are still LAPACK's."""
    S = random_symmetric(250, 5, dense_block=90)
    sn = SupernodalLDL(S, np.arange(250))
    assert np.max(np.diff(sn._start)) > supernodal._COLUMNWISE
    lam = np.linalg.eigvalsh(S.toarray())
    for a in shifts_between(lam, 10, np.random.default_rng(1)):
        cnt, fuzz = sn.count_below(a)
        assert cnt == int(np.count_nonzero(lam < a)) and fuzz < np.min(np.abs(lam - a))


@pytest.mark.parametrize("S", [random_symmetric(400, 7), particles(50, 6, 2)],
                         ids=["random", "particles"])
def test_the_factors_are_qdldls_in_its_order(S):
    """In QDLDL's own order the elimination is the same one (the same pattern
    and depth, factors equal up to rounding): the same count and a fuzz
    within 1e-9 relative of count_below's, which is computed from QDLDL's L
    and D (an independent implementation)."""
    for a in (-1.3, 0.05, 2.7):
        fac = qdldl.Solver(shifted(S, a))
        L, d, perm = fac.factors()
        sn = SupernodalLDL(S, perm)
        assert sn.nnz_L == L.nnz
        cnt, fuzz, _ = count_below(S, a, fac)
        got = sn.count_below(a)
        assert got[0] == cnt == int(np.count_nonzero(d < 0))
        assert got[1] == pytest.approx(fuzz, rel=1e-9)


def test_extend_add_by_runs_or_by_index(monkeypatch):
    """A child's update added by blocks of runs or by one indexed addition: the
    same count and fuzz, bitwise."""
    S = particles(50, 6, 3)
    perm = SymmetricLU(shifted(S, 0.0)).perm
    by_runs = SupernodalLDL(S, perm)
    assert any(isinstance(e, list) for e in by_runs._extend if e is not None)
    monkeypatch.setattr(supernodal, "_MAX_RUNS", 0)
    by_index = SupernodalLDL(S, perm)
    assert all(isinstance(e, np.ndarray) for e in by_index._extend if e is not None)
    for a in (-0.5, 3.0, 20.0):
        assert by_runs.count_below(a) == by_index.count_below(a)


def test_shifts_in_any_sequence_give_the_same_count():
    """A shift's count and fuzz do not depend on the shifts counted before."""
    S = random_symmetric(200, 11)
    sn = SupernodalLDL(S, SymmetricLU(shifted(S, 0.0)).perm)
    first = sn.count_below(0.7)
    sn.count_below(-3.0), sn.count_below(4.4)
    assert sn.count_below(0.7) == first
    assert SupernodalLDL(S, sn.perm).count_below(0.7) == first


def test_zero_pivot_and_bad_input_are_refused():
    """The first pivot of the order is S_pp - a: zero at a = S_pp, refused with
    the shift named; a perm that is not a permutation refused."""
    S = random_symmetric(120, 2)
    perm = np.random.default_rng(4).permutation(120)
    sn = SupernodalLDL(S, perm)
    a = float(S.diagonal()[perm[0]])
    with pytest.raises(ValueError, match=r"no inertia of S - a I at a = .*zero pivot"):
        sn.count_below(a)
    with pytest.raises(ValueError, match=r"perm must be a permutation of range\(120\)"):
        SupernodalLDL(S, np.zeros(120, dtype=int))
    with pytest.raises(ValueError, match=r"perm must be a permutation"):
        SupernodalLDL(S, np.arange(119))


def test_norm2_skew_by_the_multifrontal_count(monkeypatch):
    """norm2_skew's count of [[0, W], [W^T, 0]] by the multifrontal LDL^T
    (SUPERNODAL_FILL = 0: every pattern counts as dense) in the order that
    puts i and n + i together: QDLDL's count (none below -1.02 sigma, some
    below -0.9 sigma), a fuzz of the same size (another order, the same
    bound), and a bound of ||W||_2 above LAPACK's largest singular value,
    within 2 % of it, equal to QDLDL's path to 1e-9."""
    from remote_trigger.analysis.stability.sliced import inertia

    rng = np.random.default_rng(8)
    S = particles(40, 6, 4)
    G = sp.csc_matrix(S.multiply(rng.standard_normal(S.shape)))
    W = sp.csc_matrix(G - G.T)
    sigma = np.linalg.norm(W.toarray(), 2)
    aug = sp.bmat([[None, W], [W.T, None]], format="csc")
    qd = inertia._augmented_count(W, aug, -1.02 * sigma)
    b_qd = inertia.norm2_skew(W)
    monkeypatch.setattr(inertia, "SUPERNODAL_FILL", 0.0)
    mf = inertia._augmented_count(W, aug, -1.02 * sigma)
    assert mf[0] == qd[0] == 0
    assert 0.1 * qd[1] < mf[1] < 10 * qd[1] and mf[1] < 1e-10 * sigma
    assert inertia._augmented_count(W, aug, -0.9 * sigma)[0] >= 1
    b_mf = inertia.norm2_skew(W)
    assert sigma <= b_mf <= 1.02 * sigma * (1 + 1e-9) + mf[1]
    assert b_mf == pytest.approx(b_qd, rel=1e-9)


def test_one_triangle_is_refused():
    """A matrix given by one triangle only would lose half its entries in the
    permuted lower triangle: refused, with the counts named."""
    S = random_symmetric(60, 9)
    with pytest.raises(ValueError, match=r"S must store both triangles: 0 entries below"):
        SupernodalLDL(sp.triu(S), np.arange(60))
