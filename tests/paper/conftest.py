"""One ``remote-trigger paper --quick`` run shared by the paper and trigger-map tests."""
import os
import re
import subprocess
import sys

import pytest

BIN = os.path.dirname(sys.executable)
CLI = os.path.join(BIN, "remote-trigger")


@pytest.fixture(scope="session")
def paper_quick(tmp_path_factory):
    """(output folder, CompletedProcess) of ``paper --quick`` on two ranks, as ``make
    demo`` runs it (``mpirun -np 2``, launched by hand with ``-prepend-rank``).

    ``stdout`` is returned without the ``[rank] `` prefixes; ``rank_lines`` on the
    process lists ``(rank, line)`` of every output line (under MPI only rank 0
    prints)."""
    out = tmp_path_factory.mktemp("paper") / "quick-out"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run([os.path.join(BIN, "mpirun"), "-np", "2", "-prepend-rank",
                           sys.executable, "-m", "remote_trigger.pywrap.cli", "paper",
                           "--quick", "--out", str(out)], capture_output=True, text=True,
                          env=env, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    # hydra prefixes every chunk a rank writes with "[rank] " (a chunk may start
    # mid-line): split the output at the prefixes
    parts = re.split(r"\[(\d+)\] ", proc.stdout)
    proc.rank_lines = [(int(r), t) for r, t in zip(parts[1::2], parts[2::2]) if t.strip()]
    proc.stdout = parts[0] + "".join(parts[2::2])
    return str(out), proc
