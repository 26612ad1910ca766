"""Continuation is exact: data-file and restart round trips, and np=1 vs np=2.

A sheared packing with sliding contacts is continued for 1000 steps (all
disks pushed down, the upper ones also sideways). Forces of each disk are
summed in ascending partner ID, so the result does not depend on the
neighbor-list order, the atom order after read_data, or the domain
decomposition: runs must agree bitwise.

The reference for a file round trip at step 500 is the same run split into
two ``run`` commands at step 500: at a run boundary (as in write_data) LAMMPS
remaps periodic atoms into the box, and x + L rounds when x is slightly
negative, so an unsplit run differs from any split one at round-off level.
That is LAMMPS's behaviour, independent of the contact history; it is
measured below as well.
"""
import os
import subprocess
import sys

import numpy as np
import pytest

from . import lmputil, runner

NSTEPS = 1000


@pytest.fixture(scope="module")
def start(tmp_path_factory):
    """A settled, sheared packing of 200 disks written to a data file."""
    d = tmp_path_factory.mktemp("repro")
    lmp = lmputil.new_lammps()
    _, height = lmputil.settled_packing(lmp, 200, seed=7, steps=20000, shear=0.3)
    path = str(d / "start.data")
    lmp.command(f"write_data {path} pair ij")
    y = lmputil.gather(lmp, "x", 3)[:, 1]
    lmp.close()
    return path, float(np.quantile(y, 0.8)), d


def assert_same(a, b):
    for key in a:
        assert np.array_equal(a[key], b[key]), f"{key} differs: max |diff| = " \
            f"{np.abs(a[key] - b[key]).max():.3g}"


@pytest.fixture(scope="module")
def reference(start):
    path, upper, _ = start
    out = runner.continue_run(path, NSTEPS, upper)
    # the test is meaningful only if contacts slide and history changes
    assert np.count_nonzero(out["i2_mindlin_partner"]) > 300
    assert np.abs(out["v"]).max() > 1e-3
    return out


@pytest.fixture(scope="module")
def split_reference(start):
    path, upper, _ = start
    return runner.continue_run(path, NSTEPS, upper, split=NSTEPS // 2, mode="split")


def test_split_run_differs_from_unsplit_only_by_remap_round_off(reference, split_reference):
    dx = np.abs(reference["x"] - split_reference["x"]).max()
    assert dx < 1e-10, dx


@pytest.mark.parametrize("mode", ["data", "restart"])
def test_file_round_trip_continues_identically(start, split_reference, mode, tmp_path):
    path, upper, _ = start
    out = runner.continue_run(path, NSTEPS, upper, split=NSTEPS // 2, mode=mode,
                              workdir=str(tmp_path))
    assert_same(split_reference, out)


@pytest.mark.mpi
@pytest.mark.parametrize("np_", [1, 2])
def test_mpi_ranks_agree_bitwise(start, reference, np_, tmp_path):
    path, upper, _ = start
    mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
    out = str(tmp_path / "state.npz")
    cmd = [mpirun, "-np", str(np_), sys.executable, runner.__file__, path, out,
           str(NSTEPS), repr(upper)]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    got = dict(np.load(out))
    assert_same(reference, got)
