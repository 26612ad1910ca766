"""``remote-trigger paper --quick`` end to end, once, and what it must show.

The quick variant (N = 40, coarse steps, short runs) must still show the
paper's qualitative results. The checks read the HDF5 files directly (an
independent reading of what the report states) and the report's structure.
"""
import json
import os
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest
from remote_trigger.analysis.stability.decision import Decision

BIN = os.path.dirname(sys.executable)
CLI = os.path.join(BIN, "remote-trigger")

SECTIONS = ["## 1. Packing and relaxation", "## 2. Eigenvalues and F_x^c (Fig. 3)",
            "## 3. Oscillatory instability above F_x^c (Fig. 4)",
            "## 4. Perturbations below F_x^c (Fig. 5)", "## 5. Normal form (Sections III.C.2 and IV)",
            "## 6. Other measured numbers", "## 7. Figures", "## 8. Timings",
            "## 9. Choices and interpretations"]
FIGURES = ["fig1_packing", "fig2_mu_law", "fig3_eigenvalues", "fig4_msd", "fig5_perturb",
           "fig_normal_form"]
CHECK_IDS = ["packing_fraction", "residual", "real_at_zero_mu1", "real_at_zero_mu0.8",
             "coalescence_mu1", "coalescence_mu0.8", "sqrt_law_mu1", "sqrt_law_mu0.8", "F_x_c_mu1", "F_x_c_ratio",
             "msd_decades_fig4", "growth_rate_fig4", "saturation_fig4", "stable_fig5",
             "drop_unstable_fig5", "msd_growth_fig5a", "msd_level_fig5a", "msd_fig5b",
             "forcing_fig5b", "growth_rate_fig5c", "msd_decades_fig5c",
             "velocity_decades_fig5c", "mu_drop_fig5c", "control_fig5d", "control_fig5e",
             "paper_amplitude_fig5", "nf_A_sqrt_eps", "nf_slope"]
#: the checks that must pass on the quick scene: Fig. 5 shows the trigger
#: (growth_rate_fig5c is not among them: at N = 40 the exponential stretch between the
#: re-equilibration jump and the saturation spans ~2 decades, a few records; measured
#: -35 %. On the default scene it passes: tests cannot afford that run.)
MUST_PASS = ["stable_fig5", "drop_unstable_fig5", "msd_growth_fig5a", "msd_fig5b",
             "forcing_fig5b", "msd_decades_fig5c",
             "velocity_decades_fig5c", "mu_drop_fig5c", "control_fig5d", "control_fig5e"]


@pytest.fixture(scope="module")
def run(paper_quick):
    return paper_quick


def split_row(line):
    """Cells of a markdown table row (escaped pipes kept inside cells)."""
    cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
    return [c.strip().replace("\\|", "|") for c in cells]


def check_rows(text):
    rows = {}
    for line in text.splitlines():
        if line.startswith("| ") and "**" in line:
            c = split_row(line)
            assert len(c) == 6, line
            rows[c[0]] = {"quantity": c[1], "measured": c[2], "paper": c[3],
                          "verdict": c[4].strip("*"), "reason": c[5]}
    return rows


def series(out, name):
    with h5py.File(os.path.join(out, name), "r") as fh:
        return {k: fh[k][()] for k in ("t", "D", "v_top", "mu")}, dict(fh.attrs)


def test_progress_and_final_line(run):
    out, proc = run
    lines = proc.stdout.strip().splitlines()
    assert lines[-1] == f"report: {os.path.join(out, 'report.md')}"
    assert any("ramp mu = 0.8" in s for s in lines) and len(lines) < 40
    # two ranks (as make demo runs it): only rank 0 prints; the second rank group's
    # lines (the mu = 0.8 ramp, Fig. 5) reach the output through rank 0
    assert {r for r, _ in proc.rank_lines} == {0}, proc.rank_lines
    assert any("Fig. 5: done" in s for s in lines)


def test_files(run):
    out, _ = run
    for f in ["packing.data", "relax.h5", "ramp_mu1/ramp.h5", "ramp_mu0.8/ramp.h5",
              "ramp_mu1/extend.h5", "instability.h5", "perturb_a.h5", "perturb_b.h5",
              "perturb_c.h5", "perturb_d.h5", "perturb_e.h5", "perturb_p.h5", "normal_form.h5", "report.md", "report.json", "paper.json"]:
        assert os.path.isfile(os.path.join(out, f)), f
    for name in FIGURES:
        with open(os.path.join(out, name + ".png"), "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n", name


def test_report_structure(run):
    out, _ = run
    text = open(os.path.join(out, "report.md")).read()
    pos = [text.find(s) for s in SECTIONS]
    assert all(p >= 0 for p in pos), [s for s, p in zip(SECTIONS, pos) if p < 0]
    assert pos == sorted(pos)
    rows = check_rows(text)
    assert set(CHECK_IDS) <= set(rows), set(CHECK_IDS) - set(rows)
    for cid, r in rows.items():
        assert r["verdict"] in ("pass", "differs"), cid
        if r["verdict"] == "differs":
            assert len(r["reason"]) > 20, cid
        if r["measured"] not in ("yes", "no"):
            float(r["measured"])                      # numbers parse
    m = re.search(r"Summary: (\d+) pass, (\d+) differ, of (\d+) checks", text)
    assert m and int(m[1]) + int(m[2]) == int(m[3]) == len(rows)
    js = json.load(open(os.path.join(out, "report.json")))
    assert {c["id"]: c["verdict"] for c in js["checks"]} == \
        {k: r["verdict"] for k, r in rows.items()}
    for name in FIGURES:
        assert f"({name}.png)" in text
    # timings: every phase a number, total last
    tim = text[text.find("## 8. Timings"):text.find("## 9.")]
    phases = dict(split_row(s)[:2] for s in tim.splitlines() if s.startswith("| ")
                  and "---" not in s and "phase" not in s)
    assert {"relax", "instability", "perturb", "total"} <= set(phases)
    assert all(float(v) >= 0 for v in phases.values())


def test_spectrum_real_positive_at_zero_and_coalescence(run):
    """All eigenvalues real and positive at F_x = 0; a real pair becomes complex at F_x^c."""
    out, _ = run
    from remote_trigger.analysis.stability.eigtrack import track_pair
    from remote_trigger.pywrap.stages.ramp_file import read_spectra

    for mu in ("1", "0.8"):
        h5 = os.path.join(out, f"ramp_mu{mu}", "ramp.h5")
        with h5py.File(h5, "r") as fh:
            assert fh.attrs["status"] == "complete"
            lam0 = fh["eigenvalues/steps/step_00000"][()]
            assert fh["steps/F_x"][0] == 0.0 and fh["steps/complex"][0] == 0
            assert np.all(lam0.real > 0)
            assert np.max(np.abs(lam0.imag)) <= 1e-10 * np.max(np.abs(lam0))
            lo, hi = fh.attrs["F_x_c_low"], fh.attrs["F_x_c_high"]
        tr = track_pair(read_spectra(h5))
        k = int(np.argmax(tr.complex_pair))
        assert tr.F_x[k] == pytest.approx(hi) and tr.F_x[k - 1] == pytest.approx(lo)
        assert tr.lam_a[k - 1].imag == 0 and tr.lam_a[k - 1].real < tr.lam_b[k - 1].real
        assert tr.lam_b[k].imag > 0 and tr.lam_a[k] == np.conj(tr.lam_b[k])
        assert abs(tr.lam_b[k].real - 0.5 * (tr.lam_a[k - 1].real + tr.lam_b[k - 1].real)) \
            < 0.01 * tr.lam_c


def test_lower_friction_destabilises_earlier(run):
    """F_x^c(0.8) < F_x^c(1) holds on the quick packing (seed 1, N = 40)."""
    out, _ = run
    Fc = {}
    for mu in ("1", "0.8"):
        with h5py.File(os.path.join(out, f"ramp_mu{mu}", "ramp.h5"), "r") as fh:
            Fc[mu] = 0.5 * (fh.attrs["F_x_c_low"] + fh.attrs["F_x_c_high"])
    assert Fc["0.8"] < Fc["1"]
    rows = check_rows(open(os.path.join(out, "report.md")).read())
    assert float(rows["F_x_c_ratio"]["measured"]) == pytest.approx(Fc["0.8"] / Fc["1"],
                                                                   rel=1e-3)
    assert rows["F_x_c_ratio"]["verdict"] == "pass"


def test_msd_grows_above_F_x_c_at_the_predicted_rate(run):
    out, _ = run
    s, attrs = series(out, "instability.h5")
    t, D = s["t"], s["D"]
    noise = np.median(D[(t > 0)][:max(3, len(t) // 20)])
    assert np.log10(D.max() / noise) >= 12
    assert attrs["complex_pair"]
    g = attrs["predicted_growth_rate"]
    sel = (D > 1e3 * noise) & (t < t[np.argmax(D > 1e-3 * D.max())])
    slope = np.polyfit(t[sel], np.log(D[sel]), 1)[0] / 2
    assert slope == pytest.approx(g, rel=0.1)


def test_fig5_checks_pass(run):
    out, _ = run
    rows = check_rows(open(os.path.join(out, "report.md")).read())
    bad = {k: rows[k]["reason"] for k in MUST_PASS if rows[k]["verdict"] != "pass"}
    assert not bad, bad


def test_stable_below_F_x_c_with_and_without_forcing(run):
    """(a) stays at the noise; (b) f(t) alone: bounded, mu never leaves mu0."""
    out, _ = run
    a, _ = series(out, "perturb_a.h5")
    b, _ = series(out, "perturb_b.h5")
    level = np.median(a["D"][a["t"] > 0])
    assert a["D"].max() < 1e2 * level
    half = b["t"] > b["t"][-1] / 2
    assert b["D"][half].max() < 10 * b["D"][~half].max()
    assert np.all(a["mu"] == 1.0) and np.all(b["mu"] == 1.0)


def test_triggered_only_where_the_dropped_friction_is_unstable(run):
    """From the files: (c) runs away far above the control (d), whose spectrum after
    the friction drop is certified real while (c)'s is certified complex; v0 is the
    margin x the per-step noise maximum of the first half of (a)."""
    out, _ = run
    man = json.load(open(os.path.join(out, "paper.json")))["perturb"]
    a, _ = series(out, "perturb_a.h5")
    c, attrs = series(out, "perturb_c.h5")
    d, _ = series(out, "perturb_d.h5")
    e, _ = series(out, "perturb_e.h5")
    with h5py.File(os.path.join(out, "perturb_a.h5"), "r") as fh:
        run_max = fh["v_top_max"][()]
    half = int(np.searchsorted(a["t"], a["t"][-1] / 2, side="right")) - 1
    assert attrs["v0"] == pytest.approx(10 * run_max[half])
    assert run_max[half] >= np.max(np.abs(a["v_top"][:half + 1]))
    assert man["drop"]["decision"] == "complex" and man["equilibrium"]["decision"] == "real"
    assert man["control"]["drop"]["decision"] == "real"
    assert c["mu"].min() < 0.8 * 1.001 and d["mu"].min() < 0.8 * 1.001
    assert c["D"].max() > 30 * d["D"].max()      # N = 40 saturates ~2 decades above the jump
    assert np.all(e["mu"] == 1.0)                 # noise alone never switches mu(v) on


def test_growth_with_velocity_dependent_friction(run):
    out, _ = run
    a, a_attrs = series(out, "perturb_a.h5")
    c, attrs = series(out, "perturb_c.h5")
    level = np.median(a["D"][a["t"] > 0])
    assert c["D"].max() > 1e12 * level
    assert np.max(np.abs(c["v_top"])) > 1e7 * np.median(np.abs(a["v_top"][a["t"] > 0]))


def test_sliced_verdict_agrees_with_the_dense_one_on_the_ramps(run):
    """The whole-spectrum verdict by slicing (analysis.stability.sliced) and the dense
    certified decision agree on every bisection point of both quick ramps (the points
    that bracket F_x^c) and on their first and last steps; neither is undecided."""
    import glob

    from remote_trigger.analysis.stability import eigen, exceptional
    from remote_trigger.analysis.stability.sliced import classify_sliced
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    out, _ = run
    seen = {Decision.COMPLEX: 0, Decision.REAL: 0}
    for mu in ("1", "0.8"):
        steps = sorted(glob.glob(os.path.join(out, f"ramp_mu{mu}", "ramp", "step_*.dump")))
        dumps = sorted(glob.glob(os.path.join(out, f"ramp_mu{mu}", "ramp", "bisect_*.dump")))
        for path in dumps + [steps[0], steps[-1]]:
            system = reduced_system(read_equilibrium(path))
            Kr, mr = system.K, system.mass
            sliced = classify_sliced(Kr, mr)
            dense = exceptional.classify_spectrum(eigen.dynamical_matrix(Kr, mr).toarray())
            assert dense.decision is not Decision.UNDECIDED
            assert sliced.decision is dense.decision, (path, sliced.reason)
            seen[sliced.decision] += 1
    assert seen[Decision.COMPLEX] >= 2 and seen[Decision.REAL] >= 2
