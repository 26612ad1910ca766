"""pywrap.runtime.taskfarm.run_tasks (mpi4py.futures), the task farm of the
ensemble and trigger-map jobs: every task runs exactly once, on a worker
rank; rank 0 receives every result; an exception reaches every rank."""
import os
import subprocess
import sys

import pytest

from remote_trigger.pywrap.runtime.taskfarm import n_workers, run_tasks

from .conftest import cli_env

BIN = os.path.dirname(sys.executable)

SCRIPT = r'''
import sys, time
from mpi4py import MPI
from remote_trigger.pywrap.runtime.taskfarm import n_workers, run_tasks
comm = MPI.COMM_WORLD
rank = comm.Get_rank()

def square(task, offset):
    time.sleep(0.01 * (task % 3))
    return {"x": task * task + offset, "rank": MPI.COMM_WORLD.Get_rank()}

seen = []
res = run_tasks(comm, list(range(40)), square, (1,), lambda t, r, w: seen.append((t, r, w)))
if rank == 0:
    assert sorted(t for t, _ in res) == list(range(40)), res
    assert all(r["x"] == t * t + 1 for t, r in res)
    ranks = {r["rank"] for _, r in res}
    assert 0 not in ranks and ranks <= set(range(1, comm.Get_size())), ranks
    assert [(t, r) for t, r, _ in seen] == res and all(w >= 0 for *_, w in seen)
    assert n_workers(comm) == comm.Get_size() - 1
else:
    assert res is None and seen == []

def fail(task):
    if task == 5:
        raise ValueError(f"bad task {task}")
    return task

# follow-ups: each task t < 100 returned by `done` two more, 100 t + 1 and 100 t + 2,
# which run on the workers like the first ones (every one exactly once)
def parts(t, r, w):
    return [100 * t + 1, 100 * t + 2] if t < 100 else None

res = run_tasks(comm, [1, 2, 3], square, (0,), parts)
if rank == 0:
    want = [1, 2, 3] + [100 * t + k for t in (1, 2, 3) for k in (1, 2)]
    assert sorted(t for t, _ in res) == want, res
    assert all(r["x"] == t * t for t, r in res)
    assert all(r["rank"] != 0 for _, r in res)
    order = [t for t, _ in res]
    assert all(order.index(100 * t + k) > order.index(t) for t in (1, 2, 3) for k in (1, 2))

# one worker (ranks 0 and 1): the follow-ups of a task are handed out before
# the tasks not yet begun, in the order returned
sub = comm.Split(0 if rank < 2 else MPI.UNDEFINED, rank)
if sub != MPI.COMM_NULL:
    res = run_tasks(sub, [1, 2, 3], square, (0,), parts)
    if rank == 0:
        assert [t for t, _ in res] == [1, 101, 102, 2, 201, 202, 3, 301, 302], res
    sub.Free()

try:
    run_tasks(comm, list(range(8)), fail)
except ValueError as exc:
    assert str(exc) == "bad task 5", exc
else:
    raise AssertionError("no exception on rank %d" % rank)
open(f"{sys.argv[1]}/ok{rank}", "w").close()
'''


def test_one_rank_runs_the_tasks_in_order_here():
    seen = []
    res = run_tasks(None, [3, 1, 2], lambda t, k: t * k, (10,),
                    lambda t, r, w: seen.append((t, r)))
    assert res == [(3, 30), (1, 10), (2, 20)] and seen == res
    assert n_workers(None) == 1
    with pytest.raises(ZeroDivisionError):
        run_tasks(None, [1, 0], lambda t: 1 / t)


def test_one_rank_runs_follow_ups_before_the_tasks_not_started():
    """Tasks that ``done`` returns run before the tasks not yet begun, in the
    order returned, and theirs before them: a task begun is finished first."""
    res = run_tasks(None, [1, 2], lambda t: t, (),
                    lambda t, r, w: [10 * t, 10 * t + 1] if t < 100 else None)
    assert [t for t, _ in res] == [1, 10, 100, 101, 11, 110, 111,
                                   2, 20, 200, 201, 21, 210, 211]


@pytest.mark.mpi
def test_three_ranks_farm_out_every_task_once(tmp_path):
    script = tmp_path / "farm.py"
    script.write_text(SCRIPT)
    out = subprocess.run([os.path.join(BIN, "mpirun"), "-np", "3", sys.executable, str(script),
                          str(tmp_path)], capture_output=True, text=True, env=cli_env(),
                         timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert all((tmp_path / f"ok{r}").exists() for r in range(3))
