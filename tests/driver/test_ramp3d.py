"""``ramp`` of a packing of spheres: F_x steps with friction on, Newton with the
3D Jacobian, the certified decision on M^-1 K with 6 dofs per sphere.

Each equilibrium is checked independently: its dump is read back
(``read_dump3d``) and the residual recomputed by the analysis' own force law
(``generalized_forces3d``); the decisions at the ends of the bracket are
recomputed from a fresh eigen-solve (no previous basis) and compared with a
plain ``numpy.linalg.eigvals`` of the same matrix. A killed command-line ramp
resumes to the same ``ramp.h5`` bitwise (the helpers of test_kill.py).

N = 96 spheres (seed 1, L = 5, a 4 x 4 top layer) keeps a ramp point near 1 s.
"""
import os
import shutil

import h5py
import numpy as np
import pytest

from remote_trigger.analysis.stability.analyze import analyze
from remote_trigger.analysis.stability.residual import max_residual, roundoff_floor
from remote_trigger.analysis.stability.jacobian import remove_dofs
from remote_trigger.analysis.stability.jacobian3d import generalized_forces3d
from remote_trigger.analysis.stability.verdict import stability_of
from remote_trigger.analysis.state.dumpfile import read_dump3d
from remote_trigger.pywrap.stages.ramp_file import point_file

from .test_cli_errors import assert_one_line_error, run_cli
from . import test_kill
from remote_trigger.analysis.stability.decision import Decision

N = 96
SEED = 1
DF = 0.02
TOL = 1e-3


@pytest.fixture(scope="module")
def packing3d(tmp_path_factory):
    from remote_trigger.pywrap.stages.packing import generate, write_data

    path = tmp_path_factory.mktemp("packing3d") / "p96.data"
    write_data(generate(N, seed=SEED, dim=3), path)
    return str(path)


@pytest.fixture(scope="module")
def relaxed3d(tmp_path_factory, packing3d):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig

    out = tmp_path_factory.mktemp("relax3d")
    return stages.relax(RelaxConfig(datafile=packing3d), str(out), quiet=True)


@pytest.fixture(scope="module")
def ramp3d(tmp_path_factory, relaxed3d):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    out = tmp_path_factory.mktemp("ramp3d")
    cfg = RampConfig(datafile=relaxed3d.datafile, dF_x=DF, tol=TOL)
    return cfg, stages.ramp(cfg, str(out), quiet=True)


def _points(h5):
    """(kind, F_x, decision, residual, data file) of every row of ramp.h5."""
    rows = []
    with h5py.File(h5, "r") as fh:
        for kind in ("steps", "bisection"):
            g = fh[kind]
            for F, d, r, f in zip(g["F_x"][()], g["decision"][()], g["residual"][()],
                                  g["datafile"][()]):
                rows.append((kind, float(F), float(d), float(r), point_file(h5, f, fh.attrs)))
    return rows


def test_every_point_is_an_equilibrium_recomputed_independently(ramp3d):
    _, res = ramp3d
    rows = _points(res.h5)
    assert len(rows) >= 4
    umax = 0.0
    for kind, F, _, r_driver, datafile in rows:
        st = read_dump3d(datafile[:-len(".data")] + ".dump")
        assert st.F_x == F and st.n == N
        r = max_residual(generalized_forces3d(st), spheres=True)
        floor = roundoff_floor(st)
        assert r < floor <= 1e-9, (kind, F, r, floor)
        assert r == pytest.approx(r_driver, rel=0.5), (kind, F)
        if F > 0:   # friction carries the load: the history is the ramp's, not zero
            assert np.abs(st.contact_t).max() > 1e-6 and np.abs(st.wall_t).max() > 1e-6
            d = st.separation(st.contact_i, st.contact_j)
            delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.linalg.norm(d, axis=1)
            p = st.params
            u = np.linalg.norm(st.contact_t, axis=1) / (p.mu * p.k_n / p.k_t * delta)
            assert u.max() <= 1.0 + 1e-12
            umax = max(umax, float(u.max()))
    print(f"3D ramp, N = {N}: {len(rows)} equilibria, residuals "
          f"{min(r[3] for r in rows):.2g}-{max(r[3] for r in rows):.2g}, "
          f"largest |t|/t* {umax:.3g}")


def test_short_ramp_gives_a_certified_bracket(ramp3d):
    cfg, res = ramp3d
    assert res.status == "complete" and res.tol_reached, res.message
    lo, hi = res.F_x_c_low, res.F_x_c_high
    assert 0 < lo < hi <= lo + TOL
    assert res.n_undecided == 0
    rows = {F: (d, f) for _, F, d, _, f in _points(res.h5)}
    assert rows[lo][0] == 0 and rows[hi][0] == 1
    # below lo every load is certified real, above hi nothing certified real
    assert all(d == 0 for F, (d, _) in rows.items() if F < lo)
    assert all(d != 0 for F, (d, _) in rows.items() if F > hi)
    out = {}
    for F in (lo, hi):
        st = read_dump3d(rows[F][1][:-len(".data")] + ".dump")
        fresh = stability_of(st)                    # from dgeev, no previous basis
        assert fresh.decision is (Decision.REAL if F == lo else Decision.COMPLEX), (F, fresh.decision)
        assert fresh.confidence > 1
        a = analyze(st, eigenvalues=False, decide=False)
        Kr, mr = remove_dofs(a.K, a.mass, a.rattlers.keep_dofs)
        assert Kr.shape[0] == 6 * (N - a.rattlers.ids.size)
        lam = np.linalg.eigvals(Kr.toarray() / mr[:, None])
        assert lam.size == fresh.eigenvalues.size
        out[F] = lam
    # the plain eigen-solve agrees: nothing off the axis at lo, a clear pair at hi
    lmax = out[hi].real.max()
    assert np.abs(out[lo].imag).max() < 1e-9 * lmax
    k = np.argmax(np.abs(out[hi].imag))
    assert abs(out[hi][k].imag) > 1e-7 * lmax
    print(f"3D ramp, N = {N}: F_x^c in [{lo}, {hi}]; the pair at Re lambda_c / lambda_max "
          f"= {out[hi][k].real / lmax:.3g}, Im {abs(out[hi][k].imag):.3g}")


def test_a_saved_point_loads_back_as_the_same_equilibrium(ramp3d, tmp_path):
    """Data file + the dump's history give the saved residual exactly; the same
    data file with the history zeroed in its dump is far from equilibrium."""
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import load_equilibrium_scene
    from remote_trigger.pywrap.stages.equilibrium import exact_residual

    cfg, res = ramp3d
    start = [f for _, F, _, _, f in _points(res.h5) if F == res.F_x_c_low][0]
    base = start[:-len(".data")]
    lines = open(base + ".dump").read().splitlines()
    cols = lines[8].split()[2:]
    hist = [i for i, c in enumerate(cols) if c.startswith(("d2_mindlin_t", "v_wall_t"))]
    body = []
    for ln in lines[9:]:
        p = ln.split()
        for i in hist:
            p[i] = "0"
        body.append(" ".join(p))
    zeroed = tmp_path / "zero"
    (tmp_path / "zero.dump").write_text("\n".join(lines[:9] + body) + "\n")
    for ext in (".data", ".dump.json"):
        shutil.copyfile(base + ext, str(zeroed) + ext)
    r = {}
    for name, datafile in (("saved", start), ("zeroed", str(zeroed) + ".data")):
        with Engine() as eng:
            load_equilibrium_scene(eng, cfg, datafile, res.F_x_c_low, 3)
            eng.unfix("damp", "rdamp", "integ")
            r[name] = exact_residual(eng)[2]
    assert r["saved"] < roundoff_floor(read_dump3d(base + ".dump")) and r["zeroed"] > 1e-3, r


def test_resume_after_interruption_is_bitwise(ramp3d, tmp_path):
    from remote_trigger.pywrap import stages

    cfg, full = ramp3d
    part = stages.ramp(cfg, str(tmp_path), quiet=True, stop_after=3)
    assert part.status == "interrupted"
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    assert (res.F_x_c_low, res.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)
    assert test_kill.compare_ramp(test_kill.read_all(full.h5), res.h5) == []


@pytest.fixture(scope="module")
def cli_reference(relaxed3d, tmp_path_factory):
    """The uninterrupted command-line ramp (one BLAS thread, as the trials)."""
    out = tmp_path_factory.mktemp("ramp3d_cli") / "ref"
    wall, attrs, data = test_kill.run_reference(relaxed3d.datafile, out, dF_x=DF, tol=TOL)
    assert attrs["status"] == "complete"
    return wall, (attrs, data)


def test_ramp_killed_at_random_moments_resumes_bitwise(relaxed3d, cli_reference, tmp_path):
    wall, ref = cli_reference
    for trial in range(2):
        ctx = f"RT_KILL_SEED={test_kill.SEED} 3D trial {trial}"
        rng = np.random.default_rng([test_kill.SEED, 300 + trial])
        out = tmp_path / f"out{trial}"
        chain = test_kill.ramp_chain(relaxed3d.datafile, out, rng, wall, max_kills=2,
                                     first_kill_early=(trial == 0), ctx=ctx, dF_x=DF,
                                     tol=TOL)
        print(f"{ctx}: reference {wall:.2f} s; kills {chain['kills']}")
        diff = test_kill.compare_ramp(ref, out / "ramp.h5", ctx)
        assert not diff, f"{ctx}, kills {chain['kills']}: " + "; ".join(diff)


@pytest.mark.mpi
def test_two_ranks_give_the_same_ramp_bitwise(relaxed3d, cli_reference, tmp_path):
    import subprocess

    mpirun = os.path.join(test_kill.BIN, "mpirun")
    args = [mpirun, "-np", "2"] + test_kill.ramp_args(relaxed3d.datafile, tmp_path / "o", DF,
                                                      TOL)
    res = subprocess.run(args, env=test_kill.cli_env(), capture_output=True, text=True,
                         timeout=test_kill.TIMEOUT)
    assert res.returncode == 0, res.stderr[-3000:]
    assert test_kill.compare_ramp(cli_reference[1], tmp_path / "o" / "ramp.h5") == []


def test_resume_refuses_another_dump_beside_the_start(relaxed3d, tmp_path):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.stages.config import RampConfig

    start = tmp_path / "eq.data"
    for ext in (".data", ".dump", ".dump.json"):
        shutil.copyfile(relaxed3d.datafile[:-len(".data")] + ext, str(start)[:-5] + ext)
    cfg = RampConfig(datafile=str(start), dF_x=DF, tol=TOL)
    assert stages.ramp(cfg, str(tmp_path / "o"), quiet=True, stop_after=1).status == \
        "interrupted"
    dump = tmp_path / "eq.dump"
    dump.write_text(dump.read_text() + "\n")       # the same numbers, other bytes
    with pytest.raises(ConfigError, match="another dump beside it") as err:
        stages.ramp(cfg, str(tmp_path / "o"), quiet=True, resume=True)
    # the same path given: the message names the dump, and the path once
    assert str(dump) in str(err.value) and str(err.value).count(str(start)) == 1


# ------------------------------------------------------------------ bad input
def test_a_data_file_without_its_dump_is_refused(capsys, packing3d, tmp_path):
    status, _, err = run_cli(capsys, "ramp", "--datafile", packing3d, "--out", tmp_path / "o",
                             "--quiet")
    assert status == 2
    assert_one_line_error(err, "holds spheres", "p96.dump", "cannot be read")
    assert not os.path.exists(tmp_path / "o")


def test_a_truncated_dump_is_refused(capsys, relaxed3d, tmp_path):
    data = tmp_path / "eq.data"
    shutil.copyfile(relaxed3d.datafile, data)
    lines = open(relaxed3d.dumpfile).read().splitlines()
    (tmp_path / "eq.dump").write_text("\n".join(lines[:-5]) + "\n")
    status, _, err = run_cli(capsys, "ramp", "--datafile", data, "--out", tmp_path / "o",
                             "--quiet")
    assert status == 2
    assert_one_line_error(err, "eq.dump cannot be read", "truncated")
    assert not os.path.exists(tmp_path / "o" / "ramp.h5")


@pytest.mark.parametrize("args, needles", [
    (["--dim", "2"], ("--dim 2 contradicts", "spheres (dimension 3)")),
    (["--set", "newton=false"], ("newton = False is 2D only", "dimension 3")),
])
def test_options_that_contradict_spheres_are_refused(capsys, relaxed3d, tmp_path, args,
                                                     needles):
    status, _, err = run_cli(capsys, "ramp", "--datafile", relaxed3d.datafile, "--out",
                             tmp_path / "o", "--quiet", *args)
    assert status == 2
    assert_one_line_error(err, *needles)
    assert not os.path.exists(tmp_path / "o" / "ramp.h5")


def test_dim_3_that_agrees_is_accepted(capsys, relaxed3d, tmp_path):
    status, text, err = run_cli(capsys, "ramp", "--datafile", relaxed3d.datafile, "--out",
                                tmp_path / "o", "--quiet", "--dim", "3", "--dF-x", "0.05",
                                "--set", "F_x_max=0.01")
    assert status == 1, err                 # no complex pair below F_x_max
    assert "no_complex_pair" in text
    # what was decided, not "up to F_x_max": one point, the start
    assert ("no complex pair certified at the 1 ramp point(s) from F_x = 0 to 0; the next "
            "step, 0.05, passes F_x_max = 0.01") in text, text
    with h5py.File(tmp_path / "o" / "ramp.h5", "r") as fh:
        assert fh.attrs["status"] == "no_complex_pair"
        assert list(fh["steps/decision"][()]) == [0.0]
        # the bracket's keys of a complete ramp: the real end, no complex end
        assert fh.attrs["F_x_c_low"] == 0.0 and np.isnan(fh.attrs["F_x_c_high"])
        assert np.isnan(fh.attrs["F_x_c_width"]) and not fh.attrs["tol_reached"]
        assert fh.attrs["n_undecided"] == 0


# ------------------------------------------------------------------ undamped runs
def _bracket_file(res, which):
    F = res.F_x_c_low if which == "lo" else res.F_x_c_high
    return [f for _, F_, _, _, f in _points(res.h5) if F_ == F][0]


def test_perturb_of_spheres_keeps_the_equilibrium_and_mu_v_moves_it(ramp3d, tmp_path):
    """From the certified-real equilibrium below F_x^c (friction carrying the
    load, history nonzero): the unperturbed run (a) stays at rest to round-off
    -- the pair's and the wall's history were written back exactly -- and
    run (c), mu(v) on, moves the layer far more. v0 is set below the forced
    response's speeds so that mu(v) switches within the short run (measured
    from run (a)'s noise it is not reached in t = 20: mu stays mu0 and (c)
    equals (b))."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import DynamicsConfig

    _, res = ramp3d
    start = _bracket_file(res, "lo")
    cfg = DynamicsConfig(datafile=start, F_x=res.F_x_c_low, t_max=20.0, v0=1e-14)
    out = stages.perturb(cfg, str(tmp_path), quiet=True)
    assert set(out) == {"a", "b", "c"}
    assert out["a"].extra["residual"] < 1e-10
    with h5py.File(tmp_path / "perturb_a.h5", "r") as fh:
        assert fh.attrs["status"] == "complete"
    Da, Dc = out["a"].D.max(), out["c"].D.max()
    print(f"3D perturb from F_x = {res.F_x_c_low}: max D (a) {Da:.3g}, (b) "
          f"{out['b'].D.max():.3g}, (c) {Dc:.3g}; min mu (c) {out['c'].mu.min():.4g}")
    assert Da < 1e-20 and out["a"].extra["v_top_max"] < 1e-8
    assert out["c"].mu.min() < cfg.mu and Dc > 1e3 * Da


def test_instability_of_spheres_runs_from_a_certified_complex_state(ramp3d, tmp_path,
                                                                    capsys):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import DynamicsConfig

    _, res = ramp3d
    cfg = DynamicsConfig(datafile=_bracket_file(res, "hi"), F_x=res.F_x_c_high, t_max=5.0)
    out = stages.instability(cfg, str(tmp_path / "i"), quiet=True, allow_stable=False)
    assert out.extra["complex_pair"] and out.extra["predicted_growth_rate"] > 0
    assert np.all(np.isfinite(out.D)) and out.t[-1] == pytest.approx(5.0)
    # from the certified-real one it is refused, one line, nothing written
    status, _, err = run_cli(capsys, "instability", "--datafile", _bracket_file(res, "lo"),
                             "--out", tmp_path / "j", "--quiet")
    assert status == 2
    assert_one_line_error(err, "linearly stable")
    assert not os.path.exists(tmp_path / "j" / "instability.h5")


def test_the_held_system_of_spheres_is_the_dumps(relaxed3d, tmp_path):
    """A ramp point's reduced system, built from the arrays LAMMPS holds
    (``point.held_system``), is its dump's bit for bit (spheres)."""
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.common import load_equilibrium_scene, save_equilibrium
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap.stages.point import held_system

    cfg, F_x = RampConfig(datafile=relaxed3d.datafile), 0.01
    prefix = str(tmp_path / "p")
    with Engine() as eng:
        load_equilibrium_scene(eng, cfg, relaxed3d.datafile, F_x, 3)
        eq.equilibrate(eng, cfg, F_x, newton_first=True)
        save_equilibrium(eng, cfg, F_x, prefix)
        held = held_system(eng, cfg, F_x)()
    read = reduced_system(read_equilibrium(prefix + ".dump"))
    assert held.n > 0
    for name in ("indptr", "indices", "data"):
        assert getattr(held.K, name).tobytes() == getattr(read.K, name).tobytes(), name
    assert held.mass.tobytes() == read.mass.tobytes()
    assert held.keep_dofs.tobytes() == read.keep_dofs.tobytes()
