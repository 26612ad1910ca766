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
