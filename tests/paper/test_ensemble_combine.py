"""``ensemble --combine``: the finished packings of several runs in one table.

The reference ``--quick`` run of tests/data/ensemble_quick2d (N = 16 seeds
1, 2 and N = 20 seed 1, made in one run) is split into two runs, one per
size; combined again, they give that run's configuration and table.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.ensemble.job import combine_runs

from .ensemble_reference import REF, assert_reference_columns


def _run_folder(path, n, seeds, keys, **change):
    """An ensemble folder of the reference run's packings ``keys``, with its
    configuration restricted to size n and ``seeds`` (and ``change``)."""
    with open(os.path.join(REF, "config.json")) as fh:
        cfg = dict(json.load(fh), n=[n], seeds=[seeds], **change)
    os.makedirs(path / "tasks")
    (path / "config.json").write_text(json.dumps(cfg))
    for k in keys:
        shutil.copyfile(os.path.join(REF, k + ".json"), path / "tasks" / (k + ".json"))
    return str(path)


@pytest.fixture
def runs(tmp_path):
    a = _run_folder(tmp_path / "a", 16, [1, 2], ["N16_s1", "N16_s2"])
    # a run of N = 20 whose seed 2 did not finish
    b = _run_folder(tmp_path / "b", 20, [1, 2], ["N20_s1"])
    return a, b


def test_combined_runs_give_the_single_runs_table(runs, tmp_path, capsys):
    out = tmp_path / "both"
    combine_runs(runs, str(out))
    with open(os.path.join(REF, "config.json")) as fh:
        assert json.loads((out / "config.json").read_text()) == json.load(fh)
    assert_reference_columns(out / "ensemble.h5")
    man = json.loads((out / "ensemble.json").read_text())
    assert man["combined_from"] == [os.path.abspath(r) for r in runs]
    assert man["left_out"] == [f"N20_s2 ({os.path.abspath(runs[1])})"]
    assert man["sessions"][-1]["computed"] == []          # nothing recomputed
    said = capsys.readouterr().out
    assert "combined 3 finished packing(s) of 2 runs: N = 16: 2, N = 20: 1" in said
    assert "left out (not finished): N20_s2" in said
    assert (out / "ensemble.md").is_file() and (out / "ensemble.png").is_file()


def test_refusals_name_the_value(runs, tmp_path):
    a, b = runs
    # (tol may be one per N: another tol at N = 16 itself)
    c = _run_folder(tmp_path / "c", 16, [3], [], tol=1e-3)
    with pytest.raises(ConfigError, match=r"differ in tol \(0.002 vs 0.001\) for N = 16"):
        combine_runs([a, c], str(tmp_path / "o1"))
    # every key that differs is named (the first alone was)
    c = _run_folder(tmp_path / "c2", 20, [1], ["N20_s1"], frictional_relax={"max_steps": 1},
                    phi=0.6)
    with pytest.raises(ConfigError, match=r"differ in frictional_relax \(\{'max_steps': 50000\} "
                                          r"vs \{'max_steps': 1\}\); phi \(0.82 vs 0.6\); only "
                                          r"n, seeds, np and part_size may differ$"):
        combine_runs([a, c], str(tmp_path / "o1"))
    with pytest.raises(ConfigError, match="packing N16_s1 is finished in both"):
        combine_runs([a, b, a], str(tmp_path / "o2"))
    with pytest.raises(ConfigError, match="at least two ensemble folders, got 1"):
        combine_runs([a], str(tmp_path / "o3"))
    with pytest.raises(ConfigError, match="no config.json there"):
        combine_runs([a, str(tmp_path)], str(tmp_path / "o4"))
    with pytest.raises(ConfigError, match="'.*missing': no such folder"):
        combine_runs([a, str(tmp_path / "missing")], str(tmp_path / "o4"))
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x.txt").write_text("x")
    with pytest.raises(ConfigError, match="holds other files"):
        combine_runs([a, b], str(tmp_path / "full"))
    # a folder of another job: named as such (it said "unknown configuration key")
    (tmp_path / "map").mkdir()
    (tmp_path / "map" / "config.json").write_text('{"paper": "q", "a_max_factor": 2}')
    with pytest.raises(ConfigError, match="'.*map' is not an ensemble folder"):
        combine_runs([a, str(tmp_path / "map")], str(tmp_path / "o4"))
    # a folder combined before: a new --out, not --resume (which --combine refuses)
    combine_runs([a, b], str(tmp_path / "done"))
    with pytest.raises(ConfigError, match="holds a job already: --combine writes a new folder"):
        combine_runs([a, b], str(tmp_path / "done"))
    for o in ("o1", "o2", "o3", "o4"):
        assert not (tmp_path / o).exists()            # nothing written
    r = subprocess.run([sys.executable, "-m", "remote_trigger.pywrap.cli", "ensemble",
                        "--combine", a, b, "--out", str(tmp_path / "o5"), "--set", "tol=1"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "drop --set" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_combined_folder_resumes_with_its_own_config_json(runs, tmp_path):
    """``--config`` takes the combined folder's config.json (JSON with nulls,
    which no TOML file can give), so ``--resume`` finds the same configuration
    and rewrites the table, computing nothing."""
    from remote_trigger.pywrap.cli import main as cli_main

    out = tmp_path / "both"
    combine_runs(runs, str(out), speak=False)
    (out / "ensemble.md").unlink()
    code = cli_main(["ensemble", "--out", str(out), "--resume", "--quiet",
                     "--config", str(out / "config.json")])
    assert code == 0 and (out / "ensemble.md").is_file()
    man = json.loads((out / "ensemble.json").read_text())
    assert man["sessions"][-1]["computed"] == []


def _record_escape(folder, key, value):
    """Mark packing ``key`` of an ensemble folder as run with saddle_escape = value."""
    path = os.path.join(folder, "tasks", key + ".json")
    with open(path) as fh:
        d = json.load(fh)
    d["result"]["saddle_escape"] = value
    with open(path, "w") as fh:
        json.dump(d, fh)


def test_packings_with_and_without_the_saddle_escape_are_not_mixed(runs, tmp_path):
    """The reference packings record nothing (run before the escape: without
    it); a run whose packings escaped saddles is not combined with them, and a
    folder whose packing recorded False is not resumed with the escape on."""
    from mpi4py import MPI

    from remote_trigger.pywrap.jobs.ensemble import config as ec
    from remote_trigger.pywrap.jobs.ensemble.job import run_ensemble

    a, b = runs
    _record_escape(b, "N20_s1", True)
    with pytest.raises(ConfigError, match="packing N20_s1 .* was run with saddle_escape = "
                                          "True, N16_s1 .* without it"):
        combine_runs([a, b], str(tmp_path / "o1"))
    assert not (tmp_path / "o1").exists()
    # both recorded True: combined, and the combined configuration has the default
    _record_escape(a, "N16_s1", True)
    _record_escape(a, "N16_s2", True)
    combine_runs([a, b], str(tmp_path / "o2"))
    assert "saddle_escape" not in json.loads((tmp_path / "o2" / "config.json").read_text())
    # a folder of the reference run whose packing N16_s2 recorded False
    c = _run_folder(tmp_path / "c", 16, [1, 2], ["N16_s1", "N16_s2"])
    _record_escape(c, "N16_s2", False)
    cfg = ec.build_config(quick=True, overrides={"n": [16], "seeds": [[1, 2]]})
    with pytest.raises(ConfigError, match="packing N16_s2 was run with saddle_escape = "
                                          "False, this run has saddle_escape = True"):
        run_ensemble(cfg, c, comm=MPI.COMM_SELF, speak=False, resume=True)
    assert not os.path.exists(os.path.join(c, "ensemble.md"))


def _add_local_seed3(folder):
    """Put into an ensemble folder's tasks/ a packing N16_s3 (the reference's
    N16_s1 renamed) whose relaxation recorded the clearance test 'local'."""
    with open(os.path.join(REF, "N16_s1.json")) as fh:
        d = json.load(fh)
    d["task"] = dict(d["task"], key="N16_s3", seed=3)
    d["result"] = dict(d["result"], seed=3)
    d["result"]["default"]["clearance_rule"] = "local"
    (folder / "tasks" / "N16_s3.json").write_text(json.dumps(d))


def test_packings_of_one_n_relaxed_by_two_clearance_tests_are_not_mixed(runs, tmp_path):
    """The reference packings record no clearance test (relaxed before 'local'
    existed: 'all'); a packing of the same N recorded 'local' is not combined
    with them, one of another N is."""
    a, b = runs
    c = _run_folder(tmp_path / "c", 16, [3], [])
    _add_local_seed3(tmp_path / "c")
    with pytest.raises(ConfigError, match=r"packing N16_s1 \('.*a'\) was relaxed with the "
                                          r"clearance test 'all', N16_s3 \('.*c'\) with "
                                          r"'local'"):
        combine_runs([a, c], str(tmp_path / "o1"))
    assert not (tmp_path / "o1").exists()
    path = os.path.join(b, "tasks", "N20_s1.json")
    with open(path) as fh:
        e = json.load(fh)
    e["result"]["default"]["clearance_rule"] = "local"
    with open(path, "w") as fh:
        json.dump(e, fh)
    combine_runs([a, b], str(tmp_path / "o2"), speak=False)       # N = 20 alone is 'local'
    assert (tmp_path / "o2" / "ensemble.md").is_file()


def test_runs_that_set_the_clearance_test_combine_with_runs_that_did_not(runs, tmp_path):
    """A run made with ``relax.clearance = 'all'`` relaxed its packings as the
    reference run did (its packings record no test: 'all'), so the two
    combine; the combined ``relax`` leaves the setting out (it is per packing).
    Any other ``relax`` key still has to agree, and 'local' packings of one N
    are still refused beside 'all' ones."""
    with open(os.path.join(REF, "config.json")) as fh:
        relax = json.load(fh)["relax"]                  # {"settle_steps": 10000}
    a, _ = runs
    b = _run_folder(tmp_path / "b2", 20, [1], ["N20_s1"], relax=dict(relax, clearance="all"))
    combine_runs([a, b], str(tmp_path / "o1"), speak=False)
    cfg = json.loads((tmp_path / "o1" / "config.json").read_text())
    assert cfg["relax"] == relax and cfg["n"] == [16, 20]
    assert (tmp_path / "o1" / "ensemble.md").is_file()
    # both set it alike: kept
    a2 = _run_folder(tmp_path / "a2", 16, [1, 2], ["N16_s1", "N16_s2"],
                     relax=dict(relax, clearance="all"))
    combine_runs([a2, b], str(tmp_path / "o2"), speak=False)
    assert json.loads((tmp_path / "o2" / "config.json").read_text())["relax"] == \
        dict(relax, clearance="all")
    c = _run_folder(tmp_path / "c", 20, [1], ["N20_s1"],
                    relax=dict(relax, clearance="all", f_min=1e-14))
    with pytest.raises(ConfigError, match=r"differ in relax \(\{'settle_steps': 10000\} vs "
                                          r"\{'settle_steps': 10000, 'clearance': 'all', "
                                          r"'f_min': 1e-14\}\)"):
        combine_runs([a, c], str(tmp_path / "o3"))
    # the same N: one run's packing relaxed with 'local' is refused as before
    d = _run_folder(tmp_path / "d", 16, [3], [], relax=dict(relax, clearance="local"))
    _add_local_seed3(tmp_path / "d")
    with pytest.raises(ConfigError, match="relaxed with the clearance test 'all', N16_s3"):
        combine_runs([a, d], str(tmp_path / "o4"))
    assert not (tmp_path / "o3").exists() and not (tmp_path / "o4").exists()


RUNS = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "results", "runs")


def test_the_kept_runs_combine(tmp_path):
    """The result files of the runs kept in docs/results/runs (the runs of
    docs/results/ensemble.md) combine into one table whose brackets, of both
    frictions, are the packings' own, with nothing left out, and whose
    orders are those docs/results/ensemble.md counts (30 hold, 11 reversed,
    1 not decided; N = 10^4: 1, 1, 0)."""
    from remote_trigger.pywrap.jobs.ensemble import report as er

    runs = [os.path.join(RUNS, d) for d in ("N100_1600", "N6400_escape", "N10000")]
    out = tmp_path / "all"
    combine_runs(runs, str(out), speak=False)
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["n"] == [100, 400, 1600, 6400, 10000] and cfg["tol"] == 4e-6
    man = json.loads((out / "ensemble.json").read_text())
    assert man["left_out"] == [] and man["n_packings"] == 42
    t = er.read_table(str(out / "ensemble.h5"))
    assert t["key"].size == 42
    compared = 0
    for run in runs:
        for name in os.listdir(os.path.join(run, "tasks")):
            with open(os.path.join(run, "tasks", name)) as fh:
                mu0 = json.load(fh)["result"]["default"]["ramps"]["mu0"]["I0_0.5"]
            if not all(isinstance(mu0.get(k), float) and mu0[k] == mu0[k]
                       for k in ("F_x_c_low", "F_x_c_high")):
                continue                # no bracket (N = 6400 seed 3: complex at F_x = 0)
            row = list(t["key"]).index(name[:-5])
            assert (t["F_x_c_low"][row], t["F_x_c_high"][row]) == (
                mu0["F_x_c_low"], mu0["F_x_c_high"]), name
            compared += 1
            with open(os.path.join(run, "tasks", name)) as fh:
                ss = json.load(fh)["result"]["default"]["ramps"]["mu_ss"]["I0_0.5"]
            got = (t["F_x_c_ss_low"][row], t["F_x_c_ss_high"][row])
            assert np.array_equal(got, (ss["F_x_c_low"], ss["F_x_c_high"]), equal_nan=True), name
    assert compared >= 41
    order = t["order"][t["I0"] == 0.5]
    assert [int(np.sum(order == c)) for c in (1, 0, -1)] == [30, 11, 1]
    big = t["order"][(t["I0"] == 0.5) & (t["n"] == 10000)]
    assert sorted(big.tolist()) == [0, 1]


def _combine_kept(tmp_path, names):
    """Combine the kept runs ``names`` of docs/results/runs; (config, manifest,
    table) of the combined folder."""
    from remote_trigger.pywrap.jobs.ensemble import report as er

    out = tmp_path / "all"
    combine_runs([os.path.join(RUNS, d) for d in names], str(out), speak=False)
    return (json.loads((out / "config.json").read_text()),
            json.loads((out / "ensemble.json").read_text()),
            er.read_table(str(out / "ensemble.h5")))


def test_the_kept_n6400_run_with_the_clearance_set_combines(tmp_path):
    """The N = 6400 run of seeds 4-5 (``relax.clearance = 'all'`` set) and the
    kept 48-packing run (N = 6400 and 10^4 relaxed by 'all' without setting
    it) combine into the 50 packings docs/ensemble.md counts: 37 orders hold,
    12 reversed, 1 not decided; at N = 6400 3 hold, 1 reversed, 1 not decided."""
    cfg, man, t = _combine_kept(tmp_path, ("N100_10000_local1600", "N6400_s4-5"))
    assert cfg["relax"] == {} and cfg["seeds"][3] == [1, 2, 3, 4, 5]
    assert man["left_out"] == [] and man["n_packings"] == 50
    order = t["order"][t["I0"] == 0.5]
    assert [int(np.sum(order == c)) for c in (1, 0, -1)] == [37, 12, 1]
    mid = t["order"][(t["I0"] == 0.5) & (t["n"] == 6400)]
    assert sorted(mid.tolist()) == [-1, 0, 1, 1, 1]


def test_the_kept_n6400_runs_of_seeds_4_to_7_combine(tmp_path):
    """Seeds 6-7 at N = 6400 (the configuration of seeds 4-5 with other seeds)
    combine with the kept runs into the 52 packings docs/ensemble.md counts:
    38 orders hold, 13 reversed, 1 not decided; at N = 6400 seeds 2, 4, 5, 7
    hold, 1 and 6 reversed, 3 not decided; seed 6's mu0 onset is a soft mode;
    and the size dependence docs/ensemble.md gives is that of these files."""
    cfg, man, t = _combine_kept(tmp_path,
                                ("N100_10000_local1600", "N6400_s4-5", "N6400_s6-7"))
    assert cfg["seeds"][3] == [1, 2, 3, 4, 5, 6, 7]
    assert man["left_out"] == [] and man["n_packings"] == 52
    half = t["I0"] == 0.5
    assert [int(np.sum(t["order"][half] == c)) for c in (1, 0, -1)] == [38, 13, 1]
    mid = half & (t["n"] == 6400)
    order = dict(zip([str(k) for k in t["key"][mid]], t["order"][mid].tolist()))
    assert order == {"N6400_s1": 0, "N6400_s2": 1, "N6400_s3": -1, "N6400_s4": 1,
                     "N6400_s5": 1, "N6400_s6": 0, "N6400_s7": 1}
    re_rel = dict(zip(order, t["pair_re_rel"][mid].tolist()))
    assert re_rel["N6400_s6"] < 1e-4 < re_rel["N6400_s7"]      # soft, collective
    # the data set each packing was computed with, as its result records it
    prov = {(int(n), c, m) for n, c, m, i in zip(t["n"], t["clearance"], t["blas"], t["I0"])
            if i == 0.5}
    assert prov == {(100, "all", ""), (400, "all", ""), (1600, "local", "Haswell (forced)"),
                    (6400, "all", ""), (6400, "all", "Haswell (forced)"),
                    (10000, "all", "SkylakeX")}
    # the size dependence docs/ensemble.md gives (2026-11-27), from these files
    md = (tmp_path / "all" / "ensemble.md").read_text()
    for line in (
            "| every packing | all onsets | N = 100-10000 | -0.917 | [-1.05, -0.795] |",
            "| every packing | stiff onsets | N = 100-10000 | -0.859 | [-0.964, -0.747] |",
            "| every packing | all onsets | N = 100-1600 | -1.08 | [-1.32, -0.872] |",
            "| every packing | all onsets | N = 400-10000 | -0.715 | [-0.89, -0.554] |",
            "| clearance 'all' | all onsets | N = 100, 400, 6400, 10000 | -0.868 | [-0.99, "
            "-0.745] |",
            "| all onsets | -1.32 [-1.8, -0.832] (20, 11) | -0.73 [-1.4, -0.207] (11, 12) | "
            "-0.569 [-1.13, 0.00495] (12, 6) | -0.817 [-2.7, 1.36] (6, 2) |",
            "slopes -1.19 below and -0.474 above N_b = 1.01e+03 against one law N^-0.917: "
            "F = 5.37, p = 0.0583",
            "N_top F_x^c / F_y ~ 0.251 N^-0.367 (95 % bootstrap interval [-0.497, -0.245]",
            "sites M ~ N^a with a = -b k = 1.55 (95 % [1.19, 1.94]); sites in proportion to "
            "N (a = 1, b = -1/k = -0.538): p = 0.00212",
            "N PR ~ 0.372 N^0.956 (95 % bootstrap interval [0.918, 0.996]",
            "1 of 2 [0.0126, 0.987] (N = 10000) (exact 95 % intervals); trend in ln N: "
            "z = -0.877, p = 0.421"):
        assert line in md, line


def test_runs_of_per_size_steps_combine_per_size(tmp_path):
    """dF_x as one number per N: runs of other sizes combine into one list per
    N, whether a run gives a list or one number (for each of its own sizes:
    a run of small N with one step and one of a large N with a finer one);
    one N with two values is refused, naming both."""
    a = _run_folder(tmp_path / "a", 16, [1, 2], ["N16_s1", "N16_s2"], dF_x=[0.01])
    b = _run_folder(tmp_path / "b", 20, [1], ["N20_s1"], dF_x=[0.02])
    combine_runs([a, b], str(tmp_path / "both"))
    cfg = json.loads((tmp_path / "both" / "config.json").read_text())
    assert cfg["n"] == [16, 20] and cfg["dF_x"] == [0.01, 0.02]
    c = _run_folder(tmp_path / "c", 20, [1], ["N20_s1"], dF_x=0.01)    # a number: its N
    combine_runs([a, c], str(tmp_path / "same"))
    assert json.loads((tmp_path / "same" / "config.json").read_text())["dF_x"] == 0.01
    e = _run_folder(tmp_path / "e", 20, [1], ["N20_s1"], dF_x=0.03)
    combine_runs([a, e], str(tmp_path / "finer"))
    assert json.loads((tmp_path / "finer" / "config.json").read_text())["dF_x"] == [0.01, 0.03]
    g = _run_folder(tmp_path / "g", 16, [3], [], dF_x=0.03)     # N = 16 again, another step
    with pytest.raises(ConfigError, match=r"differ in dF_x \(0.01 vs 0.03\) for N = 16"):
        combine_runs([a, g], str(tmp_path / "o"))
    assert not (tmp_path / "o").exists()



def test_the_figures_legend_names_soft_onsets_once(tmp_path, monkeypatch):
    """The F_x^c-against-N panel marks every soft-mode onset and names them
    once (it named them once a size): the rows of the kept N = 100-1600 run
    (one soft onset, at N = 400) with one N = 100 row marked soft besides."""
    from remote_trigger.pywrap.jobs.ensemble import figure, job

    runs = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "results", "runs")
    got = []
    monkeypatch.setattr(job, "plot", lambda path, rows, cfg, fits=None, limit=None:
                        got.append((rows, cfg)))
    combine_runs([os.path.join(runs, "N100_1600"), os.path.join(runs, "N6400_escape")],
                 str(tmp_path / "both"))
    (rows, cfg), = got
    first = next(r for r in rows if r["n"] == 100 and np.isfinite(r["F_x_c"]))
    rows = [dict(r, soft_onset=1) if r is first else r for r in rows]
    seen = []
    monkeypatch.setattr(figure, "savefig_atomic", lambda fig, path, **kw: seen.append(fig))
    figure.plot(str(tmp_path / "f.png"), rows, cfg)
    fig, = seen
    _, labels = fig.axes[2].get_legend_handles_labels()
    assert labels.count("soft-mode onset") == 1
    marks = [ln for ln in fig.axes[2].get_lines() if ln.get_marker() == "x"]
    assert sorted(float(ln.get_xdata()[0]) for ln in marks) == [100.0, 400.0]


def test_a_seed_run_again_in_a_folder_of_its_own_is_not_left_out(tmp_path, capsys):
    """N20_s1 unfinished in one run (killed) and finished in another made for
    it alone: taken from the second, and not named as left out (it was, by
    the folder where it did not finish)."""
    a = _run_folder(tmp_path / "a", 16, [1, 2], ["N16_s1", "N16_s2"])
    b = _run_folder(tmp_path / "b", 20, [1], [])
    c = _run_folder(tmp_path / "c", 20, [1], ["N20_s1"])
    out = tmp_path / "all"
    combine_runs([a, b, c], str(out))
    man = json.loads((out / "ensemble.json").read_text())
    assert man["left_out"] == [] and man["n_packings"] == 3
    assert "left out" not in capsys.readouterr().out
    assert_reference_columns(out / "ensemble.h5")


def test_runs_of_other_part_sizes_combine(runs, tmp_path):
    """``part_size`` (how the sliced points were split; the verdicts do not
    depend on it) may differ between the runs; the combined configuration
    leaves it out."""
    a, _ = runs
    b = _run_folder(tmp_path / "b3", 20, [1], ["N20_s1"], part_size=2300)
    combine_runs([a, b], str(tmp_path / "o"), speak=False)
    cfg = json.loads((tmp_path / "o" / "config.json").read_text())
    with open(os.path.join(REF, "config.json")) as fh:
        assert cfg == dict(json.load(fh), n=[16, 20], seeds=[[1, 2], [1]])
