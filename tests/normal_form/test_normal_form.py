"""The normal form (paper Eqs. 9-17): closed-form checks and solve_ivp against them."""
import math

import numpy as np
import pytest

from remote_trigger.analysis.dynamics import normal_form as nf


@pytest.mark.parametrize("delta", [0.05, 0.3])
@pytest.mark.parametrize("eps", [0.5, 1e-3, -1e-3, -0.5])
def test_eigenvalues_of_J(delta, eps):
    lam = np.sort_complex(np.linalg.eigvals(nf.normal_form_matrix(delta, eps)))
    ref = np.sort_complex(nf.eigenvalues(delta, eps))
    np.testing.assert_allclose(lam, ref, rtol=1e-12)
    assert (np.abs(lam.imag).max() > 0) == (eps < 0)


def test_solve_ivp_matches_exact_modal_solution():
    delta, eps, tau = 0.1, 1e-3, 500.0
    run = nf.integrate(delta, eps, tau=tau, rtol=1e-11, atol=1e-13)
    ref = nf.exact_solution(delta, eps, tau, run.t)
    scale = np.abs(ref).max()
    assert np.abs(run.x - ref).max() < 1e-6 * scale


def test_undamped_amplitude_scales_as_inverse_sqrt_eps():
    errs = []
    for eps in (1e-2, 1e-3, 3e-4):
        a = nf.integrate(0.1, eps).amplitude
        errs.append(abs(a * math.sqrt(eps) - 1.0))
    # A sqrt(eps) -> 1, the correction shrinking as eps -> 0
    assert errs[0] < 1e-2 and errs[-1] < 1e-3, errs
    assert errs[0] > errs[1] > errs[2]


def test_damping_destroys_amplification_only_when_tau_shorter_than_beat():
    delta, eps = 0.1, 1e-4
    td = nf.beat_time(delta, eps)
    long_tau = nf.integrate(delta, eps, tau=30 * td).amplitude
    short_tau = nf.integrate(delta, eps, tau=td / 30).amplitude
    assert long_tau * math.sqrt(eps) > 0.95
    # tau << tau_d: A -> 2 tau delta / (sqrt 2 e), independent of eps
    assert short_tau == pytest.approx(2 * td / 30 * delta / (math.sqrt(2) * math.e), rel=0.02)
    assert nf.integrate(delta, eps / 10, tau=td / 30).amplitude == pytest.approx(short_tau,
                                                                                rel=0.02)
    for tau in (td, td / 3):
        a = nf.integrate(delta, eps, tau=tau).amplitude
        assert 0.95 < a / nf.damped_estimate(delta, eps, tau) < 1.25, tau
    # the paper's e^(-t/tau) under-estimates by 2 when tau < tau_d
    a = nf.integrate(delta, eps, tau=td / 30).amplitude
    assert a / nf.damped_estimate(delta, eps, td / 30, paper=True) == pytest.approx(2.0, rel=0.02)


def test_forcing_orthogonal_to_coalescing_vector_is_amplified():
    # a small forcing at a frequency far from resonance excites the
    # homogeneous beat: the response grows as eps decreases
    F = 1e-3
    a1 = nf.integrate(0.3, 1e-2, force=F, omega=0.01).amplitude
    a2 = nf.integrate(0.3, 1e-4, force=F, omega=0.01).amplitude
    assert a2 > 5 * a1


@pytest.mark.parametrize("kw, match", [
    (dict(delta=0.0, eps=0.1), "delta must be in"),
    (dict(delta=1.5, eps=0.1), "delta must be in"),
    (dict(delta=0.1, eps=0.0), "eps must be in"),
    (dict(delta=0.1, eps=float("nan")), "eps must be in"),
    (dict(delta=0.1, eps=0.1, tau=-1.0), "tau must be > 0"),
    (dict(delta=0.1, eps=0.1, t_max=-3.0), "t_max must be > 0"),
])
def test_bad_parameters(kw, match):
    with pytest.raises(ValueError, match=match):
        nf.integrate(**kw)


@pytest.mark.parametrize("kw, msg", [
    (dict(force=float("nan")), "force must be a finite number, got force = nan"),
    (dict(omega=float("nan")), "omega must be a finite number >= 0, got omega = nan"),
    (dict(omega=-1.0), "omega must be a finite number >= 0, got omega = -1.0"),
])
def test_forcing_out_of_range_is_refused(kw, msg):
    """A NaN forcing amplitude or frequency made solve_ivp step forever (the
    command hung with no output); refused by name before integrating."""
    from remote_trigger.analysis.dynamics.normal_form import integrate

    with pytest.raises(ValueError, match=msg):
        integrate(0.1, 0.1, **kw)
