"""``ensemble``'s ``dim`` setting, without running LAMMPS.

What must hold (each can fail): ``dim = 3`` starts from the sphere defaults
and refuses, in one line naming the value, the 2D-only parts and sizes or
fractions the sphere generator cannot use; and the ensemble of disks is
unchanged by ``dim`` -- from the three packing results of a ``--quick`` run
made with the code before ``dim`` existed (commit a163038, kept in
tests/data/ensemble_quick2d), today's configuration, table and
``ensemble.md`` are those that code wrote, byte for byte (but for the
columns and sections added since, listed in ensemble_reference.py).
"""
import json
import os

import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.ensemble import config as ec
from remote_trigger.pywrap.jobs.ensemble import report as er

from .ensemble_reference import (REF, assert_reference_columns, reference_table,
                                 without_added_sections)


def test_sphere_defaults_and_quick():
    c = ec.build_config(overrides={"dim": 3})
    assert (c.dim, c.n, c.seeds, c.phi) == (3, (160,), (tuple(range(1, 13)),), 0.64)
    assert (c.frictional, c.inertia_I0, c.I0_dynamics) == (False, None, 0.4)
    assert c.conventions() == [0.4] and c.to_dict()["dim"] == 3
    q = ec.build_config(overrides={"dim": 3}, quick=True)
    assert (q.n, q.seeds, q.dF_x, q.tol) == ((96,), ((1, 3),), 1e-2, 2e-3)
    assert (q.frictional_relax, q.inertia_extra_steps) == ({}, None)
    assert ec.build_config(overrides={"dim": 3, "n": [120]}).n == (120,)
    two = ec.build_config()
    assert (two.dim, two.I0_dynamics, two.conventions()) == (2, 0.5, [0.5, 1.0])
    assert "dim" not in two.to_dict()


@pytest.mark.parametrize("over, msg", [
    ({"dim": 4}, "dim must be 2 or 3, got dim = 4"),
    ({"dim": 3, "frictional": True}, "frictional = True is 2D only"),
    ({"dim": 3, "inertia_I0": 1}, "inertia_I0 = 1 is 2D only"),
    ({"dim": 3, "frictional_relax": {"max_steps": 10}}, "frictional_relax = {'max_steps': 10} "
                                                        "is 2D only"),
    ({"dim": 3, "inertia_extra_steps": 3}, "inertia_extra_steps = 3 is 2D only"),
    ({"dim": 3, "n": [100, 16]}, "got n = [100, 16] (N = 16: width 2.5)"),
    ({"dim": 3, "phi": 0.82}, "phi must be in (0.1, 0.74) for spheres (dim = 3), got phi = 0.82"),
])
def test_bad_sphere_settings_are_refused(over, msg):
    with pytest.raises(ConfigError) as exc:
        ec.build_config(overrides=over)
    assert msg in str(exc.value) and "\n" not in str(exc.value)


def test_disks_unchanged(tmp_path):
    """Today's rows, table and ensemble.md of the reference run's packings equal
    the files the code before ``dim`` wrote."""
    import h5py

    cfg = ec.build_config(quick=True)
    with open(os.path.join(REF, "config.json")) as fh:
        assert cfg.to_dict() == json.load(fh)
    ref = reference_table()
    rows = []
    for t in cfg.packings():
        with open(os.path.join(REF, t["key"] + ".json")) as fh:
            rows.extend(er.rows_of(t, json.load(fh)["result"], cfg))
    er.write_table(str(tmp_path / "t.h5"), rows, cfg)
    assert_reference_columns(tmp_path / "t.h5")
    with h5py.File(tmp_path / "t.h5", "r") as fh:
        attrs = {k: fh.attrs[k] for k in fh.attrs}
    assert sorted(attrs) == sorted(ref["attrs"])
    for k, v in ref["attrs"].items():
        a = attrs[k]
        assert (a.tolist() if hasattr(a, "tolist") else a) == v, k
    s = ref["session"]
    er.write_summary(str(tmp_path / "e.md"), rows, cfg, er.statistics(rows, cfg), s["wall"],
                     s["n_ranks"], s["computed"])
    with open(tmp_path / "e.md") as fh, open(os.path.join(REF, "ensemble.md")) as gh:
        got, want = fh.read(), gh.read()
    # the sections added since (size dependence) are there; the rest is the reference's
    assert all(h in got for h in ("## Data set", "## Size dependence:"))
    assert without_added_sections(got) == want
