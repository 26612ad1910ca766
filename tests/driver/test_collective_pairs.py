"""``pairs = 'collective'``: soft complex pairs do not end a ramp.

The small packing has no soft pair at the threshold 1e-4 lambda_max, so its
collective ramp is the all-pairs ramp. With the threshold raised above its
first pair's |Re lambda| / lambda_max that pair counts as soft: the ramp goes
on past it, and its bracket is checked against LAPACK's spectra of the same
equilibria (an independent eigen-solve): no pair at or above the threshold at
the lower end, one at the upper end.
"""
import numpy as np
import pytest

from remote_trigger.pywrap.stages.config import RampConfig
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.runtime.results import read_all

DF = 0.01
TOL = 1e-5
_BRACKETS = {}


@pytest.fixture(scope="module")
def all_pairs(relaxed, tmp_path_factory):
    cfg = RampConfig(datafile=relaxed.datafile, dF_x=DF, tol=TOL)
    return cfg, stages.ramp(cfg, str(tmp_path_factory.mktemp("all")), quiet=True)


def _lapack(dump):
    """Eigenvalues of M^-1 K of a dump by numpy (no certificate) and the top."""
    from remote_trigger.analysis.stability import eigen, jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    res = analyze(read_equilibrium(dump), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    lam = np.linalg.eigvals(eigen.dynamical_matrix(Kr, mr).toarray())
    return lam, float(np.max(lam.real))


def test_without_soft_pairs_the_collective_ramp_is_the_all_pairs_ramp(all_pairs, tmp_path):
    cfg, full = all_pairs
    res = stages.ramp(cfg.replace(pairs="collective"), str(tmp_path), quiet=True)
    assert res.status == "complete", res.message
    assert (res.F_x_c_low, res.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)
    np.testing.assert_array_equal(res.decision, full.decision)
    attrs, data = read_all(res.h5)
    assert attrs["pairs"] == "collective"
    assert np.all(data["steps/soft_pairs"] == 0)
    _, data_all = read_all(full.h5)
    assert np.all(np.isnan(data_all["steps/soft_pairs"]))


@pytest.mark.parametrize("sliced", [False, True])
def test_a_soft_first_pair_does_not_end_the_collective_ramp(all_pairs, monkeypatch, tmp_path,
                                                            sliced):
    from remote_trigger.analysis.stability import eigen, verdict
    from remote_trigger.pywrap.jobs.ensemble.onset import onset_numbers, read_ramp

    cfg, full = all_pairs
    first = onset_numbers(read_ramp(full.h5), DF)["pair_re_rel"]
    thr = 1.5 * abs(first)
    monkeypatch.setattr(verdict, "SOFT_MODE_REL", thr)
    if sliced:
        monkeypatch.setattr(eigen, "DENSE_MAX", 10)
    res = stages.ramp(cfg.replace(pairs="collective", F_x_max=0.6), str(tmp_path), quiet=True)
    monkeypatch.undo()
    assert res.status == "complete", res.message
    pts = read_ramp(res.h5)
    _, data = read_all(res.h5)
    soft = np.concatenate([data["steps/soft_pairs"], data["bisection/soft_pairs"]]
                          if "bisection/soft_pairs" in data else [data["steps/soft_pairs"]])
    # the all-pairs onset is passed: points above it are real with a soft pair
    # (or undecided, with the reason: at N = 20 the slicing leaves strips
    # coupled across their boundaries undecided)
    assert res.F_x_c_low > full.F_x_c_high
    assert np.max(soft) >= 1
    above = [p for p in pts if full.F_x_c_high <= p["F_x"] <= res.F_x_c_low]
    assert above and all(p["decision"] in (0, -1) for p in above)
    assert sum(p["decision"] == 0 for p in above) >= 1
    assert all(p["reason"] for p in above if p["decision"] == -1)
    # LAPACK's spectra: below the collective bracket only soft pairs ...
    lo = next(p for p in pts if p["F_x"] == res.F_x_c_low)
    lam, top = _lapack(lo["dump"])
    off = lam[lam.imag != 0]
    assert off.size and np.all(np.abs(off.real) < thr * top)
    # ... and at its upper end a pair at or above the threshold
    hi = next(p for p in pts if p["F_x"] == res.F_x_c_high and p["decision"] == 1)
    lam, top = _lapack(hi["dump"])
    off = lam[lam.imag != 0]
    assert np.any(np.abs(off.real) >= thr * top)
    monkeypatch.setattr(verdict, "SOFT_MODE_REL", thr)
    got = onset_numbers(pts, DF, "collective")["pair_re_rel"]
    monkeypatch.undo()
    assert abs(got) >= thr
    # the dense and the sliced collective ramps (the same loads) agree
    _BRACKETS[sliced] = (res.F_x_c_low, res.F_x_c_high)
    if len(_BRACKETS) == 2:
        assert _BRACKETS[True] == _BRACKETS[False]


def test_the_command_line_says_which_onset_it_bracketed(relaxed, tmp_path):
    """``remote-trigger ramp --set pairs=collective`` prints what its bracket is."""
    import os
    import subprocess
    import sys

    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    proc = subprocess.run([cli, "ramp", "--datafile", relaxed.datafile, "--dF-x", "0.05",
                           "--tol", "1e-3", "--set", "pairs=collective", "--quiet",
                           "--out", str(tmp_path / "r")], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "no complex pair that is not soft" in proc.stdout
    assert "(pairs = 'collective')" in proc.stdout


def test_the_ensembles_dense_spectrum_decides_on_the_pairs_that_are_not_soft(all_pairs,
                                                                            monkeypatch):
    """``ensemble.onset.spectrum`` (the I0 re-analysis and the frictional
    protocol's F_x = 0 point): at the all-pairs ramp's first complex point the
    decision on all pairs is complex; with a threshold above the pair's
    |Re lambda| / lambda_max it is real (every other unit certified), with 0
    complex again; under I0 = 1 as under the dynamics' I0; from a basis as from
    dgeev."""
    from remote_trigger.analysis.stability import verdict
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.pywrap.jobs.ensemble.onset import (onset_numbers, read_ramp,
                                                           reanalyse, spectrum)

    def collective(rel, call, *args):
        """``call(*args, pairs='collective')`` with the soft threshold ``rel``."""
        monkeypatch.setattr(verdict, "SOFT_MODE_REL", rel)
        try:
            return call(*args, pairs="collective")
        finally:
            monkeypatch.undo()

    _, full = all_pairs
    pts = read_ramp(full.h5)
    hi = next(p for p in pts if p["F_x"] == full.F_x_c_high and p["decision"] == 1)
    rel = abs(onset_numbers(pts, DF)["pair_re_rel"])
    state = read_dump(hi["dump"], require_contacts=False)
    assert spectrum(state)["decision"] == 1
    assert collective(0.0, spectrum, state)["decision"] == 1
    assert collective(1.5 * rel, spectrum, state)["decision"] == 0
    # under another I0, every point, each from the previous one's basis
    got = collective(1.5 * rel, reanalyse, pts, 1.0)
    plain = reanalyse(pts, 1.0)
    for g, p in zip(got, plain):
        if p["decision"] == 0:
            assert g["decision"] == 0
        state = read_dump(g["dump"], require_contacts=False, inertia_factor=1.0)
        assert g["decision"] == collective(1.5 * rel, spectrum, state)["decision"]


def test_jacobian_says_whether_the_complex_pairs_are_soft(all_pairs, tmp_path, capsys,
                                                         monkeypatch):
    """``remote-trigger jacobian`` of a complex point adds a line: how many of
    its certified complex pairs are soft and whether one is not (here the pair
    is collective; with the threshold raised above it, it is soft). A real
    point has no such line."""
    from remote_trigger.analysis.stability import verdict
    from remote_trigger.pywrap import cli
    from remote_trigger.pywrap.jobs.ensemble.onset import onset_numbers, read_ramp

    _, full = all_pairs
    pts = read_ramp(full.h5)
    hi = next(p for p in pts if p["F_x"] == full.F_x_c_high and p["decision"] == 1)
    lo = next(p for p in pts if p["F_x"] == full.F_x_c_low and p["decision"] == 0)
    rel = abs(onset_numbers(pts, DF)["pair_re_rel"])

    def run(dump, name):
        assert cli.main(["jacobian", dump, "-o", str(tmp_path / name)]) == 0
        return capsys.readouterr().out

    assert "soft pairs (|Re lambda| < 0.0001 lambda_max): 0; a complex pair that is not " \
           "soft: yes" in run(hi["dump"], "a.npz")
    assert "soft pairs" not in run(lo["dump"], "b.npz")
    monkeypatch.setattr(verdict, "SOFT_MODE_REL", 1.5 * rel)
    out = run(hi["dump"], "c.npz")
    assert "soft pairs" in out and ": 1; a complex pair that is not soft: no" in out
