"""``remote-trigger accuracy --quick``: the command runs end to end and writes a
consistent table (markdown + HDF5) and the plot, with one recommended row per
section, in well under a minute."""
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("acc")
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    p = subprocess.run([cli, "accuracy", "--quick", "-o", str(out)], capture_output=True,
                       text=True, timeout=120, env=env)
    assert p.returncode == 0, p.stderr[-2000:]
    return out, p.stdout


def test_files_and_sections(result):
    out, stdout = result
    for name in ("accuracy.md", "accuracy.h5", "accuracy.png"):
        assert os.path.getsize(out / name) > 0
    assert not [f for f in os.listdir(out) if ".part" in f or f.startswith(".tmp")]
    with h5py.File(out / "accuracy.h5", "r") as h5:
        sec = [s.decode() for s in h5["table/section"][()]]
        rec = h5["table/recommended"][()]
        err = h5["table/error"][()]
        wall = h5["table/wall_time"][()]
        assert h5.attrs["quick"]
        assert h5.attrs["dt_limit"] > 0
    for s in ("timestep", "relaxation", "jacobian", "eigen", "normal_form"):
        assert s in sec
        assert sum(bool(r) for r, x in zip(rec, sec) if x == s) == 1, s
    assert np.all(wall[np.isfinite(wall)] > 0)
    md = open(out / "accuracy.md").read()
    assert md.count("\n| ") == len(sec) + 1          # header + one line per row
    assert "**yes**" in stdout


def test_measured_numbers_are_sane(result):
    out, _ = result
    with h5py.File(out / "accuracy.h5", "r") as h5:
        sec = np.array([s.decode() for s in h5["table/section"][()]])
        meth = np.array([s.decode() for s in h5["table/method"][()]])
        err = h5["table/error"][()]
        val = h5["table/value"][()]
    # analytic Jacobian agrees with the independent complex-step law to round-off
    an = err[(sec == "jacobian") & (meth == "analytic (stiffness_matrix)")][0]
    assert an < 1e-10
    # LAMMPS finite differences: best step within 1e-5 of the analytic K
    fd = err[(sec == "jacobian") & (meth == "LAMMPS central FD")]
    assert fd.min() < 1e-5
    # normal form: tighter tolerance, smaller error, for each method
    for m in ("RK45", "DOP853", "Radau"):
        sel = (sec == "normal_form") & (meth == m)
        e, tol = err[sel], val[sel]
        assert np.all(np.diff(e[np.argsort(-tol)]) < 0), (m, e)
    # the projected test at the pair decides (its shift sat on an eigenvalue of
    # the closest real pair: "decision None, confidence 0")
    with h5py.File(out / "accuracy.h5", "r") as h5:
        note = [s.decode() for s in h5["table/note"][()]]
    row = list(meth).index("certified test, projected (classify_projected)")
    dense = list(meth).index("certified test, dense (classify_spectrum)")
    assert note[row].split(",")[0] == note[dense].split(",")[0], (note[row], note[dense])
    assert float(note[row].rsplit(" ", 1)[1]) > 1, note[row]
    # Newton polishing reaches 1e-10, damped dynamics alone does not in the budget
    rel = (sec == "relaxation") & (val == 1e-10)
    assert np.isfinite(err[rel]).all()


def test_an_earlier_result_is_kept(result):
    """accuracy into a folder holding its results: refused before any run
    (it replaced them), one line, exit status 2; the same for normal-form."""
    out, _ = result
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    before = (out / "accuracy.h5").read_bytes()
    p = subprocess.run([cli, "accuracy", "--quick", "-o", str(out)], capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 2 and "already holds accuracy.md" in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert (out / "accuracy.h5").read_bytes() == before
    nf = out / "nf"
    argv = [cli, "normal-form", "-o", str(nf), "--eps", "0.1", "0.01", "--tau", "inf"]
    first = subprocess.run(argv, capture_output=True, text=True, timeout=60)
    assert first.returncode == 0, first.stderr
    # the console table labels its columns with eps, largest first
    head = first.stdout.splitlines()[1].split()
    assert head == ["eps", "=", "0.1", "eps", "=", "0.01"], first.stdout
    p = subprocess.run(argv, capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and "already holds normal_form.h5" in p.stderr, p.stderr


@pytest.mark.parametrize("opts, needle", [
    (["--sections", ""], "sections is empty"),
    (["--n", "0", "--sections", "jacobian"], "n must be >= 6, got n = 0"),
    (["--seed", "-1", "--sections", "jacobian"], "seed must be >= 0, got seed = -1"),
])
def test_bad_arguments_before_anything_is_written(tmp_path, opts, needle):
    """--sections "" failed in matplotlib after writing half a folder, --n 0 ran
    N = 20, --seed -1 named neither; each is now one line, and no --out."""
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    out = tmp_path / "acc"
    p = subprocess.run([cli, "accuracy", "--quick", "-o", str(out), *opts],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and needle in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert not out.exists()
