"""``remote-trigger paper --dim 3 --quick``: the paper job with spheres, once.

The same phases as the 2D job (docs/paper.md, Spheres); the checks here are
structural (every row of the 2D report is there, with a verdict) and the one
number the job must get right whatever the scene: the certified brackets of
F_x^c, each ordered and the lower friction's below the higher one's (the
window of Fig. 5).
"""
import json
import os
import subprocess
import sys

import h5py
import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.paper.config import DIM3, QUICK, QUICK3D, build_config
from tests.paper.test_paper_quick import CHECK_IDS, FIGURES, SECTIONS, check_rows

BIN = os.path.dirname(sys.executable)


def test_config_of_spheres():
    """dim = 3 starts from DIM3 (and QUICK3D with --quick); given values win."""
    c = build_config(overrides={"dim": 3})
    assert (c.dim, c.n, c.phi) == (3, DIM3["n"], DIM3["phi"])
    q = build_config(overrides={"dim": 3}, quick=True)
    assert (q.n, q.dF_x, q.tol) == (QUICK3D["n"], QUICK["dF_x"], QUICK["tol"])
    assert build_config(overrides={"dim": 3, "n": 120}, quick=True).n == 120
    with pytest.raises(ConfigError, match=r"phi must be in \(0.1, 0.91\), got phi = 0.95"):
        build_config(overrides={"phi": 0.95})
    two = build_config(quick=True)
    assert (two.dim, two.n, two.phi) == (2, QUICK["n"], 0.82)
    with pytest.raises(ConfigError, match="dim must be 2 or 3"):
        build_config(overrides={"dim": 4})
    with pytest.raises(ConfigError, match=r"phi must be in \(0.1, 0.74\) for spheres \(dim = 3\)"):
        build_config(overrides={"dim": 3, "phi": 0.82})


@pytest.fixture(scope="module")
def run3d(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper3d") / "quick-out"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    # two ranks (the job re-launches itself under mpirun): the ramps, and Fig. 4
    # against Fig. 5, side by side
    proc = subprocess.run([os.path.join(BIN, "remote-trigger"), "paper", "--dim", "3",
                           "--quick", "--np", "2", "--out", str(out)], capture_output=True,
                          text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return str(out), proc


def test_report_rows_and_figures(run3d):
    out, proc = run3d
    assert proc.stdout.strip().splitlines()[-1] == f"report: {os.path.join(out, 'report.md')}"
    text = open(os.path.join(out, "report.md")).read()
    assert "--dim 3 --quick: N = 96 spheres" in text
    for s in SECTIONS:
        assert s in text, s
    rows = check_rows(text)
    for cid in CHECK_IDS:
        assert cid in rows, cid
        assert rows[cid]["verdict"] in ("pass", "differs"), rows[cid]
    for f in FIGURES:
        assert os.path.getsize(os.path.join(out, f + ".png")) > 1000, f
    rep = json.load(open(os.path.join(out, "report.json")))
    assert {c["id"] for c in rep["checks"]} >= set(CHECK_IDS)


def test_certified_brackets_ordered(run3d):
    out, _ = run3d
    man = json.load(open(os.path.join(out, "paper.json")))
    assert man["status"] == "complete" and man["config"]["dim"] == 3
    assert man["n_ranks"] == 2
    r1, r08 = man["ramps"]
    for r in (r1, r08):
        assert r["status"] == "complete", r
        assert 0 < r["F_x_c_low"] < r["F_x_c_high"], r
        with h5py.File(r["h5"], "r") as fh:     # the stored ramp says the same
            assert fh.attrs["F_x_c_low"] == r["F_x_c_low"]
            assert fh.attrs["F_x_c_high"] == r["F_x_c_high"]
    # the window of Fig. 5: F_x^c(mu_ss mu0) below F_x^c(mu0), the load inside it
    assert r08["F_x_c_high"] < r1["F_x_c_low"]
    lo, hi = man["perturb"]["window"]
    assert lo < man["perturb"]["F_x"] < hi


def test_trigger_map_spectral_numbers_of_spheres(run3d):
    """``trigger-map``'s spectral numbers of a load of spheres (its Fig. 5 load):
    the growth rate after the drop equals the job's certified one; with no
    damping in effect the damped rate is that rate; with weak damping on the
    translations only (``fix viscous``: dofs 6k..6k+2, jacobian3d's layout)
    it moves by the first-order shift -(w^H M^-1 C x) / (2 w^H x) of the
    pair's left and right eigenvectors (fails if the rotations were damped
    or the wrong dofs were); D_drop is the mean-square displacement with the
    minimum image along x and z."""
    import numpy as np
    import scipy.linalg as sla

    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.jacobian import remove_dofs
    from remote_trigger.analysis.state.dumpfile import read_dump3d
    from remote_trigger.pywrap.jobs.trigger_map.loads import spectrum_numbers

    out, _ = run3d
    eq, dr = (os.path.join(out, "perturb", f + ".dump") for f in ("equilibrium", "drop"))
    with open(os.path.join(out, "paper.json")) as fh:
        g = json.load(fh)["perturb"]["drop"]["growth_rate"]
    assert g > 0
    tau = 10.0 / g
    num = spectrum_numbers(eq, dr, [1e12, tau])
    assert abs(num["growth"] - g) <= 1e-9 * g
    assert abs(num["growth_tau"][0] - g) <= 1e-6 * g
    s1 = read_dump3d(dr)
    an = analyze(s1, eigenvalues=False, decide=False)
    keep = an.rattlers.keep_dofs
    Kr, mr = remove_dofs(an.K, an.mass, keep)
    lam, wl, vr = sla.eig(eigen.dynamical_matrix(Kr, mr).toarray(), left=True, right=True)
    i = int(np.argmax(np.abs(np.sqrt(lam).imag)))
    x, w = vr[:, i], wl[:, i]
    c = (1.0 / tau) * ((keep % 6) < 3) / mr          # M^-1 C, translations only
    shift = (-np.vdot(w, c * x) / (2.0 * np.vdot(w, x))).real
    assert shift < 0
    assert abs((num["growth_tau"][1] - g) - shift) < 0.02 * abs(shift)
    s0 = read_dump3d(eq)
    d = s1.positions - s0.positions
    for a in (0, 2):
        L = s0.box_hi[a] - s0.box_lo[a]
        d[:, a] -= L * np.round(d[:, a] / L)
    assert num["D_drop"] == pytest.approx(float(np.mean(np.sum(d * d, axis=1))), rel=1e-12)
