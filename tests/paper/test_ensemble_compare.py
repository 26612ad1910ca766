"""``ensemble --compare``: the laws of several finished ensembles side by side.

The kept 52-packing run of disks (docs/results/runs/N100_10000_s52, its
table rebuilt by ``--resume``) against its packings' own result files; a
made-up table of spheres whose F_x^c follows a known power law; the
refusals.
"""
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.ensemble.compare import compare_runs, read_run_rows
from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig
from remote_trigger.pywrap.jobs.ensemble.job import run_ensemble
from remote_trigger.pywrap.jobs.ensemble.report import COLUMNS, STR_COLS, write_table

RUNS = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "results", "runs")


@pytest.fixture(scope="module")
def disks(tmp_path_factory):
    """The kept 52-packing run with its ensemble.h5 (``--resume``: nothing computed)."""
    from mpi4py import MPI

    path = tmp_path_factory.mktemp("cmp") / "s52"
    shutil.copytree(os.path.join(RUNS, "N100_10000_s52"), path)
    with open(path / "config.json") as fh:
        cfg = EnsembleConfig.from_dict(json.load(fh))
    run_ensemble(cfg, str(path), comm=MPI.COMM_SELF, speak=False, resume=True)
    return str(path)


def _spheres(path, law=(0.02, -0.7), seed=0, **keys):
    """A made-up finished ensemble of spheres at N = 160, 640 and 2560 (8
    packings each) whose F_x^c(mu0) / F_y is law[0] N^law[1] times a log-normal
    scatter, seed 1 of N = 640 a soft-mode onset, one failed row; ``keys``
    more keys of its configuration."""
    cfg = EnsembleConfig.from_dict({"dim": 3, "phi": 0.64, "frictional": False, "inertia_I0": None,
                                    "inertia_extra_steps": None, "n": [160, 640, 2560],
                                    "seeds": list(range(1, 9)), **keys})
    rng = np.random.default_rng(seed)
    rows = []
    for n in cfg.n:
        for s in range(1, 9):
            r = {c: ("" if c in STR_COLS else math.nan) for c in COLUMNS}
            f = law[0] * n ** law[1] * math.exp(0.3 * rng.standard_normal()) * cfg.F_y
            r.update(key=f"N{n}_s{s}", n=n, seed=s, protocol="frictionless-then-friction",
                     I0=cfg.I0_dynamics, dynamics_consistent=1, status="ok", F_x_c=f,
                     F_x_c_ss=0.9 * f, ratio=0.9, order=1, soft_onset=0, commit="abc",
                     cpu="test CPU", clearance="local")
            if n == 640 and s == 1:
                r["soft_onset"] = 1
            if n == 2560 and s == 8:
                r.update(status="failed", F_x_c=math.nan)
            rows.append(r)
    os.makedirs(path)
    with open(os.path.join(path, "config.json"), "w") as fh:
        json.dump(cfg.to_dict(), fh)
    write_table(os.path.join(path, "ensemble.h5"), rows, cfg)
    return str(path)


def test_the_disks_law_is_that_of_the_packings_result_files(disks, tmp_path):
    """The exponents compare.md gives are those of an ordinary least-squares
    line (scipy.stats.linregress) through ln(F_x^c / F_y) of the packings'
    result files (bracket midpoints at mu0), stiff onsets apart; the
    referee's numbers of the kept run (-0.86 [-0.96, -0.75] stiff, -0.92
    [-1.05, -0.80] every onset)."""
    md = compare_runs([disks], str(tmp_path / "out"), speak=False)
    text = open(md).read()
    n, f = [], []
    for name in sorted(os.listdir(os.path.join(disks, "tasks"))):
        with open(os.path.join(disks, "tasks", name)) as fh:
            res = json.load(fh)["result"]["default"]
        mu0 = res["ramps"]["mu0"]["I0_0.5"]
        lo, hi = mu0.get("F_x_c_low"), mu0.get("F_x_c_high")
        if not (isinstance(lo, float) and isinstance(hi, float) and lo == lo and hi == hi):
            continue
        n.append(int(name.split("_")[0][1:]))
        f.append(0.5 * (lo + hi) / 3.0)
    n, f = np.array(n, float), np.array(f)
    run = read_run_rows(disks)
    nn, ff = run.loads()
    np.testing.assert_allclose(np.array(sorted(zip(nn, ff))), np.array(sorted(zip(n, f))),
                               rtol=1e-12)
    every = stats.linregress(np.log(n), np.log(f)).slope
    assert f"N^{every:.3g}" in text
    ns, fs = run.loads(stiff_only=True)
    stiff = stats.linregress(np.log(ns), np.log(fs)).slope
    assert f"N^{stiff:.3g}" in text
    assert "N^-0.859 (95 % bootstrap interval [-0.964, -0.747]" in text
    assert "N^-0.917 (95 % bootstrap interval [-1.05, -0.795]" in text
    assert "| 10000 | 2 (0) |" in text and "| 100 | 20 (0) |" in text
    assert os.path.getsize(tmp_path / "out" / "compare.png") > 10_000


def test_spheres_beside_disks_recover_a_planted_law(disks, tmp_path):
    sph = _spheres(tmp_path / "sph")
    md = compare_runs([disks, sph], str(tmp_path / "out"), speak=False)
    text = open(md).read()
    assert "## disks, free top line (s52)" in text and "## spheres, free top layer (sph)" in text
    part = text[text.index("## spheres"):]
    assert "| 640 | 8 (1) |" in part and "| 2560 | 7 (0) |" in part     # failed row left out
    # the planted exponent -0.7, within the bootstrap interval printed
    line = next(x for x in part.splitlines() if x.startswith("- stiff onsets"))
    b = float(line.split("N^")[1].split(" ")[0])
    lo, hi = (float(v) for v in line.split("interval [")[1].split("]")[0].split(", "))
    assert lo < -0.7 < hi and abs(b + 0.7) < 0.15
    assert "abc" in part and "test CPU" in part and "local" in part


def test_refusals_name_the_value(disks, tmp_path):
    with pytest.raises(ConfigError, match="given twice"):
        compare_runs([disks, disks + "/"], str(tmp_path / "a"), speak=False)
    empty = tmp_path / "empty"
    os.makedirs(empty)
    (empty / "config.json").write_text((open(os.path.join(disks, "config.json")).read()))
    with pytest.raises(ConfigError, match="no ensemble.h5 there"):
        compare_runs([str(empty)], str(tmp_path / "b"), speak=False)
    with pytest.raises(ConfigError, match="no such folder"):
        compare_runs([str(tmp_path / "nowhere")], str(tmp_path / "c"), speak=False)
    out = tmp_path / "d"
    os.makedirs(out)
    (out / "compare.md").write_text("mine")
    with pytest.raises(ConfigError, match="exists; give another --out"):
        compare_runs([disks], str(out), speak=False)
    assert (out / "compare.md").read_text() == "mine" and not (out / "compare.png").exists()


def test_two_folders_of_one_name_are_told_apart(disks, tmp_path):
    a = _spheres(tmp_path / "a" / "run", seed=1)
    b = _spheres(tmp_path / "b" / "run", seed=2)
    text = open(compare_runs([a, b], str(tmp_path / "out"), speak=False)).read()
    assert f"## spheres, free top layer ({a})" in text
    assert f"## spheres, free top layer ({b})" in text


def test_each_folder_names_its_loading_and_steps(disks, tmp_path):
    """Disks' free top line, spheres' free layer and the rigid plate are named
    in the headings and the figure's legend; each folder's ramp steps per N."""
    free = _spheres(tmp_path / "free", seed=1)
    plate = _spheres(tmp_path / "plate", seed=2, relax={"top_layer": "rigid"},
                     dF_x=[5e-5, 5e-5, 2e-5], between=3, dF_x_max=5e-4)
    runs = [read_run_rows(p) for p in (disks, free, plate)]
    assert [r.loading for r in runs] == ["free top line", "free top layer",
                                         "top layer a rigid plate"]
    text = open(compare_runs([disks, free, plate], str(tmp_path / "out"), speak=False)).read()
    assert "## spheres, top layer a rigid plate (plate)" in text
    assert "ramp steps dF_x = 5e-05 (N = 160), 5e-05 (N = 640), 2e-05 (N = 2560) " \
           "(adaptive, up to 0.0005), sub-steps per step (`between`) 3" in text
    assert "## disks, free top line (s52)" in text and "ramp steps dF_x = 0.00025," in text


def test_the_command_line(disks, tmp_path):
    cmd = [sys.executable, "-m", "remote_trigger.pywrap.cli", "ensemble"]
    got = subprocess.run(cmd + ["--compare", disks, "--out", str(tmp_path / "o")],
                         capture_output=True, text=True)
    assert got.returncode == 0, got.stderr
    assert (tmp_path / "o" / "compare.md").is_file()
    for extra in (["--resume"], ["--combine", disks]):
        bad = subprocess.run(cmd + ["--compare", disks, "--out", str(tmp_path / "p")] + extra,
                             capture_output=True, text=True)
        assert bad.returncode == 2 and bad.stderr.count("\n") == 1, bad.stderr
        assert ("--resume" in bad.stderr) if extra == ["--resume"] else ("--combine" in bad.stderr)


def test_the_kept_runs_of_disks_and_spheres_give_the_docs_numbers(disks, tmp_path):
    """The kept 20-packing run of spheres (docs/results/runs/N160_640_3d, its
    table rebuilt by ``--resume``) beside the disks: the numbers
    docs/ensemble.md quotes (section Spheres)."""
    from mpi4py import MPI

    sph = tmp_path / "N160_640_3d"
    shutil.copytree(os.path.join(RUNS, "N160_640_3d"), sph)
    with open(sph / "config.json") as fh:
        cfg = EnsembleConfig.from_dict(json.load(fh))
    run_ensemble(cfg, str(sph), comm=MPI.COMM_SELF, speak=False, resume=True)
    run = read_run_rows(str(sph))
    assert len(run.rows) == 20 and {int(r["n"]) for r in run.rows} == {160, 640}
    order = [int(r["order"]) for r in run.rows]
    assert (order.count(1), order.count(0), order.count(-1)) == (14, 6, 0)
    text = open(compare_runs([disks, str(sph)], str(tmp_path / "out"), speak=False)).read()
    part = text[text.index("## spheres"):]
    assert "N^-0.793 (95 % bootstrap interval [-1.21, -0.357]" in part
    assert "| 160 | 12 (0) | 0.002246 [0.001691, 0.005041] |" in part
    assert "| 640 | 8 (0) | 0.0009142 [0.0005883, 0.001033] |" in part
    assert "two sizes: a line through two clouds" in part
