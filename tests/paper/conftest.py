"""One ``remote-trigger paper --quick`` run shared by the paper and trigger-map tests."""
import os
import subprocess
import sys

import pytest

BIN = os.path.dirname(sys.executable)
CLI = os.path.join(BIN, "remote-trigger")


@pytest.fixture(scope="session")
def paper_quick(tmp_path_factory):
    """(output folder, CompletedProcess) of ``paper --quick``."""
    out = tmp_path_factory.mktemp("paper") / "quick-out"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run([CLI, "paper", "--quick", "--out", str(out)], capture_output=True,
                          text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return str(out), proc
