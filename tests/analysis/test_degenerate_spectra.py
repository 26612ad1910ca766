"""Degenerate spectra: the vectorised separation bound of the dense decision
(enclosure.sep_2x2_lower) and a tiled packing decided by both paths."""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.analysis.stability.enclosure import (
    accurate_residual, sep_2x2_lower, sigma_min_lower, sigma_min_lower_many)
from remote_trigger.analysis.stability.sliced import classify_sliced
from remote_trigger.analysis.stability.system import reduced_system
from remote_trigger.analysis.stability.verdict import VerdictOptions, decide
from remote_trigger.analysis.state.dumpfile import read_equilibrium

EPS = np.finfo(float).eps


def _sep_matrix(S, B):
    """I (x) B - S^T (x) I, whose smallest singular value is sep(B, S)."""
    return np.kron(np.eye(2), B) - np.kron(S.T, np.eye(2))


def _blocks(rng, S, p):
    """p 2 x 2 blocks about S: far, near, equal to S, and S's real or complex kind."""
    kind = rng.integers(0, 4, p)
    scale = 10.0 ** rng.uniform(-12, 1, p)
    B = np.empty((p, 2, 2))
    for j in range(p):
        if kind[j] == 0:                            # anywhere
            B[j] = rng.standard_normal((2, 2)) * 10.0 ** rng.uniform(-1, 2)
        elif kind[j] == 1:                          # S shifted along the identity
            B[j] = S + scale[j] * rng.choice([-1, 1]) * np.eye(2)
        elif kind[j] == 2:                          # S perturbed
            B[j] = S + scale[j] * rng.standard_normal((2, 2))
        else:                                       # S itself: sep 0
            B[j] = S
    return B


@pytest.mark.parametrize("seed", range(3))
def test_sep_2x2_lower_between_the_old_bound_and_the_separation(seed):
    rng = np.random.default_rng(seed)
    for trial in range(150):
        c = rng.standard_normal(4) * 10.0 ** rng.uniform(-1, 2)
        S = c.reshape(2, 2)
        if trial % 3 == 0:                          # a complex pair
            S = np.array([[c[0], abs(c[1]) + 1e-3], [-abs(c[2]) - 1e-3, c[0] + 1e-3 * c[3]]])
        p = int(rng.integers(1, 40))
        B = _blocks(rng, S, p)
        if trial % 5 == 0:
            B = B[(B != S).any(axis=(1, 2))]        # no exact copy of S
            if B.shape[0] == 0:
                continue
        got = sep_2x2_lower(S, B)
        Ks = [_sep_matrix(S, Bj) for Bj in B]
        true = min(np.linalg.svd(K, compute_uv=False)[-1] for K in Ks)
        norm = max(np.linalg.norm(K, 2) for K in Ks)
        # never above the separation (the SVD's own error is ~ eps ||K||)
        assert got <= true + 8 * EPS * norm, (seed, trial, got, true)
        # never below the bound of one 4 x 4 inversion per block (the old one)
        old = min(sigma_min_lower(K) for K in Ks)
        assert got >= old * (1 - 1e-12), (seed, trial, got, old)
        assert got >= 0.0


def test_sep_2x2_lower_edge_cases():
    S = np.array([[1.0, 2.0], [-3.0, 1.5]])
    assert sep_2x2_lower(S, np.empty((0, 2, 2))) == np.inf
    # a copy of S: sep exactly 0, and no positive bound may be claimed
    assert sep_2x2_lower(S, np.stack([S, S + 5 * np.eye(2)])) == 0.0
    # a shift along the identity by t: sep = |t| exactly; the inverse bound
    # (1 - e) / ||Z||_F is at most a factor sqrt(4) below it for a 4 x 4 matrix
    for t in (1e-9, 1e-3, 7.0):
        got = sep_2x2_lower(S, (S + t * np.eye(2))[None])
        assert 0.5 * t * (1 - 1e-6) <= got <= t


def test_sigma_min_lower_many_is_the_one_at_a_time_bound():
    rng = np.random.default_rng(7)
    K = rng.standard_normal((50, 4, 4))
    K[3] = 0.0                                  # singular: bound 0
    K[4] = np.outer(np.arange(4.0), np.ones(4))
    many = sigma_min_lower_many(K)
    one = np.array([sigma_min_lower(k) for k in K])
    assert many[3] == 0.0 and many[4] == 0.0
    np.testing.assert_allclose(many, one, rtol=1e-12, atol=0.0)
    true = np.linalg.svd(K, compute_uv=False)[:, -1]
    assert np.all(many <= true * (1 + 1e-12))


def test_accurate_residual_of_a_sparse_A_is_the_dense_one():
    rng = np.random.default_rng(3)
    A = sp.random(60, 60, density=0.1, random_state=rng).toarray()
    A[np.abs(A) > 0] += 1e-3 * rng.standard_normal(np.count_nonzero(A))
    Q = rng.standard_normal((60, 2))
    M = rng.standard_normal((2, 2))
    Rd, ed = accurate_residual(A, Q, M)
    Rs, es = accurate_residual(sp.csr_matrix(A), Q, M)
    assert np.array_equal(Rd, Rs) and np.array_equal(ed, es)


def test_accurate_residual_of_blocks_is_each_blocks_own():
    """M block-diagonal, given as its 2 x 2 blocks: each column the bits of its
    block's own call, dense or sparse A; a shape that does not fit is refused."""
    rng = np.random.default_rng(5)
    A = sp.random(50, 50, density=0.15, random_state=rng).toarray()
    Q = rng.standard_normal((50, 8))
    B = rng.standard_normal((4, 2, 2))
    for Am in (A, sp.csr_matrix(A)):
        R, e = accurate_residual(Am, Q, B)
        for j in range(4):
            Rj, ej = accurate_residual(Am, Q[:, 2 * j:2 * j + 2], B[j])
            assert np.array_equal(R[:, 2 * j:2 * j + 2], Rj)
            assert np.array_equal(e[:, 2 * j:2 * j + 2], ej)
    with pytest.raises(ValueError, match="does not fit"):
        accurate_residual(A, Q, B[:3])


def test_sparse_copy_shifted_is_the_difference():
    """SparseCopy.shifted(sigma): the entries and structure of csc(A - sigma I),
    also where a diagonal entry becomes exactly 0 (dropped, as the difference
    drops it)."""
    from remote_trigger.analysis.stability.verification import SparseCopy

    rng = np.random.default_rng(6)
    A = sp.random(40, 40, density=0.1, random_state=rng).toarray() + np.diag(
        rng.uniform(1, 2, 40))
    Ap = SparseCopy(A)
    for sigma in (0.3, 1.5, float(A[7, 7])):
        want = sp.csc_matrix(sp.csr_matrix(A) - sigma * sp.identity(40, format="csr"))
        got = Ap.shifted(sigma)
        for attr in ("data", "indices", "indptr"):
            assert np.array_equal(getattr(got, attr), getattr(want, attr)), (sigma, attr)


@pytest.fixture(scope="module")
def tiled3(tmp_path_factory):
    from tests.data import unpack

    tmp = tmp_path_factory.mktemp("tiled3")
    unpack("tiled3_F0.0625.dump.json", tmp)
    return reduced_system(read_equilibrium(unpack("tiled3_F0.0625", tmp)))


def test_tiled_packing_complex_by_both_paths(tiled3):
    """Three exact copies of the default packing at F_x = 0.0625 (the cell
    alone is real there): hundreds of close pairs. Both paths certify complex,
    and the sliced scan, stopped at its first complex strip, lists the dense
    path's eigenvalues below where it stopped."""
    system = tiled3
    assert system.K.shape[0] == 837
    dense = decide(system, VerdictOptions(method="dense"))
    sliced = decide(system, VerdictOptions(method="sliced", stop_at_complex=True))
    assert dense.decision is Decision.COMPLEX and dense.confidence > 1
    assert sliced.decision is Decision.COMPLEX and sliced.confidence > 1
    below = sliced.scanned_below
    lam_d = dense.eigenvalues[dense.eigenvalues.real < below]
    lam_s = sliced.eigenvalues
    assert lam_s.size == lam_d.size > 0
    scale = float(np.max(np.abs(dense.eigenvalues)))
    # the same spectrum below the stop, complex pairs included (sorted alike)
    key = lambda z: (round(z.real / scale, 6), z.imag)  # noqa: E731
    ls, ld = sorted(lam_s, key=key), sorted(lam_d, key=key)
    assert np.max(np.abs(np.array(ls) - np.array(ld))) < 1e-6 * scale
    # the complex pair that stopped the scan is one of the dense path's certified ones
    top = lam_s[np.abs(lam_s.imag) > 0]
    assert top.size and np.min(np.abs(dense.eigenvalues[:, None] - top[None])) < 1e-6 * scale


def test_tiled_packing_every_strip_decided_as_lapack_has_it(tiled3):
    """The whole sliced scan of the three copies (about 260 strips of 2-9
    eigenvalues, most of them decided by the deflated route, one sparse LU
    each): every strip is certified, and against LAPACK's eigenvalues (dense
    path): each strip's estimates are eigenvalues of A (to 1e-6 of max
    |lambda|), a strip certified complex holds a non-real one, a strip
    certified real only real ones."""
    system = tiled3
    dense = decide(system, VerdictOptions(method="dense"))
    sliced = classify_sliced(system.K, system.mass)
    assert sliced.decision is Decision.COMPLEX and dense.decision is Decision.COMPLEX
    strips = [p for p in sliced.pairs if p.method == "sliced-strip"]
    assert len(strips) > 200 and all(p.certified for p in strips), \
        [p.reason for p in strips if not p.certified][:3]
    lam = dense.eigenvalues
    scale = float(np.max(np.abs(lam)))
    n_real = n_complex = 0
    for p in strips:
        est = np.asarray(p.eigenvalues)
        dist = np.abs(est[:, None] - lam[None])
        assert np.max(np.min(dist, axis=1)) < 1e-6 * scale
        near = lam[np.argmin(dist, axis=1)]
        if p.is_complex:
            n_complex += 1
            assert np.max(np.abs(near.imag)) > 1e-9 * scale
        else:
            n_real += 1
            assert np.max(np.abs(near.imag)) < 1e-9 * scale
    assert n_complex > 200 and n_real >= 1


def test_near_double_pairs_of_an_almost_normal_matrix_are_not_refined(monkeypatch):
    """A symmetric 40 x 40 matrix with 20 near-double eigenvalues (split 1e-13
    and 1e-11): the dense decision merges each pair (their discs touch) and,
    as every pair's eigenvector basis already spans an invariant subspace to
    the rounding of its own residual (n u ||A||_F), refines none (the sparse
    LUs of the refinement were most of the time on near-double spectra). The
    decision is the same as with every pair refined (no floor):
    real, every pair certified. A pair near an exceptional point (parallel
    eigenvectors) is still refined."""
    from remote_trigger.analysis.stability import verification
    from remote_trigger.analysis.stability.exceptional import classify_spectrum

    calls = []
    refine = verification._refine

    def counted(*a, **k):
        calls.append(1)
        return refine(*a, **k)
    monkeypatch.setattr(verification, "_refine", counted)
    rng = np.random.default_rng(5)
    n = 40
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    for delta in (1e-13, 1e-11):
        d = np.repeat(np.arange(1.0, n // 2 + 1), 2) + np.tile([0.0, delta], n // 2)
        A = (Q * d) @ Q.T
        calls.clear()
        skipped = classify_spectrum(A)
        assert not calls
        with monkeypatch.context() as mp:              # no floor: every merged pair refined
            mp.setattr(verification, "_pair_basis",
                       lambda A, lam, V, un, Ap=None, floor=None, f=verification._pair_basis:
                       f(A, lam, V, un, Ap, None))
            calls.clear()
            refined = classify_spectrum(A)
            assert len(calls) == n // 2
        for dec in (skipped, refined):
            assert dec.decision is Decision.REAL
            assert all(p.certified and not p.is_complex for p in dec.pairs)
    # a Jordan-like pair (eigenvectors nearly parallel: a merged unit whose
    # basis is ill-conditioned) is refined
    # (rotated: in J's own coordinates the basis would be exact)
    J = np.diag(np.arange(1.0, 11.0))
    J[4, 5], J[5, 5] = 1.0, 5.0 + 1e-9
    R, _ = np.linalg.qr(rng.standard_normal((10, 10)))
    calls.clear()
    classify_spectrum(R @ J @ R.T)
    assert calls
