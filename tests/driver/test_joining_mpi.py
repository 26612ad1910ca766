"""pywrap.runtime.joining: workers of a task farm left without a task join the
points of the running tasks.

Under ``mpirun -np 4`` (rank 0 schedules, 3 workers): with one task, the two
free workers join its points (its map's tasks run on more than one rank) and
the answers are those of one rank; a task queued behind the helpers (a
follow-up) still runs, the helpers being sent away; a point that raises,
or a task that raises, leaves no helper waiting; and the sliced verdict in parts of a stored N = 400
equilibrium, decided through the driver's ``decide_on_rank0`` inside a farm
task, has the same bits as on one rank alone. ``kill -9`` of the rank that
owns a joined point (right after the point's second part is saved), then the
same farm again: the saved tasks are read back and the verdict has the bits
of one rank alone."""
import os
import pickle
import subprocess
import sys
import time
from types import SimpleNamespace

import numpy as np
import pytest

from remote_trigger.pywrap.runtime.joining import active, point_map

from tests.data import unpack

from .conftest import MPIRUN, cli_env

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def where(i):
    """A point's task: its value and the farm rank that ran it."""
    from mpi4py import MPI

    time.sleep(0.03)
    return i * i, MPI.COMM_WORLD.Get_rank()


def bad(i):
    if i == 5:
        raise ValueError("bad part 5")
    time.sleep(0.01)
    return i


def owner(task, n_points):
    """A farm task with ``n_points`` points of 12 map tasks each."""
    from mpi4py import MPI

    assert active(MPI.COMM_SELF)
    out = []
    time.sleep(0.3)                      # (the helpers report to rank 0 first)
    for _ in range(n_points):
        with point_map() as pmap:
            out.append(list(pmap(where, range(12))))
        time.sleep(0.1)                  # between points: the helpers report back
    return task, out


def failing(task):
    """A farm task whose point raises, then one that does not."""
    time.sleep(0.3)
    with point_map() as pmap:
        try:
            list(pmap(bad, range(8)))
        except ValueError as exc:
            msg = str(exc)
    time.sleep(0.1)
    with point_map() as pmap:
        again = list(pmap(where, range(6)))
    return msg, [v for v, _ in again]


def bits(res):
    """A verdict's decision, eigenvalues, largest |Im|, reason and dofs, as bytes."""
    return pickle.dumps((str(res.decision), np.asarray(res.eigenvalues).tobytes(),
                         float(res.max_imag), res.reason, res.n_dof))


def verdict_bits(dump):
    """The sliced verdict in parts of the equilibrium ``dump``, twice, through
    the driver's decide_on_rank0 on this rank (and the farm's helpers)."""
    from mpi4py import MPI

    from remote_trigger.analysis.stability.verdict import VerdictOptions
    from remote_trigger.pywrap.stages.common import decide_on_rank0

    opts = VerdictOptions(method="sliced", part_size=400)
    out = []
    for pause in (1.0, 0.3):             # (the helpers report to rank 0 first)
        time.sleep(pause)
        res = decide_on_rank0(SimpleNamespace(comm=MPI.COMM_SELF), dump, opts)
        out.append(bits(res))
    return out


SCRIPT = r'''
import sys, time
sys.path.insert(0, sys.argv[2])
from mpi4py import MPI
from remote_trigger.pywrap.runtime import taskfarm
from remote_trigger.pywrap.runtime.taskfarm import run_tasks
from tests.driver.test_joining_mpi import owner, failing, verdict_bits

comm = MPI.COMM_WORLD
rank = comm.Get_rank()
want = [i * i for i in range(12)]

# one task, two free workers: they join its points
res = run_tasks(comm, ["a"], owner, (4,), join=True)
if rank == 0:
    [(task, (name, points))] = res
    assert name == "a" and len(points) == 4
    assert all([v for v, _ in p] == want for p in points), points
    ranks = [sorted({r for _, r in p}) for p in points]
    assert any(len(r) > 1 for r in ranks), ranks          # helpers ran some of its tasks
    assert taskfarm.helped["points"] >= 1, taskfarm.helped
    assert len(taskfarm.helped["helpers"]) >= 2, taskfarm.helped

# a follow-up task queued while helpers hold the free workers still runs
def more(t, r, w):
    return ["c"] if t == "b" else None
res = run_tasks(comm, ["a", "b"], owner, (6,), more, join=True)
if rank == 0:
    assert sorted(t for t, _ in res) == ["a", "b", "c"], res

# a point that raises leaves no helper waiting; the next point runs
res = run_tasks(comm, ["x"], failing, (), join=True)
if rank == 0:
    [(_, (msg, again))] = res
    assert msg == "bad part 5" and again == [i * i for i in range(6)], (msg, again)

# a task that raises (after its helpers joined a point): raised on every rank,
# no helper left waiting
try:
    run_tasks(comm, [sys.argv[1] + "/missing.dump"], verdict_bits, (), join=True)
except ValueError as exc:
    assert "missing.dump" in str(exc), exc
else:
    raise AssertionError("no exception on rank %d" % rank)

# the driver's verdict in parts inside a farm task, helpers joining
res = run_tasks(comm, [sys.argv[3]], verdict_bits, (), join=True)
if rank == 0:
    alone = verdict_bits(sys.argv[3])      # one rank, no farm (the same process)
    assert res[0][1] == alone and alone[0] == alone[1]
    assert taskfarm.helped["points"] >= 1, taskfarm.helped
open(f"{sys.argv[1]}/ok{rank}", "w").close()
'''


def checkpointed_bits(dump, folder, mode):
    """The sliced verdict in parts of ``dump`` through ``decide_on_rank0`` with
    its checkpoint in ``folder``; ``mode`` 'kill': this process kills itself
    (SIGKILL) once the point's second part is saved, after writing the helpers
    that joined the point to ``folder``/joined; 'resume': also how many saved
    tasks were read back."""
    import signal

    from mpi4py import MPI

    from remote_trigger.analysis.stability.sliced import checkpoint
    from remote_trigger.analysis.stability.verdict import VerdictOptions
    from remote_trigger.pywrap.runtime import joining
    from remote_trigger.pywrap.stages.common import decide_on_rank0

    joined, hits = [], []
    call, save, load = (joining.PointMap.__call__, checkpoint.ScanFiles.save_task,
                        checkpoint.ScanFiles.load_task)

    def call_and_note(self, fn, tasks):
        out = call(self, fn, tasks)
        joined[:] = self.helpers
        return out

    def save_then_kill(self, kind, j, result):
        save(self, kind, j, result)
        if mode == "kill" and kind == "part" and j > 0:
            with open(os.path.join(folder, "joined"), "w") as fh:
                fh.write(" ".join(map(str, joined)))
            os.kill(os.getpid(), signal.SIGKILL)

    def load_and_count(self, kind, j):
        r = load(self, kind, j)
        hits.append(r is not None)
        return r

    joining.PointMap.__call__ = call_and_note
    checkpoint.ScanFiles.save_task, checkpoint.ScanFiles.load_task = (save_then_kill,
                                                                      load_and_count)
    try:
        time.sleep(1.0)                  # (the helpers report to rank 0 first)
        opts = VerdictOptions(method="sliced", part_size=400, checkpoint_dir=folder)
        res = decide_on_rank0(SimpleNamespace(comm=MPI.COMM_SELF), dump, opts)
    finally:
        joining.PointMap.__call__ = call
        checkpoint.ScanFiles.save_task, checkpoint.ScanFiles.load_task = save, load
    return bits(res), sum(hits), list(joined)


KILL_SCRIPT = r'''
import sys
sys.path.insert(0, sys.argv[2])
from mpi4py import MPI
from remote_trigger.pywrap.runtime.taskfarm import run_tasks
from tests.driver.test_joining_mpi import checkpointed_bits, verdict_bits

comm = MPI.COMM_WORLD
folder, dump, mode = sys.argv[1], sys.argv[3], sys.argv[4]
res = run_tasks(comm, [dump], checkpointed_bits, (folder, mode), join=True)
if comm.Get_rank() == 0:
    bits, hits, joined = res[0][1]
    alone = verdict_bits(dump)[0]          # one rank, no farm, no checkpoint
    with open(folder + "/resumed", "w") as fh:
        fh.write(f"{int(bits == alone)} {hits} {len(joined)}")
'''


def test_outside_a_joining_farm_a_point_is_not_joined():
    assert not active(None)


def stored_dump(folder):
    """The stored N = 400 equilibrium (with its sidecar) unpacked into ``folder``."""
    unpack("free_rotation_N400_s5_step_00002.dump.json", str(folder))
    return unpack("free_rotation_N400_s5_step_00002", str(folder))


def farm_of_four(script, folder, dump, *args):
    """``script`` (its text, written to ``folder``) under ``mpirun -np 4`` with the
    arguments folder, the repository's root, ``dump`` and ``args``."""
    path = folder / "farm.py"
    path.write_text(script)
    return subprocess.run([MPIRUN, "-np", "4", sys.executable, str(path), str(folder), ROOT,
                           dump, *args], capture_output=True, text=True, env=cli_env(),
                          timeout=300)


@pytest.mark.mpi
def test_free_workers_join_the_points_of_a_running_task(tmp_path):
    res = farm_of_four(SCRIPT, tmp_path, stored_dump(tmp_path))
    assert res.returncode == 0, res.stdout + res.stderr
    assert all((tmp_path / f"ok{r}").exists() for r in range(4))


@pytest.mark.mpi
def test_kill_inside_a_joined_point_then_resume(tmp_path):
    dump = stored_dump(tmp_path)
    folder = tmp_path / "verdicts"
    folder.mkdir()

    def farm(mode):
        return farm_of_four(KILL_SCRIPT, folder, dump, mode)

    res = farm("kill")
    assert res.returncode != 0
    assert len((folder / "joined").read_text().split()) >= 1    # the killed point was joined
    saved = sorted(p.name.split(".", 1)[1] for p in folder.glob("sliced-*.task-*"))
    assert saved == ["task-cut-00001.pkl", "task-cut-00002.pkl", "task-part-00000.pkl",
                     "task-part-00001.pkl"], saved
    res = farm("resume")
    assert res.returncode == 0, res.stdout + res.stderr
    same, hits, helpers = map(int, (folder / "resumed").read_text().split())
    assert (same, hits) == (1, 4), (same, hits)       # the bits of one rank; 4 tasks read back
    assert helpers >= 1
