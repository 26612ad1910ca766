"""The default job's bisection of F_x^c, decided again and checked with Arb.

``remote-trigger paper`` (default configuration) brackets F_x^c(mu) by
bisection from its last real ramp step. Its start equilibria are stored
(tests/data); the test writes a ramp.h5 holding the two ramp steps around
F_x^c exactly as the default job had them and resumes it, so the bisection
runs from the same equilibrium with the same loads as in the default job.
Every decision of the analyzer is then checked independently: Arb's
eigenpair enclosure (tests/analysis/arb_oracle.py) on the same float64
M^-1 K, with every entry widened by half an ulp, must prove the same answer
for the pair nearest its exceptional point.
"""
import numpy as np
import pytest

from remote_trigger.pywrap import stages
from remote_trigger.pywrap.jobs.paper import ramp_config
from remote_trigger.pywrap.jobs.paper.config import PaperConfig

from tests.analysis.arb_oracle import pair_is
from tests.data import unpack
from remote_trigger.analysis.stability.decision import Decision

U = 2.0 ** -53

# mu, stored start file, last real and first complex ramp loads of the default job
JOBS = [(1.0, "default_job_mu1_step_00258", 0.0645, 0.06475),
        (0.8, "default_job_mu0.8_step_00234", 0.0585, 0.05875)]


def matrix(dump):
    """M^-1 K after rattler removal, as the ramp's analysis forms it."""
    from remote_trigger.analysis.stability import eigen, jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.state.dumpfile import read_dump

    res = analyze(read_dump(dump, require_contacts=False), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    return eigen.dynamical_matrix(Kr, mr).toarray()


def ep_pair(A):
    """The two eigenvalues nearest an exceptional point (LAPACK approximations).

    A complex pair if there is one with the smallest |Im|; else the two
    neighbouring real eigenvalues whose eigenvectors are most nearly parallel.
    """
    lam, V = np.linalg.eig(A)
    cx = np.flatnonzero(lam.imag > 0)
    if cx.size:
        j = cx[np.argmin(lam[cx].imag)]
        return [lam[j], np.conj(lam[j])]
    order = np.argsort(lam.real)
    W = V[:, order].real / np.linalg.norm(V[:, order].real, axis=0)
    cos = np.abs(np.sum(W[:, :-1] * W[:, 1:], axis=0))
    k = int(np.argmax(cos))
    return [lam[order[k]], lam[order[k + 1]]]


@pytest.mark.slow
@pytest.mark.parametrize("mu, name, F_lo, F_hi", JOBS)
def test_default_job_bisection_is_certified_and_agrees_with_arb(mu, name, F_lo, F_hi,
                                                                tmp_path):
    from remote_trigger.analysis.stability import exceptional

    start = unpack(name, tmp_path)
    cfg = ramp_config(PaperConfig(), start, mu)
    out = tmp_path / "ramp"
    from remote_trigger.pywrap.stages.ramp_file import RampLog as _RampLog

    rlog = _RampLog(cfg, str(out / "ramp.h5"))
    out.mkdir()
    for k, (F, c) in enumerate(((F_lo, 0), (F_hi, 1))):
        vals = {col: 0.0 for col in _RampLog.COLS}
        vals.update(F_x=F, complex=float(c), decision=float(c), confidence=10.0)
        rlog.add("steps", f"step_{k:05d}", start if c == 0 else str(out / "none.data"), vals,
                 [])
    rlog.write("running")
    res = stages.ramp(cfg, str(out), quiet=True, resume=True)
    assert res.status == "complete", res.message
    # every bisection point certified: the bracket is tol wide and only certified ends
    dec = res.bisection_decision
    assert res.n_undecided == 0 and np.all(np.isin(dec, (0, 1))), dec
    assert res.tol_reached and 0 < res.F_x_c_width <= cfg.tol
    assert res.bisection_F_x.size == 12
    # ... and each decision agrees with Arb on the same float64 matrix
    for j, (F, d) in enumerate(zip(res.bisection_F_x, dec)):
        A = matrix(str(out / "ramp" / f"bisect_{j:03d}.dump"))
        ours = exceptional.classify_spectrum(A)
        assert ours.decision is Decision.certified(d == 1)
        assert pair_is(A, ep_pair(A), rel=U) == ("complex" if d == 1 else "real"), (mu, F)
