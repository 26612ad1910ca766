"""``remote-trigger ensemble --dim 3 --quick``: spheres, two ranks, resume.

What must hold (each can fail): two packings of N = 96 spheres run on two
ranks give one row each (the default protocol at the spheres' I0 = 2/5; no
frictional or I0 = 1 rows) with certified brackets of F_x^c(mu0) and
F_x^c(0.8 mu0) to tol, the per-packing order from those brackets, the
report's note of what 3D skips; a packing whose second ramp was not yet
recorded is resumed serially without redoing its relaxation or first ramp,
and the table is that of the uninterrupted run, as it is again from
``--resume`` alone (the folder's own configuration); a 2D ``--resume`` of
that folder, or a 2D-only option with ``--dim 3``, is refused in one line.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from remote_trigger.pywrap.jobs.ensemble import job as en
from remote_trigger.pywrap.jobs.ensemble import report as er
from remote_trigger.pywrap.jobs.ensemble import task as et
from tests.driver.test_cli_errors import assert_one_line_error
from tests.paper.test_ensemble_quick import _same

CLI = os.path.join(os.path.dirname(sys.executable), "remote-trigger")


def _run(args):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([CLI, "ensemble", "--dim", "3", "--quick"] + args,
                          capture_output=True, text=True, env=env, timeout=900)


@pytest.fixture(scope="module")
def spheres(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("ens3d") / "np2")
    proc = _run(["--np", "2", "--out", out, "--quiet"])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return out, er.read_table(os.path.join(out, en.TABLE))


def test_rows_and_order(spheres):
    out, t = spheres
    assert list(t["key"]) == ["N96_s1", "N96_s3"]
    assert set(t["protocol"]) == {"frictionless-then-friction"}
    assert np.all(t["I0"] == 0.4) and np.all(t["dynamics_consistent"] == 1)
    for i in range(2):
        assert t["status"][i] == "ok", t["reason"][i]
        for a, b in (("F_x_c_low", "F_x_c_high"), ("F_x_c_ss_low", "F_x_c_ss_high")):
            assert 0 < t[b][i] - t[a][i] <= 2e-3 * (1 + 1e-12)
        assert t["order"][i] == er.order_code(t["F_x_c_low"][i], t["F_x_c_high"][i],
                                               t["F_x_c_ss_low"][i], t["F_x_c_ss_high"][i])
        assert t["order"][i] in (0, 1)          # the quick brackets are disjoint
        assert t["decision_at_zero"][i] == 0
        assert 1 <= t["pair_index"][i] < t["n_dof"][i] and t["n_dof"][i] % 6 == 0
    with open(os.path.join(out, "config.json")) as fh:
        assert json.load(fh)["dim"] == 3
    with open(os.path.join(out, en.MANIFEST)) as fh:
        assert json.load(fh)["sessions"][-1]["n_ranks"] == 2
    md = open(os.path.join(out, "ensemble.md")).read()
    assert md.startswith("# Ensemble of packings of spheres (dim = 3)")
    assert "Skipped in 3D: the frictional relaxation protocol" in md
    assert "I0 = 1 re-analysis rows" in md
    assert "## Frictional relaxation" not in md and "analysis convention only" not in md
    o = {1: "holds", 0: "reversed"}
    for i in range(2):
        assert f"| {t['key'][i]} | frictionless-then-friction | 0.4 | ok |" in md
        assert f"| {o[int(t['order'][i])]} |" in md


def test_resumed_packing_gives_the_same_table(spheres, tmp_path):
    """The state a run killed between the two ramps of N96_s3 leaves (its
    result missing, its progress without the mu_ss part), resumed serially."""
    src, t1 = spheres
    out = str(tmp_path / "resumed")
    shutil.copytree(src, out)
    os.remove(os.path.join(out, "tasks", "N96_s3.json"))
    pack = os.path.join(out, "packings", "N96_s3")
    with open(os.path.join(pack, et.PROGRESS)) as fh:
        progress = json.load(fh)
    del progress["ramps"]["mu_ss"]
    with open(os.path.join(pack, et.PROGRESS), "w") as fh:
        json.dump(progress, fh)
    shutil.rmtree(os.path.join(pack, "ramp_mu_ss"))
    kept = [os.path.join(pack, "default", "relax.h5"),
            os.path.join(pack, "ramp_mu0", "ramp.h5")]
    stamps = [os.stat(f).st_mtime_ns for f in kept]

    r = subprocess.run([CLI, "ensemble", "--quick", "--out", out, "--resume"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert_one_line_error(r.stderr, "dim = 3 (then) vs None (now)")
    r = _run(["--out", out, "--set", "frictional=true"])
    assert r.returncode == 2
    assert_one_line_error(r.stderr, "frictional = True is 2D only")

    r = _run(["--out", out, "--resume", "--quiet"])
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    with open(os.path.join(out, en.MANIFEST)) as fh:
        man = json.load(fh)
    assert man["sessions"][-1]["computed"] == ["N96_s3"] and man["sessions"][-1]["resume"]
    assert [os.stat(f).st_mtime_ns for f in kept] == stamps, "a recorded stage was redone"
    _same(t1, er.read_table(os.path.join(out, en.TABLE)))
    # --resume alone takes the folder's configuration (dim = 3 with it): nothing to compute
    r = subprocess.run([CLI, "ensemble", "--out", out, "--resume", "--quiet"],
                       capture_output=True, text=True, timeout=300,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    assert r.returncode == 0, r.stderr[-3000:]
    with open(os.path.join(out, en.MANIFEST)) as fh:
        assert json.load(fh)["sessions"][-1]["computed"] == []
    _same(t1, er.read_table(os.path.join(out, en.TABLE)))
