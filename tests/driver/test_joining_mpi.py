"""pywrap.runtime.joining: workers of a task farm left without a task join the
points of the running tasks.

Under ``mpirun -np 4`` (rank 0 schedules, 3 workers): with one task, the two
free workers join its points (its map's tasks run on more than one rank) and
the answers are those of one rank; a task queued behind the helpers (a
follow-up) still runs, the helpers being sent away; a point that raises,
or a task that raises, leaves no helper waiting; and the sliced verdict in parts of a stored N = 400
equilibrium, decided through the driver's ``decide_on_rank0`` inside a farm
task, has the same bits as on one rank alone."""
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
        out.append(pickle.dumps((str(res.decision), np.asarray(res.eigenvalues).tobytes(),
                                 float(res.max_imag), res.reason, res.n_dof)))
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


def test_outside_a_joining_farm_a_point_is_not_joined():
    assert not active(None)


@pytest.mark.mpi
def test_free_workers_join_the_points_of_a_running_task(tmp_path):
    unpack("free_rotation_N400_s5_step_00002.dump.json", str(tmp_path))
    dump = unpack("free_rotation_N400_s5_step_00002", str(tmp_path))
    script = tmp_path / "s.py"
    script.write_text(SCRIPT)
    res = subprocess.run([MPIRUN, "-np", "4", sys.executable, str(script), str(tmp_path),
                          ROOT, dump], capture_output=True, text=True, env=cli_env(),
                         timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    assert all((tmp_path / f"ok{r}").exists() for r in range(4))
