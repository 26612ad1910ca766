"""A decision on part of the spectrum is labelled partial, never a verdict.

``remote-trigger jacobian`` decides on the whole spectrum: with the dense
path up to ``eigen.DENSE_MAX`` dofs, above it by spectrum slicing (both the
stability verdict). ``--method sparse`` decides on the k eigenvalues nearest
a shift only: that is printed and stored as a partial decision (``coverage
= 'partial'``, ``complex_pair = -1``). Tested on a small packing and on the
stored N = 1600 packing (4800 dofs, above the switch).
"""
import os
import sys

import numpy as np
import pytest

from remote_trigger.analysis.stability import eigen
from remote_trigger.pywrap.cli import main

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", ".."))
from tests.analysis.builders import random_packing, write_dump  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks"))
from bench_scale import STORED as _BENCH_PACKINGS  # noqa: E402

STORED = _BENCH_PACKINGS[1600]


def _jacobian(capsys, *args):
    status = main(["jacobian", *map(str, args)])
    return status, capsys.readouterr().out


def test_sparse_path_is_a_partial_decision(capsys, tmp_path):
    st = random_packing(21, nx=10, ny=8, xi_scale=0.3, cap_fraction=0.2)
    dump = write_dump(tmp_path / "eq.dump", st)
    status, out = _jacobian(capsys, dump, "-o", tmp_path / "s.npz", "--method", "sparse",
                            "--k", 8, "--allow-residual")
    assert status == 0
    assert "partial decision (8 of " in out and "not a stability verdict" in out
    assert "complex pair: " not in out
    d = np.load(tmp_path / "s.npz")
    assert str(d["coverage"]) == "partial" and int(d["complex_pair"]) == -1
    assert int(d["partial_complex_pair"]) in (0, 1, -1)
    # the dense path on the same dump is the verdict (the check above can fail)
    status, out = _jacobian(capsys, dump, "-o", tmp_path / "d.npz", "--method", "dense",
                            "--allow-residual")
    d = np.load(tmp_path / "d.npz")
    assert status == 0 and "complex pair: " in out and "partial decision" not in out
    assert str(d["coverage"]) == "whole" and int(d["complex_pair"]) in (0, 1)
    assert int(d["partial_complex_pair"]) == -1


@pytest.mark.slow
@pytest.mark.skipif(not os.path.exists(STORED), reason="stored N = 1600 packing not present")
def test_above_the_dense_switch_the_default_is_the_sliced_verdict(capsys, tmp_path):
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium
    from remote_trigger.pywrap.stages.config import RampConfig

    F_x = 5e-4
    cfg = RampConfig(datafile=STORED, dF_x=2.5e-4, F_x=0.0)
    with Engine() as eng:
        load_relax_scene(eng, cfg, STORED, F_x, deck="in.ramp_step")
        eq.equilibrate(eng, cfg, F_x, newton_first=True)
        prefix = str(tmp_path / "n1600")
        save_equilibrium(eng, cfg, F_x, prefix)
    status = main(["jacobian", prefix + ".dump", "-o", str(tmp_path / "K.npz")])
    cap = capsys.readouterr()
    out = cap.out
    d = np.load(tmp_path / "K.npz")
    assert status == 0
    assert d["keep_dofs"].size > eigen.DENSE_MAX            # above the switch
    # the sliced verdict's progress bar (stderr), up to every eigenvalue
    n = d["keep_dofs"].size
    assert "verdict" in cap.err and f"{n}/{n}" in cap.err
    assert "complex pair: no" in out and "partial decision" not in out
    assert "eigenvalues (sliced)" in out
    assert "approximate (the symmetric part's Ritz values outside pairs)" in out
    # whole spectrum, certified real (the N = 1600 ramp turns complex above F_x = 0.0025)
    assert str(d["coverage"]) == "whole" and int(d["complex_pair"]) == 0
    assert str(d["method"]) == "sliced" and d["eigenvalues"].size == d["keep_dofs"].size
