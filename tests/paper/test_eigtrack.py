"""Tracking of the coalescing pair on spectra with a known exceptional point."""
import numpy as np
import pytest

from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.analysis.stability.eigtrack import track_pair


def synthetic(F, F_c=0.05, lam_c=100.0, c=250.0):
    """Spectrum with one EP at F_c: lam_c -/+ c sqrt(F_c - F), plus bystanders.

    The bystanders drift with F, as real spectra do (two of them cross each
    other, far from the pair: the tracking must not care).
    """
    d = F_c - F
    if d > 0:
        pair = [lam_c - c * np.sqrt(d), lam_c + c * np.sqrt(d)]
    else:
        pair = [lam_c - 1j * c * np.sqrt(-d), lam_c + 1j * c * np.sqrt(-d)]
    others = [2.0 + 10 * F, 20.0 + 5 * F, 200.0 + 1000 * F, 300.0, 250.0 - 100 * F]
    lam = np.array(pair + others, complex)
    order = np.lexsort((lam.imag, lam.real))
    return lam[order], Decision.certified(d < 0)


def test_track_finds_birth_and_ancestors():
    Fs = list(np.arange(0.0, 0.05, 0.002)) + [0.0499, 0.04995, 0.05005, 0.0501] + \
        list(np.arange(0.052, 0.07, 0.004))
    pts = [(F,) + synthetic(F) for F in Fs]
    np.random.default_rng(0).shuffle(pts)            # order must not matter
    tr = track_pair(pts)
    assert tr is not None
    first = np.argmax(tr.complex_pair)
    assert tr.F_x[first] == pytest.approx(0.05005)
    assert tr.lam_c == pytest.approx(100.0)
    assert tr.rank == 2 and tr.n_modes == 7          # 2, 20, then the pair
    below = ~tr.complex_pair
    c, F_c = 250.0, 0.05
    np.testing.assert_allclose(tr.lam_a[below].real, 100 - c * np.sqrt(F_c - tr.F_x[below]))
    np.testing.assert_allclose(tr.lam_b[below].real, 100 + c * np.sqrt(F_c - tr.F_x[below]))
    above = tr.complex_pair
    np.testing.assert_allclose(tr.lam_b[above].imag, c * np.sqrt(tr.F_x[above] - F_c))
    np.testing.assert_allclose(tr.lam_a[above], np.conj(tr.lam_b[above]))
    assert tr.ambiguity < 0.5


def test_decisions_override_eigenvalues():
    """The certified decision, not the eigenvalue array, decides; undecided points are skipped."""
    pts = []
    for F in (0.0, 0.01, 0.02, 0.03):
        lam, is_c = synthetic(F, F_c=0.025)
        pts.append((F, lam, is_c))
    # undecided points next to the EP: computed as a complex pair (round-off at the EP)
    for F in (0.0249, 0.0251):
        lam, _ = synthetic(0.02501, F_c=0.025)
        pts.append((F, lam, Decision.UNDECIDED))
    # a certified-real point whose eigenvalue array carries a spurious tiny Im
    lam, _ = synthetic(0.0245, F_c=0.025)
    lam = lam.copy()
    lam[np.argmin(np.abs(lam - 100))] += 1e-9j
    pts.append((0.0245, lam, Decision.REAL))
    tr = track_pair(pts)
    assert 0.0249 not in tr.F_x and 0.0251 not in tr.F_x
    k = int(np.argmax(tr.complex_pair))
    assert tr.F_x[k] == pytest.approx(0.03) and tr.F_x[k - 1] == pytest.approx(0.0245)
    assert tr.lam_a[k - 1].real < tr.lam_b[k - 1].real


def test_no_pair_and_complex_at_start():
    stable = [(F,) + synthetic(F, F_c=1.0) for F in (0.0, 0.1)]
    assert track_pair(stable) is None
    unstable = [(F,) + synthetic(F, F_c=-1.0) for F in (0.0, 0.1)]
    assert track_pair(unstable) is None
    with pytest.raises(ValueError, match="spectrum"):
        track_pair([(0.0, np.zeros(0), Decision.REAL)])
