"""Near the exceptional point: F_x within 1e-14 of F_x^c, without a ramp.

A cheap stand-in for the ramp: the normal form J(d, eps) of docs/model.md section 8
embedded, by an orthogonal similarity, in a larger non-normal matrix with a
spread of real eigenvalues (the rest of the spectrum), and the distance to the
exceptional point written as eps = c (F_x^c - F_x). Complex iff F_x > F_x^c.
The certified test must never be wrong, must say "undecided" (confidence < 1)
rather than guess, must certify (confidence > 1) once |F_x - F_x^c| is at the
1e-14 level (the float64 resolution of this matrix: 1e-15 is undecided),
and a bisection driven by it must bracket F_x^c.
"""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.dynamics.normal_form import normal_form_matrix
from remote_trigger.analysis.stability import exceptional as ex
from remote_trigger.analysis.stability import projected
from remote_trigger.analysis.stability.decision import Decision

FXC = 0.0123456789
C = 1.0                      # d eps / d F_x


def embedded(F_x, d=0.5, n=40, seed=0):
    eps = C * (FXC - F_x)
    rng = np.random.default_rng(seed)
    lam = np.linspace(3.0, 60.0, n - 2)
    T = np.diag(lam) + np.triu(rng.normal(scale=0.3, size=(n - 2, n - 2)), 1)
    B = np.zeros((n, n))
    B[:2, :2] = 10.0 * normal_form_matrix(d, eps)      # pair near 10, inside the spectrum
    B[2:, 2:] = T
    B[:2, 2:] = rng.normal(scale=0.3, size=(2, n - 2))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ B @ Q.T


@pytest.mark.parametrize("dF", [1e-6, 1e-8, 1e-10, 1e-12, 1e-13, 1e-14, -1e-14, -1e-13, -1e-12,
                                -1e-10, -1e-8, -1e-6])
def test_decision_correct_and_confident_within_1e_14(dF):
    dec = ex.classify_spectrum(embedded(FXC + dF))
    assert dec.decision is not Decision.UNDECIDED, dec.confidence
    assert dec.decision is Decision.certified(dF > 0)
    assert dec.confidence > 1.0
    if abs(dF) >= 1e-13:
        assert dec.confidence > 10.0


@pytest.mark.parametrize("dF", [1e-15, -1e-15, 3e-16, -3e-16, 0.0])
def test_closer_than_resolution_is_undecided_not_wrong(dF):
    dec = ex.classify_spectrum(embedded(FXC + dF))
    if dec.decision is Decision.UNDECIDED:
        assert dec.confidence <= 1.0
    else:
        assert dec.decision is Decision.certified(dF > 0) and dec.confidence > 1.0


def test_confidence_grows_linearly_with_distance():
    for dFs in ((1e-12, 1e-11, 1e-10), (1e-8, 1e-7, 1e-6)):
        m = [ex.classify_spectrum(embedded(FXC + dF)).confidence for dF in dFs]
        assert 3 < m[1] / m[0] < 30 and 3 < m[2] / m[1] < 30, m


def test_bisection_brackets_the_critical_load():
    lo, hi = FXC - 1.3e-4, FXC + 2.9e-4
    while hi - lo > 1e-13:
        mid = 0.5 * (lo + hi)
        dec = ex.classify_spectrum(embedded(mid))
        if dec.decision is Decision.UNDECIDED:          # only within the float64 resolution
            assert abs(mid - FXC) < 1e-14 and dec.confidence <= 1.0
            break
        if dec.decision is Decision.COMPLEX:
            hi = mid
        else:
            lo = mid
    assert lo <= FXC <= hi and hi - lo <= 1e-13


@pytest.mark.parametrize("dF", [1e-7, -1e-7])
def test_projected_sparse_path_near_the_point(dF):
    A = sp.csr_matrix(embedded(FXC + dF, n=60))
    dec, res = projected.classify_projected(A, sigma=10.0, k=8)
    assert dec.decision is Decision.UNDECIDED or dec.decision is Decision.certified(dF > 0)
    if dec.decision is Decision.UNDECIDED:
        assert dec.confidence <= 1.0
    else:
        assert dec.confidence > 1.0
