"""``relax`` of a packing of spheres: FIRE, then Newton with the 3D Jacobian, friction on.

The equilibrium is checked by an independent computation: the dump is read
back (``read_dump3d``) and its residual recomputed by the analysis' own force
law (``generalized_forces3d``), which must also reproduce the contact forces
LAMMPS wrote.
"""
import json
import os

import h5py
import numpy as np
import pytest

from remote_trigger.analysis.stability.residual import max_residual, roundoff_floor
from remote_trigger.analysis.stability.jacobian3d import generalized_forces3d
from remote_trigger.analysis.state.datafile import read_data
from remote_trigger.analysis.state.dumpfile import dump_dimension, read_dump3d
from remote_trigger.pywrap import cli

from .test_cli_errors import assert_one_line_error, run_cli

SEED = 1


@pytest.fixture(scope="module")
def packing3d(tmp_path_factory):
    from remote_trigger.pywrap.stages.packing import N_3D, generate, write_data

    path = tmp_path_factory.mktemp("packing3d") / "p3.data"
    write_data(generate(N_3D, seed=SEED, dim=3), path)
    return str(path)


@pytest.fixture(scope="module")
def relaxed3d(tmp_path_factory, packing3d):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig

    out = tmp_path_factory.mktemp("relax3d")
    return stages.relax(RelaxConfig(datafile=packing3d), str(out), quiet=True)


def test_equilibrium_residual_recomputed_independently(relaxed3d):
    res = relaxed3d
    assert dump_dimension(res.dumpfile) == 3
    st = read_dump3d(res.dumpfile)
    floor = roundoff_floor(st)
    G = generalized_forces3d(st)
    r = max_residual(G, spheres=True)
    print(f"3D relax: driver residual {res.residual:.3g}, recomputed {r:.3g}, floor {floor:.3g}, "
          f"{st.n_contacts} contacts, {st.wall_index.size} on the wall, {res.wall_time:.1f} s")
    assert res.residual < floor and r < floor <= 1e-9
    assert r == pytest.approx(res.residual, rel=0.5)
    # the analysis' force law gives the contact forces LAMMPS wrote, to the
    # round-off of summing each sphere's contacts in another order (well below the floor)
    lines = open(res.dumpfile).read().splitlines()
    cols = lines[8].split()[2:]
    data = np.array([ln.split() for ln in lines[9:]], float)
    c = {k: i for i, k in enumerate(cols)}
    R = data[:, c["radius"]]
    lmp = np.column_stack([data[:, [c["fx"], c["fy"], c["fz"]]],
                           data[:, [c["tqx"], c["tqy"], c["tqz"]]] / R[:, None]])
    Gc = generalized_forces3d(st, external=False).reshape(-1, 6)
    assert np.abs(Gc - lmp).max() <= 0.1 * floor
    # a state that is not the equilibrium: loads doubled
    st2 = read_dump3d(res.dumpfile, F_y=6.0)
    st2.external[:] *= 2.0
    assert max_residual(generalized_forces3d(st2), spheres=True) > 1e3 * floor


def test_friction_on_with_zero_history(relaxed3d):
    res = relaxed3d
    st = read_dump3d(res.dumpfile)
    side = json.load(open(res.dumpfile + ".json"))
    assert side["mu"] == 1.0 and side["F_y"] == 3.0 and side["wall_y"] == 0.0
    assert st.params.mu == 1.0 and st.n_contacts > 2 * st.n
    assert not np.any(st.contact_t) and not np.any(st.wall_t)
    assert res.antisymmetry < 1e-14
    with h5py.File(res.h5, "r") as f:
        phases = [p.decode() for p in f["history/phase"][:]]
        assert phases[0] == "fire" and phases[-1] == "friction-on" and "newton" in phases
        assert f.attrs["top_clearance"] > 0 and f.attrs["packing_fraction"] > 0.55
        assert f.attrs["dt_fraction_equilibrium"] < 0.5


def test_equilibrium_data_file_round_trip(relaxed3d):
    """equilibrium.data holds the dump's positions exactly and is seen as 3D."""
    st = read_dump3d(relaxed3d.dumpfile)
    d = read_data(relaxed3d.datafile)
    assert d.dimension == 3 and d.n == st.n
    np.testing.assert_array_equal(np.column_stack([d.positions, d.z]), st.positions)
    assert int(d.top.sum()) == 16


def test_relax_again_from_the_equilibrium(relaxed3d, tmp_path):
    """settle_steps = 0 from the equilibrium's data file: FIRE and Newton keep it."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig

    res = stages.relax(RelaxConfig(datafile=relaxed3d.datafile, settle_steps=0), str(tmp_path),
                       quiet=True)
    st0, st1 = read_dump3d(relaxed3d.dumpfile), read_dump3d(res.dumpfile)
    assert res.residual < roundoff_floor(st1)
    assert np.abs(st1.positions - st0.positions).max() < 1e-6


# ------------------------------------------------------------------ bad input
def test_dim_contradicting_the_data_file(capsys, packing3d, packing_file, tmp_path):
    status, _, err = run_cli(capsys, "relax", "--datafile", packing3d, "--dim", "2",
                             "--out", tmp_path / "a", "--quiet")
    assert status == 2
    assert_one_line_error(err, "--dim 2", packing3d, "dimension 3")
    status, _, err = run_cli(capsys, "relax", "--datafile", packing_file, "--dim", "3",
                             "--out", tmp_path / "b", "--quiet")
    assert status == 2
    assert_one_line_error(err, "--dim 3", "dimension 2")
    assert not os.path.exists(tmp_path / "a") and not os.path.exists(tmp_path / "b")


@pytest.mark.parametrize("argv, needle", [
    (["--set", "protocol=frictional"], "protocol = 'frictional' is 2D only"),
    (["--set", "relax_dynamics=damped"], "relax_dynamics = 'damped' is 2D only"),
    (["--no-newton"], "newton = False is 2D only"),
])
def test_2d_only_relax_options(capsys, packing3d, tmp_path, argv, needle):
    status, _, err = run_cli(capsys, "relax", "--datafile", packing3d, "--out",
                             tmp_path / "o", "--quiet", *argv)
    assert status == 2
    assert_one_line_error(err, needle, "spheres")
    assert not os.path.exists(tmp_path / "o" / "relax.h5")


@pytest.mark.parametrize("command", ["ramp", "perturb", "instability"])
def test_stages_refuse_spheres_without_their_dump(capsys, packing3d, tmp_path, command):
    """A data file of spheres has no history: the stages after relax need the
    equilibrium dump beside it (a generated packing has none)."""
    status, _, err = run_cli(capsys, command, "--datafile", packing3d, "--out", tmp_path / "o",
                             "--quiet")
    assert status == 2
    assert_one_line_error(err, "holds spheres", "p3.dump", "cannot be read")
    assert not os.path.exists(tmp_path / "o" / f"{command}.h5")


# ------------------------------------------------------------------ jacobian
def test_jacobian_of_a_sphere_equilibrium(relaxed3d, tmp_path, capsys):
    """K (6 dofs per sphere), rattlers (< 3 contacts), eigenvalues and the decision."""
    from remote_trigger.analysis.stability.jacobian import remove_dofs
    from remote_trigger.analysis.stability.jacobian3d import (
        find_rattlers3d, stiffness_matrix3d)

    out = tmp_path / "j.npz"
    status, text, _ = run_cli(capsys, "jacobian", relaxed3d.dumpfile, "-o", out)
    assert status == 0 and "160 spheres" in text
    z = np.load(out)
    st = read_dump3d(relaxed3d.dumpfile)
    N = st.n
    assert tuple(z["K_shape"]) == (6 * N, 6 * N)
    np.testing.assert_array_equal(z["ids"], np.repeat(st.ids, 6))
    np.testing.assert_array_equal(z["mass"].reshape(N, 6)[:, 3:], 0.4 * np.ones((N, 3)))
    # rattlers: removed iteratively below 3 contacts; every kept sphere has >= 3 kept ones
    rat = find_rattlers3d(st)
    np.testing.assert_array_equal(z["rattlers"], rat.ids)
    kept = np.setdiff1d(np.arange(N), rat.indices)
    counts = np.zeros(N, int)
    both = np.isin(st.contact_i, kept) & np.isin(st.contact_j, kept)
    np.add.at(counts, st.contact_i[both], 1)
    np.add.at(counts, st.contact_j[both], 1)
    np.add.at(counts, st.wall_index[np.isin(st.wall_index, kept)], 1)
    assert counts[kept].min() >= 3
    # the eigenvalues: those of M^-1 K on the kept dofs, computed here directly
    Kr, mr = remove_dofs(stiffness_matrix3d(st), st.mass_diagonal(), rat.keep_dofs)
    lam = np.sort(np.linalg.eigvals(Kr.toarray() / mr[:, None]).real)
    got = z["eigenvalues"]
    assert got.size == 6 * (N - rat.ids.size) == lam.size
    np.testing.assert_allclose(np.sort(got.real), lam, rtol=1e-9, atol=1e-9 * lam.max())
    # zero history at F_x = 0: K symmetric, the spectrum real and positive, certified
    assert np.abs(got.imag).max() == 0 and got.real.min() > 0
    assert int(z["complex_pair"]) == 0 and str(z["coverage"]) == "whole"
    assert int(z["equilibrium"]) == 1 and float(z["residual"]) < roundoff_floor(st)


def test_jacobian_refuses_a_sphere_state_that_is_not_an_equilibrium(relaxed3d, tmp_path,
                                                                     capsys):
    status, _, err = run_cli(capsys, "jacobian", relaxed3d.dumpfile, "-o", tmp_path / "j.npz",
                             "--k-n", "3e5", "--override")
    assert status == 2
    assert_one_line_error(err, "not an equilibrium", "k_n = 300000.0")
    assert not (tmp_path / "j.npz").exists()


def test_jacobian_names_a_missing_sphere_column(relaxed3d, tmp_path, capsys):
    text = open(relaxed3d.dumpfile).read().replace(" v_wall_tz", " v_wall_tq", 1)
    bad = tmp_path / "bad.dump"
    bad.write_text(text)
    status, _, err = run_cli(capsys, "jacobian", bad, "-o", tmp_path / "j.npz",
                             "--k-n", "2e5", "--k-t", str(2e5 * 2 / 7), "--mu", "1",
                             "--wall-y", "0")
    assert status == 2
    assert_one_line_error(err, "v_wall_tz")


def test_relax3d_deck_standalone(packing3d, relaxed3d, tmp_path):
    """``lmp -in in.relax3d``: the driver's protocol without Newton (FIRE to
    3e-6): the driver's placement of the layer (the first, clear by the
    'local' test) and its packing fraction (measured: within 2e-9)."""
    import subprocess

    from remote_trigger.pywrap.bindings.decks import deck_path
    from remote_trigger.pywrap.stages.common import packing_fraction

    from .conftest import LMP, cli_env

    out = tmp_path / "r"
    proc = subprocess.run([LMP, "-in", deck_path("in.relax3d"), "-log", "none",
                           "-var", "datafile", packing3d, "-var", "out", str(out)],
                          cwd=tmp_path, env=cli_env(), capture_output=True, text=True,
                          timeout=280)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    st = read_dump3d(str(out) + ".dump")
    r = max_residual(generalized_forces3d(st), spheres=True)
    assert r < 1e-5 and st.params.mu == 1.0 and not np.any(st.contact_t)
    assert read_data(str(out) + ".data").dimension == 3
    places = [ln for ln in proc.stdout.splitlines() if ln.startswith("in.relax3d: placement")]
    assert relaxed3d.top_attempts == 1 and relaxed3d.top_clearance > 0
    assert places == ["in.relax3d: placement 1 of 4 (layer shifted by dx = 0) kept: clear "
                      "(local: 0)"], places
    assert abs(packing_fraction(st) - relaxed3d.packing_fraction) < 1e-7
