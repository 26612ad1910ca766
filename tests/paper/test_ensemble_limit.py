"""The size dependence in ``ensemble.md`` (pywrap.jobs.ensemble.limit), without LAMMPS.

What must hold (each can fail): a row names what its packing was computed
with, from every environment its result records; the fits are of
F_x^c / F_y over the data sets and size ranges they name; a broken law in
the rows is found and one law is not rejected; the total load is N_top
F_x^c with the generator's N_top; the window's width is taken over every
decided packing, reversed ones included.
"""
import math

import numpy as np
import pytest

from remote_trigger.pywrap.jobs.ensemble import config as ec
from remote_trigger.pywrap.jobs.ensemble import limit as el
from remote_trigger.pywrap.jobs.ensemble import report as er
from remote_trigger.pywrap.stages.packing import box_width, top_count

SIZES = (100, 400, 1600, 6400, 10000)


def _env(cpu, arch, commit=None, forced=None, modified=False):
    return {"cpu": cpu, "blas": [{"architecture": arch}, {"architecture": arch}],
            "openblas_coretype": forced,
            "source": {"commit": commit, "modified": modified if commit else None}}


def test_provenance_names_every_recorded_environment():
    c1 = "0123456789abcdef0123456789abcdef01234567"
    result = {"default": {"clearance_rule": "local", "environment": _env("AMD EPYC", "Haswell",
                                                                         c1, forced="Haswell"),
                          "ramps": {"mu0": {"environment": _env("Xeon", "SkylakeX", c1,
                                                                modified=True)},
                                    "mu_ss": {}}},
              "frictional": None, "environment": _env("Xeon", "SkylakeX", c1, modified=True)}
    p = el.provenance(result)
    assert p == {"clearance": "local", "cpu": "AMD EPYC + Xeon",
                 "blas": "Haswell (forced) + SkylakeX",
                 "commit": "0123456789 + 0123456789+modified"}
    # a result of a version that recorded none: relaxed by 'all', nothing else known
    assert el.provenance({"default": {"ramps": {}}}) == {
        "clearance": "all", "cpu": "", "blas": "", "commit": ""}
    # and every row of the packing carries it
    cfg = ec.EnsembleConfig.from_dict({"n": [100], "seeds": [[1]], "inertia_I0": None,
                                       "frictional": False})
    failed = dict(result, wall=1.0, default=dict(result["default"], error="x", ramps={}))
    rows = er.rows_of({"key": "N100_s1", "n": 100, "seed": 1}, failed, cfg)
    assert [(r["clearance"], r["cpu"]) for r in rows] == [("local", "AMD EPYC + Xeon")]


def _rows(F, Fss=None, clearance=None, soft=None, cfg=None):
    """Rows of the default protocol with F_x^c = F (per packing; n from F's keys)."""
    rows = []
    for i, (n, f) in enumerate(F):
        row = er._empty_row({"key": f"N{n}_s{i}", "n": n, "seed": i},
                            "frictionless-then-friction", 0.5, 0.5)
        fss = f * 0.9 if Fss is None else Fss[i]
        row.update(status="ok", F_x_c=f, F_x_c_ss=fss, ratio=fss / f,
                   order=1 if fss < f else 0, pair_re_rel=0.1, soft_onset=0,
                   pair_particles=0.3 * n, clearance=clearance[i] if clearance else "all")
        if soft and soft[i]:
            row.update(pair_re_rel=1e-6, soft_onset=1, pair_particles=1.0)
        rows.append(row)
    return rows


def _cfg():
    return ec.EnsembleConfig.from_dict({"n": list(SIZES), "seeds": [[1]] * 5,
                                        "inertia_I0": None, "frictional": False})


def _law(below, above, per=20, scatter=0.3, seed=0):
    rng = np.random.default_rng(seed)
    out = []
    for n in SIZES:
        x = math.log(n / 1000.0)
        for _ in range(per):
            out.append((n, 0.004 * math.exp((below if x < 0 else above) * x
                                            + scatter * rng.standard_normal())))
    return out


def test_a_broken_law_is_found_and_named():
    cfg = _cfg()
    st = el.limit_statistics(_rows(_law(-1.4, -0.4, seed=1)), cfg)
    t = st["crossover"]["all onsets"]
    assert t.p_value < 0.01 and 400 <= t.break_n <= 2500, t.describe()
    # the fits by range see the two slopes; each fit is of F_x^c / F_y
    fits = {(d, on, r): f for d, on, r, f in st["fits"]}
    lo = fits[("every packing", "all onsets", "N = 100-1600")]
    hi = fits[("every packing", "all onsets", "N = 1600-10000")]
    assert lo.exponent < -1.1 and hi.exponent > -0.7
    whole = fits[("every packing", "all onsets", "N = 100-10000")]
    direct = er.size_fits(_rows(_law(-1.4, -0.4, seed=1)))["F_x_c"]
    assert whole.exponent == pytest.approx(direct.exponent, rel=1e-12)
    assert whole.prefactor == pytest.approx(direct.prefactor / cfg.F_y, rel=1e-12)
    lines = "\n".join(el.limit_lines(st, [], cfg))
    assert "| every packing | stiff onsets | N = 100-10000 |" in lines
    assert "F_x^c / F_y (F_y = 3)" in lines and "shear-to-normal stress ratio" in lines


def test_one_law_is_not_rejected():
    st = el.limit_statistics(_rows(_law(-0.9, -0.9, seed=2)), _cfg())
    t = st["crossover"]["all onsets"]
    assert t.p_value > 0.05 and t.lack_of_fit_p > 0.05, t.describe()
    assert all(-1.3 < s.slope < -0.5 for s in st["local"]["all onsets"])


def test_data_sets_of_one_protocol_and_soft_onsets_apart():
    """Two clearance rules: each has its fit; soft onsets are in 'all onsets' only."""
    F = _law(-0.9, -0.9, per=6, seed=3)
    clearance = ["local" if n == 1600 else "all" for n, _ in F]
    soft = [n == 1600 and i % 6 == 0 for i, (n, _) in enumerate(F)]
    st = el.limit_statistics(_rows(F, clearance=clearance, soft=soft), _cfg())
    names = {(d, on, r) for d, on, r, _ in st["fits"]}
    assert ("clearance 'all'", "all onsets", "N = 100, 400, 6400, 10000") in names
    whole = {on: f for d, on, r, f in st["fits"] if d == "every packing" and r == "N = 100-10000"}
    assert whole["all onsets"].n_points == 30 and whole["stiff onsets"].n_points == 29
    sets = {s["n"]: s for s in st["sets"]}
    assert sets[1600]["clearance"] == {"local": 6} and sets[1600]["soft"] == 1
    assert sets[100]["machine"] == {"environment not recorded": 6}


def test_total_load_uses_the_generators_top_line():
    cfg = _cfg()
    F = _law(-0.9, -0.9, per=4, seed=4)
    st = el.limit_statistics(_rows(F), cfg)
    n_top = {n: top_count(box_width(n, cfg.phi)) for n in SIZES}
    assert st["n_top"] == n_top and n_top[100] == 8
    from remote_trigger.analysis.scaling import power_law_fit
    want = power_law_fit([n for n, _ in F], [n_top[n] * f / cfg.F_y for n, f in F])
    assert st["total"]["all onsets"].exponent == pytest.approx(want.exponent, rel=1e-12)


def test_the_windows_width_counts_reversed_packings():
    """Where > 0 only, the median width is a selection; over every decided
    packing the reversed ones pull it down."""
    cfg = ec.EnsembleConfig.from_dict({"n": [100, 400], "seeds": [[1, 2, 3]] * 2,
                                       "inertia_I0": None, "frictional": False})
    F = [(100, 0.02), (100, 0.02), (100, 0.02), (400, 0.005), (400, 0.005), (400, 0.005)]
    Fss = [0.016, 0.018, 0.03, 0.004, 0.006, 0.007]
    rows = _rows(F, Fss)
    st = er.statistics(rows, cfg)
    p400 = next(p for p in st["per_n"] if p["n"] == 400 and p["I0"] == 0.5)
    assert p400["window_rel"][:3] == (3, pytest.approx(-0.3), pytest.approx(-0.2))
    assert p400["window_rel_pos"][0] == 1 and p400["window_rel_pos"][2] == pytest.approx(0.2)
    w = st["limit"]["window"]
    assert w.present == (2, 1) and w.totals == (3, 3)
    lines = "\n".join(el.limit_lines(st["limit"], st["per_n"][:2], cfg))
    assert "| 400 | -0.2 [-0.3, 0] (3) | 0.2 (1) |" in lines
