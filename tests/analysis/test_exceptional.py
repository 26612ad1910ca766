"""Certified complex-pair decisions near an exceptional point (docs/model.md section 8)."""
from fractions import Fraction
import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.eigen import condition_numbers
from remote_trigger.analysis.stability.enclosure import accurate_residual
from remote_trigger.analysis.stability.exceptional import (
    block_discriminant, classify_spectrum)
from remote_trigger.analysis.dynamics.normal_form import normal_form_matrix
from remote_trigger.analysis.stability.projected import classify_projected

from .arb_oracle import discriminant_2x2, full_spectrum, pair_is
from remote_trigger.analysis.stability.decision import Decision

EPSILONS = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10]
U = 2.0 ** -53


@pytest.mark.parametrize("d", [0.5, 0.1, 0.01])
@pytest.mark.parametrize("eps", EPSILONS + [-e for e in EPSILONS])
def test_normal_form_decided_correctly(d, eps):
    """J = [[1-d, eta], [-eta, 1+d]], eta = d (1 - eps): complex iff eps < 0."""
    J = normal_form_matrix(d, eps)
    res = classify_spectrum(J)
    assert res.decision is Decision.certified(eps < 0), (res.confidence, res.pairs)
    assert res.confidence > 1.0
    pair = res.pairs[0]
    assert len(res.pairs) == 1 and pair.method == "exact-2x2"
    assert pair.certified and pair.margin == res.confidence
    # the discriminant is that of the stored matrix, exactly (rational arithmetic) ...
    assert pair.discriminant == float(discriminant_2x2(J))
    # ... and d^2 eps (2 - eps) up to the rounding of the entries
    assert abs(pair.discriminant - d * d * eps * (2.0 - eps)) <= 4 * pair.bound


def _box_has_both_signs(J, scale):
    """Some corner of |J~ - J| <= scale u |J| has D > 0 and another D < 0 (exact)."""
    signs = set()
    for corner in itertools.product((-1, 1), repeat=4):
        Jc = [Fraction(float(x)) * (1 + c * scale * Fraction(U))
              for x, c in zip(np.ravel(J), corner)]
        D = ((Jc[0] - Jc[3]) / 2) ** 2 + Jc[1] * Jc[2]
        signs.add((D > 0) - (D < 0))
    return {1, -1} <= signs


@pytest.mark.parametrize("d, finest", [(0.5, 1e-15), (0.1, 1e-15), (0.01, 1e-13)])
def test_normal_form_never_wrong_undecided_only_where_float64_cannot_tell(d, finest):
    """Down to eps = 1e-17: right, or 'undecided' only where the float64 matrix cannot tell.

    Certified answers agree with the exact (rational) discriminant of the
    stored matrix and with the sign of eps; an undecided matrix has, within
    4 half-ulps of its entries, matrices with a real and with a complex
    pair.
    """
    certified = []
    for k in range(2, 18):
        for sign in (1, -1):
            eps = sign * 10.0 ** -k
            J = normal_form_matrix(d, eps)
            res = classify_spectrum(J)
            if res.decision is Decision.UNDECIDED:
                assert res.confidence <= 1.0
                assert _box_has_both_signs(J, 4.0), (d, eps, res.confidence)
            else:
                assert res.decision is Decision.certified(eps < 0), (d, eps)
                assert res.decision is Decision.certified(discriminant_2x2(J) < 0), (d, eps)
                certified.append(abs(eps))
    assert min(certified) <= finest
    # at eps = 1e-17 the stored matrix is an exceptional point or nearly: no answer
    assert classify_spectrum(normal_form_matrix(d, 1e-17)).decision is Decision.UNDECIDED
    assert classify_spectrum(normal_form_matrix(d, -1e-17)).decision is Decision.UNDECIDED
    # decided for A exactly as stored (rel_error = 0), the 2 x 2 answer is exact
    for eps in (1e-16, -1e-16, 3e-17):
        J = normal_form_matrix(d, eps)
        D = discriminant_2x2(J)
        res = classify_spectrum(J, rel_error=0.0)
        assert res.decision is (Decision.UNDECIDED if D == 0 else Decision.certified(D < 0))


def test_normal_form_eigenvalues_and_condition_numbers():
    """lambda = 1 -+ d sqrt(1 - nu^2) (Eq. 11); kappa grows like eps^(-1/2) at the EP."""
    import scipy.linalg as sla

    d = 0.3
    kap = []
    for eps in (1e-4, 1e-6, 1e-8):
        J = normal_form_matrix(d, eps)
        lam, vl, vr = sla.eig(J, left=True, right=True)
        nu = 1.0 - eps
        np.testing.assert_allclose(np.sort(lam.real), 1.0 + np.array([-1, 1]) * d
                                   * np.sqrt(1 - nu * nu), rtol=0, atol=1e-7)
        kap.append(condition_numbers(vl, vr).max())
    kap = np.array(kap)
    np.testing.assert_allclose(kap[1:] / kap[:-1], 10.0, rtol=0.05)
    assert kap[-1] > 1e3                      # ill-conditioned eigenvalues ...
    assert classify_spectrum(normal_form_matrix(d, 1e-8)).confidence > 100   # ... sound decision


def embedded(d, eps, n=30, seed=0):
    """The normal form hidden in an n x n non-normal matrix by an orthogonal similarity."""
    rng = np.random.default_rng(seed)
    B = np.zeros((n, n))
    B[:2, :2] = normal_form_matrix(d, eps)
    B[2:, 2:] = np.diag(np.linspace(2.0, 10.0, n - 2)) + \
        np.triu(rng.normal(scale=0.3, size=(n - 2, n - 2)), 1)
    B[:2, 2:] = rng.normal(scale=0.3, size=(2, n - 2))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ B @ Q.T


@pytest.mark.parametrize("seed", [0, 1])
def test_embedded_normal_form(seed):
    for k in range(2, 15, 2):
        for sign in (1, -1):
            eps = sign * 10.0 ** -k
            res = classify_spectrum(embedded(0.5, eps, seed=seed))
            if k <= 6:
                assert res.decision is Decision.certified(eps < 0) and res.confidence > 10, (eps, res)
            elif res.decision is not Decision.UNDECIDED:
                assert res.decision is Decision.certified(eps < 0), eps


def test_symmetric_matrix_is_certified_real():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(25, 25))
    res = classify_spectrum(X + X.T)
    assert res.decision is Decision.REAL and res.confidence > 1
    assert all(not p.is_complex for p in res.pairs)
    assert len(res.pairs) == 24


def test_input_uncertainty_lowers_confidence():
    J = normal_form_matrix(0.1, -1e-6)
    r0 = classify_spectrum(J)
    r1 = classify_spectrum(J, input_error=1e-9)
    assert r0.decision is r1.decision is Decision.COMPLEX
    assert r1.confidence < r0.confidence / 100
    assert classify_spectrum(J, input_error=1e-5).decision is Decision.UNDECIDED


def test_block_discriminant():
    D, g, rnd = block_discriminant([[1.0, 2.0], [-3.0, 4.0]])
    assert D == pytest.approx(2.25 - 6.0) and g == pytest.approx(np.sqrt(2 * 2.25 + 4 + 9))
    assert 0 < rnd < 1e-14


def test_bad_input():
    with pytest.raises(ValueError, match="square"):
        classify_spectrum(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="non-finite"):
        classify_spectrum(np.array([[1.0, np.nan], [0.0, 1.0]]))
    with pytest.raises(ValueError, match="real"):
        classify_spectrum(np.eye(2) * 1j)
    with pytest.raises(ValueError, match="input_error"):
        classify_spectrum(np.eye(2), input_error=-1.0)
    with pytest.raises(ValueError, match="rel_error"):
        classify_spectrum(np.eye(2), rel_error=0.5)


def sparse_with_pair(eps, n=1500, d=0.05, seed=0):
    """Sparse non-normal matrix, eigenvalues 1..40 plus the normal form shifted to 20.

    Block upper-triangular (eigenvalues are those of the diagonal blocks), then
    symmetrically permuted.
    """
    rng = np.random.default_rng(seed)
    diag = np.linspace(1.0, 40.0, n - 2)
    diag = diag[np.abs(diag - 20.0) > 0.05]
    m = diag.size + 2
    A = sp.lil_matrix((m, m))
    A[0:2, 0:2] = 20.0 * normal_form_matrix(d, eps)
    for k, v in enumerate(diag):
        A[k + 2, k + 2] = v
    rows = rng.integers(0, m, 3 * m)
    cols = rng.integers(0, m, 3 * m)
    keep = cols > rows
    upper = sp.coo_matrix((rng.normal(scale=0.2, size=keep.sum()), (rows[keep], cols[keep])),
                          shape=(m, m))
    A = (A.tocsr() + upper.tocsr())
    A[0, 1] = 20.0 * d * (1 - eps)
    A[1, 0] = -20.0 * d * (1 - eps)
    p = rng.permutation(m)
    P = sp.identity(m, format="csr")[p]
    return (P @ A @ P.T).tocsr()


@pytest.mark.parametrize("eps", [1e-3, -1e-3, 1e-6, -1e-6])
def test_sparse_projected_decision(eps):
    A = sparse_with_pair(eps)
    res, resid = classify_projected(A, sigma=19.95, k=12)
    assert resid < 1e-8
    assert res.decision is Decision.certified(eps < 0), res.confidence
    lam = res.eigenvalues
    assert np.min(np.abs(lam - 20.0)) < 0.5


def test_accurate_residual_against_rational_arithmetic():
    """A Q - Q M entry by entry: within the returned bound of the exact value, bound ~ u."""
    rng = np.random.default_rng(7)
    n = 25
    A = rng.normal(size=(n, n)) * 10.0 ** rng.integers(-8, 5, size=(n, n))
    A[rng.random((n, n)) < 0.5] = 0.0
    Q = rng.normal(size=(n, 2))
    M = rng.normal(size=(2, 2))
    r, err = accurate_residual(A, Q, M)
    Af = [[Fraction(float(x)) for x in row] for row in A]
    for i in range(n):
        for k in range(2):
            exact = sum(Af[i][j] * Fraction(float(Q[j, k])) for j in range(n)) \
                - sum(Fraction(float(Q[i, l])) * Fraction(float(M[l, k])) for l in range(2))
            assert abs(Fraction(float(r[i, k])) - exact) <= Fraction(float(err[i, k]))
            assert err[i, k] <= 3 * U * abs(r[i, k]) + 1e-300
    with pytest.raises(ValueError, match="too large"):
        accurate_residual(np.full((2, 2), 1e300), np.ones((2, 2)), np.eye(2))


def test_accurate_residual_with_cancellation_against_rational_arithmetic():
    """Q, M an eigenpair block of A: the residual cancels to ~1e-15 of its terms;
    the bound still holds entry by entry (Dot2's gamma^2 term), and stays within
    1e-13 of the terms' size (the sum of |terms|)."""
    rng = np.random.default_rng(11)
    n = 30
    B = rng.normal(size=(n, n)) * (rng.random((n, n)) < 0.3)
    A = B + B.T + np.diag(rng.normal(size=n) * 1e3)
    w, V = np.linalg.eigh(A)
    Q, M = V[:, 3:5], np.diag(w[3:5])
    r, err = accurate_residual(A, Q, M)
    Af = [[Fraction(float(x)) for x in row] for row in A]
    scale = np.abs(A) @ np.abs(Q) + np.abs(Q) @ np.abs(M)
    assert np.max(np.abs(r)) < 1e-13 * np.max(scale)   # the cancellation is real
    for i in range(n):
        for k in range(2):
            exact = sum(Af[i][j] * Fraction(float(Q[j, k])) for j in range(n)) \
                - sum(Fraction(float(Q[i, l])) * Fraction(float(M[l, k])) for l in range(2))
            assert abs(Fraction(float(r[i, k])) - exact) <= Fraction(float(err[i, k]))
    assert np.all(err <= 1e-13 * np.max(scale))


EP_DISTANCES = [1e-6, 1e-8, 1e-10, 1e-12, 1e-14, -1e-14, -1e-12, -1e-10, -1e-8, -1e-6]


@pytest.mark.parametrize("dist", EP_DISTANCES)
def test_decisions_agree_with_arb(dist):
    """The normal form hidden in a 40 x 40 non-normal matrix, eps = dist (complex iff < 0).

    Independent checks with Arb: the enclosure of the whole spectrum of the
    stored matrix, and the pair-local eigenpair test on every matrix that
    rounds to it. Certified down to |eps| = 1e-14.
    """
    A = embedded(0.5, dist, n=40, seed=2)
    res = classify_spectrum(A)
    assert res.decision is Decision.certified(dist < 0), (dist, res.confidence, res.reason)
    want = "complex" if res.decision is Decision.COMPLEX else "real"
    assert full_spectrum(A) == want
    box = pair_is(A, res.critical_pair.eigenvalues, rel=U)
    assert box in (want, None)                  # the oracle may fail to decide, not disagree
    if abs(dist) >= 1e-12:
        assert box == want


def test_arb_oracle_can_fail():
    """The oracle refuses a defective matrix and a normal form below the float64 resolution."""
    assert pair_is(np.array([[1.0, 1.0], [0.0, 1.0]]), [1.0, 1.0]) is None
    assert full_spectrum(np.array([[1.0, 1.0], [0.0, 1.0]])) is None
    assert pair_is(normal_form_matrix(0.5, 1e-3), [0.9, 1.1]) == "real"
    assert pair_is(normal_form_matrix(0.5, -1e-3), [1 + 0.02j, 1 - 0.02j]) == "complex"


def test_sqrt_law_exponents_can_fail():
    """A generic exceptional point gives 1/2 on both sides; a linear approach gives 1."""
    from remote_trigger.analysis.stability.eigtrack import sqrt_law

    Fc, w = 0.05, 1e-8
    F = np.concatenate([Fc - np.geomspace(1e-6, 2e-3, 12), Fc + np.geomspace(1e-6, 2e-3, 8)])
    d = F - Fc
    mean = 100.0 + 3.0 * d
    half = np.where(d < 0, 0.7 * np.sqrt(np.abs(d)), 0.0)
    im = np.where(d > 0, 0.4 * np.sqrt(np.abs(d)), 0.0)
    a, b = mean - half - 1j * im, mean + half + 1j * im
    r = sqrt_law(F, a, b, Fc - w / 2, Fc + w / 2)
    assert r["below"] == pytest.approx(0.5, abs=1e-9) and r["above"] == pytest.approx(0.5, abs=1e-9)
    assert r["n_below"] == 12 and r["n_above"] == 8
    lin = np.where(d < 0, 5.0 * np.abs(d), 0.0)           # two eigenvalues that merely meet
    r = sqrt_law(F, mean - lin, mean + lin + 1j * im, Fc - w / 2, Fc + w / 2)
    assert r["below"] == pytest.approx(1.0, abs=1e-9)
    r = sqrt_law(F[:2], a[:2], b[:2], Fc - w / 2, Fc + w / 2)   # too few points
    assert np.isnan(r["below"]) and np.isnan(r["above"])
