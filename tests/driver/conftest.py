"""Shared fixtures of the driver tests: one small packing, relaxed once.

Tests import the installed package (``remote_trigger.pywrap``), never the
source folders. N = 20 keeps every stage to seconds.
"""
import os
import sys

import pytest

N_SMALL = 20
SEED = 1

BIN = os.path.dirname(sys.executable)
LMP = os.path.join(BIN, "lmp")
MPIRUN = os.path.join(BIN, "mpirun")
CLI = os.path.join(BIN, "remote-trigger")


def cli_env():
    """Environment for subprocesses (quiet OpenMP, one thread)."""
    env = dict(os.environ)
    env.setdefault("OMP_NUM_THREADS", "1")
    return env


@pytest.fixture(scope="session")
def packing_file(tmp_path_factory):
    from remote_trigger.pywrap.stages.packing import generate, write_data

    path = tmp_path_factory.mktemp("packing") / "p20.data"
    write_data(generate(N_SMALL, seed=SEED), path)
    return str(path)


@pytest.fixture(scope="session")
def relaxed(tmp_path_factory, packing_file):
    """Relax result of the small packing (settled, Newton-polished)."""
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap import stages

    out = tmp_path_factory.mktemp("relax")
    cfg = RelaxConfig(datafile=packing_file, settle_steps=20000)
    return stages.relax(cfg, str(out), quiet=True)
