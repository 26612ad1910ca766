"""examples/pour/in.pour: fix pour into a walled 2D box with stock granular and
with mindlin/smooth (only the pair and wall lines differ), on 1 and 2 ranks."""
import os
import re
import subprocess
import sys

import numpy as np
import pytest

BIN = os.path.dirname(sys.executable)
DECK = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "pour", "in.pour")
NDISKS = 300


def run_pour(tmp_path, pair, nprocs):
    out = tmp_path / f"{pair}_np{nprocs}"
    cmd = ([os.path.join(BIN, "mpirun"), "-np", str(nprocs)] if nprocs > 1 else []) + [
        os.path.join(BIN, "lmp"), "-in", os.path.abspath(DECK), "-var", "pair", pair,
        "-var", "out", str(out), "-log", str(out) + ".log", "-screen", "none"]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
    log = open(str(out) + ".log").read()
    assert res.returncode == 0, log[-3000:] + res.stderr[-2000:]
    neigh = float(re.findall(r"Ave neighs/atom = (\S+)", log)[-1])
    natoms = int(re.findall(r"Loop time of \S+ on \d+ procs for \d+ steps with (\d+) atoms",
                            log)[-1])
    dump = np.loadtxt(f"{out}.{pair}.dump", skiprows=9)
    return natoms, neigh, dump


def overlaps(dump):
    """Largest overlap of any two disks and of any disk with a wall, over R."""
    r, x, y = dump[:, 1], dump[:, 2], dump[:, 3]
    d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    ov = (r[:, None] + r[None, :] - d) / np.minimum(r[:, None], r[None, :])
    np.fill_diagonal(ov, -np.inf)
    wall = np.max(np.stack([r - x, r - (20.0 - x), r - y]) / r, axis=0)
    return ov.max(), wall.max()


@pytest.fixture(scope="module")
def pours(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pour")
    return {(pair, n): run_pour(tmp, pair, n)
            for pair in ("granular", "mindlin") for n in (1, 2)}


@pytest.mark.mpi
@pytest.mark.parametrize("nprocs", [1, 2])
def test_pour_mindlin_like_stock(pours, nprocs):
    n_stock, neigh_stock, dump_stock = pours[("granular", nprocs)]
    n_ours, neigh_ours, dump_ours = pours[("mindlin", nprocs)]
    assert n_stock == n_ours == NDISKS
    # ours is a full list (each pair twice), stock a half list
    half = neigh_ours / 2.0
    assert 1.0 < neigh_stock < 4.0
    assert 0.5 * neigh_stock < half < 2.0 * neigh_stock, (half, neigh_stock)
    # the disks stay between the walls and above the floor, and none passes
    # through another (the last ones inserted are still falling)
    for dump in (dump_stock, dump_ours):
        disk, wall = overlaps(dump)
        assert 0.0 < disk < 0.05 and wall < 0.05, (disk, wall)


@pytest.mark.mpi
def test_pour_mindlin_np1_equals_np2(pours):
    np.testing.assert_array_equal(pours[("mindlin", 1)][2], pours[("mindlin", 2)][2])
