"""``remote-trigger paper --resume``: a killed job continues to the same report.

One small job (``--quick`` with ``t_perturb = 150``, ~25 s) runs twice, side by
side:

* uninterrupted (with ``--resume`` into an empty folder, which must start a
  new job);
* killed with SIGKILL three times -- in the middle of the second ramp
  (after the first ramp's summary reached ``paper.json``), just after a seeded
  random one of the Fig. 5 runs (a), (b), (c) wrote its file (the kills wait for
  files, never for a time: a faster step cannot move them out of their phase), and while the figures and the report are being
  written -- with the normal form's file deleted before the last run, and
  resumed with ``--resume`` after each kill; the folder is moved after the
  second kill, and the job resumes in its new place.

Both reports must state the same numbers (report.json: every check and
every extra value, compared exactly), report.md may differ only in its
timings section, and the HDF5 results (ramp brackets, D(t) series) must be
bitwise equal. Then ``--resume`` on the complete job must change nothing,
and ``--resume`` with another configuration must be refused naming the key
and both values, with nothing deleted.
"""
import json
import os
import random
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from remote_trigger.pywrap.jobs import paper
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.paper.config import build_config

BIN = os.path.dirname(sys.executable)
CLI = os.path.join(BIN, "remote-trigger")
JOB = ["paper", "--quick", "--set", "t_perturb=150"]
ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
#: seed of the random kill moment (printed on failure)
KILL_SEED = int(os.environ.get("PAPER_RESUME_SEED", "7"))


def manifest(out):
    """paper.json of ``out`` or {} (it is replaced atomically: never half-written)."""
    try:
        with open(os.path.join(out, "paper.json")) as fh:
            return json.load(fh)
    except FileNotFoundError:
        return {}


def read(*parts):
    with open(os.path.join(*parts)) as fh:
        return fh.read()


def start(out, *extra):
    with open(out + ".log", "a") as log:
        return subprocess.Popen([CLI, *JOB, "--out", out, *extra], stdout=log,
                                stderr=subprocess.STDOUT, text=True, env=ENV)


def finish(out, *extra):
    proc = subprocess.run([CLI, *JOB, "--out", out, *extra], capture_output=True, text=True,
                          env=ENV, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc


def kill_when(proc, ready, what, timeout=300.0, delay=0.0):
    """SIGKILL ``proc`` once ``ready()`` holds (polled every 20 ms), after ``delay`` s."""
    t0 = time.monotonic()
    while not ready():
        assert proc.poll() is None, f"job ended (status {proc.returncode}) before {what}"
        assert time.monotonic() - t0 < timeout, f"timeout waiting for {what}"
        time.sleep(0.02)
    time.sleep(delay)
    assert proc.poll() is None, f"job ended before the kill {what} (+{delay:.2f} s)"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()


def snapshot(out):
    """{relative path: (size, mtime_ns)} of every file under ``out``."""
    snap = {}
    for root, _, files in os.walk(out):
        for f in files:
            p = os.path.join(root, f)
            st = os.stat(p)
            snap[os.path.relpath(p, out)] = (st.st_size, st.st_mtime_ns)
    return snap


@pytest.fixture(scope="module")
def jobs(tmp_path_factory):
    base = tmp_path_factory.mktemp("resume")
    ref, res = str(base / "ref"), str(base / "res")
    # the uninterrupted job runs beside the killed ones (independent folders; the
    # kills wait for files, not for times, so the second core only saves time)
    t0 = time.perf_counter()
    ref_run = subprocess.Popen([CLI, *JOB, "--out", ref, "--resume"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=ENV)
    states = []

    t0 = time.perf_counter()
    # run 1: killed in the middle of the second ramp
    p = start(res)
    kill_when(p, lambda: os.path.exists(os.path.join(res, "ramp_mu0.8", "ramp.h5")),
              "the second ramp's first step")
    states.append(manifest(res))
    # run 2: killed in the Fig. 5 runs, once a seeded random one of (a), (b), (c)
    # has written its file (runs (d), (e), (p) are still to come)
    run = random.Random(KILL_SEED).choice("abc")
    p = start(res, "--resume")
    kill_when(p, lambda: bool(manifest(res).get("instability"))
              and os.path.exists(os.path.join(res, f"perturb_{run}.h5")),
              f"Fig. 5 run ({run}) written")
    states.append(manifest(res))
    # the killed job's folder is moved (its log with it): the rest resumes there
    moved = str(base / "moved")
    os.rename(res, moved)
    os.rename(res + ".log", moved + ".log")
    res = moved
    # run 3: killed while the figures and the report are written
    p = start(res, "--resume")
    kill_when(p, lambda: bool(manifest(res).get("normal_form")), "the figures")
    states.append(manifest(res))
    # run 4: finishes (the normal form redone: its file is gone)
    os.remove(os.path.join(res, "normal_form.h5"))
    last = finish(res, "--resume")
    t_res = time.perf_counter() - t0
    out, err = ref_run.communicate(timeout=600)     # no paper.json: a new job
    assert ref_run.returncode == 0, out[-3000:] + err[-3000:]
    ref_proc = subprocess.CompletedProcess(ref_run.args, 0, out, err)
    t_ref = time.perf_counter() - t0
    log = read(res + ".log")
    return {"ref": ref, "res": res, "states": states, "last": last, "log": log,
            "ref_proc": ref_proc, "fig5_run": run, "t_ref": t_ref, "t_res": t_res}


def test_fresh_start_with_resume_flag(jobs):
    """--resume in a folder without paper.json runs a new job: one session, not resumed."""
    m = manifest(jobs["ref"])
    assert m["status"] == "complete"
    assert [s["resume"] for s in m["sessions"]] == [False]
    assert "reusing" not in jobs["ref_proc"].stdout


def test_what_each_kill_left(jobs):
    s1, s2, s3 = jobs["states"]
    # 1: first ramp (and relax) persisted, second in progress in its ramp.h5
    assert s1["status"] == "running" and s1["relax"] and s1["ramps"][0]
    assert s1["ramps"][1] is None and not s1.get("instability")
    # 2: both ramps and Fig. 4 persisted, Fig. 5 not
    assert s2["ramps"][1] and s2["instability"] and not s2.get("perturb"), jobs["fig5_run"]
    assert s2["sessions"][-1]["reused"] == ["ramp0", "relax"]
    # 3: every phase persisted, report not finished
    assert s3["status"] == "running"
    assert all(s3.get(k) for k in ("relax", "instability", "perturb", "normal_form"))
    assert s3["sessions"][-1]["reused"] == ["instability", "ramp0", "ramp1", "relax"]
    final = manifest(jobs["res"])
    assert final["status"] == "complete" and len(final["sessions"]) == 4
    assert [s["resume"] for s in final["sessions"]] == [False, True, True, True]
    # the normal form's file was deleted: redone; the rest reused
    assert final["sessions"][-1]["reused"] == ["instability", "perturb", "ramp0", "ramp1",
                                               "relax"]
    log = jobs["log"] + jobs["last"].stdout
    assert "ramp mu = 0.8: dF_x = 0.002, bisection to 2e-05 (continuing ramp_mu0.8/ramp.h5)" \
        in log
    assert "ramp mu = 1: done earlier (paper.json)" in log
    assert "perturb: done earlier (paper.json)" in jobs["last"].stdout
    assert "normal form: A sqrt(eps)" in jobs["last"].stdout
    assert jobs["last"].stdout.strip().splitlines()[-1] == \
        f"report: {os.path.join(jobs['res'], 'report.md')}"


def test_resumed_report_equals_uninterrupted(jobs):
    ref, res = jobs["ref"], jobs["res"]
    a = json.loads(read(ref, "report.json"))
    b = json.loads(read(res, "report.json"))
    assert a["checks"] == b["checks"]            # measured values, verdicts, reasons: exact
    assert a["info"] == b["info"]
    ids = {c["id"] for c in a["checks"]}
    assert {"F_x_c_mu1", "F_x_c_ratio", "growth_rate_fig4", "msd_decades_fig5c"} <= ids

    def body(path):
        text = read(path, "report.md")
        return text[:text.find("## 8. Timings")] + text[text.find("## 9."):]

    assert body(ref) == body(res)
    assert "Resumed job (`--resume`): 4 sessions" in read(res, "report.md")


def test_resumed_results_bitwise(jobs):
    ref, res = jobs["ref"], jobs["res"]
    for mu in ("1", "0.8"):
        f = f"ramp_mu{mu}/ramp.h5"
        with h5py.File(os.path.join(ref, f)) as x, h5py.File(os.path.join(res, f)) as y:
            for k in ("F_x_c_low", "F_x_c_high", "status"):
                assert x.attrs[k] == y.attrs[k], (f, k)
            for k in ("steps/F_x", "steps/residual", "steps/growth_rate", "bisection/F_x"):
                np.testing.assert_array_equal(x[k][()], y[k][()], err_msg=f"{f} {k}")
    for f in ("instability.h5", "perturb_a.h5", "perturb_b.h5", "perturb_c.h5",
              "ramp_mu1/extend.h5"):
        with h5py.File(os.path.join(ref, f)) as x, h5py.File(os.path.join(res, f)) as y:
            for k in ("t", "D", "v_top", "mu", "F_x", "growth_rate"):
                if k in x:
                    np.testing.assert_array_equal(x[k][()], y[k][()], err_msg=f"{f} {k}")
    a, b = manifest(ref), manifest(res)
    for k in ("relax", "ramps", "instability", "perturb"):
        assert _numbers(a[k]) == _numbers(b[k]), k


def _numbers(d):
    """Numeric and boolean leaves of a summary (no wall times, no paths)."""
    if isinstance(d, dict):
        return {k: _numbers(v) for k, v in d.items() if not k.startswith("wall")
                and not isinstance(v, str)}
    if isinstance(d, list):
        return [_numbers(v) for v in d]
    return d


def test_resume_of_complete_job_changes_nothing(jobs):
    res = jobs["res"]
    before = snapshot(res)
    proc = finish(res, "--resume")
    assert "complete; nothing to do" in proc.stdout
    assert proc.stdout.strip().splitlines()[-1] == f"report: {os.path.join(res, 'report.md')}"
    assert snapshot(res) == before


def test_resume_with_other_configuration_refused(jobs):
    res = jobs["res"]
    before = snapshot(res)
    proc = subprocess.run([CLI, *JOB, "--seed", "2", "--out", res, "--resume"],
                          capture_output=True, text=True, env=ENV, timeout=120)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "seed = 1 in paper.json, seed = 2 now" in proc.stderr, proc.stderr
    assert "nothing was deleted" in proc.stderr
    assert snapshot(res) == before


def test_config_difference_names_every_key(tmp_path):
    """Unit level: load_manifest lists each differing key with both values; np is free."""
    from remote_trigger.pywrap.runtime.jobfolder import write_json

    cfg = build_config(None, {"seed": 3}, quick=True)
    out = tmp_path / "job"
    out.mkdir()
    write_json(str(out / "paper.json"), {"config": cfg.to_dict(), "out": str(out),
                                         "status": "running"})
    assert paper.load_manifest(str(out), build_config(None, {"seed": 3, "np": 2},
                                                      quick=True))["status"] == "running"
    with pytest.raises(ConfigError) as exc:
        paper.load_manifest(str(out), build_config(None, {"seed": 3, "dF_x": 1e-3}))
    msg = str(exc.value)
    assert "dF_x = 0.002 in paper.json, dF_x = 0.001 now" in msg
    assert "n = 40 in paper.json, n = 100 now" in msg and "quick = True" in msg
    # (it said "drop --resume to start over", which the job then refused too)
    assert msg.endswith("or give --overwrite in place of --resume to start over (nothing was "
                        "deleted)"), msg
    # the Fig. 5 load may change while Fig. 5 has not begun, not after
    for key, val in (("fig5_F_x", 0.01), ("fig5_window", 0.3)):
        assert paper.load_manifest(str(out), build_config(None, {"seed": 3, key: val},
                                                          quick=True))["status"] == "running"
    (out / "perturb").mkdir()
    with pytest.raises(ConfigError, match="fig5_F_x = None in paper.json, fig5_F_x = 0.01 now"):
        paper.load_manifest(str(out), build_config(None, {"seed": 3, "fig5_F_x": 0.01},
                                                   quick=True))
    (out / "perturb").rmdir()
    moved = tmp_path / "moved"
    os.rename(out, moved)
    # a moved folder: its manifest's paths are moved with it
    man = paper.load_manifest(str(moved), cfg)
    assert man["out"] == str(moved) and man["status"] == "running"
    assert paper.manifest.rebased({"h5": [str(out / "ramp_mu1" / "ramp.h5"), str(out) + "x"]},
                                  str(out), str(moved)) == \
        {"h5": [str(moved / "ramp_mu1" / "ramp.h5"), str(out) + "x"]}
    (moved / "paper.json").write_text("{not json")
    with pytest.raises(ConfigError, match="unreadable manifest .* run with --overwrite in place "
                                          "of --resume to start the job over"):
        paper.load_manifest(str(moved), cfg)
