"""kill -9 at random moments: every result file stays readable, a ramp resumes exactly.

Issue requirement: "A ramp killed with kill -9 at random moments (several
trials) resumes and produces the same F_x^c and eigenvalues as an
uninterrupted run, and no HDF5 file is left unreadable."

* The reference is an uninterrupted ``remote-trigger ramp`` (the command
  line, which pins BLAS to one thread, as the trials do; an in-process ramp
  could differ in the last bits through a threaded BLAS).
* A trial is a chain: start the ramp, SIGKILL it at a moment drawn
  uniformly over the reference's wall time, check every ``*.h5`` under the
  output folder with a plain ``h5py.File(path, 'r')`` and :func:`read_all`
  (``ramp.h5``, if present, has ``status = 'running'``, or ``'complete'``
  if the kill came after its last write, while the process was exiting),
  continue with ``--resume`` (killed again, up to ``MAX_KILLS`` times),
  until it completes; then ``ramp.h5`` must equal the reference: F_x^c
  bracket (``==``), every eigenvalue set and every column except wall
  times bitwise. Trial 0 is first killed as soon as ``out/ramp/`` exists,
  before ``ramp.h5`` is written: ``--resume`` must then simply start.
* The undamped runs (``perturb``) and :class:`SeriesWriter` itself are
  killed likewise; their files must open, with ``status = 'running'`` for
  the run in progress and t a prefix of the record times.

Random moments come from ``numpy.random.default_rng([seed, trial])``; the
seed is ``RT_KILL_SEED`` if set, else taken from the clock, and is in every
assertion message: ``RT_KILL_SEED=<seed> pytest tests/driver/test_kill.py``
replays the same moments (up to the machine's timing).

The helpers (:func:`ramp_chain`, :func:`check_files`, :func:`compare_ramp`)
take no pytest fixtures; ``benchmarks/bench_kill.py`` runs more trials with
them.
"""
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from remote_trigger.pywrap.runtime.results import SeriesWriter, read_all, write_atomic

BIN = os.path.dirname(sys.executable)
CLI = os.path.join(BIN, "remote-trigger")

#: ramp of the N = 20 packing: ~100 steps + ~11 bisections, ~4 s on the CLI
DF = 0.002
TOL = 1e-6
N_TRIALS = 3
MAX_KILLS = 3           # per trial; then the chain runs to completion
TIMEOUT = 300.0         # any single process (a hung run fails the test)

SEED = int(os.environ.get("RT_KILL_SEED", time.time_ns() % 2**31))

#: ramp.h5 columns that must be bitwise equal after resuming (not wall times)
EXACT = ("F_x", "residual", "complex", "decision", "confidence", "growth_rate",
         "max_imag", "n_rattlers", "damped_time", "newton_steps")


def cli_env():
    """Environment of the command-line runs: one OpenMP/BLAS thread."""
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(var, "1")
    return env


def ramp_args(datafile, out, dF_x=DF, tol=TOL):
    return [CLI, "ramp", "--datafile", str(datafile), "--out", str(out),
            "--dF-x", repr(dF_x), "--tol", repr(tol), "--quiet"]


def _start(args, errfile):
    with open(errfile, "ab") as err:
        # own process group, so that the kill reaches anything it may spawn
        return subprocess.Popen(args, env=cli_env(), stdout=subprocess.DEVNULL,
                                stderr=err, start_new_session=True)


def _kill(proc):
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def check_files(out, ctx=""):
    """Open every ``*.h5`` under ``out`` with plain h5py and :func:`read_all`.

    Returns ``{relative path: attrs}``; raises AssertionError naming the
    file if one cannot be read.
    """
    import h5py

    found = {}
    for p in sorted(Path(out).rglob("*.h5")):
        try:
            with h5py.File(p, "r") as fh:
                fh.visit(lambda name: None)
            attrs, _ = read_all(str(p))
        except Exception as exc:          # noqa: BLE001 - any failure is the bug
            raise AssertionError(f"{ctx}: {p} is unreadable after kill -9: "
                                 f"{type(exc).__name__}: {exc}") from None
        found[str(p.relative_to(out))] = attrs
    return found


def run_reference(datafile, out, errfile=None, dF_x=DF, tol=TOL):
    """Uninterrupted CLI ramp; returns ``(wall seconds, attrs, data)``."""
    errfile = errfile or str(out) + ".stderr"
    t0 = time.monotonic()
    proc = _start(ramp_args(datafile, out, dF_x, tol), errfile)
    rc = proc.wait(timeout=TIMEOUT)
    wall = time.monotonic() - t0
    assert rc == 0, f"reference ramp failed ({rc}): {Path(errfile).read_text()}"
    attrs, data = read_all(os.path.join(str(out), "ramp.h5"))
    return wall, attrs, data


def ramp_chain(datafile, out, rng, expected, max_kills=MAX_KILLS, first_kill_early=False,
               ctx="", dF_x=DF, tol=TOL):
    """Start a CLI ramp, kill -9 it at random moments, resume until it completes.

    Parameters
    ----------
    datafile, out : str
    rng : numpy.random.Generator
        Draws every kill moment, uniform on [0, expected) seconds after the
        start of that process.
    expected : float
        Wall time of an uninterrupted run (s).
    max_kills : int
        Kills per chain; the run after the last one is not killed.
    first_kill_early : bool
        Kill the first run as soon as ``out/ramp/`` exists, before
        ``ramp.h5`` is written (no random draw for that kill).
    dF_x, tol : float
        The ramp's options (default the N = 20 ramp's).

    Returns
    -------
    dict
        ``kills`` (list of ``(moment s, ramp.h5 existed, its status, number
        of ramp.h5 steps + bisections)``), ``runs``, ``resumes``,
        ``files_checked``, ``wall``.
    """
    errfile = os.path.join(str(out) + ".stderr")
    os.makedirs(out, exist_ok=True)
    h5 = Path(out) / "ramp.h5"
    kills, runs, checked = [], 0, 0
    t_chain = time.monotonic()
    while True:
        args = ramp_args(datafile, out, dF_x, tol) + (["--resume"] if runs else [])
        t0 = time.monotonic()
        proc = _start(args, errfile)
        runs += 1
        killed = False
        if len(kills) < max_kills:
            if first_kill_early and not kills:
                while proc.poll() is None and not (Path(out) / "ramp").is_dir():
                    if time.monotonic() - t0 > TIMEOUT:
                        break
                    time.sleep(0.001)
                killed = proc.poll() is None
            else:
                moment = float(rng.uniform(0.0, expected))
                try:
                    proc.wait(timeout=moment)
                except subprocess.TimeoutExpired:
                    killed = True
            if killed:
                _kill(proc)
                moment = time.monotonic() - t0
                attrs = check_files(out, f"{ctx}, kill {len(kills) + 1} at {moment:.3f} s")
                checked += len(attrs)
                status, nrows = None, 0
                if h5.exists():
                    a = attrs["ramp.h5"]
                    status = a["status"]
                    # 'complete': killed after the final write, while exiting;
                    # --resume then returns at once (compared at the end)
                    assert status in ("running", "complete"), (
                        f"{ctx}: ramp.h5 has status {status!r} after kill -9 at "
                        f"{moment:.3f} s")
                    _, d = read_all(str(h5))
                    nrows = len(d["steps/F_x"]) + len(d["bisection/F_x"])
                kills.append((moment, h5.exists(), status, nrows))
                continue
        rc = proc.wait(timeout=TIMEOUT)
        assert rc == 0, (f"{ctx}: run {runs} ended with {rc} after kills at "
                         f"{[round(k[0], 3) for k in kills]}: {Path(errfile).read_text()}")
        break
    checked += len(check_files(out, f"{ctx}, after completion"))
    return {"kills": kills, "runs": runs, "resumes": runs - 1, "files_checked": checked,
            "wall": time.monotonic() - t_chain}


def _bits(a):
    a = np.asarray(a)
    return a.dtype.str, a.shape, a.tobytes() if a.dtype.kind != "O" else tuple(a)


def compare_ramp(ref, path, ctx=""):
    """Return a list of differences between ``ramp.h5`` at ``path`` and ``ref``.

    ``ref`` is ``(attrs, data)`` of the reference. Compared exactly: status,
    F_x^c bracket (``==``), the set of datasets, every eigenvalue set and
    every column of :data:`EXACT` bitwise, data file names (the folder
    differs).
    """
    ra, rd = ref
    attrs, data = read_all(str(path))
    diff = []
    for k in ("status", "F_x_c_low", "F_x_c_high"):
        if not attrs.get(k) == ra.get(k):
            diff.append(f"{k}: {attrs.get(k)!r} != reference {ra.get(k)!r}")
    if set(data) != set(rd):
        diff.append(f"datasets differ: only here {sorted(set(data) - set(rd))}, only "
                    f"in the reference {sorted(set(rd) - set(data))}")
    neig = 0
    for name in sorted(set(data) & set(rd)):
        kind, _, col = name.rpartition("/")
        if name.startswith("eigenvalues/") or col in EXACT:
            neig += name.startswith("eigenvalues/")
            if _bits(data[name]) != _bits(rd[name]):
                diff.append(f"{name} differs bitwise")
        elif col == "datafile":
            if [os.path.basename(s) for s in data[name]] != \
                    [os.path.basename(s) for s in rd[name]]:
                diff.append(f"{name} differs")
    if neig == 0:
        diff.append("no eigenvalue datasets")
    return diff


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def reference(relaxed, tmp_path_factory):
    out = tmp_path_factory.mktemp("kill_ref") / "out"
    wall, attrs, data = run_reference(relaxed.datafile, out)
    assert attrs["status"] == "complete"
    return wall, (attrs, data), out / "ramp.h5"


# --------------------------------------------------------------------------- ramp
@pytest.mark.parametrize("trial", range(N_TRIALS))
def test_ramp_killed_at_random_moments_resumes_bitwise(reference, relaxed, tmp_path, trial):
    wall, ref, _ = reference
    ctx = f"RT_KILL_SEED={SEED} trial {trial}"
    rng = np.random.default_rng([SEED, trial])
    out = tmp_path / "out"
    chain = ramp_chain(relaxed.datafile, out, rng, wall, first_kill_early=(trial == 0),
                       ctx=ctx)
    print(f"{ctx}: reference {wall:.2f} s; kills {chain['kills']}; "
          f"{chain['resumes']} resumes; {chain['wall']:.2f} s")
    if trial == 0:
        # killed before ramp.h5 existed: --resume just started the ramp
        assert chain["kills"] and chain["kills"][0][1] is False, (ctx, chain["kills"])
    diff = compare_ramp(ref, out / "ramp.h5", ctx)
    assert not diff, f"{ctx}, kills {chain['kills']}: " + "; ".join(diff)


def test_compare_ramp_sees_one_bit(reference, tmp_path):
    """The comparison of the trials is bitwise: one flipped bit is reported."""
    import shutil
    import h5py

    _, ref, path = reference
    assert compare_ramp(ref, path) == []
    copy = tmp_path / "ramp.h5"
    shutil.copyfile(path, copy)
    with h5py.File(copy, "a") as fh:
        name = sorted(k for k in fh["eigenvalues/bisection"])[-1]
        ds = fh[f"eigenvalues/bisection/{name}"]
        v = ds[()]
        v.view(np.uint64)[-1] ^= 1
        ds[...] = v
    assert compare_ramp(ref, copy) == [f"eigenvalues/bisection/{name} differs bitwise"]


# --------------------------------------------------------------------------- undamped runs
def test_perturb_killed_leaves_readable_series(relaxed, tmp_path):
    """kill -9 during ``perturb``: the series files open, t is a prefix of the records."""
    rng = np.random.default_rng([SEED, 100])
    out = tmp_path / "out"
    args = [CLI, "perturb", "--datafile", relaxed.datafile, "--F-x", "0.1", "--override",
            "--out", str(out), "--t-max", "300", "--runs", "abc", "--quiet"]
    err = tmp_path / "stderr"
    proc = _start(args, err)
    first = out / "perturb_a.h5"
    t0 = time.monotonic()
    while proc.poll() is None and not first.exists() and time.monotonic() - t0 < TIMEOUT:
        time.sleep(0.005)
    assert first.exists(), err.read_text()
    delay = float(rng.uniform(0.0, 7.0))     # a run takes ~3.5 s here; checkpoints 2 s
    ctx = f"RT_KILL_SEED={SEED}: perturb killed {delay:.3f} s after perturb_a.h5 appeared"
    try:
        proc.wait(timeout=delay)
        killed = False
    except subprocess.TimeoutExpired:
        _kill(proc)
        killed = True
    attrs = check_files(out, ctx)
    print(ctx, "(killed)" if killed else "(finished first)",
          {k: (a["status"], read_all(str(out / k))[1]["t"].size) for k, a in attrs.items()})
    names = [f"perturb_{r}.h5" for r in "abc" if f"perturb_{r}.h5" in attrs]
    assert names and names == [f"perturb_{r}.h5" for r in "abc"[:len(names)]], (ctx, attrs)
    step = 100 * 1e-3                        # record_every * dt (defaults)
    for i, name in enumerate(names):
        status = attrs[name]["status"]
        _, d = read_all(str(out / name))
        t = d["t"]
        assert all(d[c].shape == t.shape for c in ("D", "v_top", "mu")), ctx
        assert np.all(np.diff(t) > 0), f"{ctx}: {name}: t not increasing"
        np.testing.assert_allclose(t, step * np.arange(t.size), rtol=1e-12, atol=0,
                                   err_msg=f"{ctx}: {name}")
        # finished runs are complete; only the run in progress (the last file)
        # is 'running' (a kill between two runs leaves none running)
        if status == "complete":
            assert t.size == 3001, f"{ctx}: {name} complete with {t.size} records"
        else:
            assert killed and status == "running" and i == len(names) - 1, (
                f"{ctx}: {name} has status {status!r} ({'' if killed else 'not '}killed)")
    if not killed:
        assert len(names) == 3, ctx


# --------------------------------------------------------------------------- the writer
WRITER = textwrap.dedent("""
    import sys
    from remote_trigger.pywrap.runtime.results import SeriesWriter
    path, every = sys.argv[1], float(sys.argv[2])
    print("ready", flush=True)
    while True:                  # writers open, append and close, over and over
        w = SeriesWriter(path, {"stage": "test"}, ["t", "x"], checkpoint_seconds=every)
        for i in range(50):
            w.append({"t": float(i), "x": 0.5 * i})
        w.close(status="stopped")
""")


@pytest.mark.parametrize("every", [0.0, 0.01])
def test_series_writer_killed_anywhere(tmp_path, every):
    """SIGKILL a process that only writes series (checkpoint at every row / 10 ms).

    With ``checkpoint_seconds = 0`` most of the time is spent inside a
    rewrite or a close, so kills land there; every time the file opens, has
    status ``'running'`` or ``'stopped'`` and rows 0..n-1.
    """
    rng = np.random.default_rng([SEED, 200, int(every * 1000)])
    path = tmp_path / "s.h5"
    seen = {}
    tmp_left = 0
    for k in range(8):
        ctx = f"RT_KILL_SEED={SEED} every={every} kill {k}"
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), str(every)],
                                stdout=subprocess.PIPE, env=cli_env())
        assert proc.stdout.readline().strip() == b"ready", ctx
        time.sleep(float(rng.uniform(0.0, 0.4)))
        proc.kill()
        proc.wait()
        proc.stdout.close()
        tmp_left += any(".tmp" in p for p in os.listdir(tmp_path))
        if not path.exists():
            # killed before the first write of any process so far (on a loaded
            # machine a process may not reach its first write in 0.4 s); once the
            # file has existed it must stay
            assert not seen, f"{ctx}: s.h5 existed after an earlier kill and is gone"
            continue
        try:
            attrs, d = read_all(str(path))
        except OSError as exc:
            raise AssertionError(f"{ctx}: unreadable: {exc}") from None
        assert attrs["status"] in ("running", "stopped"), (ctx, attrs)
        assert attrs["stage"] == "test"
        n = d["t"].size
        np.testing.assert_array_equal(d["t"], np.arange(n, dtype=float), err_msg=ctx)
        np.testing.assert_array_equal(d["x"], 0.5 * np.arange(n), err_msg=ctx)
        if attrs["status"] == "stopped":
            assert n == 50, ctx
        seen[attrs["status"]] = seen.get(attrs["status"], 0) + 1
    print(f"every={every}: statuses {seen}, kills leaving a temporary file {tmp_left}")


def test_series_writer_checkpoints_and_close(tmp_path):
    path = str(tmp_path / "s.h5")
    w = SeriesWriter(path, {"a": 1.5, "name": "x"}, ["t", "D"], checkpoint_seconds=3600)
    attrs, d = read_all(path)                  # exists at once, empty, running
    assert attrs["status"] == "running" and d["t"].shape == (0,)
    for i in range(5000):                      # past the initial buffer of 1024
        w.append({"t": i, "D": -i, "ignored": 0})
    assert read_all(path)[1]["t"].shape == (0,)     # no checkpoint due yet
    w.checkpoint()
    assert read_all(path)[1]["t"].shape == (5000,)
    with pytest.raises(KeyError):
        w.append({"t": 1.0})
    assert w.n == 5000
    w.close(attrs={"v0": 2.0}, status="stopped")
    w.close()                                  # no effect
    attrs, d = read_all(path)
    assert attrs["status"] == "stopped" and attrs["v0"] == 2.0 and attrs["a"] == 1.5
    np.testing.assert_array_equal(d["D"], -np.arange(5000.0))
    with pytest.raises(ValueError):
        w.append({"t": 0.0, "D": 0.0})
    with pytest.raises(ValueError):
        SeriesWriter(path, {}, ["t", "t"])
    with pytest.raises(ValueError):
        SeriesWriter(path, {}, ["t"], checkpoint_seconds=-1)


def test_stale_temporary_files_are_removed(tmp_path):
    """``<path>.tmp<pid>`` of a dead process goes at the next write; a live one stays."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    for name, writer in (("a.h5", lambda p: write_atomic(p, {}, {"x": [1.0]})),
                         ("b.h5", lambda p: SeriesWriter(p, {}, ["x"]).close())):
        path = tmp_path / name
        stale = tmp_path / f"{name}.tmp{dead.pid}"
        live = tmp_path / f"{name}.tmp{os.getppid()}"
        other = tmp_path / f"other.h5.tmp{dead.pid}"
        for p in (stale, live, other):
            p.write_bytes(b"partial")
        writer(str(path))
        assert not stale.exists() and live.exists() and other.exists()
        assert path.exists()
