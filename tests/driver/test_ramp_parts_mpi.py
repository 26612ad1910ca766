"""``mpirun -np 2 remote-trigger ramp --set part_size=P``: every rank runs parts of
each point's sliced verdict, and the answer is that of one process.

The verdict is sliced by lowering the dense-path switch below the N = 20
packing's size and the slice size to 12 (as test_verdict_checkpoint.py
does; set on every rank by the script), in parts of 24 (3 parts per point).

* The ramp on two ranks (both run tasks): each point's decision, margin and eigenvalues
  (ramp.h5) are bitwise those of the point's dump decided again here, in
  one process, by the builtin map (the held system is the dump's, bit for
  bit: test_held_system.py).
* ``kill -9`` of rank 0 inside a point (right after its second part is
  saved) and ``--resume`` on two ranks: the saved tasks are read back
  (their files were there after the kill) and ramp.h5 is bitwise that of
  the uninterrupted two-rank ramp."""
import glob
import os
import subprocess
import sys

import numpy as np
import pytest

from remote_trigger.analysis.stability import eigen
from remote_trigger.analysis.stability.sliced import scan
from remote_trigger.analysis.stability.verdict import VerdictOptions, stability_of_dump
from remote_trigger.pywrap.runtime.results import read_all
from remote_trigger.pywrap.stages.ramp_file import read_points

from .conftest import MPIRUN, cli_env
from .test_kill import compare_ramp

pytestmark = [pytest.mark.mpi]

PART = 24

SCRIPT = r'''
import os, signal, sys
out, data, mode = sys.argv[1:4]
from remote_trigger.analysis.stability import eigen
from remote_trigger.analysis.stability.sliced import checkpoint, scan
eigen.DENSE_MAX = 10
scan.SLICE_SIZE = 12
from mpi4py import MPI
rank = MPI.COMM_WORLD.Get_rank()
save, load = checkpoint.ScanFiles.save_task, checkpoint.ScanFiles.load_task
hits = []
if mode == "kill" and rank == 0:
    def save_task(self, kind, j, result):
        save(self, kind, j, result)
        if kind == "part" and j > 0:
            os.kill(os.getpid(), signal.SIGKILL)
    checkpoint.ScanFiles.save_task = save_task
if mode == "resume" and rank == 0:
    def load_task(self, kind, j):
        r = load(self, kind, j)
        hits.append(r is not None)
        return r
    checkpoint.ScanFiles.load_task = load_task
from remote_trigger.pywrap.runtime import rankmap
ran_by = []
if rank == 0:
    close = rankmap.RankMap.close
    def close_and_count(self):
        close(self)
        ran_by.extend(r.rank for r in self.log)
    rankmap.RankMap.close = close_and_count
from remote_trigger.pywrap.cli import main
status = main(["ramp", "--datafile", data, "--out", out, "--quiet", "--set", "dF_x=0.02",
               "--set", "tol=1e-3", "--set", "part_size=%d"]
              + (["--resume"] if mode == "resume" else []))
if rank == 0 and mode == "resume":
    with open(os.path.join(out, "hits"), "w") as fh:
        fh.write(str(sum(hits)))
if rank == 0 and mode == "ref":
    with open(os.path.join(out, "ranks"), "w") as fh:
        fh.write(" ".join(map(str, ran_by)))
sys.exit(status)
''' % PART


def _ramp(tmp_path, out, datafile, mode):
    script = tmp_path / "ramp_parts.py"
    script.write_text(SCRIPT)
    env = dict(cli_env(), OPENBLAS_NUM_THREADS="1")
    return subprocess.run([MPIRUN, "-np", "2", sys.executable, str(script), str(out),
                           datafile, mode], env=env, capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def two_rank_ramp(relaxed, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ramp_parts")
    out = tmp / "ref"
    res = _ramp(tmp, out, relaxed.datafile, "ref")
    assert res.returncode == 0, res.stdout + res.stderr
    return tmp, out


def test_two_ranks_decide_as_one_process(two_rank_ramp, monkeypatch):
    _, out = two_rank_ramp
    monkeypatch.setattr(eigen, "DENSE_MAX", 10)
    monkeypatch.setattr(scan, "SLICE_SIZE", 12)
    attrs, data = read_all(str(out / "ramp.h5"))
    assert attrs["status"] == "complete"
    F, files = read_points(str(out / "ramp.h5"))
    assert len(files) >= 2
    opts = VerdictOptions(stop_at_complex=True, part_size=PART)
    decided = set()
    for k, datafile in enumerate(files):
        res = stability_of_dump(datafile[:-len(".data")] + ".dump", opts, allow_residual=True)
        assert res.method == "sliced"
        assert data["steps/decision"][k] == float(res.decision)
        assert data["steps/confidence"][k] == res.confidence
        lam = data[f"eigenvalues/steps/step_{k:05d}"]
        assert lam.tobytes() == res.eigenvalues.tobytes(), k
        decided.add(int(res.decision))
    assert decided == {0, 1}                    # real steps and the complex one
    ranks = [int(r) for r in (out / "ranks").read_text().split()]
    assert ranks.count(1) > 0 and ranks.count(0) > 0, ranks     # both ranks ran tasks


def test_kill_inside_a_point_then_resume(two_rank_ramp, relaxed):
    tmp, ref = two_rank_ramp
    out = tmp / "killed"
    res = _ramp(tmp, out, relaxed.datafile, "kill")
    assert res.returncode != 0
    saved = sorted(os.path.basename(p).split(".", 1)[1]
                   for p in glob.glob(str(out / "ramp" / "verdicts" / "sliced-*.task-*")))
    assert saved == ["task-cut-00001.pkl", "task-cut-00002.pkl", "task-part-00000.pkl",
                     "task-part-00001.pkl"], saved
    res = _ramp(tmp, out, relaxed.datafile, "resume")
    assert res.returncode == 0, res.stdout + res.stderr
    assert int((out / "hits").read_text()) == 4           # the four saved tasks read back
    assert compare_ramp(read_all(str(ref / "ramp.h5")), out / "ramp.h5") == []


def test_ramp_np_relaunches_under_mpirun(relaxed, tmp_path):
    """``ramp --np 2 --part-size 60`` from a serial shell: the ramp runs on two
    ranks (ramp.h5 records n_ranks 2 and part_size 60); ``--np 0`` is refused."""
    from .conftest import CLI

    out = tmp_path / "np2"
    base = [CLI, "ramp", "--datafile", relaxed.datafile, "--out", str(out), "--set",
            "dF_x=0.02", "--set", "tol=1e-3", "--quiet"]
    res = subprocess.run(base + ["--np", "2", "--part-size", "60"], env=cli_env(),
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.count("ramp: F_x^c in") == 1
    attrs, _ = read_all(str(out / "ramp.h5"))
    assert (attrs["status"], attrs["n_ranks"], attrs["part_size"]) == ("complete", 2, 60)
    res = subprocess.run(base + ["--np", "0"], env=cli_env(), capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 2 and "--np must be >= 1, got --np 0" in res.stderr
