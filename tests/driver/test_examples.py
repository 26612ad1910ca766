"""The examples run as documented: the stage decks through ``lmp -in`` and the
Python-driver script (small N)."""
import os
import subprocess
import sys

import numpy as np

from .conftest import cli_env
from remote_trigger.analysis.stability.decision import Decision

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
BIN = os.path.dirname(sys.executable)


def _env():
    env = cli_env()
    env["PATH"] = BIN + os.pathsep + env.get("PATH", "")
    return env


def test_stage_decks_script(tmp_path):
    from remote_trigger.pywrap.bindings.decks import DECK_DIR
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.state.dumpfile import read_dump

    script = os.path.join(ROOT, "examples", "stages", "run_stages.sh")
    p = subprocess.run(["sh", script, "20", "1", DECK_DIR], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    assert analyze(read_dump(str(tmp_path / "relaxed.dump"))).decision.decision is Decision.REAL
    st = read_dump(str(tmp_path / "step.dump"))
    assert st.F_x == 0.001
    rows = np.loadtxt(tmp_path / "perturb.txt")         # step time D v_top mu
    assert rows.shape[1] == 5 and np.min(rows[:, 4]) < 1.0


def test_python_driver_script(tmp_path):
    script = os.path.join(ROOT, "examples", "python", "relax_ramp_analyze.py")
    p = subprocess.run([sys.executable, script, "--n", "20", "--steps", "3", "--out",
                        str(tmp_path / "run")], env=_env(), capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    lines = p.stdout.splitlines()
    assert lines[0].startswith("relax: phi = ") and "verdict at F_x = 0: real (margin " in lines[0]
    assert sum(s.startswith("F_x = ") for s in lines) >= 3
    assert lines[-1].startswith("ramp: ") and "nan" not in lines[-1]
    # a second run into the same folder: a one-line usage error, nothing touched
    before = sorted(os.listdir(tmp_path / "run"))
    p = subprocess.run([sys.executable, script, "--n", "20", "--out", str(tmp_path / "run")],
                       env=_env(), capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and "exists" in p.stderr and "Traceback" not in p.stderr
    assert sorted(os.listdir(tmp_path / "run")) == before
