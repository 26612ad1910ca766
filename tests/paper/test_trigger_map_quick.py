"""``remote-trigger trigger-map --quick --np 2`` on the ``paper --quick`` job.

What must hold (each can fail): at the load inside the window the bisected
a_c brackets the linear-response prediction a_lin of the probe run; below the
window, and with damping tau = 0.25 / g (predicted decay after the drop),
nothing runs away up to a_max; the bracketed runaway rose at the predicted
rate (growth check, re-measured from the run file); no control (mu(v), no forcing) triggers; the
bracket at dt / 2 overlaps the one at dt. The run files are re-read here.
"""
import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from remote_trigger.analysis.dynamics.series import runaway_rate
from remote_trigger.pywrap.jobs.trigger_map.job import rise_of

CLI = os.path.join(os.path.dirname(sys.executable), "remote-trigger")


def _run(args):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([CLI, "trigger-map"] + args, capture_output=True, text=True,
                          env=env, timeout=900)


@pytest.fixture(scope="module")
def tmap(paper_quick, tmp_path_factory):
    paper, _ = paper_quick
    out = str(tmp_path_factory.mktemp("tmap") / "map")
    proc = _run(["--quick", "--np", "2", "--paper", paper, "--out", out])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with h5py.File(os.path.join(out, "trigger_map.h5"), "r") as fh:
        pts = {k: fh["points/" + k][()] for k in fh["points"]}
        loads = {k: fh["loads/" + k][()] for k in fh["loads"]}
        attrs = dict(fh.attrs)
        kap = {k: fh["ramp_kappa/" + k][()] for k in fh["ramp_kappa"]}
    for k in ("key", "kind", "onset", "check_of", "status", "forced_by"):
        pts[k] = np.array([x.decode() if isinstance(x, bytes) else str(x) for x in pts[k]])
    return out, proc, pts, loads, attrs, kap


def _task(out, key):
    with open(os.path.join(out, "tasks", key + ".json")) as fh:
        return json.load(fh)


def test_outputs(tmap):
    out, proc, pts, loads, attrs, _ = tmap
    for f in ("trigger_map.h5", "trigger_map.md", "trigger_map.json", "loads.json"):
        assert os.path.isfile(os.path.join(out, f)), f
    with open(os.path.join(out, "trigger_map.png"), "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    assert proc.stdout.strip().splitlines()[-1].startswith("trigger map: ")
    # 2 loads x (undamped + 1 tau) x 1 omega x 2 onsets, plus 1 point at dt / 2
    assert len(pts["key"]) == 9 and np.sum(pts["check_of"] != "") == 1
    assert list(loads["kind"].astype(str)) == ["window 0.6", "below"]
    md = open(os.path.join(out, "trigger_map.md")).read()
    assert "## Map" in md and "## Time step check" in md and "## Condition number" in md
    # t_max-marginal flag: set exactly where the triggering run ended after 0.95 t_max
    assert "t_max-marginal points" in md
    t_max = json.load(open(os.path.join(out, "config.json")))["t_max"]
    late = np.nan_to_num(pts["t_run"], nan=0.0) > 0.95 * t_max
    np.testing.assert_array_equal(pts["marginal"].astype(bool), late)


def test_window_load_triggers_at_the_predicted_amplitude(tmap):
    out, _, pts, loads, attrs, _ = tmap
    sel = (pts["load"] == 0) & np.isinf(pts["tau"]) & (pts["check_of"] == "")
    assert sel.sum() == 2
    for i in np.flatnonzero(sel):
        assert pts["status"][i] == "bracketed", pts["key"][i]
        lo, hi = pts["a_lo"][i], pts["a_hi"][i]
        assert hi / lo <= 1.5 * (1 + 1e-12)
        # the probe's linear-response estimate lies in the bracket, up to its factor
        assert lo / 1.5 <= pts["a_lin"][i] <= hi * 1.5, (lo, hi, pts["a_lin"][i])
        # re-read the runs: a_hi ran away after mu left mu0, a_lo never passed D_run
        log = _task(out, pts["key"][i])
        # growth check: the a_hi run rose through its last decade below D_run at the
        # predicted rate (the table's number re-measured from the run's records)
        g = pts["growth_tau"][i]
        assert g > 0 and pts["forced_by"][i] == ""
        a_hi_run = next(r for r in log["runs"] if r["kind"] == "mu(v)" and r["a"] == hi)
        with h5py.File(a_hi_run["h5"], "r") as fh:
            rate, n = runaway_rate(fh["t"][()], fh["D"][()], a_hi_run["d_run"])
        assert rate == pts["rise_rate"][i] and n == pts["rise_records"][i] >= 5
        assert 0.5 <= rate / g <= 2.0, (rate, g)
        # a log written before the check existed is measured from the run file
        old = {k: v for k, v in a_hi_run.items() if not k.startswith("rise_")}
        assert rise_of(old) == (rate, n)
        # the forced twin (a_hi, mu0 throughout) stays below D_run: the friction drop did it
        twin = [r for r in log["runs"] if r["kind"] == "twin"]
        assert log["forced"] is False and len(twin) == 1 and twin[0]["a"] == hi
        assert not twin[0]["triggered"] and twin[0]["D_max"] < twin[0]["d_run"] / 10
        runs = {r["a"]: r for r in log["runs"] if r["kind"] == "mu(v)"}
        for a, want in ((hi, True), (lo, False)):
            r = runs[a]
            with h5py.File(r["h5"], "r") as fh:
                D, mu = fh["D"][()], fh["mu"][()]
            assert (np.max(D) > r["d_run"]) == want
            if want:
                assert np.min(mu) < 1.0
                # the runaway is far above what the friction drop alone gives
                assert np.max(D) > 50 * loads["D_drop"][0]


def test_no_trigger_where_the_drop_cannot_destabilise(tmap):
    """Below the window (certified real after the drop) and with damping that makes
    the dropped state decay (predicted max Re s < 0): nothing up to a_max."""
    _, _, pts, loads, _, _ = tmap
    assert loads["growth"][1] == 0.0 and loads["growth"][0] > 0
    assert np.all(loads["growth_tau"][:, 0] < 0)
    none = (pts["load"] == 1) | np.isfinite(pts["tau"])
    assert none.sum() == 6
    assert set(pts["status"][none]) == {"none up to a_max"}
    # decay predicted: the strongest forcing a_max is asked first, and it is measured
    # not to run away (mu(v) switched on, D stayed below D_run): one run per point
    out = tmap[0]
    for key in pts["key"][none]:
        log = _task(out, key)
        assert log["shortcut"] == "decay predicted" and log["n_runs"] == 1, key
        (r,) = log["runs"]
        assert r["kind"] == "mu(v)" and r["a"] == log["a_max"] and not r["triggered"]
        assert r["t_switch"] is not None and r["D_max"] < r["d_run"]


def test_controls_untriggered(tmap):
    out, _, pts, _, _, _ = tmap
    for i in range(2):
        for j in range(2):
            d = _task(out, f"control_L{i}_T{j}")
            assert d["noise_triggered"] is False and d["switched"] is False
    assert "noise-triggered" not in set(pts["status"])


def test_half_time_step_bracket_overlaps(tmap):
    _, _, pts, _, _, _ = tmap
    k = int(np.flatnonzero(pts["check_of"] != "")[0])
    o = int(np.flatnonzero(pts["key"] == pts["check_of"][k])[0])
    assert pts["dt_fraction"][k] == 0.5 * pts["dt_fraction"][o]
    assert max(pts["a_lo"][k], pts["a_lo"][o]) <= min(pts["a_hi"][k], pts["a_hi"][o])


def test_kappa_grows_toward_the_exceptional_point(tmap):
    _, _, _, _, _, kap = tmap
    assert np.all(np.diff(kap["F_x"]) > 0) and np.all(kap["kappa"] >= 1)
    assert kap["gap"][-1] < kap["gap"][0] and kap["kappa"][-1] > kap["kappa"][0]


def test_resume_redoes_only_what_is_missing(tmap, tmp_path):
    out, _, pts, _, _, _ = tmap
    copy = str(tmp_path / "map")
    shutil.copytree(out, copy)
    key = "L0_T1_W0_step"
    os.remove(os.path.join(copy, "tasks", key + ".json"))
    before = {f: os.path.getmtime(os.path.join(copy, "tasks", f))
              for f in os.listdir(os.path.join(copy, "tasks"))}
    paper = json.load(open(os.path.join(out, "config.json")))["paper"]
    proc = _run(["--quick", "--paper", paper, "--out", copy])
    assert proc.returncode == 2 and "--resume" in proc.stderr
    proc = _run(["--quick", "--paper", paper, "--out", copy, "--resume", "--quiet"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    after = {f: os.path.getmtime(os.path.join(copy, "tasks", f))
             for f in os.listdir(os.path.join(copy, "tasks"))}
    assert all(after[f] == t for f, t in before.items())
    assert key + ".json" in after
    with h5py.File(os.path.join(copy, "trigger_map.h5"), "r") as fh:
        for c in ("a_lo", "a_hi", "a_lin"):
            np.testing.assert_array_equal(fh["points/" + c][()], pts[c])
