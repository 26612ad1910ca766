"""Time step of the driver stages: 'auto' from the contact stiffness, refusal at the limit.

The limits are recomputed here independently of the driver: from the dump of
the equilibrium (``analysis.state.read_dump``) and
``analysis.timestep.stability_limit``; for a compaction, from
``analysis.timestep.hertz_limit`` with the documented force estimate.
"""
import math
import os
import subprocess

import numpy as np
import pytest

from remote_trigger.analysis.stability import timestep as ts
from remote_trigger.analysis.state.dumpfile import read_dump
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import DynamicsConfig, RampConfig, RelaxConfig
from remote_trigger.pywrap.runtime.results import read_all

from .conftest import CLI, N_SMALL, SEED, cli_env


@pytest.fixture(scope="module")
def limit(relaxed):
    return ts.stability_limit(read_dump(relaxed.dumpfile))


def test_config_accepts_auto_and_names_bad_dt(packing_file):
    assert RelaxConfig(datafile=packing_file, dt="auto").dt == "auto"
    for bad in ("fast", -1e-3, 0.0, float("nan"), True):
        with pytest.raises(ConfigError, match=r"dt"):
            RelaxConfig(datafile=packing_file, dt=bad)
    with pytest.raises(ConfigError, match="'fast'"):
        DynamicsConfig(datafile=packing_file, dt="fast")


@pytest.mark.parametrize("frac", [1.0, 1.5])
def test_ramp_refuses_dt_at_or_above_limit(relaxed, limit, tmp_path, frac):
    cfg = RampConfig(datafile=relaxed.datafile, dt=frac * limit, dF_x=0.05)
    with pytest.raises(ts.TimestepError) as exc:
        stages.ramp(cfg, str(tmp_path), quiet=True)
    msg = str(exc.value)
    assert f"dt_max = 2/omega_max = {limit:.6g}" in msg, msg
    assert f"use dt <= {0.1 * limit:.4g}" in msg, msg
    assert not (tmp_path / "ramp.h5").exists()          # refused before any output


def test_instability_refuses_and_accepts_below_limit(relaxed, limit, tmp_path):
    bad = DynamicsConfig(datafile=relaxed.datafile, dt=1.01 * limit, t_max=1.0)
    with pytest.raises(ts.TimestepError, match="stability limit"):
        stages.instability(bad, str(tmp_path / "bad"), quiet=True)
    assert not (tmp_path / "bad" / "instability.h5").exists()
    ok = bad.replace(dt=0.9 * limit, t_max=50 * 0.9 * limit, record_every=10)
    res = stages.instability(ok, str(tmp_path / "ok"), quiet=True)
    assert res.extra["timestep"]["dt_fraction"] == pytest.approx(0.9, rel=1e-12)
    assert np.all(np.isfinite(res.D)) and res.D[-1] < 1e-10


def test_dt_auto_is_safety_factor_of_start_limit(relaxed, limit, tmp_path):
    cfg = DynamicsConfig(datafile=relaxed.datafile, dt="auto", t_max=2.0, record_every=50)
    res = stages.perturb(cfg, str(tmp_path), quiet=True, runs="a")["a"]
    info = res.extra["timestep"]
    assert info["dt_auto"] and info["dt_limit_source"] == "eigen"
    assert info["dt_max"] == pytest.approx(limit, rel=1e-10)
    assert info["dt_used"] == pytest.approx(ts.SAFETY_FACTOR * limit, rel=1e-10)
    attrs, data = read_all(res.h5)
    assert attrs["dt"] == info["dt_used"] and attrs["dt_auto"]
    np.testing.assert_allclose(np.diff(data["t"]), 50 * info["dt_used"], rtol=1e-9)
    with open(os.path.join(tmp_path, "perturb", "equilibrium.dump.json")) as fh:
        import json
        assert json.load(fh)["dt"] == info["dt_used"]


def test_ramp_auto_records_dt_and_resume_keeps_it(relaxed, limit, tmp_path):
    cfg = RampConfig(datafile=relaxed.datafile, dt="auto", dF_x=0.05, tol=1e-3)
    part = stages.ramp(cfg, str(tmp_path), quiet=True, stop_after=2)
    assert part.status == "interrupted"
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    attrs, _ = read_all(res.h5)
    assert attrs["dt"] == "auto"
    assert attrs["dt_used"] == pytest.approx(0.1 * limit, rel=1e-10)
    assert res.timestep["dt_used"] == attrs["dt_used"]
    assert RampConfig.from_attrs(attrs) == cfg


def _expected_relax_bound(cfg):
    """hertz_limit at FORCE_FACTOR x column load, from the generator's packing."""
    from remote_trigger.pywrap.stages.packing import generate
    from remote_trigger.pywrap.stages.timestep import FORCE_FACTOR

    p = generate(N_SMALL, seed=SEED)
    force = FORCE_FACTOR * max(math.hypot(cfg.F_x, cfg.F_y),
                               cfg.g_settle * 1.0 * (p.n - p.n_top) / p.n_top)
    return ts.hertz_limit(cfg.k_n, force, k_t=cfg.k_t, mass=1.0)


@pytest.mark.parametrize("k_n", [2e7, 2e9])
def test_relax_auto_at_stiff_contacts(packing_file, tmp_path, k_n):
    """dt = 'auto' scales as k_n^(-1/3); the stiff packing relaxes; the final
    equilibrium's own limit is > 10x the step used."""
    cfg = RelaxConfig(datafile=packing_file, k_n=k_n, dt="auto")
    res = stages.relax(cfg, str(tmp_path), quiet=True)
    info = res.timestep
    assert info["dt_limit_source"] == "hertz a priori"
    bound = _expected_relax_bound(cfg)
    assert info["dt_max"] == pytest.approx(bound, rel=1e-12)
    base = _expected_relax_bound(cfg.replace(k_n=2e5, k_t=None))
    assert info["dt_used"] == pytest.approx(0.1 * base * (2e5 / k_n) ** (1 / 3), rel=1e-9)
    eq_limit = ts.stability_limit(read_dump(res.dumpfile))
    assert info["dt_max_equilibrium"] == pytest.approx(eq_limit, rel=1e-8)
    assert info["dt_used"] < 0.1 * eq_limit
    # equilibrium at the stiffness-scaled round-off floor (f_accept = None)
    from remote_trigger.pywrap.stages.equilibrium import ROUNDOFF_FACTOR
    keff = 1.5 * k_n ** (2 / 3) * cfg.F_y ** (1 / 3)
    st = read_dump(res.dumpfile)
    X = max(float(np.max(np.abs(st.positions))), float(np.max(st.box_length)))
    assert res.residual < max(1e-10, ROUNDOFF_FACTOR * np.finfo(float).eps * X * keff)


def test_cli_refuses_dt_with_exit_2(relaxed, limit, tmp_path):
    out = subprocess.run([CLI, "ramp", "--datafile", relaxed.datafile, "--out",
                          str(tmp_path), "--dt", repr(2 * limit), "--quiet"],
                         env=cli_env(), capture_output=True, text=True)
    assert out.returncode == 2, out.stderr
    assert f"dt_max = 2/omega_max = {limit:.6g}" in out.stderr
    bad = subprocess.run([CLI, "ramp", "--datafile", relaxed.datafile, "--dt", "fast"],
                         env=cli_env(), capture_output=True, text=True)
    assert bad.returncode == 2 and "'fast'" in bad.stderr


@pytest.mark.parametrize("stage", ["relax", "ramp"])
def test_a_start_without_contacts_gets_the_a_priori_limit(packing_file, tmp_path, stage):
    """A loose packing has no contact, so no eigen limit: the a-priori Hertz
    bound of the loads' contacts applies (the limit was infinite, any dt passed,
    and the run lost atoms), and the refusal leaves no ramp/ folder behind."""
    if stage == "relax":
        cfg = RelaxConfig(datafile=packing_file, settle_steps=0, dt=0.05)
    else:
        cfg = RampConfig(datafile=packing_file, dt=0.05)
    with pytest.raises(ts.TimestepError, match=r"dt = 0\.05 is at or above .*a-priori Hertz"):
        getattr(stages, stage)(cfg, str(tmp_path / "o"), quiet=True)
    assert not (tmp_path / "o" / "ramp").exists()
