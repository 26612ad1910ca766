"""A verified basis carried over to other kept dofs (a rattler gained or lost).

A ramp's next point may keep other dofs than the previous one (a disk that
gained or lost its last contacts). ``SpectrumBasis.on_dofs`` maps the
previous basis onto the new dofs; the decision from it must give the same
certified answer as the decision from dgeev (both rigorous), and take the
basis path when the dropped or added dofs are weakly coupled, as a
rattler's are.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.decision import SpectrumBasis
from remote_trigger.analysis.stability.exceptional import classify_spectrum

from .arb_oracle import full_spectrum
from .test_exceptional import embedded
from remote_trigger.analysis.stability.decision import Decision


def _with_rattler(A, extra=3, coupling=1e-3, seed=7):
    """A with ``extra`` dofs appended that are weakly coupled to it (a rattler's
    modes: soft, their own diagonal, small off-diagonal entries)."""
    rng = np.random.default_rng(seed)
    n = A.shape[0]
    F = np.zeros((n + extra, n + extra))
    F[:n, :n] = A
    F[n:, n:] = np.diag(np.linspace(0.3, 0.6, extra))
    F[n:, :n] = coupling * rng.normal(size=(extra, n))
    F[:n, n:] = coupling * rng.normal(size=(n, extra))
    return F


def _decide(A, dofs, basis=None):
    dec = classify_spectrum(A, basis=basis)
    dec.basis.dofs = np.asarray(dofs, np.int64)
    return dec


@pytest.mark.parametrize("eps", [1e-2, -1e-2, 1e-4])
def test_rattler_lost_and_gained_same_answer_as_dgeev(eps):
    n = 40
    A_small = embedded(0.5, eps, n=n, seed=2)
    A_big = _with_rattler(embedded(0.5, 1.05 * eps, n=n, seed=2))
    # the extra disk's dofs are the last three of the whole system (0..n+2);
    # the small system keeps 0..n-1
    big_dofs, small_dofs = np.arange(n + 3), np.arange(n)
    # lost: basis of the big system carried to the small one
    prev = _decide(A_big, big_dofs)
    carried = prev.basis.on_dofs(small_dofs)
    assert carried is not None and carried.X.shape == (n, n)
    assert sum(k for _, k in carried.blocks) == n
    warm, cold = classify_spectrum(A_small, basis=carried), classify_spectrum(A_small)
    assert warm.start == "basis", warm.reason
    assert warm.decision is cold.decision is Decision.certified(eps < 0)
    # gained: basis of the small system carried to the big one
    prev = _decide(A_small, small_dofs)
    carried = prev.basis.on_dofs(big_dofs)
    assert carried is not None and carried.X.shape == (n + 3, n + 3)
    warm, cold = classify_spectrum(A_big, basis=carried), classify_spectrum(A_big)
    assert warm.start == "basis", warm.reason
    assert warm.decision is cold.decision is Decision.certified(eps < 0)


def test_rattler_dofs_in_the_middle_and_arb():
    """Dropped dofs inside the numbering (rows removed in the middle), checked
    against Arb's enclosure of the whole spectrum."""
    n = 30
    A_big = _with_rattler(embedded(0.5, -1e-3, n=n, seed=1))
    perm = np.r_[0:10, n:n + 3, 10:n]           # the rattler's dofs at positions 10-12
    A_big = A_big[np.ix_(perm, perm)]
    dofs_big = np.arange(n + 3)
    dofs_small = np.r_[0:10, 13:n + 3]
    A_small = A_big[np.ix_(dofs_small, dofs_small)]
    carried = _decide(A_big, dofs_big).basis.on_dofs(dofs_small)
    warm = classify_spectrum(A_small, basis=carried)
    assert warm.start == "basis", warm.reason
    assert warm.decision is Decision.COMPLEX
    assert full_spectrum(A_small) == "complex"


def test_on_dofs_same_dofs_and_unknown_dofs():
    A = embedded(0.5, 1e-2, n=20, seed=3)
    basis = _decide(A, np.arange(20)).basis
    assert basis.on_dofs(np.arange(20)) is basis
    basis.dofs = None
    assert basis.on_dofs(np.arange(19)) is None        # no record: no carry-over


def test_dofs_saved_and_loaded(tmp_path):
    A = embedded(0.5, 1e-2, n=20, seed=3)
    basis = _decide(A, np.arange(3, 23)).basis
    basis.save(str(tmp_path / "b.npz"))
    back = SpectrumBasis.load(str(tmp_path / "b.npz"))
    np.testing.assert_array_equal(back.dofs, np.arange(3, 23))
    basis.dofs = None
    basis.save(str(tmp_path / "c.npz"))
    assert SpectrumBasis.load(str(tmp_path / "c.npz")).dofs is None
