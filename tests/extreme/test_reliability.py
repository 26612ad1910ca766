"""Reliability: corrupted analyzer inputs fail clearly; memory stays flat in long runs.

Only what ``tests/analysis/test_state.py`` does not already cover: a header
whose column count disagrees with the rows, scaled/unwrapped coordinates
instead of x y, duplicate ids, inf positions, NaN in the history and in the
sidecar, a negative radius, and a LAMMPS data file with overlapping centres
read through the driver's path into the analyzer. Then a 20,000-step
undamped LAMMPS run in chunks with the RSS measured.
"""
import json

import numpy as np
import pytest

from remote_trigger.analysis.state.dumpfile import read_dump

from ..analysis.builders import random_packing, write_dump
from . import lmp_helpers as H


@pytest.fixture(scope="module")
def packing():
    return random_packing(seed=5)


def _edit(path, fn):
    lines = open(path).read().splitlines()
    lines = fn(lines)
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")


def test_header_and_rows_disagree(tmp_path, packing):
    path = write_dump(tmp_path / "a.dump", packing)
    _edit(path, lambda L: L[:8] + [L[8] + " extra"] + L[9:])
    with pytest.raises(ValueError, match="expected .* values"):
        read_dump(path)


@pytest.mark.parametrize("new", ["xs ys", "xu yu"])
def test_scaled_or_unwrapped_coordinates_are_named(tmp_path, packing, new):
    path = write_dump(tmp_path / "b.dump", packing)
    _edit(path, lambda L: L[:8] + [L[8].replace(" x y ", f" {new} ")] + L[9:])
    with pytest.raises(ValueError, match=r"missing dump columns \['x', 'y'\]"):
        read_dump(path)


def test_duplicate_id(tmp_path, packing):
    path = write_dump(tmp_path / "c.dump", packing)

    def dup(L):
        first = L[9].split()
        second = L[10].split()
        second[0] = first[0]
        L[10] = " ".join(second)
        return L
    _edit(path, dup)
    with pytest.raises(ValueError, match="appears twice"):
        read_dump(path)


@pytest.mark.parametrize("col,val", [("y", "inf"), ("d2_mindlin_t[1]", "nan"),
                                     ("radius", "-0.5")])
def test_bad_values(tmp_path, packing, col, val):
    path = write_dump(tmp_path / "d.dump", packing)

    def poison(L):
        cols = L[8].split()[2:]
        parts = L[12].split()
        parts[cols.index(col)] = val
        L[12] = " ".join(parts)
        return L
    _edit(path, poison)
    with pytest.raises(ValueError, match="non-finite|must be > 0"):
        read_dump(path)


def test_nan_in_sidecar(tmp_path, packing):
    path = write_dump(tmp_path / "e.dump", packing)
    side = json.load(open(str(path) + ".json"))
    side["k_n"] = float("nan")
    json.dump(side, open(str(path) + ".json", "w"))      # Python writes NaN literally
    with pytest.raises(ValueError, match="k_n must be a finite number"):
        read_dump(path)


def test_data_file_with_overlapping_centres(tmp_path):
    """A data file whose centres overlap: LAMMPS reads it, the driver's conversion to
    the analyzer (newton_solve.analysis_state) refuses it with the atom ids."""
    from remote_trigger.pywrap.stages import newton_solve
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.packing import generate, write_data

    p = generate(20, seed=3)
    pos = p.positions.copy()
    pos[5] = pos[4] + [0.01, 0.0]
    import dataclasses
    bad = dataclasses.replace(p, positions=pos)
    path = str(tmp_path / "bad.data")
    write_data(bad, path)
    cfg = RelaxConfig(datafile=path)
    with Engine() as eng:
        stages.load_relax_scene(eng, cfg, path, 0.0)
        eng.run(0)
        st = eng.gather_state()
        with pytest.raises(ValueError, match=r"overlapping centres: atom ids 5 and 6"):
            newton_solve.analysis_state(st, cfg.k_n, cfg.k_t, cfg.mu, 0.0, cfg.F_y)


def _rss_kb():
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def test_long_run_memory_is_flat():
    """20,000 undamped steps of 96 frictional disks in 40 chunks of 500, gathering
    the state after every chunk (what the driver's undamped stages do): the RSS
    after the first 5 chunks and at the end differ by < 2 MB (measured: 64 kB)."""
    k_n = 2e5
    d0 = (3.0 / k_n) ** (2.0 / 3.0)
    pos, R, L = H.lattice(12, 8, d0)
    v = np.random.default_rng(3).normal(size=pos.shape) * np.sqrt(3.0 * d0)
    lmp = H.scene(pos, R, k_n, 2 * k_n / 7, 1.0, 1e-3, width=L, velocities=v,
                  ylo=-1.0, yhi=40.0)
    rss = []
    for k in range(40):
        lmp.command("run 500 pre no post no")
        a = H.arrays(lmp)
        assert np.all(np.isfinite(a["x"]))
        rss.append(_rss_kb())
    assert lmp.extract_global("ntimestep") == 20000
    lmp.close()
    growth = rss[-1] - rss[4]
    print(f"RSS after 2500 steps {rss[4]} kB, after 20000 steps {rss[-1]} kB, "
          f"growth {growth} kB")
    assert growth < 2048, rss
