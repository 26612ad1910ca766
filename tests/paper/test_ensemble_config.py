"""``ensemble`` configuration: bad input is refused, naming the value, nothing written."""
import numpy as np
import pytest

from remote_trigger.pywrap.jobs.ensemble import config as ec
from remote_trigger.pywrap.jobs.ensemble import job as en
from remote_trigger.pywrap.jobs.ensemble import report as er
from remote_trigger.pywrap.jobs.ensemble import onset
from remote_trigger.pywrap.cli import main
from remote_trigger.pywrap.config import ConfigError


def test_n_without_seeds_says_whose_default_the_seeds_are():
    """``--set n=[100]`` alone: the two default seed lists belong to n =
    [100, 400]; the message says so (it named seeds the user never set)."""
    with pytest.raises(ConfigError, match=r"seeds holds 2 lists of seeds for 1 size\(s\) N: "
                                          r"give one list per N.*n = \[100, 400\]"):
        ec.EnsembleConfig.from_dict({"n": [100]})


@pytest.mark.parametrize("key,val,words", [
    ("seeds", [], "seeds = []"),
    ("seeds", [[1, 2], []], "seeds = [[1, 2], []]"),
    ("seeds", [[1], [2], [3]], "seeds = [[1], [2], [3]]"),
    ("seeds", [1, -2], "seeds = [1, -2]"),
    ("seeds", [1, 1], "seeds = [1, 1]"),
    ("n", [100, 401], "n = [100, 401]"),
    ("n", [4], "n = [4]"),
    ("n", [], "n = []"),
    ("mu_ss", 0.0, "mu_ss = 0.0"),
    ("mu_ss", 1.2, "mu_ss = 1.2"),
    ("mu", -1.0, "mu = -1.0"),
    ("dF_x", 0.0, "dF_x = 0.0"),
    ("dF_x_max", 2.5e-4, "dF_x_max = 0.00025"),
    ("dF_x_max", -1.0, "dF_x_max = -1.0"),
    ("tol", -1e-7, "tol = -1e-07"),
    ("phi", 0.95, "phi = 0.95"),
    ("inertia_I0", 0.5, "inertia_I0 = 0.5"),
    ("inertia_extra_steps", -1, "inertia_extra_steps = -1"),
    ("relax", {"settle_steps": -5}, "settle_steps = -5"),
    ("frictional_relax", {"protocol": "frictional"}, "frictional_relax.protocol"),
    ("np", 0, "np = 0"),
])
def test_bad_values_name_the_value(key, val, words):
    d = {"n": [100, 400]}
    d[key] = val
    with pytest.raises(ConfigError) as err:
        ec.EnsembleConfig.from_dict(d)
    assert words in str(err.value)


def test_unknown_key():
    with pytest.raises(ConfigError, match="'seed'"):
        ec.EnsembleConfig.from_dict({"seed": 3})


def test_defaults_quick_and_precedence(tmp_path):
    cfg = ec.EnsembleConfig()
    pk = cfg.packings()
    assert len(pk) == 25 and pk[0] == {"key": "N100_s1", "n": 100, "seed": 1}
    assert sum(p["n"] == 400 for p in pk) == 5
    assert (cfg.dF_x, cfg.tol, cfg.mu, cfg.mu_ss) == (2.5e-4, 1e-7, 1.0, 0.8)
    one = ec.EnsembleConfig(n=[16, 20], seeds=[3, 4])
    assert one.seeds == ((3, 4), (3, 4))
    toml = tmp_path / "e.toml"
    toml.write_text("n = [16]\nseeds = [7]\n[relax]\ng_settle = 0.4\n")
    cfg = ec.build_config(str(toml), {"tol": 1e-3}, quick=True)
    assert cfg.n == (16,) and cfg.seeds == ((7,),) and cfg.tol == 1e-3 and cfg.quick
    assert cfg.relax == {"settle_steps": 10000, "g_settle": 0.4}
    assert cfg.dF_x == ec.QUICK["dF_x"]


@pytest.mark.parametrize("argv,words", [
    (["--set", "seeds=[]"], "seeds = []"),
    (["--set", "n=[100,33]"], "n = [100, 33]"),
    (["--set", "mu_ss=1.5"], "mu_ss = 1.5"),
    (["--set", "mu_ss=0"], "mu_ss = 0"),
    (["--np", "0"], "np = 0"),
    (["--set", "bogus=1"], "'bogus'"),
])
def test_cli_refuses_and_writes_nothing(argv, words, tmp_path, capsys):
    out = tmp_path / "ens"
    status = main(["ensemble", "--out", str(out)] + argv)
    assert status == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_cli_refuses_foreign_or_existing_folder(tmp_path, capsys):
    out = tmp_path / "ens"
    out.mkdir()
    (out / "x.txt").write_text("mine")
    assert main(["ensemble", "--quick", "--out", str(out)]) == 2
    assert "holds other files" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["x.txt"]


def test_bracket_order_and_slope():
    pts = [{"F_x": 0.0, "decision": 0}, {"F_x": 0.1, "decision": 0},
           {"F_x": 0.15, "decision": -1}, {"F_x": 0.2, "decision": 1},
           {"F_x": 0.3, "decision": 1}]
    assert onset.bracket(pts) == (0.1, 0.2)
    lo, hi = onset.bracket(pts[:2])
    assert lo == 0.1 and hi == float("inf")
    assert er.order_code(0.1, 0.2, 0.05, 0.08) == 1
    assert er.order_code(0.1, 0.2, 0.25, 0.3) == 0
    assert er.order_code(0.1, 0.2, 0.15, 0.3) == -1
    assert er.order_code(0.1, 0.2, 0.25, float("inf")) == 0
    # g = 3 sqrt(F - 0.1) exactly: the fit returns s = 3 and the onset 0.1
    F = [0.1 + 1e-4, 0.1 + 4e-4, 0.1 + 9e-4]
    g = [3 * (f - 0.1) ** 0.5 for f in F]
    out = onset.growth_slope(F, g, 0.0999, 0.10005)
    assert out["slope"] == pytest.approx(3.0, rel=1e-9)
    assert out["F_x_onset_fit"] == pytest.approx(0.1, abs=1e-12)
    one = onset.growth_slope([0.2], [0.3], 0.1, 0.2)
    assert one["slope"] == pytest.approx(0.3 / 0.05 ** 0.5)


def test_pair_position():
    lam = [1.0, 2.0, 5.0 + 0.5j, 5.0 - 0.5j, 7.0, 10.0]
    p = onset.pair_position(lam)
    assert p["pair_index"] == 3 and p["n_dof"] == 6
    assert p["pair_re_rel"] == pytest.approx(0.5)
    assert p["lambda_c"] == [5.0, 0.5]
    # a negative real eigenvalue (a statically unstable equilibrium) grows faster
    # (|Im sqrt(-9)| = 3 > |Im sqrt(5 + 0.5i)|) but is no pair
    p = onset.pair_position([-9.0] + lam)
    assert p["lambda_c"] == [5.0, 0.5] and p["pair_index"] == 4
    none = onset.pair_position([-9.0, 1.0, 2.0])
    assert none["pair_index"] == -1 and none["pair_re_rel"] != none["pair_re_rel"]


def test_saddles_are_counted_and_a_saddle_at_a_bracket_end_is_named():
    """Points with an eigenvalue below -NEGATIVE_REL lambda_max are saddles; the
    bracket's lower end here is one, so it is listed; escapes are counted from
    the column (0 where a file predates it)."""
    stable = np.array([1.0, 2.0, 10.0], complex)
    saddle = np.array([-0.04, 2.0, 10.0], complex)
    roundoff = np.array([-1e-12, 2.0, 10.0], complex)
    cplx = np.array([1.0, 5.0 + 0.5j, 5.0 - 0.5j, 10.0])
    pts = [{"F_x": 0.0, "decision": 0, "growth": 0.0, "eigenvalues": stable},
           {"F_x": 0.1, "decision": 0, "growth": 0.0, "eigenvalues": roundoff,
            "saddle_escaped": 1.0},
           {"F_x": 0.15, "decision": 0, "growth": 0.0, "eigenvalues": saddle},
           {"F_x": 0.2, "decision": 1, "growth": 0.3, "eigenvalues": cplx,
            "saddle_escaped": 2.0}]
    o = onset.onset_numbers(pts, 0.1)
    assert (o["F_x_c_low"], o["F_x_c_high"]) == (0.15, 0.2)
    assert o["n_saddle"] == 1 and o["saddle_ends"] == [0.15] and o["n_escaped"] == 2
    assert onset.is_saddle(pts[2]) and not onset.is_saddle(pts[1])
    # the ramp's own count, where recorded, decides (a sliced list holds the
    # symmetric part's Ritz values: a free rotation is negative there)
    assert not onset.is_saddle(dict(pts[2], n_negative=0.0))
    assert onset.is_saddle(dict(pts[0], n_negative=1.0))
    assert onset.is_saddle(dict(pts[2], n_negative=-1.0))       # no count: the list
    # a partial spectrum: the scale is the recorded lambda_max
    assert onset.is_saddle({"eigenvalues": np.array([-1e-6, 1.0]), "lambda_max": 100.0})
    assert not onset.is_saddle({"eigenvalues": np.array([-1e-6, 1.0]), "lambda_max": 1e4})


def test_soft_mode_onsets_are_flagged_and_kept_out_of_the_stiff_statistics():
    """A first complex pair at |Re lambda_c| < SOFT_MODE_REL lambda_max is a soft-mode
    onset: counted, and left out of the 'stiff onsets only' median and exponent."""
    import math

    from remote_trigger.pywrap.jobs.ensemble import report as er

    assert er.soft_onset(1.1e-7) == 1 and er.soft_onset(-8e-7) == 1
    assert er.soft_onset(0.013) == 0 and er.soft_onset(math.nan) == -1
    cfg = ec.EnsembleConfig.from_dict({"n": [100, 400], "seeds": [[1, 2], [1, 2]],
                                       "inertia_I0": None, "frictional": False})
    rows = []
    for n, seed, fc, rel in ((100, 1, 0.02, 0.2), (100, 2, 0.04, 0.1),
                             (400, 1, 0.005, 0.09), (400, 2, 0.0005, 1e-6)):
        row = er._empty_row({"key": f"N{n}_s{seed}", "n": n, "seed": seed},
                            "frictionless-then-friction", 0.5, cfg.I0_dynamics)
        row.update(status="ok", F_x_c=fc, pair_re_rel=rel, soft_onset=er.soft_onset(rel))
        rows.append(row)
    st = er.statistics(rows, cfg)
    p400 = next(p for p in st["per_n"] if p["n"] == 400)
    assert p400["n_soft"] == 1 and p400["F_x_c_stiff"][0] == 1
    assert p400["F_x_c_stiff"][2] == 0.005 and p400["F_x_c"][2] == 0.00275
    assert st["n_exponent_stiff"][0.5] == math.log(0.005 / 0.03) / math.log(4)
    # the fit over every packing: two sizes, F_x_c_ss not recorded (absent)
    fit = st["n_fit"][0.5]["F_x_c"]
    assert set(st["n_fit"][0.5]) == {"F_x_c"}
    assert fit.sizes == (100, 400) and fit.n_points == 4
    expected = (math.log(0.005 * 0.0005) - math.log(0.02 * 0.04)) / 2 / math.log(4)
    assert fit.exponent == pytest.approx(expected, rel=1e-12)


def test_a_packing_without_f_x_c_is_counted_in_the_summary(tmp_path):
    """A usable packing whose ramp has no F_x^c (complex at its first point):
    the per-size cells say how many of the usable packings the median is of."""
    import math

    from remote_trigger.pywrap.jobs.ensemble import report as er

    cfg = ec.EnsembleConfig.from_dict({"n": [100], "seeds": [[1, 2, 3]],
                                       "inertia_I0": None, "frictional": False})
    rows = []
    for seed, fc, fss in ((1, 0.02, 0.01), (2, 0.04, math.nan), (3, 0.03, 0.02)):
        row = er._empty_row({"key": f"N100_s{seed}", "n": 100, "seed": seed},
                            "frictionless-then-friction", 0.5, cfg.I0_dynamics)
        row.update(status="ok", F_x_c=fc, F_x_c_ss=fss, ratio=fss / fc, phi=0.81)
        rows.append(row)
    path = tmp_path / "e.md"
    er.write_summary(str(path), rows, cfg, er.statistics(rows, cfg), 1.0, 0, [])
    line = next(L for L in path.read_text().splitlines() if L.startswith("| 100 | 0.5 |"))
    cells = [c.strip() for c in line.split("|")[1:-1]]
    assert cells[2] == "3 (3)"
    assert cells[3] == "0.03 [0.025, 0.035]"                    # all three: no count
    assert cells[4] == "0.015 [0.0125, 0.0175] (2 of 3)"
    assert cells[5].endswith("(2 of 3)") and cells[6] == "0.81 [0.81, 0.81]"
    assert "(k of m): only k of the m usable packings have the value" in path.read_text()
    assert er._q(er.quartiles([]), of=2) == "-"


def test_pair_shape_unmeasured_is_nan_never_a_failure(tmp_path, monkeypatch):
    """No complex point, a dump that is gone, or an eigenvector ARPACK cannot
    compute: NaN, and the packing goes on."""
    import math

    import remote_trigger.analysis.stability.modeshape as ms

    nums = {"F_x_c_high": 0.1, "lambda_c": [5.0, 0.5]}
    gone = [{"F_x": 0.1, "decision": 1, "dump": str(tmp_path / "gone.dump")}]
    assert math.isnan(onset.pair_shape(gone, nums)["pair_pr"])
    assert math.isnan(onset.pair_shape([], {"F_x_c_high": math.inf})["pair_particles"])

    def fail(*a, **k):
        raise RuntimeError("ARPACK error -1: No convergence")
    monkeypatch.setattr(ms, "pair_mode", fail)
    monkeypatch.setattr("remote_trigger.analysis.state.dumpfile.read_equilibrium",
                        lambda path: object())
    there = tmp_path / "there.dump"
    there.write_text("x")
    pts = [{"F_x": 0.1, "decision": 1, "dump": str(there)}]
    assert math.isnan(onset.pair_shape(pts, nums)["pair_pr"])


def test_ramp_step_and_tolerance_per_size():
    """dF_x and tol: one number for every N, or one per N (F_x^c falls by 50
    from N = 100 to 10^4); for_size gives the numbers of one N; a list of another length
    is refused, naming both lengths."""
    import json

    cfg = ec.EnsembleConfig.from_dict({"n": [100, 400], "dF_x": [2.5e-4, 5e-5],
                                       "tol": 1e-6})
    assert cfg.dF_x == (2.5e-4, 5e-5) and cfg.tol == 1e-6
    assert cfg.for_size(400).dF_x == 5e-5 and cfg.for_size(100).dF_x == 2.5e-4
    assert cfg.for_size(400).tol == 1e-6 and cfg.for_size(400).n == (100, 400)
    assert json.loads(json.dumps(cfg.to_dict()))["dF_x"] == [2.5e-4, 5e-5]
    assert ec.EnsembleConfig().for_size(100) == ec.EnsembleConfig()
    with pytest.raises(ConfigError, match=r"dF_x holds 3 values for 2 size\(s\) N "
                                          r"\[100, 400\]"):
        ec.EnsembleConfig.from_dict({"n": [100, 400], "dF_x": [1e-4, 1e-4, 1e-4]})
    with pytest.raises(ConfigError, match="tol = -1"):
        ec.EnsembleConfig.from_dict({"n": [100, 400], "tol": [1e-6, -1]})
    with pytest.raises(ConfigError, match=r"dF_x_max must be > dF_x = \(0.001, 0.002\)"):
        ec.EnsembleConfig.from_dict({"n": [100, 400], "dF_x": [1e-3, 2e-3],
                                     "dF_x_max": 1.5e-3})
    with pytest.raises(ConfigError, match="N = 1600 is not one of"):
        cfg.for_size(1600)


def test_each_size_ramps_with_its_own_step(tmp_path):
    """A run with dF_x = [0.01, 0.02] and between = [1, 2] for N = 16 and 20:
    each packing's ramp steps by its N's step and checks its N's loads between
    steps (N = 20: the midpoint of every step interval below the first complex
    step), and ensemble.md says which step and check each N had."""
    import os
    import subprocess
    import sys

    import h5py

    out = str(tmp_path / "ens")
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    proc = subprocess.run([cli, "ensemble", "--quick", "--out", out, "--quiet",
                           "--set", "seeds=[[1],[1]]", "--set", "dF_x=[0.01,0.02]",
                           "--set", "between=[1,2]",
                           "--set", "frictional=false", "--set", "inertia_I0=null"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for n, step, m in ((16, 0.01, 1), (20, 0.02, 2)):
        with h5py.File(os.path.join(out, "packings", f"N{n}_s1", "ramp_mu0", "ramp.h5")) as fh:
            F = fh["steps/F_x"][()]
            dec = fh["steps/decision"][()]
            B = fh["bisection/F_x"][()]
            assert fh.attrs["between"] == m
        assert F.size >= 2
        np.testing.assert_allclose(np.diff(F), step, rtol=1e-12)
        mids = [0.5 * (F[k] + F[k + 1]) for k in range(F.size - 1) if dec[k] == 0]
        if m == 2:          # the midpoints first, lowest first, up to the first complex one
            k = next((i for i, f in enumerate(B[:len(mids)]) if f not in mids), len(mids))
            np.testing.assert_array_equal(B[:k], mids[:k])
            assert k >= 1
        else:
            assert not set(B) & set(mids[:-1])
    with open(os.path.join(out, "ensemble.md")) as fh:
        text = fh.read()
    assert "ramp dF_x = 0.01 (N = 16), 0.02 (N = 20)" in text
    assert "loads between the steps checked: 1 (N = 16), 2 (N = 20) sub-steps per step" in text


def test_pair_position_leaves_out_soft_pairs_when_asked():
    """A soft pair (|Re| = 1e-5 lambda_max) grows faster than the stiff one, so
    it is the pair by default; with soft_rel = 1e-4 the stiff one is."""
    lam = [1e-4 - 1e-3j, 1e-4 + 1e-3j, 2.0, 5.0 - 0.01j, 5.0 + 0.01j, 10.0]
    assert onset.pair_position(lam)["lambda_c"] == [1e-4, 1e-3]
    p = onset.pair_position(lam, soft_rel=1e-4)
    assert p["lambda_c"] == [5.0, 0.01] and p["pair_index"] == 4
    none = onset.pair_position(lam[:3], soft_rel=1e-4)
    assert none["pair_index"] == -1


def test_pairs_collective_configuration(tmp_path):
    """``pairs``: 'all' or 'collective', named when bad; config.json holds the
    key only when 'collective', so older folders resume as 'all'."""
    cfg = ec.EnsembleConfig.from_dict({"pairs": "collective"})
    assert cfg.to_dict()["pairs"] == "collective"
    assert "pairs" not in ec.EnsembleConfig().to_dict()
    with pytest.raises(ConfigError, match="got pairs = 'stiff'"):
        ec.EnsembleConfig.from_dict({"pairs": "stiff"})
    from remote_trigger.pywrap.stages.config import RampConfig
    data = tmp_path / "x.data"
    data.write_text("")
    with pytest.raises(ConfigError, match="got pairs = 'any'"):
        RampConfig(datafile=str(data), pairs="any")
    assert RampConfig(datafile=str(data)).pairs == "all"


def test_between_configuration(tmp_path):
    """``between``: an integer >= 1 or one per N, named when bad; config.json
    holds it only when not 1 (older folders resume with 1); each ramp of the
    job gets its N's value."""
    from remote_trigger.pywrap.jobs.paper.stage_configs import ramp_config

    cfg = ec.EnsembleConfig.from_dict({"between": 4})
    assert cfg.to_dict()["between"] == 4
    assert "between" not in ec.EnsembleConfig().to_dict()
    for bad in (0, 2.0, "3"):
        with pytest.raises(ConfigError, match=f"got between = {bad!r}"):
            ec.EnsembleConfig.from_dict({"between": bad})
    with pytest.raises(ConfigError, match=r"between holds 3 values for 2 size\(s\) N"):
        ec.EnsembleConfig.from_dict({"between": [1, 2, 3]})
    with pytest.raises(ConfigError, match="got between = 0"):
        ec.EnsembleConfig.from_dict({"between": [1, 0]})
    data = tmp_path / "x.data"
    data.write_text("")
    assert ramp_config(cfg, str(data), 1.0).between == 4
    assert ramp_config(ec.EnsembleConfig(), str(data), 1.0).between == 1
    per_n = ec.EnsembleConfig.from_dict({"n": [100, 400], "between": [1, 3]})
    assert per_n.to_dict()["between"] == [1, 3]
    assert ec.EnsembleConfig.from_dict(per_n.to_dict()).between == (1, 3)
    assert [ramp_config(per_n.for_size(n), str(data), 1.0).between for n in (100, 400)] == [1, 3]


def test_collective_ensemble_runs_and_says_so(tmp_path):
    """``--set pairs=collective`` through the command line, with the I0
    re-analysis and the frictional protocol: its ramps record it and the
    soft-pair counts, and ensemble.md says what F_x^c is."""
    import json
    import os
    import subprocess
    import sys

    import h5py

    out = str(tmp_path / "ens")
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    proc = subprocess.run([cli, "ensemble", "--quick", "--out", out, "--quiet",
                           "--set", "seeds=[[1],[1]]", "--set", "pairs=collective"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with open(os.path.join(out, "config.json")) as fh:
        assert json.load(fh)["pairs"] == "collective"
    with h5py.File(os.path.join(out, "packings", "N16_s1", "ramp_mu0", "ramp.h5")) as fh:
        assert fh.attrs["pairs"] == "collective"
        assert np.all(fh["steps/soft_pairs"][()] >= 0)
    with open(os.path.join(out, "ensemble.md")) as fh:
        text = fh.read()
    assert "pairs = 'collective': a soft pair" in text
    assert "- N = 16: a soft pair certified at a load up to F_x^c in " in text
    cols = er.read_table(os.path.join(out, "ensemble.h5"))
    assert cols["F_x_soft"].shape == cols["F_x_soft_ss"].shape == cols["key"].shape


def test_a_narrow_bracket_prints_with_the_digits_that_tell_its_ends_apart():
    """The progress line printed a bracket 7e-8 wide as
    [0.0646371, 0.0646371]: six significant digits, whatever the width."""
    from remote_trigger.analysis.output import bracket_text

    assert bracket_text(0.06463708, 0.06463715) == "[0.0646371, 0.0646372]"
    assert bracket_text(0.064637085, 0.0646371) == "[0.06463708, 0.0646371]"
    assert bracket_text(0.00038281, 0.00038672) == "[0.00038281, 0.00038672]"
    assert bracket_text(0.1, np.nextafter(0.1, 1)) == \
        "[0.10000000000000001, 0.10000000000000002]"
    assert bracket_text(0.5, 0.5) == "[0.5, 0.5]"
    assert bracket_text(float("nan"), float("inf")) == "[nan, inf]"
    assert bracket_text(0.25, 0.5, digits=20) == "[0.25, 0.5]"    # (at most 17)
    assert bracket_text(0.1013000001, 0.1013000002, 9) == "[0.1013000001, 0.1013000002]"


def test_a_bracket_in_words_says_what_the_ramp_found():
    """Status and progress lines: a ramp certified complex at its first point,
    F_x = 0, has no F_x^c (was printed "[nan, 0]"); one that starts higher
    has an upper bound only; one with no complex point, a lower bound
    only (was "[lo, inf]")."""
    nan, inf = float("nan"), float("inf")
    pts = [{"F_x": 0.0, "decision": 1}, {"F_x": 0.1, "decision": 1}]
    assert onset.bracket_words(*onset.bracket(pts), "F_x^c(mu0)") == \
        "complex at F_x = 0 (no F_x^c(mu0))"
    assert onset.bracket_words(0.1, 0.2) == "F_x^c in [0.1, 0.2]"
    assert onset.bracket_words(nan, 0.2) == "complex at F_x = 0.2, no real point below (F_x^c <= 0.2)"
    assert onset.bracket_words(0.1, inf) == "real up to F_x = 0.1"
    assert onset.bracket_words(nan, inf) == "no certified point"


def test_part_size_configuration(tmp_path):
    """``part_size``: None or an integer >= the slice size (60), named when
    bad; config.json holds it only when set (older folders resume without);
    every ramp of the job gets it."""
    from remote_trigger.pywrap.jobs.paper.stage_configs import ramp_config

    cfg = ec.EnsembleConfig.from_dict({"part_size": 2300})
    assert cfg.to_dict()["part_size"] == 2300
    assert "part_size" not in ec.EnsembleConfig().to_dict()
    for bad in (59, 2300.0, "2300", True):
        with pytest.raises(ConfigError, match=f"got part_size = {bad!r}"):
            ec.EnsembleConfig.from_dict({"part_size": bad})
    data = tmp_path / "x.data"
    data.write_text("")
    assert ramp_config(cfg, str(data), 1.0).part_size == 2300
    assert ramp_config(ec.EnsembleConfig(), str(data), 1.0).part_size is None
