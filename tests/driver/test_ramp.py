"""Ramp: a complex pair appears, bisection brackets F_x^c, resume reproduces it."""
import os
import time

import numpy as np
import pytest

from remote_trigger.pywrap.stages.config import RampConfig
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.runtime.results import read_all
from remote_trigger.pywrap.stages import ramp_file as rf
from remote_trigger.pywrap.stages.ramp_file import point_file, read_points
from remote_trigger.analysis.stability.decision import Decision

DF = 0.01
TOL = 1e-5


@pytest.fixture(scope="module")
def full_ramp(relaxed, tmp_path_factory):
    out = tmp_path_factory.mktemp("ramp_full")
    cfg = RampConfig(datafile=relaxed.datafile, dF_x=DF, tol=TOL)
    return cfg, stages.ramp(cfg, str(out), quiet=True)


def test_ramp_finds_complex_pair_and_bisects(full_ramp):
    cfg, res = full_ramp
    assert res.status == "complete", res.message
    # every step before the last is stable, the last has a complex pair
    assert res.complex_pair[-1] and not np.any(res.complex_pair[:-1])
    assert res.growth_rate[-1] > 0 and np.all(res.growth_rate[:-1] == 0)
    np.testing.assert_allclose(res.F_x, cfg.F_x + DF * np.arange(res.F_x.size), rtol=0,
                               atol=1e-15)
    # bracket inside the last ramp interval and narrower than tol
    assert res.F_x[-2] <= res.F_x_c_low < res.F_x_c_high <= res.F_x[-1]
    assert 0 < res.F_x_c_high - res.F_x_c_low <= TOL
    assert res.tol_reached and res.F_x_c_width == res.F_x_c_high - res.F_x_c_low
    # the bracket ends are certified answers: certified complex above it, real below
    bf, bd = res.bisection_F_x, res.bisection_decision
    assert np.all(bf[bd == 1] >= res.F_x_c_high) and np.all(bf[bd == 0] <= res.F_x_c_low)
    assert res.F_x_c_low in set(bf[bd == 0]) | {res.F_x[-2]}
    assert res.F_x_c_high in set(bf[bd == 1]) | {res.F_x[-1]}
    assert np.all(res.residual < 1e-10)


def test_ramp_h5_layout(full_ramp):
    cfg, res = full_ramp
    attrs, data = read_all(res.h5)
    assert attrs["status"] == "complete" and attrs["stage"] == "ramp"
    assert RampConfig.from_attrs(attrs) == cfg
    assert attrs["F_x_c_low"] == res.F_x_c_low and attrs["F_x_c_high"] == res.F_x_c_high
    assert attrs["F_x_c_width"] == res.F_x_c_width and bool(attrs["tol_reached"])
    assert attrs["n_undecided"] == res.n_undecided == 0
    n = res.F_x.size
    for c in ("F_x", "residual", "complex", "decision", "confidence", "growth_rate",
              "newton_steps", "datafile"):
        assert data[f"steps/{c}"].shape == (n,)
    # the analyzer's certified decision: real before, complex at the last step
    assert np.all(data["steps/decision"][:-1] == 0) and data["steps/decision"][-1] == 1
    assert np.all(data["steps/confidence"] > 1)
    np.testing.assert_array_equal(data["steps/complex"], data["steps/decision"] == 1)
    np.testing.assert_array_equal(res.decision, data["steps/decision"])
    # stored relative to the ramp file's folder (it can be moved)
    assert not any(os.path.isabs(f) for f in data["steps/datafile"])
    assert attrs["datafile_relative"]
    assert attrs["n_ranks"] == 1                # (ramp.h5 alone lacked it)
    assert all(os.path.exists(point_file(res.h5, f, attrs)) for f in data["steps/datafile"])
    last = f"eigenvalues/steps/step_{n - 1:05d}"
    assert np.any(np.abs(data[last].imag) > 0)


def test_resume_after_interruption_reproduces(full_ramp, relaxed, tmp_path):
    cfg, full = full_ramp
    rng = np.random.default_rng(int(time.time()))
    k = int(rng.integers(1, full.F_x.size + full.bisection_F_x.size - 1))
    part = stages.ramp(cfg, str(tmp_path), quiet=True, stop_after=k)
    assert part.status == "interrupted"
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    assert res.status == "complete"
    assert res.F_x_c_low == full.F_x_c_low and res.F_x_c_high == full.F_x_c_high, k
    np.testing.assert_array_equal(res.residual, full.residual)
    np.testing.assert_array_equal(res.bisection_F_x, full.bisection_F_x)
    # the same numbers, the decisions' margins included (the saved spectrum basis)
    _, a = read_all(res.h5)
    _, b = read_all(full.h5)
    for key in ("steps/confidence", "steps/from_basis", "bisection/confidence"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=f"{key}, k = {k}")


def _dump(datafile):
    s = datafile.decode() if isinstance(datafile, bytes) else str(datafile)
    return s[:-len(".data")] + ".dump"


def test_decisions_from_a_previous_basis_are_dgeev_s(full_ramp):
    """A point decided from a previous basis (a step from the previous step's, a
    bisection point from its start's): the same answer as dgeev's.

    The independent check is the analyzer run afresh on each point's dump
    (dgeev's eigenvectors, no basis); both answers are certified, so they
    must agree, and the eigenvalues must agree to the basis's accuracy.
    """
    from remote_trigger.analysis.stability.verdict import stability_of_dump

    cfg, res = full_ramp
    attrs, data = read_all(res.h5)
    fb = data["steps/from_basis"]
    assert fb[0] == 0 and fb.sum() >= (fb.size - 1) // 2, fb     # the path is taken
    fbb = data["bisection/from_basis"]
    assert fbb.sum() >= fbb.size // 2, fbb
    for kind, stem in (("steps", "step_{:05d}"), ("bisection", "bisect_{:03d}")):
        for k, f in enumerate(data[f"{kind}/datafile"]):
            cold = stability_of_dump(_dump(point_file(res.h5, f, attrs)))
            assert cold.start == "dgeev", (kind, k)
            assert cold.policy_decision == data[f"{kind}/decision"][k], (kind, k)
            lam = data[f"eigenvalues/{kind}/{stem.format(k)}"]
            np.testing.assert_allclose(np.sort_complex(lam),
                                       np.sort_complex(cold.eigenvalues), rtol=0,
                                       atol=1e-10 * np.abs(cold.eigenvalues).max(),
                                       err_msg=f"{kind} {k} {f}")
    assert not [f for f in os.listdir(os.path.dirname(_dump(point_file(res.h5, f, attrs))))
                if f.endswith(".basis.npz")]


def test_a_moved_ramp_folder_resumes_there(full_ramp, tmp_path):
    """An interrupted ramp's folder, moved: --resume there continues from the
    equilibria its ramp.h5 names (relative to the file's folder) and saved
    spectrum basis, with the uninterrupted ramp's numbers."""
    cfg, full = full_ramp
    first, moved = tmp_path / "first", tmp_path / "moved"
    part = stages.ramp(cfg, str(first), quiet=True, stop_after=3)
    assert part.status == "interrupted"
    os.rename(first, moved)
    res = stages.ramp(cfg, str(moved), quiet=True, resume=True)
    assert res.status == "complete"
    assert (res.F_x_c_low, res.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)
    np.testing.assert_array_equal(res.residual, full.residual)
    _, a = read_all(res.h5)
    _, b = read_all(full.h5)
    for key in ("steps/confidence", "steps/from_basis", "bisection/confidence"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    for kind in ("steps", "bisection"):
        files = read_points(res.h5, kind)[1]
        assert files and all(f.startswith(str(moved)) and os.path.isfile(f) for f in files)


def test_resume_starts_from_the_saved_basis(full_ramp, tmp_path):
    """Interrupted among the steps and resumed: the next step starts from the basis
    saved with the last recorded step. Without that file (deleted here) the
    step is decided from dgeev: the same answer with another margin, so the
    resumed ramp would not store the same numbers."""
    import glob
    import shutil

    cfg, full = full_ramp
    _, ref = read_all(full.h5)
    k = max(2, full.F_x.size // 2)
    first = tmp_path / "a"
    part = stages.ramp(cfg, str(first), quiet=True, stop_after=k)
    assert part.status == "interrupted" and part.F_x.size == k
    assert os.path.exists(first / "ramp" / f"step_{k - 1:05d}.basis.npz")
    second = tmp_path / "b"
    shutil.copytree(first, second)
    for f in glob.glob(str(second / "ramp" / "*.basis.npz")):
        os.remove(f)
    out = {}
    for name, folder in (("kept", first), ("deleted", second)):
        res = stages.ramp(cfg, str(folder), quiet=True, resume=True)
        assert res.status == "complete"
        out[name] = read_all(res.h5)[1]
    np.testing.assert_array_equal(out["kept"]["steps/confidence"], ref["steps/confidence"])
    np.testing.assert_array_equal(out["deleted"]["steps/decision"], ref["steps/decision"])
    assert ref["steps/from_basis"][k] == 1 and out["deleted"]["steps/from_basis"][k] == 0
    assert out["deleted"]["steps/confidence"][k] != ref["steps/confidence"][k]


# kill -9 at random moments, then --resume: tests/driver/test_kill.py


def test_undecided_points_leave_the_honest_wide_bracket(full_ramp, monkeypatch, capsys,
                                                        tmp_path):
    """All points within W of F_x^c undecided: the bracket stays [certified real, complex].

    The analyzer is made to answer 'undecided' near F_x^c (as it would for a
    pair closer to its exceptional point than float64 resolves). The ramp
    and its bisection must not count those points as stable: the bracket is
    at least 2 W wide, wider than tol, and the command line says why.
    """
    import dataclasses
    import json

    from remote_trigger.analysis.stability import verdict as stability
    from remote_trigger.pywrap import cli

    cfg, full = full_ramp
    F_c = full.F_x_c
    W = 0.3 * min(F_c - full.F_x[-2], full.F_x[-1] - F_c)
    real = stability.decide

    def fuzzy(system, *args, **kw):
        res = real(system, *args, **kw)
        F = system.state.F_x
        if abs(F - F_c) < W:
            return dataclasses.replace(res, decision=Decision.UNDECIDED,
                                       confidence=0.5, max_imag=0.0,
                                       reason=f"strip of 9 eigenvalues (> 8) at {F:.6g}")
        return res

    monkeypatch.setattr(stability, "decide", fuzzy)
    out = str(tmp_path)
    start = os.path.join(os.path.dirname(full.h5), "ramp", f"step_{full.F_x.size - 2:05d}.data")
    F0 = float(full.F_x[-2])
    rc = cli.main(["ramp", "--datafile", start, "--out", out, "--F-x", repr(F0),
                   "--dF-x", repr(DF), "--tol", repr(TOL), "--quiet"])
    text = capsys.readouterr().out
    assert rc == 0, text
    attrs, data = read_all(os.path.join(out, "ramp.h5"))
    lo, hi = attrs["F_x_c_low"], attrs["F_x_c_high"]
    assert attrs["status"] == "complete" and not attrs["tol_reached"]
    assert lo < F_c - W and hi > F_c + W            # only certified points bound it
    assert 2 * W < hi - lo <= 2 * W + TOL            # ... and it is narrowed up to the zone
    assert attrs["F_x_c_width"] == hi - lo and attrs["n_undecided"] >= 2
    dec = np.concatenate([data["steps/decision"], data["bisection/decision"]])
    F = np.concatenate([data["steps/F_x"], data["bisection/F_x"]])
    assert np.all(np.abs(F[dec == -1] - F_c) < W) and np.all(np.abs(F[dec >= 0] - F_c) >= W)
    assert "bisection stopped at width" in attrs["message"]
    assert f"width {hi - lo:.3g}" in text and "could not be certified" in text
    # the message names the undecided points' own reasons (the last one's in full)
    last = json.loads(attrs["undecided_reasons"])
    assert len(last) == attrs["n_undecided"]
    assert (f"{len(last)} undecided point(s), the last reason given: "
            f"{list(last.values())[-1]}") in attrs["message"]
    assert "strip of 9 eigenvalues" in text


def test_ramp_file_layout_and_reader(full_ramp):
    """pywrap.ramp_file names what RampLog writes; read_points returns its rows."""
    _, res = full_ramp
    attrs, data = read_all(res.h5)
    for kind in (rf.STEPS, rf.BISECTION):
        F, files = rf.read_points(res.h5, kind)
        np.testing.assert_array_equal(F, data[rf.column(kind, "F_x")])
        assert len(files) == F.size and all(os.path.isfile(f) for f in files)
        assert all(os.path.basename(f) == rf.point_name(kind, k) + ".data"
                   for k, f in enumerate(files))
        for c in rf.COLUMNS:
            assert data[rf.column(kind, c)].shape == F.shape, c
        # the verdict's split of its time: within the point's wall time; no
        # dgeev where the previous point's basis certified the decision
        te, td = data[rf.column(kind, "eigen_time")], data[rf.column(kind, "decision_time")]
        cold = data[rf.column(kind, "from_basis")] == 0
        assert np.all(te >= 0) and np.all(td >= 0) and np.all(te[cold] > 0)
        assert np.all(te + td <= data[rf.column(kind, "wall_time")])
        for k in range(F.size):
            assert f"{rf.EIGENVALUES}/{kind}/{rf.point_name(kind, k)}" in data
    np.testing.assert_array_equal(rf.read_points(res.h5)[0], res.F_x)
    # entries relative to the file's folder where the file says so; files of
    # older versions name them as their run was given them
    rel = {rf.RELATIVE_PATHS: True}
    assert rf.point_file("a/ramp.h5", "ramp/x.data", rel) == os.path.join("a", "ramp/x.data")
    assert rf.point_file("a/ramp.h5", b"a/ramp/x.data", {}) == "a/ramp/x.data"
    assert rf.point_file("a/ramp.h5", "/b/x.data", rel) == "/b/x.data"
    assert rf.point_name(rf.STEPS, 12) == "step_00012"
    assert rf.point_name(rf.BISECTION, 3) == "bisect_003"


# --------------------------------------------------------------------------- adaptive ramp
DF_FINE, DF_MAX = 1e-3, 0.05


@pytest.fixture(scope="module")
def adaptive_ramp(relaxed, tmp_path_factory):
    out = tmp_path_factory.mktemp("ramp_adaptive")
    cfg = RampConfig(datafile=relaxed.datafile, dF_x=DF_FINE, dF_x_max=DF_MAX, tol=TOL)
    return cfg, stages.ramp(cfg, str(out), quiet=True)


def test_adaptive_ramp_brackets_the_same_onset_with_fewer_steps(adaptive_ramp, full_ramp):
    """The adaptive ramp's certified bracket overlaps the fixed ramp's.

    A fixed ramp at the adaptive ramp's smallest step (1e-3) would need
    ~F_x^c / 1e-3 ~ 200 steps to get there; the adaptive one may take at most
    a quarter of them, with steps between dF_x and dF_x_max.
    """
    cfg, res = adaptive_ramp
    _, fixed = full_ramp
    assert res.status == "complete" and res.tol_reached, res.message
    assert res.F_x_c_low < fixed.F_x_c_high and fixed.F_x_c_low < res.F_x_c_high, (
        res.F_x_c_low, res.F_x_c_high, fixed.F_x_c_low, fixed.F_x_c_high)
    assert res.F_x.size <= 0.25 * res.F_x_c_high / DF_FINE, res.F_x.size
    h = np.diff(res.F_x)
    assert np.all(h >= DF_FINE * (1 - 1e-12)) and np.all(h <= DF_MAX * (1 + 1e-12))
    assert h.max() > 5 * DF_FINE          # it did take large steps
    assert res.complex_pair[-1] and not np.any(res.complex_pair[:-1])


def test_adaptive_ramp_resume_takes_the_same_loads(adaptive_ramp, tmp_path):
    cfg, full = adaptive_ramp
    k = max(3, full.F_x.size // 2)            # interrupted among the adaptive steps
    part = stages.ramp(cfg, str(tmp_path), quiet=True, stop_after=k)
    assert part.status == "interrupted" and part.F_x.size == k
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    np.testing.assert_array_equal(res.F_x, full.F_x)
    np.testing.assert_array_equal(res.bisection_F_x, full.bisection_F_x)
    assert (res.F_x_c_low, res.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)


@pytest.mark.parametrize("dmax", [1e-3, 5e-4, float("nan")])
def test_adaptive_ramp_needs_dF_x_max_above_dF_x(relaxed, dmax):
    from remote_trigger.pywrap.config import ConfigError

    with pytest.raises(ConfigError, match="dF_x_max"):
        RampConfig(datafile=relaxed.datafile, dF_x=1e-3, dF_x_max=dmax)


def test_adaptive_step_rules():
    """Half the predicted distance, clipped; dF_x unless both loads are certified real."""
    from remote_trigger.pywrap.stages.ramp import ADAPTIVE_SAFETY, adaptive_step

    def spec(F, F_c=0.5):                   # a pair closing like sqrt(F_c - F)
        g = 0.2 * np.sqrt(F_c - F)
        return np.array([1.0 - g, 1.0 + g, 3.0], complex)

    prev, last = (0.40, 0, spec(0.40)), (0.42, 0, spec(0.42))
    assert adaptive_step(1e-3, 1.0, prev, last) == pytest.approx(ADAPTIVE_SAFETY * 0.08)
    assert adaptive_step(1e-3, 0.01, prev, last) == 0.01                 # clipped above
    near = (0.4999, 0, spec(0.4999))
    assert adaptive_step(1e-3, 1.0, last, near) == 1e-3                  # clipped below
    for dec in (-1, 1):
        assert adaptive_step(1e-3, 1.0, prev, (0.42, dec, spec(0.42))) == 1e-3
    assert adaptive_step(1e-3, 1.0, prev, (0.42, 0, spec(0.42)[:2])) == 1e-3   # rattlers


def test_inertia_reanalysis_from_bases_gives_dgeev_s_decisions(full_ramp, monkeypatch):
    """The ensemble's I0 = 1 re-analysis chains each point's basis to the next: the
    same decisions as each point decided alone from dgeev (the independent
    check), and the chain is used."""
    from remote_trigger.analysis.stability import exceptional
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.pywrap.jobs.ensemble.onset import read_ramp, reanalyse, spectrum

    cfg, res = full_ramp
    pts = read_ramp(res.h5)
    starts = []
    real = exceptional.classify_spectrum

    def spy(A, *a, **kw):
        dec = real(A, *a, **kw)
        starts.append(dec.start)
        return dec

    monkeypatch.setattr(exceptional, "classify_spectrum", spy)
    chained = reanalyse(pts, 1.0)
    assert starts.count("basis") >= len(pts) // 3, starts
    monkeypatch.setattr(exceptional, "classify_spectrum", real)
    alone = [spectrum(read_dump(p["dump"], require_contacts=False, inertia_factor=1.0))
             for p in pts]
    assert [p["decision"] for p in chained] == [s["decision"] for s in alone]
    for p, s in zip(chained, alone):
        np.testing.assert_allclose(np.sort_complex(p["eigenvalues"]),
                                   np.sort_complex(s["eigenvalues"]), rtol=0,
                                   atol=1e-10 * np.abs(s["eigenvalues"]).max())


def _stored_points(folder):
    """Stems of the equilibria in a ramp folder, with the extensions each has."""
    from collections import defaultdict

    from remote_trigger.pywrap.stages.common import EQUILIBRIUM_EXTS

    have = defaultdict(set)
    for f in os.listdir(folder):
        for ext in EQUILIBRIUM_EXTS:
            if f.endswith(ext):
                have[f[:-len(ext)]].add(ext)
    return dict(have)


def test_keep_equilibria_false_keeps_only_the_bracket_and_the_same_numbers(full_ramp,
                                                                           tmp_path):
    """``keep_equilibria = False``: the same rows and bracket as the full ramp,
    bitwise, and only the bracket's two ends and the last step on disk, each
    with its three files (interrupted and resumed half-way, too)."""
    from remote_trigger.pywrap.stages.common import EQUILIBRIUM_EXTS

    cfg, full = full_ramp
    pcfg = cfg.replace(keep_equilibria=False)
    k = max(2, (full.F_x.size + full.bisection_F_x.size) // 2)
    part = stages.ramp(pcfg, str(tmp_path), quiet=True, stop_after=k)
    assert part.status == "interrupted"
    # while it runs: at most the last step and the bracket's ends (here: 1-3 points)
    assert 1 <= len(_stored_points(tmp_path / "ramp")) <= 3
    # resumed by the configuration that keeps everything: a storage choice only
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    assert res.status == "complete"
    _, a = read_all(res.h5)
    _, b = read_all(full.h5)
    for key in b:
        if key.endswith("/datafile") or key.rsplit("/", 1)[-1] in rf.TIME_COLUMNS:
            continue
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    assert (res.F_x_c_low, res.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)

    # a whole ramp without the equilibria: the ends of the bracket stay
    out = tmp_path / "pruned"
    res = stages.ramp(pcfg, str(out), quiet=True)
    attrs, a = read_all(res.h5)
    rows = {f: (F, d) for kind in ("steps", "bisection")
            for F, d, f in zip(a[f"{kind}/F_x"], a[f"{kind}/decision"],
                               (_dump(point_file(res.h5, x, attrs))[:-len(".dump")]
                                for x in a[f"{kind}/datafile"]))}
    kept = _stored_points(out / "ramp")
    assert all(exts == set(EQUILIBRIUM_EXTS) for exts in kept.values()), kept
    kept_rows = sorted(rows[str(out / "ramp" / stem)] for stem in kept)
    assert (res.F_x_c_low, 0.0) in kept_rows and (res.F_x_c_high, 1.0) in kept_rows
    assert len(kept) <= 3 < len(rows), (kept, len(rows))


def test_undecided_points_keep_their_reason_in_ramp_h5(full_ramp, tmp_path, monkeypatch):
    """An undecided point's reason (the decision's own words) is stored in ramp.h5's
    ``undecided_reasons`` and survives an interruption and --resume."""
    import dataclasses
    import json

    from remote_trigger.analysis.stability import verdict

    real = verdict.decide
    why = "strip of 9 eigenvalues (> 8)"
    cfg, full = full_ramp

    def forced(system, *args, **kw):
        res = real(system, *args, **kw)
        if system.state.F_x == full.F_x[1]:         # step_00001
            return dataclasses.replace(res, decision=Decision.UNDECIDED, reason=why)
        return res

    monkeypatch.setattr(verdict, "decide", forced)
    part = stages.ramp(cfg, str(tmp_path), quiet=True, stop_after=3)
    assert part.status == "interrupted"
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    attrs, data = read_all(res.h5)
    assert data["steps/decision"][1] == -1 and res.n_undecided == 1
    assert json.loads(attrs["undecided_reasons"]) == {"step_00001": why}
    assert (res.F_x_c_low, res.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)
    # the ensemble reads it back and names it in its table's reason column
    from remote_trigger.pywrap.jobs.ensemble.onset import onset_numbers, read_ramp
    from remote_trigger.pywrap.jobs.ensemble.report import _default_row

    pts = read_ramp(res.h5)
    assert [p["reason"] for p in pts if p["decision"] == -1] == [why]
    o = onset_numbers(pts, cfg.dF_x)
    assert o["undecided"] == [[pts[1]["F_x"], why]]
    ramp = {"ramp_status": "complete", "tol_reached": True, "message": "", "mu": cfg.mu,
            "n_steps": 3, "n_bisection": 0, "I0_0.5": dict(o, n_new=0, tol_reached=True)}
    row = _default_row({"key": "N10_s1", "n": 10, "seed": 1},
                       {"wall": 1.0, "default": {"ramps": {"mu0": ramp, "mu_ss": None}}},
                       0.5, 0.5)
    assert f"1 undecided point(s) at mu0, the first at F_x = {pts[1]['F_x']:.6g}: {why}" \
        in row["reason"]
    # a ramp with no undecided point has no such attribute
    assert "undecided_reasons" not in read_all(full.h5)[0]


def test_sliced_ramp_stops_at_the_pair_and_measures_the_same_onset(full_ramp, monkeypatch,
                                                                   tmp_path, capsys):
    """The same ramp decided by slicing (the switch lowered below its n): its
    scans stop at the first complex strip (ramp.h5's ``scanned_below`` finite
    at complex points only, fewer eigenvalues there), its certified answers
    agree with the dense ramp's bracket, and the onset numbers from the
    stopped scan -- the pair's place and index, the spectrum's size and top
    -- are those of the dense whole spectrum of the same equilibrium. The
    progress bar shows each point's verdict as it scans."""
    from remote_trigger.analysis.stability import eigen, verdict
    from remote_trigger.pywrap.jobs.ensemble.onset import (onset_numbers, pair_position,
                                                           read_ramp)

    from remote_trigger.pywrap.stages import common

    cfg, full = full_ramp
    monkeypatch.setattr(eigen, "DENSE_MAX", 10)
    # every update of the bar a line of the log (a line per 10 s would hide
    # the verdict's updates of a ramp that takes a few seconds)
    monkeypatch.setattr(common, "LOG_INTERVAL", 0.0)
    res = stages.ramp(cfg, str(tmp_path), quiet=False)
    monkeypatch.undo()
    assert res.status == "complete", res.message
    err = capsys.readouterr().err
    assert ": verdict " in err and " eigenvalues" in err
    # the two certified brackets overlap, and no certified answer of the sliced
    # ramp contradicts the dense bracket (an undecided point sends the bisection
    # elsewhere, so the sliced bracket may also be narrower on one side)
    assert max(res.F_x_c_low, full.F_x_c_low) < min(res.F_x_c_high, full.F_x_c_high)
    pts = read_ramp(res.h5)
    assert all(p["F_x"] > full.F_x_c_low for p in pts if p["decision"] == 1)
    assert all(p["F_x"] < full.F_x_c_high for p in pts if p["decision"] == 0)
    _, data = read_all(res.h5)
    for kind in ("steps", "bisection"):
        cplx = data[f"{kind}/decision"] == 1
        assert np.all(np.isfinite(data[f"{kind}/scanned_below"][cplx]))
        assert np.all(np.isinf(data[f"{kind}/scanned_below"][~cplx]))
        assert np.all(data[f"{kind}/n_negative"] == 0)      # the screen's count (sliced)
    hi = next(p for p in pts if p["F_x"] == res.F_x_c_high and p["decision"] == 1)
    assert 0 < len(hi["eigenvalues"]) < hi["n_dof"]
    dense = verdict.stability_of_dump(hi["dump"])
    assert dense.decision is Decision.COMPLEX and dense.n_dof == hi["n_dof"]
    want = pair_position(dense.eigenvalues)
    got = onset_numbers(pts, cfg.dF_x)
    assert got["n_dof"] == want["n_dof"] and got["pair_index"] == want["pair_index"]
    assert got["lambda_c"] == pytest.approx(want["lambda_c"], rel=1e-9)
    # the top: ARPACK's of the symmetric part S, as the sliced scan lists it for
    # a one-eigenvalue strip; W moves A's at second order (6e-5 here, N = 20)
    assert hi["lambda_max"] == pytest.approx(dense.lambda_max, rel=1e-4)
    assert got["pair_re_rel"] == pytest.approx(want["pair_re_rel"], rel=1e-4)


def test_a_finished_packing_without_the_long_wave_fraction_gets_it_from_its_equilibria(
        full_ramp):
    """``ensemble.task.add_missing_shape`` on a ramp part recorded before the
    long-wave fraction existed: it is computed from the ramp's kept
    equilibria (the first complex point's pair mode, as a fresh run records
    it), the recorded onset numbers unchanged; a part that has it is left alone."""
    import math

    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.analysis.stability.modeshape import pair_mode
    from remote_trigger.pywrap.jobs.ensemble import config as ec
    from remote_trigger.pywrap.jobs.ensemble.onset import onset_numbers, read_ramp
    from remote_trigger.pywrap.jobs.ensemble.task import add_missing_shape

    cfg, res = full_ramp
    ecfg = ec.build_config(quick=True)
    key = f"I0_{ecfg.I0_dynamics:g}"
    pts = read_ramp(res.h5)
    o = onset_numbers(pts, ecfg.dF_x)
    result = {"default": {"ramps": {"mu0": {"h5": res.h5, key: dict(o)}, "mu_ss": None}}}
    assert add_missing_shape(ecfg, result, os.path.dirname(res.h5)) == (1, 1)
    got = result["default"]["ramps"]["mu0"][key]
    top = next(p for p in pts if p["F_x"] == o["F_x_c_high"] and p["decision"] == 1)
    want = pair_mode(read_equilibrium(top["dump"]), complex(*o["lambda_c"]))
    assert got["pair_longwave"] == want.long_wave and 0 <= want.long_wave <= 1
    assert got["pair_pr"] == want.participation_ratio
    for k, v in o.items():
        assert got[k] == v or (isinstance(v, float) and math.isnan(v)), k
    assert add_missing_shape(ecfg, result, os.path.dirname(res.h5)) == (0, 0)
    # recorded onset numbers are kept as they are (not recomputed)
    marked = {"default": {"ramps": {"mu0": {"h5": res.h5, key: dict(o, pair_index=-7)}}}}
    assert add_missing_shape(ecfg, marked, os.path.dirname(res.h5)) == (1, 1)
    assert marked["default"]["ramps"]["mu0"][key]["pair_index"] == -7
