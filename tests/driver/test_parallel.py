"""pywrap.parallel.on_rank0: rank 0's result or exception, with its type, on every rank."""
import os
import subprocess
import sys

import pytest

from remote_trigger.analysis.errors import InputError
from remote_trigger.pywrap.runtime.parallel import on_rank0

from .conftest import cli_env

BIN = os.path.dirname(sys.executable)

SCRIPT = r'''
from mpi4py import MPI
from remote_trigger.analysis.errors import InputError, RemoteTriggerError
from remote_trigger.pywrap.runtime.parallel import on_rank0
comm = MPI.COMM_WORLD
calls = []
def f(x):
    calls.append(comm.Get_rank())
    return {"x": x, "rank": comm.Get_rank()}
res = on_rank0(comm, f, 3)
assert res == {"x": 3, "rank": 0} and calls == ([0] if comm.Get_rank() == 0 else []), (res, calls)
def bad():
    raise InputError("bad value: --n 7")
try:
    on_rank0(comm, bad)
except InputError as exc:
    assert str(exc) == "bad value: --n 7"
else:
    raise AssertionError("no exception")
class Unpicklable(Exception):
    def __init__(self, a, b):
        super().__init__(a)
def ugly():
    raise Unpicklable("x", 2)
try:
    on_rank0(comm, ugly)
except (Unpicklable, RemoteTriggerError) as exc:
    assert "x" in str(exc), exc
import sys
open(f"{sys.argv[1]}/ok{comm.Get_rank()}", "w").close()
'''


def test_serial_is_a_plain_call():
    assert on_rank0(None, lambda a, b=1: a + b, 2, b=3) == 5
    with pytest.raises(InputError, match="named"):
        on_rank0(None, lambda: (_ for _ in ()).throw(InputError("named")))


@pytest.mark.mpi
def test_two_ranks_get_result_and_exception_type(tmp_path):
    script = tmp_path / "s.py"
    script.write_text(SCRIPT)
    out = subprocess.run([os.path.join(BIN, "mpirun"), "-np", "2", sys.executable, str(script),
                          str(tmp_path)], capture_output=True, text=True, env=cli_env(),
                         timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / "ok0").exists() and (tmp_path / "ok1").exists()
