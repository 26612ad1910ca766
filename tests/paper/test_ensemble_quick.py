"""``remote-trigger ensemble --quick``: serial and two ranks, resume, recorded failures.

What must hold (each can fail): serial and ``--np 2`` give the same table
(every column but the wall times); killed with SIGKILL after its first
packing, while another is half done, and resumed, it keeps the finished
packing and the other's finished stages and gives the same table again; a
packing whose relaxation fails is recorded with its reason while the others
finish; the I0 = 1 rows are flagged as inconsistent with the dynamics.
"""
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.ensemble import config as ec
from remote_trigger.pywrap.jobs.ensemble import job as en
from remote_trigger.pywrap.jobs.ensemble import report as er
from remote_trigger.pywrap.jobs.ensemble import task as et
from remote_trigger.pywrap.jobs.ensemble.status import ensemble_status
from remote_trigger.pywrap.runtime.environment import source

CLI = os.path.join(os.path.dirname(sys.executable), "remote-trigger")


def _run(args):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([CLI, "ensemble"] + args, capture_output=True, text=True, env=env,
                          timeout=900)


def _same(a, b):
    assert sorted(a) == sorted(b)
    for c in a:
        if c == "wall":
            continue
        if a[c].dtype.kind in "fi":
            assert np.array_equal(a[c], b[c], equal_nan=True), c
        else:
            assert list(a[c]) == list(b[c]), c


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("ens") / "serial")
    proc = _run(["--quick", "--out", out])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return out, proc, er.read_table(os.path.join(out, en.TABLE))


def test_outputs_and_rows(serial):
    out, proc, t = serial
    for f in ("ensemble.h5", "ensemble.md", "ensemble.json", "config.json"):
        assert os.path.isfile(os.path.join(out, f)), f
    with open(os.path.join(out, "ensemble.png"), "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    assert proc.stdout.strip().splitlines()[-1].startswith("ensemble: ")
    # 3 packings x (default I0 = 1/2, default I0 = 1, frictional)
    assert len(t["key"]) == 9
    assert list(t["key"][:3]) == ["N16_s1"] * 3
    assert set(t["protocol"]) == {"frictionless-then-friction", "frictional"}
    ft = (t["protocol"] == "frictionless-then-friction") & (t["I0"] == 0.5)
    assert ft.sum() == 3
    # certified brackets to tol at I0 = 1/2, mu_ss mu0 ramp too; ratio from the midpoints
    for i in np.flatnonzero(ft):
        assert t["status"][i] == "ok", t["reason"][i]
        assert 0 < t["F_x_c_high"][i] - t["F_x_c_low"][i] <= 2e-3 * (1 + 1e-12)
        assert 0 < t["F_x_c_ss_high"][i] - t["F_x_c_ss_low"][i] <= 2e-3 * (1 + 1e-12)
        mid = 0.5 * (t["F_x_c_low"][i] + t["F_x_c_high"][i])
        mid_ss = 0.5 * (t["F_x_c_ss_low"][i] + t["F_x_c_ss_high"][i])
        assert t["ratio"][i] == pytest.approx(mid_ss / mid, rel=1e-12)
        assert t["decision_at_zero"][i] == 0          # default protocol: real at F_x = 0
        assert 1 <= t["pair_index"][i] < t["n_dof"][i]
        assert 0 < t["pair_re_rel"][i] < 1
        # the pair's mode: a participation ratio in [1/N, 1], N PR particles
        assert 1 / t["n"][i] <= t["pair_pr"][i] <= 1
        assert t["pair_particles"][i] == pytest.approx(t["n"][i] * t["pair_pr"][i], rel=1e-12)
        assert 0 <= t["pair_longwave"][i] <= 1
        assert 0.5 < t["phi"][i] < 0.9
        # saddles counted: none left where every escape succeeded
        assert t["n_saddle"][i] >= 0 and t["n_escaped"][i] >= 0
        if "on a saddle" in t["reason"][i]:
            assert t["n_saddle"][i] > 0
    # I0 = 1 rows: flagged, same packings and phi
    one = t["I0"] == 1.0
    assert one.sum() == 3 and np.all(t["dynamics_consistent"][one] == 0)
    assert all("inconsistent with the dynamics" in r for r in t["reason"][one])
    assert np.array_equal(t["phi"][one], t["phi"][ft])
    # every failed row says why
    for s, r in zip(t["status"], t["reason"]):
        assert s in ("ok", "incomplete", "failed")
        if s == "failed":
            assert r
    # and the console's last line of the job counts the rows that are not ok
    done = next(x for x in proc.stdout.splitlines() if "done: 9 rows" in x)
    bad = {k: int((t["status"] == k).sum()) for k in ("failed", "incomplete")}
    if any(bad.values()):
        assert "rows not ok: " + ", ".join(f"{n} {k}" for k, n in sorted(bad.items()) if n) \
            + " (reasons in ensemble.md)" in done, done
    else:
        assert "not ok" not in done, done
    md = open(os.path.join(out, "ensemble.md")).read()
    for head in ("## F_x^c by size", "## N dependence", "hold for every packing",
                 "## The paper's bracket", "## Frictional relaxation", "## Packings",
                 "| long-wave fraction, abs(m) <= 3 | a random vector's, 7/N |"):
        assert head in md, head
    assert "analysis convention only" in md
    # the saddle counts of the default rows, summed per size
    sad = md.split("## Saddles")[1].split("##")[0]
    for n in (16, 20):
        rows = ft & (t["n"] == n)
        line = next(x for x in sad.splitlines() if x.startswith(f"| {n} |"))
        assert line == (f"| {n} | {rows.sum()} | {t['n_escaped'][rows].sum():.0f} | "
                        f"{t['n_saddle'][rows].sum():.0f} | "
                        f"{sum('on a saddle' in r for r in t['reason'][rows])} |")


def test_two_ranks_same_table(serial, tmp_path):
    _, _, t1 = serial
    out = str(tmp_path / "np2")
    # part_size: free ranks may join sliced points (the quick's are dense: the
    # helpers are handed out and sent away, and the table is the same)
    proc = _run(["--quick", "--np", "2", "--out", out, "--quiet", "--set", "part_size=60"])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with open(os.path.join(out, en.MANIFEST)) as fh:
        session = json.load(fh)["sessions"][-1]
    assert session["n_ranks"] == 2
    with open(os.path.join(out, "config.json")) as fh:
        assert json.load(fh)["part_size"] == 60
    import numpy
    _same(t1, er.read_table(os.path.join(out, en.TABLE)))
    # warnings of the analysis are recorded per packing, not printed by any rank
    assert "Warning" not in proc.stderr, proc.stderr[-2000:]
    for name in os.listdir(os.path.join(out, "tasks")):
        with open(os.path.join(out, "tasks", name)) as fh:
            result = json.load(fh)["result"]
        assert isinstance(result["warnings"], list), name
        # what the worker rank computed with: this environment's versions
        assert result["environment"]["packages"]["numpy"] == numpy.__version__, name
        assert result["environment"]["source"] == source(), name
        # and each stage what its own rank computed with (the two ramps were
        # tasks of their own here): commit, BLAS kernel set, CPU
        stages = [result["default"]] + list(result["default"]["ramps"].values())
        if result["frictional"] and not result["frictional"].get("error"):
            stages.append(result["frictional"])
        assert len(result["default"]["ramps"]) == 2, name
        for st in stages:
            env = st["environment"]
            assert env["source"] == source() and env["cpu"] == result["environment"]["cpu"]
            assert [b["architecture"] for b in env["blas"]] == \
                [b["architecture"] for b in result["environment"]["blas"]], name
    assert session["environment"]["packages"]["numpy"] == numpy.__version__


def _started(out):
    """(finished packings, {unfinished packing: its recorded ramp parts})."""
    tasks, packs = os.path.join(out, "tasks"), os.path.join(out, "packings")
    done = sorted(n[:-len(".json")] for n in os.listdir(tasks) if n.endswith(".json")) \
        if os.path.isdir(tasks) else []
    parts = {}
    for key in (os.listdir(packs) if os.path.isdir(packs) else []):
        try:
            with open(os.path.join(packs, key, et.PROGRESS)) as fh:
                ramps = json.load(fh)["ramps"]
        except (OSError, ValueError):
            continue
        if key not in done:
            parts[key] = sorted(ramps)
    return done, parts


def _job_pids(pid):
    """``pid`` and every process descended from it. A job re-launched under
    mpirun (``--np N``) has its ranks in sessions of their own (hydra's proxy
    calls setsid): ``killpg`` of the job's group reaches the re-launching
    process and mpiexec, and the ranks go on (writing into --out) until the
    proxy notices and kills them, measured 3-65 ms later."""
    children = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d))
    pids, todo = [], [pid]
    while todo:
        p = todo.pop()
        pids.append(p)
        todo.extend(children.get(p, ()))
    return pids


def _state(pid):
    """The state letter of ``pid`` (``T`` stopped, ``Z`` zombie), None once reaped."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return None


def _signal_all(pids, sig, until):
    for p in pids:
        try:
            os.kill(p, sig)
        except ProcessLookupError:
            pass
    t0 = time.monotonic()
    while not all(_state(p) in until for p in pids):
        assert time.monotonic() - t0 < 60, f"signal {sig} not taken by {pids} in 60 s"
        time.sleep(0.001)


def _kill_when(proc, ready, what, timeout=600):
    """SIGKILL every process of the job ``proc`` in a state where ``ready()`` holds.

    ``ready()`` is polled; once it holds, the whole job is stopped (SIGSTOP,
    each process until it is stopped), ``ready()`` is asked again of the
    frozen folder and the job is killed if it still holds (else continued):
    nothing is written between the state checked and the kill. Returns that
    value of ``ready()`` once every process of the job is dead (a zombie
    holds no file and no lock)."""
    t0 = time.monotonic()
    while True:
        assert proc.poll() is None, f"finished before {what}"
        assert time.monotonic() - t0 < timeout, f"no {what} in {timeout} s"
        if ready():
            pids = _job_pids(proc.pid)
            _signal_all(pids, signal.SIGSTOP, ("T", "Z", None))
            new = [p for p in _job_pids(proc.pid) if p not in pids]
            _signal_all(new, signal.SIGSTOP, ("T", "Z", None))   # started meanwhile
            pids += new
            value = ready()
            if value:
                _signal_all(pids, signal.SIGKILL, ("Z", None))
                return value
            _signal_all(pids, signal.SIGCONT, ("R", "S", "D", "Z", None))
        time.sleep(0.02)


def _mu0_recorded(out):
    """(finished packings, packings with the mu0 ramp part recorded but no result)."""
    done, parts = _started(out)
    return done, [k for k, r in parts.items() if "mu0" in r]


def test_killed_and_resumed_gives_the_same_table(serial, tmp_path):
    """kill -9 once a packing is finished and another has recorded its first
    ramp part; the folder is then moved: --resume there keeps the finished
    packing, continues the other from its recorded stages (its relaxation is
    not redone; the records name files relative to the packing's folder and
    its ramp.h5's), runs the rest and gives the serial run's table."""
    _, _, t1 = serial
    out = str(tmp_path / "killed")
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([CLI, "ensemble", "--quick", "--out", out], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        _kill_when(proc, lambda: all(_mu0_recorded(out)),
                   "a finished packing and another with its mu0 ramp recorded")
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    tasks = os.path.join(out, "tasks")
    kept, mid = _mu0_recorded(out)
    assert 0 < len(kept) < len(set(t1["key"])) and mid, (kept, mid)
    assert not [n for n in os.listdir(tasks) if n.endswith(".claim")]   # MPI hands out tasks
    with open(os.path.join(out, "packings", mid[0], et.PROGRESS)) as fh:
        progress = json.load(fh)
    assert not os.path.isabs(progress["relax"]["datafile"])
    assert not os.path.isabs(progress["ramps"]["mu0"]["h5"])
    moved = str(tmp_path / "moved")
    os.rename(out, moved)
    out, tasks = moved, os.path.join(moved, "tasks")
    relaxed = os.path.join(out, "packings", mid[0], "default", "relax.h5")
    stamp = os.stat(relaxed).st_mtime_ns
    r = _run(["--quick", "--out", out])                         # no --resume: refused
    assert r.returncode == 2 and "--resume" in r.stderr
    r = _run(["--quick", "--out", out, "--set", "tol=0.001", "--resume"])
    assert r.returncode == 2 and "tol = 0.002 (then) vs 0.001 (now)" in r.stderr
    r = _run(["--quick", "--out", out, "--resume"])
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    with open(os.path.join(out, en.MANIFEST)) as fh:
        man = json.load(fh)
    everything = sorted(set(t1["key"]))
    assert man["sessions"][-1]["computed"] == [k for k in everything if k not in kept]
    assert man["sessions"][-1]["resume"] is True
    assert not [n for n in os.listdir(tasks) if n.endswith(".claim")]
    assert os.stat(relaxed).st_mtime_ns == stamp, "the recorded relaxation was redone"
    _same(t1, er.read_table(os.path.join(out, en.TABLE)))


def _one_ramp_recorded(out):
    """Packings with exactly one ramp part recorded and no result yet."""
    return [k for k, r in _started(out)[1].items() if len(r) == 1]


def test_two_ranks_ramps_apart_killed_and_resumed(serial, tmp_path):
    """On two worker ranks a relaxed packing's ramps are two tasks: kill -9 once
    one ramp part of a packing is recorded and the other is not; --resume on two
    ranks keeps the recorded part and the relaxation and gives the serial table."""
    _, _, t1 = serial
    out = str(tmp_path / "apart")
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([CLI, "ensemble", "--quick", "--np", "2", "--out", out], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            start_new_session=True, text=True)
    try:
        mid = _kill_when(proc, lambda: _one_ramp_recorded(out), "a ramp part recorded")
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout = proc.communicate()[0]
    assert "its ramps mu0, mu_ss as tasks of their own" in stdout, stdout
    relaxed = os.path.join(out, "packings", mid[0], "default", "relax.h5")
    stamp = os.stat(relaxed).st_mtime_ns
    with open(os.path.join(out, "packings", mid[0], et.PROGRESS)) as fh:
        (recorded, part), = json.load(fh)["ramps"].items()
    r = _run(["--quick", "--np", "2", "--out", out, "--resume"])
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert os.stat(relaxed).st_mtime_ns == stamp, "the recorded relaxation was redone"
    with open(et.task_path(out, mid[0])) as fh:
        assert json.load(fh)["result"]["default"]["ramps"][recorded] == part
    _same(t1, er.read_table(os.path.join(out, en.TABLE)))


def test_failure_is_recorded_and_others_finish(tmp_path, monkeypatch):
    from mpi4py import MPI
    from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError

    real = et._relax

    def relax(cfg, datafile, folder, protocol):
        if "N16_s2" in folder and protocol != "frictional":
            raise NoEquilibriumError("top layer slid away (forced by the test)")
        return real(cfg, datafile, folder, protocol)

    monkeypatch.setattr(et, "_relax", relax)
    cfg = ec.build_config(None, {"n": [16], "seeds": [1, 2], "inertia_I0": None}, quick=True)
    out = str(tmp_path / "fail")
    en.run_ensemble(cfg, out, comm=MPI.COMM_SELF, speak=False)
    t = er.read_table(os.path.join(out, en.TABLE))
    assert list(t["key"]) == ["N16_s1", "N16_s1", "N16_s2", "N16_s2"]
    bad = (t["key"] == "N16_s2") & (t["protocol"] == "frictionless-then-friction")
    assert t["status"][bad][0] == "failed"
    assert "NoEquilibriumError: top layer slid away" in t["reason"][bad][0]
    assert math.isnan(t["F_x_c_low"][bad][0])
    good = (t["key"] == "N16_s1") & (t["protocol"] == "frictionless-then-friction")
    assert t["status"][good][0] == "ok" and t["F_x_c_low"][good][0] > 0
    # the frictional protocol of the failed packing still ran
    fr = (t["key"] == "N16_s2") & (t["protocol"] == "frictional")
    assert t["status"][fr][0] == "ok"
    md = open(os.path.join(out, "ensemble.md")).read()
    assert "top layer slid away" in md


def test_a_packing_failed_in_a_ramp_keeps_its_equilibria_and_can_be_continued(tmp_path,
                                                                              monkeypatch):
    """A packing whose 0.8 mu0 ramp fails part-way (an OSError after 3
    equilibria, forced) is recorded with that reason and keeps that ramp's
    equilibria; ``resume`` alone leaves it as it is; ``resume`` with
    ``retry_failed`` (or with its task file removed) continues the ramp from
    its ``ramp.h5`` to the table of a run that never failed."""
    from mpi4py import MPI
    from remote_trigger.pywrap import stages

    cfg = ec.build_config(None, {"n": [16], "seeds": [1], "inertia_I0": None,
                                 "frictional": False}, quick=True)
    ref = str(tmp_path / "ref")
    en.run_ensemble(cfg, ref, comm=MPI.COMM_SELF, speak=False)
    real = stages.ramp

    def ramp(rcfg, out, **kw):
        if out.endswith("ramp_mu_ss"):
            real(rcfg, out, stop_after=3, **kw)
            raise OSError("the scratch disk went away (forced by the test)")
        return real(rcfg, out, **kw)

    monkeypatch.setattr(stages, "ramp", ramp)
    out = str(tmp_path / "failed")
    en.run_ensemble(cfg, out, comm=MPI.COMM_SELF, speak=False)
    t = er.read_table(os.path.join(out, en.TABLE))
    assert t["status"][0] == "incomplete" and "scratch disk went away" in t["reason"][0]
    kept = os.listdir(os.path.join(out, "packings", "N16_s1", "ramp_mu_ss", "ramp"))
    assert sum(f.endswith(".data") for f in kept) >= 1, kept
    monkeypatch.undo()
    retry = str(tmp_path / "retry")
    shutil.copytree(out, retry)
    os.remove(et.task_path(out, "N16_s1"))
    en.run_ensemble(cfg, out, comm=MPI.COMM_SELF, speak=False, resume=True)
    _same(er.read_table(os.path.join(ref, en.TABLE)), er.read_table(os.path.join(out, en.TABLE)))
    # the same without removing the task file: --resume keeps the failure,
    # --resume --retry-failed continues it
    en.run_ensemble(cfg, retry, comm=MPI.COMM_SELF, speak=False, resume=True)
    assert er.read_table(os.path.join(retry, en.TABLE))["status"][0] == "incomplete"
    line, = [s for s in ensemble_status(retry) if s.startswith("N16_s1:")]
    assert "scratch disk went away" in line and "--retry-failed" in line
    with pytest.raises(ConfigError, match="resume"):
        en.run_ensemble(cfg, retry, comm=MPI.COMM_SELF, speak=False, retry_failed=True)
    en.run_ensemble(cfg, retry, comm=MPI.COMM_SELF, speak=False, resume=True,
                    retry_failed=True)
    _same(er.read_table(os.path.join(ref, en.TABLE)),
          er.read_table(os.path.join(retry, en.TABLE)))
    with open(os.path.join(retry, en.MANIFEST)) as fh:
        sessions = json.load(fh)["sessions"]
    assert [(s["computed"], s["retry_failed"]) for s in sessions] == \
        [(["N16_s1"], False), ([], False), (["N16_s1"], True)]
    r = subprocess.run([sys.executable, "-m", "remote_trigger.pywrap.cli", "ensemble",
                        "--quick", "--out", retry, "--retry-failed"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "give --resume too" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_adaptive_ramps_and_continuation(tmp_path):
    """``dF_x_max``: the ramps take adaptive steps (some larger than dF_x, none
    outside [dF_x, dF_x_max]) and the I0 = 1 continuation above the ramp's end (it
    is needed for this packing: its I0 = 1 onset lies above the I0 = 1/2 one) runs
    with the same rule and brackets the onset."""
    from remote_trigger.pywrap.runtime.results import read_all

    out = str(tmp_path / "adaptive")
    proc = _run(["--quick", "--out", out, "--set", "n=[16]", "--set", "seeds=[4]",
                 "--set", "dF_x_max=0.05", "--set", "keep_equilibria=true", "--quiet"])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    t = er.read_table(os.path.join(out, en.TABLE))
    rows = {(t["protocol"][i], float(t["I0"][i])): i for i in range(len(t["key"]))}
    half, one = rows["frictionless-then-friction", 0.5], rows["frictionless-then-friction", 1.0]
    assert t["status"][half] == "ok" and t["status"][one] == "ok", list(t["reason"])
    folder = os.path.join(out, "packings", "N16_s4", "ramp_mu0")
    _, d = read_all(os.path.join(folder, "ramp.h5"))
    h = np.diff(d["steps/F_x"])
    assert np.all(h >= 1e-2 * (1 - 1e-12)) and np.all(h <= 0.05 * (1 + 1e-12))
    assert h.max() > 1e-2 * (1 + 1e-6)
    ext = sorted(f for f in os.listdir(os.path.join(folder, "I0_1"))
                 if f.startswith("ext_") and f.endswith(".dump.json"))
    assert ext and t["F_x_c_low"][one] > d["steps/F_x"][-1]
    loads = [d["steps/F_x"][-1]]
    for f in ext:
        with open(os.path.join(folder, "I0_1", f)) as fh:
            loads.append(json.load(fh)["F_x"])
    step = np.diff(loads)
    assert np.all(step >= 1e-2 * (1 - 1e-12)) and np.all(step <= 0.05 * (1 + 1e-12))



def test_packing_without_memory_for_the_verdict_is_recorded_and_others_finish(tmp_path,
                                                                              monkeypatch):
    """A packing whose dense verdict would not fit in memory (here: a limit
    set between the two sizes' needs) ends with status 'failed' and the
    reason naming its order n and the memory available; the smaller packing
    finishes. (The frictional-protocol rows are not asserted: at N = 40 that
    relaxation fails on its own in the quick setting.)"""
    from mpi4py import MPI
    from remote_trigger.analysis.stability import verdict

    need = {n: verdict.DENSE_PEAK_MATRICES * 8 * (3 * n) ** 2 for n in (16, 40)}
    monkeypatch.setenv(verdict.MEMORY_ENV, repr((need[16] + need[40]) / 2 / 2**30))
    cfg = ec.build_config(None, {"n": [16, 40], "seeds": [1], "inertia_I0": None}, quick=True)
    out = str(tmp_path / "mem")
    en.run_ensemble(cfg, out, comm=MPI.COMM_SELF, speak=False)
    t = er.read_table(os.path.join(out, en.TABLE))
    main = t["protocol"] == "frictionless-then-friction"
    big, small = main & (t["key"] == "N40_s1"), main & (t["key"] == "N16_s1")
    assert big.sum() == 1 and small.sum() == 1
    assert t["status"][big][0] == "failed" and math.isnan(t["F_x_c_low"][big][0])
    reason = t["reason"][big][0]
    assert "TooLargeError" in reason and "dense verdict for n = " in reason, reason
    assert "available" in reason, reason
    assert t["status"][small][0] == "ok" and t["F_x_c_low"][small][0] > 0


def test_a_part_recorded_without_the_pair_shape_is_completed_on_resume(serial):
    """A ramp part recorded by a version without ``pair_pr`` (a resumed run of an
    older version) gets its onset numbers again from its ramp.h5, the same as
    recorded, and the pair's shape (NaN here: the quick run keeps no equilibria)."""
    out, _, _ = serial
    cfg = ec.build_config(quick=True)
    key = f"I0_{cfg.I0_dynamics:g}"
    folder = os.path.join(out, "packings", "N16_s1")
    with open(os.path.join(folder, et.PROGRESS)) as fh:
        part = json.load(fh)["ramps"]["mu0"]
    assert not et._shape_missing(cfg, part)
    old = dict(part, **{key: {k: v for k, v in part[key].items()
                              if k not in ("pair_pr", "pair_particles", "pair_longwave")}})
    assert et._shape_missing(cfg, old)
    new = et._with_shape(cfg, old, folder)
    assert not et._shape_missing(cfg, new)
    for k, v in old[key].items():
        assert new[key][k] == v or (v != v and new[key][k] != new[key][k]), k
    assert math.isnan(new[key]["pair_pr"]) and math.isnan(new[key]["pair_particles"])
    assert math.isnan(new[key]["pair_longwave"])
    gone = et._with_shape(cfg, dict(old, h5=os.path.join(out, "no.h5")), folder)
    assert math.isnan(gone[key]["pair_pr"])
    # recorded before the long-wave fraction: the measured numbers are kept
    # where the equilibria are gone (ramp.h5 there or not)
    assert math.isfinite(part[key]["pair_pr"]) and math.isfinite(part[key]["pair_particles"])
    older = dict(part, **{key: {k: v for k, v in part[key].items() if k != "pair_longwave"}})
    assert et._shape_missing(cfg, older)
    for h5 in (part["h5"], os.path.join(out, "no.h5")):
        got = et._with_shape(cfg, dict(older, h5=h5), folder)[key]
        assert got["pair_pr"] == part[key]["pair_pr"], h5
        assert got["pair_particles"] == part[key]["pair_particles"], h5
        assert math.isnan(got["pair_longwave"]), h5


def _killed_scan(folder):
    """A sliced verdict's scan (n = 80, a symmetric chain: real) saved in
    ``folder`` after each slice and killed in its third; the progress counts."""
    import scipy.sparse as sp
    from remote_trigger.analysis.stability.sliced import classify_sliced

    n = 80
    K = sp.diags([np.full(n - 1, -1.0), np.linspace(3.0, 90.0, n), np.full(n - 1, -1.0)],
                 [-1, 0, 1]).tocsr()
    seen = []

    class Killed(Exception):
        pass

    def kill(done, _):
        seen.append(done)
        if len(seen) == 3:
            raise Killed

    with pytest.raises(Killed):
        classify_sliced(K, np.ones(n), slice_size=20, progress=kill, checkpoint_dir=folder,
                        checkpoint_seconds=0)
    return seen


def _unfinished(serial, tmp_path):
    """A copy of the finished quick run whose first packing has no result
    file; returns (copy, that packing's key, its folder)."""
    import shutil

    out, _, _ = serial
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    key = ec.build_config(quick=True).packings()[0]["key"]
    os.remove(et.task_path(str(copy), key))
    return copy, key, copy / "packings" / key


def _status_line(copy, key):
    """``ensemble --status``'s line of packing ``key``, with the folder's lock
    held as by the job still running in it."""
    from remote_trigger.pywrap.runtime.outlock import lock_output_folder

    fd = lock_output_folder(str(copy))
    try:
        proc = subprocess.run([CLI, "ensemble", "--status", "--out", str(copy)],
                              capture_output=True, text=True, timeout=300)
    finally:
        os.close(fd)
    assert proc.returncode == 0, proc.stderr
    return next(x for x in proc.stdout.splitlines() if x.startswith(f"{key}: "))


def test_status_of_a_relaxing_packing_says_since_when(serial, tmp_path):
    """A packing with its generated file and no relaxed state yet is
    ``relaxing`` since that file's time."""
    import time

    copy, key, folder = _unfinished(serial, tmp_path)
    os.remove(folder / et.PROGRESS)
    stamp = time.time() - 3570          # "60 min" for the next minute
    os.utime(folder / "packing.data", (stamp, stamp))
    when = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(stamp))
    line = _status_line(copy, key)
    assert line == f"{key}: relaxing since {when} (60 min)", line


def test_status_of_a_ramp_before_its_first_point(serial, tmp_path):
    """A ramp whose folder exists and whose ramp.h5 does not yet (its first
    point is being computed: at N = 10^4 for half an hour) is running, not
    'not started'."""
    import shutil

    copy, key, folder = _unfinished(serial, tmp_path)
    prog = json.loads((folder / et.PROGRESS).read_text())
    prog["ramps"] = {}
    (folder / et.PROGRESS).write_text(json.dumps(prog))
    os.remove(folder / "ramp_mu0" / "ramp.h5")
    shutil.rmtree(folder / "ramp_mu_ss")
    line = _status_line(copy, key)
    assert "mu0 running, no point recorded yet; mu_ss not started" in line, line


def test_status_reads_how_far_each_packing_has_come(serial, tmp_path):
    """``ensemble --status`` on a copy of the finished run made to look
    interrupted: a finished packing with its bracket, a packing whose mu0
    ramp is recorded and whose mu_ss ramp is running (its points so far and
    the bracket they give: the finished one) and whose point's sliced
    verdict was killed after a save (its count then), a packing not started;
    the folder is left as it was; a folder that is no ensemble is refused."""
    import shutil

    out, _, t = serial
    cfg = ec.build_config(quick=True)
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    keys = [p["key"] for p in cfg.packings()]
    done, running, absent = keys
    os.remove(et.task_path(str(copy), running))
    os.remove(et.task_path(str(copy), absent))
    shutil.rmtree(copy / "packings" / absent)
    prog_file = copy / "packings" / running / et.PROGRESS
    prog = json.loads(prog_file.read_text())
    del prog["ramps"]["mu_ss"]
    prog_file.write_text(json.dumps(prog))
    # the running point's sliced verdict, killed after its third slice (saved after the second)
    seen = _killed_scan(copy / "packings" / running / "verdicts")
    # and one of a ramp run as a task of its own (its own folder)
    seen_ss = _killed_scan(copy / "packings" / running / "verdicts" / "mu_ss")
    before = sorted(str(p) for p in copy.rglob("*"))
    proc = subprocess.run([CLI, "ensemble", "--status", "--out", str(copy)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[0] == f"ensemble {copy}: 3 packing(s), 1 finished, 1 started, 1 not started"
    ft = (t["protocol"] == "frictionless-then-friction") & (t["I0"] == cfg.I0_dynamics)

    def bracket(key, col="F_x_c"):
        i = int(np.flatnonzero(ft & (t["key"] == key))[0])
        return f"[{t[col + '_low'][i]:.6g}, {t[col + '_high'][i]:.6g}]"

    assert lines[1] == f"{done}: finished, F_x^c(mu0) in {bracket(done)}"
    assert lines[2].startswith(f"{running}: relaxed (phi ")
    assert f"mu0 complete, F_x^c in {bracket(running)}" in lines[2]
    assert ("mu_ss running: " in lines[2]
            and f" point(s), F_x^c in {bracket(running, 'F_x_c_ss')}" in lines[2]), lines[2]
    assert lines[3] == f"{absent}: not started"
    assert lines[2].endswith(")") and (
        f"; a point's verdict in progress: {seen[1]}/80 eigenvalues at its last save ("
        in lines[2]), lines[2]
    assert (f"; a point's verdict in progress (mu_ss): {seen_ss[1]}/80 eigenvalues at its "
            "last save (" in lines[2]), lines[2]
    assert sorted(str(p) for p in copy.rglob("*")) == before
    proc = subprocess.run([CLI, "ensemble", "--status", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0 and "--status" in proc.stderr and "no config.json" in proc.stderr
