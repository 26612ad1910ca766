"""Saddles: a Newton ramp point that lands on one is equilibrated again by
damped dynamics (``stages.point.ramp_point``, ``RampConfig.saddle_escape``),
and the screen that finds it (``analysis.stability.analyze.negative_modes``)
counts what the dense spectra count."""
import numpy as np
import pytest

from remote_trigger.pywrap.stages.config import RampConfig
from remote_trigger.analysis.stability.decision import Decision


def _dense_counts(dump):
    """Negative eigenvalues of M^-1 K (LAPACK) and of the symmetric part of
    M^-1/2 K M^-1/2 (eigvalsh), below -1e-9 of their scale, and the screen's."""
    from remote_trigger.analysis.stability import jacobian
    from remote_trigger.analysis.stability.analyze import analyze, negative_modes
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    state = read_equilibrium(dump)
    res = analyze(state, eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    s = 1.0 / np.sqrt(mr)
    A = (Kr.toarray() * s[:, None]) * s[None, :]
    lam = np.linalg.eigvals(A)
    theta = np.linalg.eigvalsh(0.5 * (A + A.T))
    thr = 1e-9 * np.max(lam.real)                                    # the screen's t
    return (int(np.count_nonzero(lam.real < -thr)), int(np.count_nonzero(theta < -thr)),
            negative_modes(state), float(np.min(lam.real)))


@pytest.fixture(scope="module")
def saddle_points(tmp_path_factory):
    """The step F_x = 0.00075 -> 0.001 of the N = 400 packing: with an escape
    whose damped dynamics fail (made to here), which keeps Newton's
    equilibrium; and with the escape, by ``remote-trigger ramp`` from the
    stored step (F_x_max just above the saddle's load: two steps)."""
    import subprocess

    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.runtime.results import read_all
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.point import ramp_point
    from tests.data import unpack

    from .conftest import CLI, cli_env

    real = eq.equilibrate

    def no_damped(eng, cfg, F_x, *args, newton_first=False, **kw):
        if not newton_first:
            raise eq.NoEquilibriumError(f"no equilibrium at F_x = {F_x!r} (planted)")
        return real(eng, cfg, F_x, *args, newton_first=newton_first, **kw)

    d = tmp_path_factory.mktemp("saddle")
    start = unpack("saddle_N400_s8_step_00003", str(d))
    cfg = RampConfig(datafile=start, F_x=0.00075, mu=1.0, dF_x=0.00025, tol=4e-6)
    out = {}
    with Engine() as eng:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(eq, "equilibrate", no_damped)
            vals, res = ramp_point(eng, cfg, start, 0.001, str(d / "newton"))
        out["newton"] = (vals, res, str(d / "newton") + ".dump")
    r = str(d / "r")
    proc = subprocess.run([CLI, "ramp", "--datafile", start, "--out", r, "--F-x", "0.00075",
                           "--dF-x", "0.00025", "--set", "F_x_max=0.0011", "--quiet"],
                          capture_output=True, text=True, env=cli_env())
    _, data = read_all(r + "/ramp.h5")
    row = {c: float(data[f"steps/{c}"][-1]) for c in
           ("saddle_escaped", "damped_time", "n_negative", "decision", "residual")}
    out["escape"] = (row, proc, r + "/ramp/step_00001.dump", data)
    return out


def test_newton_lands_on_a_saddle_the_screen_sees_it(saddle_points):
    """Newton's equilibrium, kept by a failed escape (the point does not end)."""
    vals, res, dump = saddle_points["newton"]
    assert vals["saddle_escaped"] == 0 and vals["damped_time"] == 0
    assert res.decision is Decision.REAL and vals["n_negative"] == 1
    n_lapack, n_sym, n_screen, low = _dense_counts(dump)
    assert n_lapack == n_sym == n_screen == 1
    assert -0.1 < low < -0.01                   # -0.042: one weakly held disk


def test_the_escape_reaches_a_stable_equilibrium(saddle_points):
    """Damped dynamics from the same start: every eigenvalue positive, the
    lowest that of the steps before (6.39), at the ramp's residual."""
    vals, _, dump, _ = saddle_points["escape"]
    assert vals["saddle_escaped"] >= 1 and vals["damped_time"] > 0
    assert vals["n_negative"] == 0 and vals["decision"] == 0          # real
    n_lapack, n_sym, n_screen, low = _dense_counts(dump)
    assert n_lapack == n_sym == n_screen == 0
    assert 6.0 < low < 7.0
    assert vals["residual"] < 1e-10
    assert saddle_points["newton"][0]["residual"] < 1e-10


def test_an_older_ramp_resumes_only_without_the_escape(relaxed, tmp_path):
    """A ramp.h5 written before the option (no saddle_escape attribute) is one
    without escape: resumed with the default it is refused, naming the key;
    with saddle_escape = False it completes."""
    import h5py

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.config import ConfigError

    cfg = RampConfig(datafile=relaxed.datafile, dF_x=0.01, tol=1e-3)
    part = stages.ramp(cfg.replace(saddle_escape=False), str(tmp_path), quiet=True,
                       stop_after=2)
    assert part.status == "interrupted"
    with h5py.File(part.h5, "a") as fh:
        del fh.attrs["saddle_escape"]
    with pytest.raises(ConfigError, match="saddle_escape = False"):
        stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    done = stages.ramp(cfg.replace(saddle_escape=False), str(tmp_path), quiet=True,
                       resume=True)
    assert done.status == "complete"
    with h5py.File(done.h5, "r") as fh:
        attrs = dict(fh.attrs)
    assert RampConfig.from_attrs(attrs).saddle_escape is False
    old = {k: v for k, v in attrs.items() if k != "saddle_escape"}
    assert RampConfig.from_attrs(old).saddle_escape is False
    assert RampConfig.from_attrs(dict(old, saddle_escape=True)).saddle_escape is True


def test_the_ramp_counts_and_prints_its_escapes(saddle_points):
    """``remote-trigger ramp`` from the stored step over the saddle (F_x_max just
    above it): one escape, no point left on a saddle, said in one line."""
    _, proc, _, data = saddle_points["escape"]
    assert proc.returncode == 1, proc.stderr           # no complex pair up to F_x_max
    assert ("ramp: 1 point(s) whose Newton equilibrium was a saddle, equilibrated again by "
            "damped dynamics; 0 left on a saddle") in proc.stdout
    assert list(data["steps/saddle_escaped"]) == [0.0, 1.0]
    assert list(data["steps/n_negative"]) == [0.0, 0.0]


def test_without_the_escape_nothing_is_screened(relaxed, tmp_path, monkeypatch):
    """saddle_escape = False: Newton's equilibrium is kept unscreened."""
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import point

    def screened(*args):
        raise AssertionError("screened")

    monkeypatch.setattr(point, "_screen", screened)
    cfg = RampConfig(datafile=relaxed.datafile, saddle_escape=False)
    with Engine() as eng:
        vals, res = point.ramp_point(eng, cfg, relaxed.datafile, 0.01, str(tmp_path / "p"))
    assert vals["saddle_escaped"] == 0 and res.decision in (Decision.REAL, Decision.COMPLEX)
    with pytest.raises(AssertionError, match="screened"):
        with Engine() as eng:
            point.ramp_point(eng, cfg.replace(saddle_escape=True), relaxed.datafile, 0.01,
                             str(tmp_path / "q"))


def test_a_free_rotation_is_no_saddle(saddle_points, tmp_path, monkeypatch):
    """A disk whose contacts all slide (the stored equilibrium): its rotation is
    free (eigenvalue 0 of M^-1 K) and the symmetric part has a negative
    eigenvalue. No saddle, by both of the screen's eigen-solves (LAPACK; ARPACK
    with the dense limit lowered), which still find the saddle of Newton's
    N = 400 step."""
    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.analyze import negative_modes
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from tests.data import unpack

    unpack("free_rotation_N400_s5_step_00002.dump.json", str(tmp_path))
    dump = unpack("free_rotation_N400_s5_step_00002", str(tmp_path))
    n_lapack, n_sym, n_screen, low = _dense_counts(dump)
    assert (n_lapack, n_sym, n_screen) == (0, 1, 0)
    assert abs(low) < 1e-9                      # the free rotation
    monkeypatch.setattr(eigen, "DENSE_MAX", 10)
    assert negative_modes(read_equilibrium(dump)) == 0
    assert negative_modes(read_equilibrium(saddle_points["newton"][2])) == 1
