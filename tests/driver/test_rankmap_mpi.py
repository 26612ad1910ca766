"""pywrap.runtime.rankmap: a map_tasks over the ranks of a communicator.

Under ``mpirun -np 2``: the results come back in task order whichever rank
ran each task (both ranks run some), a shared object is sent once, a task's
exception is raised on rank 0 at its place in the order, an early stop
leaves no rank waiting (the next computation runs on both), and the sliced
verdict in parts on two ranks is that of the builtin map on one rank, bit
for bit (decision, margins, reasons, eigenvalues, strips, statistics)."""
from dataclasses import dataclass
import os
import subprocess
import sys
import time

import pytest

from remote_trigger.pywrap.runtime.rankmap import on_rank0_with_ranks

from .conftest import MPIRUN, cli_env

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@dataclass
class Big:
    """A shared object (sent once)."""

    data: list


@dataclass
class Task:
    big: Big
    i: int


def square(task):
    time.sleep(0.02)
    return task.i * task.i, task.big.data[-1]


def boom(task):
    if task.i >= 3:
        time.sleep(0.01 * (6 - task.i))     # (the later ones fail first)
        raise ValueError(f"bad task {task.i}")
    time.sleep(0.05)
    return task.i


def slow(task):
    time.sleep(0.05)
    return task.i


SCRIPT = r'''
import sys
sys.path.insert(0, sys.argv[2])
from mpi4py import MPI
from remote_trigger.pywrap.runtime.rankmap import on_rank0_with_ranks
from tests.driver.test_rankmap_mpi import Big, Task, square, boom, slow, sliced_fingerprint

comm = MPI.COMM_WORLD
big = Big(list(range(100000)))

def plain(pmap):
    out = list(pmap(square, [Task(big, i) for i in range(12)]))
    return out, sorted({r.rank for r in pmap.log}), pmap.bcast_seconds > 0
out, ranks, sent = on_rank0_with_ranks(comm, plain, (Big,))
assert out == [(i * i, 99999) for i in range(12)], out
assert ranks == [0, 1] and sent, (ranks, sent)

def failing(pmap):
    got = []
    try:
        for r in pmap(boom, [Task(big, i) for i in range(6)]):
            got.append(r)
    except ValueError as exc:
        return got, str(exc)
    return got, None
got, err = on_rank0_with_ranks(comm, failing, (Big,))
assert got == [0, 1, 2] and err == "bad task 3", (got, err)

def early(pmap):                # the first result is all the caller reads
    it = pmap(boom, [Task(big, i) for i in (0, 4, 5)])
    first = next(it)
    it.close()
    return first
assert on_rank0_with_ranks(comm, early, (Big,)) == 0

def stopped(pmap):
    it = pmap(slow, [Task(big, i) for i in range(40)])
    first = next(it)
    it.close()
    return first, len(pmap.log)
first, ran = on_rank0_with_ranks(comm, stopped, (Big,))
assert first == 0 and ran < 10, (first, ran)

# both ranks are free again
assert on_rank0_with_ranks(comm, lambda pmap: list(pmap(square, [Task(big, 5)]))) \
    == [(25, 99999)]
prints = on_rank0_with_ranks(comm, lambda pmap: sliced_fingerprint(pmap))
if comm.Get_rank() == 0:
    with open(f"{sys.argv[1]}/sliced", "w") as fh:
        fh.write("\n".join(prints))
open(f"{sys.argv[1]}/ok{comm.Get_rank()}", "w").close()
'''


def sliced_fingerprint(map_tasks=None):
    """Fingerprints of the sliced verdict in parts of 100 of a planted n = 300
    matrix (two complex strips, one real; whole scan and stopped at its first
    complex strip), its tasks run by ``map_tasks``."""
    from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced
    from tests.analysis.test_sliced import planted
    from tests.analysis.test_sliced_parts import fingerprint

    K, mass = planted(n=300, pairs=[(100, 1.5), (220, 0.9), (250, 1.2)], seed=1)
    out = []
    for stop in (False, True):
        st = SlicedStats()
        res = classify_sliced(K, mass, stats=st, slice_size=20, part_size=100,
                              stop_at_complex=stop, map_tasks=map_tasks)
        assert st.parts == 3
        out.append(fingerprint(res, st))
    return out


def test_one_rank_is_a_plain_call():
    assert on_rank0_with_ranks(None, lambda pmap: pmap) is None


@pytest.mark.mpi
def test_two_ranks(tmp_path):
    script = tmp_path / "s.py"
    script.write_text(SCRIPT)
    res = subprocess.run([MPIRUN, "-np", "2", sys.executable, str(script), str(tmp_path),
                          ROOT], capture_output=True, text=True, env=cli_env(), timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    assert (tmp_path / "ok0").exists() and (tmp_path / "ok1").exists()
    assert (tmp_path / "sliced").read_text().split("\n") == sliced_fingerprint()
