"""Each deck runs standalone with the venv's lmp and writes what it documents."""
import json
import os
import subprocess

import numpy as np
import pytest

from remote_trigger.pywrap.bindings.decks import DECK_DIR, deck_sections
from remote_trigger.pywrap.bindings.engine import DUMP_COLUMNS
from remote_trigger.pywrap.stages.config import RELAX_DYNAMICS_AUTO_N

from .conftest import LMP, cli_env
from remote_trigger.analysis.stability.decision import Decision


def _lmp(tmp_path, deck, **var):
    args = [LMP, "-in", os.path.join(DECK_DIR, deck), "-log", "log.lammps"]
    for k, v in var.items():
        args += ["-var", k, str(v)]
    out = subprocess.run(args, cwd=tmp_path, env=cli_env(), capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    assert "ERROR" not in out.stdout
    return out.stdout


def _check_dump(path):
    from remote_trigger.analysis.state.dumpfile import read_dump

    with open(path) as fh:
        lines = fh.read().splitlines()
    header = next(l for l in lines if l.startswith("ITEM: ATOMS")).split()[2:]
    base = [c for c in DUMP_COLUMNS.split() if "[*]" not in c]
    assert [c for c in header if "[" not in c] == base
    assert sum(c.startswith("i2_mindlin_partner[") for c in header) == 8
    side = json.load(open(path + ".json"))
    from remote_trigger.analysis.state.dumpfile import PARAM_KEYS

    assert set(side) == set(PARAM_KEYS)             # the deck prints what write_sidecar writes
    return read_dump(path, require_contacts=False), side


def test_decks_have_sections():
    for deck in ("in.relax", "in.ramp_step", "in.perturb"):
        sec = deck_sections(os.path.join(DECK_DIR, deck))
        integ = sec["dynamics"] if deck == "in.perturb" else sec["damped"]
        assert "read_data" in sec["scene"] and "fix integ" in integ
        assert sec["variables"].lstrip().startswith("#")   # documented on top
    relax = deck_sections(os.path.join(DECK_DIR, "in.relax"))
    for name in ("friction", "clearance_test", "compact", "lower_measure", "lower", "place",
                 "shift", "press", "press_loop", "press_end", "relax", "placement_test",
                 "output", "fire"):
        assert relax.get(name, "").strip(), name
    relax3d = deck_sections(os.path.join(DECK_DIR, "in.relax3d"))
    for name in ("friction", "clearance_test", "compact", "lower", "place", "shift", "press",
                 "press_end", "relax", "placement_test", "output", "fire"):
        assert relax3d.get(name, "").strip(), name


def test_relax_decks_take_the_drivers_defaults(packing_file):
    """The decks' placements: RelaxConfig's count and shift rule, and the
    'local' test's horizontal distance (stages.packing.TOP_SPACING_3D)."""
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import TOP_SPACING_3D

    cfg = RelaxConfig(datafile=packing_file)
    for deck in ("in.relax", "in.relax3d"):
        sec = deck_sections(os.path.join(DECK_DIR, deck))
        assert f"variable top_attempts index {cfg.top_attempts}\n" in sec["variables"]
        assert f"variable nsteps index {cfg.max_steps}\n" in sec["variables"]
        assert f"<{TOP_SPACING_3D})*(y[${{id}}]>y)" in sec["clearance_test"]
        assert "displace_atoms top move ${dx} 0.0 0.0 units box" in sec["shift"]
    sec = deck_sections(os.path.join(DECK_DIR, "in.relax"))
    assert "$((v_place-1)*(lx/count(top))/v_top_attempts:%.17g)" in sec["place"]
    assert f"'$(count(all)) > {RELAX_DYNAMICS_AUTO_N}'" in sec["actions"]


def test_driver_protocol_commands_come_from_the_deck():
    """The stage modules write none of the protocol's LAMMPS commands: one source."""
    import ast
    import inspect

    from remote_trigger.pywrap.stages import equilibrium, ramp, relax, runs, common as stage_common

    strings = []                # string literals of the code, docstrings excluded
    for mod in (relax, stage_common, ramp, runs, equilibrium):
        tree = ast.parse(inspect.getsource(mod))
        docs = {id(n.body[0].value) for n in ast.walk(tree)
                if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef)) and n.body
                and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
        strings += [n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)
                    and isinstance(n.value, str) and id(n) not in docs]
    code = "\n".join(strings)
    for cmd in ("pair_coeff", "aveforce", "fix grav bulk", "fix damp", "fix integ",
                "viscous", "variable mu_now", "min_style", "minimize ", "displace_atoms"):
        assert cmd not in code, cmd
    relax = deck_sections(os.path.join(DECK_DIR, "in.relax"))
    assert "fix piston top aveforce" in relax["press"]
    assert "fix grav bulk gravity ${g_settle}" in relax["compact"]
    assert "pair_coeff * * ${kn} ${kt} ${mu_set}" in relax["friction"]
    assert "min_style fire" in relax["fire"]
    assert "jump SELF deck_end" in relax["output"]      # a standalone run skips fire


def test_relax_deck(tmp_path, packing_file, relaxed):
    """The deck runs the driver's protocol: same packing fraction, certified real at F_x = 0."""
    from remote_trigger.analysis.stability.analyze import analyze

    _lmp(tmp_path, "in.relax", datafile=packing_file, settle_steps=20000, out="r")
    st, side = _check_dump(str(tmp_path / "r.dump"))
    assert st.n == 20 and side["F_x"] == 0 and side["F_y"] == 3 and side["mu"] == 1.0
    assert os.path.exists(tmp_path / "r.data")
    a = analyze(st)
    assert a.max_residual < 1e-9                       # fmin 1e-10 includes damping forces
    assert a.decision.decision is Decision.REAL         # certified real, like the driver
    assert np.all(st.contact_xi == 0) and np.all(st.wall_xi == 0)   # friction on, zero history

    def phi(s):
        L = s.box_hi[0] - s.box_lo[0]
        return np.sum(np.pi * s.radii ** 2) / (L * np.max(s.positions[:, 1] + s.radii))
    from remote_trigger.analysis.state.dumpfile import read_dump
    drv = read_dump(relaxed.datafile[:-len(".data")] + ".dump")
    # the same compaction, line placement and piston (the driver runs these
    # sections of the deck, in the same chunks); then damped vs damped + Newton
    assert phi(st) == pytest.approx(phi(drv), abs=1e-6)
    top = st.external[:, 1] != 0
    assert np.min(st.positions[top, 1]) > np.max(st.positions[~top, 1])   # line on top


def test_relax_deck_stops_on_an_unreached_residual(tmp_path, packing_file):
    args = [LMP, "-in", os.path.join(DECK_DIR, "in.relax"), "-log", "none", "-var",
            "datafile", packing_file, "-var", "settle_steps", "2000", "-var", "nsteps", "1000"]
    out = subprocess.run(args, cwd=tmp_path, env=cli_env(), capture_output=True, text=True)
    assert out.returncode == 3 and "still above fmin" in out.stdout
    assert not os.path.exists(tmp_path / "relaxed.dump")


def test_ramp_step_deck(tmp_path, relaxed):
    out = _lmp(tmp_path, "in.ramp_step", datafile=relaxed.datafile, Fx=0.001, out="s")
    assert "Fix halt condition for fix-id conv met" in out    # stops on fmin, not nsteps
    st, side = _check_dump(str(tmp_path / "s.dump"))
    assert side["F_x"] == 0.001
    np.testing.assert_array_equal(st.external[st.external[:, 1] < 0, 0], 0.001)
    # without -var Fx: LAMMPS's error naming Fx before anything is read (it was
    # "Variable load_x: Invalid thermo keyword 'REQUIRED'" at the first step)
    args = [LMP, "-in", os.path.join(DECK_DIR, "in.ramp_step"), "-log", "none", "-var",
            "datafile", relaxed.datafile]
    out = subprocess.run(args, cwd=tmp_path, env=cli_env(), capture_output=True, text=True)
    assert out.returncode != 0
    assert "Substitution for illegal variable Fx" in out.stdout + out.stderr
    assert "Reading data file" not in out.stdout


def test_perturb_deck(tmp_path, relaxed):
    _lmp(tmp_path, "in.perturb", datafile=relaxed.datafile, a=1e-6, wp=1.0,
         muv=1, v0=1e-9, nsteps=2000, every=100, out="p")
    rows = np.loadtxt(tmp_path / "p.txt")              # step time D v_top mu
    assert rows.shape == (21, 5)
    np.testing.assert_allclose(rows[:, 1], rows[:, 0] * 1e-3, rtol=1e-12)
    assert np.all(rows[:, 4] <= 1.0) and np.all(rows[:, 4] >= 0.8)
    assert np.min(rows[:, 4]) < 1.0                  # mu(v) acted
    _lmp(tmp_path, "in.perturb", datafile=relaxed.datafile, nsteps=1000, out="q")
    rows = np.loadtxt(tmp_path / "q.txt")
    assert np.all(rows[:, 4] == 1.0) and np.max(rows[:, 2]) < 1e-20


def test_scenes_contain_only_what_they_need(relaxed):
    from remote_trigger.pywrap.bindings.engine import Engine

    def scene(**var):
        eng = Engine()
        eng.load_deck("in.perturb", dict(datafile=relaxed.datafile, **var),
                      ("scene", "dynamics"))
        return eng

    with scene() as eng:                                   # (a)
        assert not eng.has_fix("muv") and not eng.has_fix("damp")
        assert "pert" not in eng.lmp.available_ids("variable")
    with scene(a=1e-12) as eng:                            # (b)
        assert "pert" in eng.lmp.available_ids("variable") and not eng.has_fix("muv")
    with scene(a=1e-12, muv=1, v0=1e-10) as eng:           # (c)
        assert eng.has_fix("muv") and not eng.has_fix("damp")
    with Engine() as eng:                                  # relax: damping only here
        eng.load_deck("in.relax", {"datafile": relaxed.datafile}, ("scene", "damped", "dynamics"))
        assert eng.has_fix("damp") and not eng.has_fix("muv")
