"""``top_layer = 'rigid'``: the top layer of spheres kept a rigid plate (fix aveforce).

Relax and ramp a small sphere packing with the layer translating as one
body. Checked independently of the driver's Newton (which ties the layer's
x, y and z): every saved equilibrium is read back from its dump, whose
sidecar says ``top_layer = 'rigid'``, and its residual recomputed by the
analysis' own force law with the layer's forces summed (``generalized_residual``);
the layer stays level (it was pressed as one body and moved as one); the
verdict of the ramp's bracket is recomputed from the dumps by a plain
``numpy.linalg.eigvals`` of P^T K P; the deck ``in.relax3d`` with
``-var top_layer rigid`` reaches the driver's packing; a ramp or a dynamics
stage from that state without the setting, a relax of disks with it and an
ensemble of disks with it are refused.
"""
import json

import h5py
import numpy as np
import pytest

from remote_trigger.analysis.stability.residual import (
    generalized_residual, max_residual, roundoff_floor)
from remote_trigger.analysis.stability.system import reduced_system
from remote_trigger.analysis.state.dumpfile import read_dump3d
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.ramp_file import point_file

N = 96
DF = 0.004
TOL = 1e-3


@pytest.fixture(scope="module")
def relaxed(tmp_path_factory):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    d = tmp_path_factory.mktemp("rigid3d")
    write_data(generate(N, seed=1, dim=3), d / "p.data")
    res = stages.relax(RelaxConfig(datafile=str(d / "p.data"), top_layer="rigid"),
                       str(d / "relax"), quiet=True)
    return d, res


@pytest.fixture(scope="module")
def ramped(relaxed):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    d, res = relaxed
    cfg = RampConfig(datafile=res.datafile, dF_x=DF, tol=TOL, top_layer="rigid")
    return stages.ramp(cfg, str(d / "ramp"), quiet=True)


def _state(datafile):
    return read_dump3d(datafile[:-len(".data")] + ".dump")


def test_relax_keeps_the_layer_one_level_body(relaxed):
    d, res = relaxed
    with open(res.dumpfile + ".json") as fh:
        assert json.load(fh)["top_layer"] == "rigid"
    st = _state(res.datafile)
    layer = st.rigid_layer
    assert layer is not None and layer.size == np.count_nonzero(st.external[:, 1])
    assert np.ptp(st.positions[layer, 1]) <= 1e-12          # pressed and moved as one
    r = max_residual(generalized_residual(st), spheres=True)
    assert r < roundoff_floor(st), r
    # each sphere of the layer alone is not in equilibrium: the plate holds it
    free = st.__class__(**{**st.__dict__, "rigid_layer": None})
    assert max_residual(generalized_residual(free), spheres=True) > 1e-3
    assert res.top_clearance > 0


def test_ramp_points_are_equilibria_and_the_bracket_holds(ramped):
    res = ramped
    assert res.status == "complete" and res.n_undecided == 0, res.message
    lo, hi = res.F_x_c_low, res.F_x_c_high
    assert 0 < lo < hi <= lo + TOL
    with h5py.File(res.h5, "r") as fh:
        rows = {float(F): point_file(res.h5, f, fh.attrs)
                for kind in ("steps", "bisection")
                for F, f in zip(fh[kind]["F_x"][()], fh[kind]["datafile"][()])}
    lam = {}
    for F, datafile in rows.items():
        st = _state(datafile)
        assert st.rigid_layer is not None and st.F_x == F
        assert np.ptp(st.positions[st.rigid_layer, 1]) <= 1e-12
        assert max_residual(generalized_residual(st), spheres=True) < roundoff_floor(st)
        if F in (lo, hi):
            s = reduced_system(st)
            assert s.tied.shape[1] == 3 * (st.rigid_layer.size - 1)
            lam[F] = np.linalg.eigvals(s.K.toarray() / s.mass[:, None])
    lmax = lam[hi].real.max()
    assert np.abs(lam[lo].imag).max() < 1e-9 * lmax
    assert np.abs(lam[hi].imag).max() > 1e-7 * lmax
    print(f"rigid layer, N = {N}: F_x^c in [{lo}, {hi}], {len(rows)} equilibria")


def test_a_ramp_must_use_the_layer_it_was_relaxed_with(relaxed, tmp_path):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    _, res = relaxed
    with pytest.raises(ConfigError, match=r"top_layer = 'free' differs from the start "
                                          r"state's 'rigid'"):
        stages.ramp(RampConfig(datafile=res.datafile, dF_x=DF), str(tmp_path / "r"),
                    quiet=True)


def test_disks_refuse_a_rigid_layer(tmp_path):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    write_data(generate(20, seed=1), tmp_path / "d.data")
    with pytest.raises(ConfigError, match="top_layer = 'rigid' is for spheres"):
        stages.relax(RelaxConfig(datafile=str(tmp_path / "d.data"), top_layer="rigid"),
                     str(tmp_path / "out"), quiet=True)
    with pytest.raises(ConfigError, match="top_layer must be one of free, rigid"):
        RelaxConfig(datafile=str(tmp_path / "d.data"), top_layer="plate")


def test_the_deck_keeps_the_plate_as_the_driver(relaxed, tmp_path):
    """``lmp -in in.relax3d -var top_layer rigid``: the driver's protocol without
    Newton (FIRE to 3e-6), the layer the same rigid plate: its sidecar, a level
    layer, the layer's summed forces balanced to FIRE's tolerance, the
    driver's packing fraction."""
    import subprocess

    from remote_trigger.pywrap.bindings.decks import deck_path
    from remote_trigger.pywrap.stages.common import packing_fraction

    from .conftest import LMP, cli_env

    d, res = relaxed
    out = tmp_path / "r"
    proc = subprocess.run([LMP, "-in", deck_path("in.relax3d"), "-log", "none",
                           "-var", "datafile", str(d / "p.data"), "-var", "out", str(out),
                           "-var", "top_layer", "rigid"],
                          cwd=tmp_path, env=cli_env(), capture_output=True, text=True,
                          timeout=280)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    with open(str(out) + ".dump.json") as fh:
        assert json.load(fh)["top_layer"] == "rigid"
    st = read_dump3d(str(out) + ".dump")
    assert st.rigid_layer is not None and np.ptp(st.positions[st.rigid_layer, 1]) <= 1e-12
    assert max_residual(generalized_residual(st), spheres=True) < 1e-5
    assert abs(packing_fraction(st) - res.packing_fraction) < 1e-6
    bad = subprocess.run([LMP, "-in", deck_path("in.relax3d"), "-log", "none",
                          "-var", "datafile", str(d / "p.data"), "-var", "out", str(out),
                          "-var", "top_layer", "plate"],
                         cwd=tmp_path, env=cli_env(), capture_output=True, text=True,
                         timeout=60)
    assert bad.returncode == 2 and "top_layer = plate: give free or rigid" in bad.stdout


def test_the_dynamics_stages_refuse_a_rigid_layer(relaxed, tmp_path):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import DynamicsConfig

    _, res = relaxed
    with pytest.raises(ConfigError, match=r"differs from the start state's 'rigid'.*perturb "
                                          r"runs the free layer only"):
        stages.perturb(DynamicsConfig(datafile=res.datafile), str(tmp_path / "p"), quiet=True)
    assert not (tmp_path / "p").exists() or not any((tmp_path / "p").iterdir())


def test_the_ensemble_takes_the_plate_for_spheres_only():
    from remote_trigger.pywrap.jobs.ensemble.config import DIM3, EnsembleConfig

    cfg = EnsembleConfig.from_dict(dict(DIM3, dim=3, relax={"top_layer": "rigid"}))
    assert cfg.relax["top_layer"] == "rigid"
    with pytest.raises(ConfigError, match="relax.top_layer = 'rigid' is for spheres"):
        EnsembleConfig.from_dict({"relax": {"top_layer": "rigid"}})
    with pytest.raises(ConfigError, match="top_layer"):
        EnsembleConfig.from_dict(dict(DIM3, dim=3, relax={"top_layer": "glued"}))
