"""The pair's mode shape (analysis.stability.modeshape): the participation ratio
of known vectors, and the ARPACK shift-invert eigenvector against LAPACK's."""
import numpy as np
import pytest

from remote_trigger.analysis.stability import eigen, jacobian
from remote_trigger.analysis.stability.analyze import analyze
from remote_trigger.analysis.stability.modeshape import (long_wave_fraction, pair_mode,
                                                        participation_ratio)

from .builders import random_packing


def test_participation_ratio_of_known_vectors():
    n = 50
    one = np.zeros((n, 2))
    one[7] = [0.3, -0.4]
    assert participation_ratio(one) == pytest.approx(1 / n, rel=1e-15)
    assert participation_ratio(np.ones((n, 2)) * (1 + 1j)) == pytest.approx(1.0, rel=1e-15)
    half = np.zeros((n, 3))
    half[: n // 2] = 1.0
    assert participation_ratio(half) == pytest.approx(0.5, rel=1e-15)
    assert np.isnan(participation_ratio(np.zeros((n, 2))))
    with pytest.raises(ValueError, match=r"shape \(5,\)"):
        participation_ratio(np.ones(5))


def test_long_wave_fraction_of_known_vectors():
    """1 for a combination of the long waves (any positions), 0 for a shorter
    wave on a lattice (orthogonal there), (2 m_max + 1)/N on average for random
    vectors, and refusals that name the value."""
    rng = np.random.default_rng(3)
    n, L = 60, 30.0
    x = rng.uniform(0.0, L, n)
    k2, k3 = 2 * np.pi * 2 / L, 2 * np.pi * -3 / L
    u = np.column_stack([np.exp(1j * k2 * x), 0.5 * np.exp(1j * k3 * x) - 2j])
    assert long_wave_fraction(u, x, L) == pytest.approx(1.0, rel=1e-12)
    assert long_wave_fraction(u.real, x, L) == pytest.approx(1.0, rel=1e-12)  # cos = sum of two
    lattice = np.arange(n) * (L / n)
    short = np.column_stack([np.exp(1j * 2 * np.pi * 5 / L * lattice), np.zeros(n)])
    assert long_wave_fraction(short, lattice, L) < 1e-25
    assert long_wave_fraction(short, lattice, L, m_max=5) == pytest.approx(1.0, rel=1e-12)
    got = [long_wave_fraction(rng.standard_normal((n, 2)) + 1j * rng.standard_normal((n, 2)),
                              x, L) for _ in range(400)]
    assert np.mean(got) == pytest.approx(7 / n, rel=0.1)
    assert np.isnan(long_wave_fraction(np.zeros((n, 2)), x, L))
    with pytest.raises(ValueError, match="L_x = -1.0"):
        long_wave_fraction(u, x, -1.0)
    with pytest.raises(ValueError, match=r"\(60, 2\) and 59"):
        long_wave_fraction(u, x[:-1], L)
    with pytest.raises(ValueError, match="7 waves for 5 particles"):
        long_wave_fraction(u[:5], x[:5], L)


def _dense_reference(state):
    """The complex eigenvalue of largest |Im| and the PR of its LAPACK eigenvector."""
    res = analyze(state, eigenvalues=False, decide=False)
    keep = res.rattlers.keep_dofs
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, keep)
    lam, V = np.linalg.eig(eigen.dynamical_matrix(Kr, mr).toarray())
    j = int(np.argmax(lam.imag))
    full = np.zeros(3 * state.n, complex)
    full[keep] = V[:, j] / np.sqrt(mr)
    return lam[j], participation_ratio(full.reshape(state.n, 3)[:, :2])


@pytest.mark.parametrize("nx, ny", [(4, 3), (12, 10)])      # 36 dofs: dense; 360: ARPACK
def test_pair_mode_matches_lapack(nx, ny):
    st = random_packing(5, nx=nx, ny=ny, cap_fraction=0.6)
    lam, pr = _dense_reference(st)
    assert lam.imag > 0                        # the random history makes K far from symmetric
    m = pair_mode(st, lam * (1 + 1e-7))
    assert m.eigenvalue == pytest.approx(lam, rel=1e-10)
    assert m.participation_ratio == pytest.approx(pr, rel=1e-8)
    assert m.n_particles == pytest.approx(st.n * pr, rel=1e-8)
    assert m.translations.shape == (st.n, 2)
    assert np.linalg.norm(m.translations) == pytest.approx(1.0, rel=1e-12)
    assert m.residual < 1e-12
    assert m.long_wave == long_wave_fraction(m.translations, st.positions[:, 0],
                                             st.box_length[0])
    assert 0 <= m.long_wave <= 1


def test_pair_mode_refuses_a_nonfinite_eigenvalue():
    with pytest.raises(ValueError, match="nan"):
        pair_mode(random_packing(1, nx=4, ny=3), complex(float("nan"), 1.0))


def test_pair_mode_is_reproducible():
    """ARPACK's random start made the mode's participation ratio differ in its
    last digits from call to call (an ensemble's table between a run and its
    resume); a fixed start vector gives the same bits."""
    st = random_packing(5, nx=12, ny=10, cap_fraction=0.6)      # 360 dofs: the ARPACK path
    lam, _ = _dense_reference(st)
    a, b = pair_mode(st, lam * (1 + 1e-7)), pair_mode(st, lam * (1 + 1e-7))
    assert a.eigenvalue == b.eigenvalue
    assert a.participation_ratio == b.participation_ratio and a.long_wave == b.long_wave
    assert np.array_equal(a.translations, b.translations)
