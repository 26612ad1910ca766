"""The default relax protocol 'frictionless-then-friction' (docs/driver.md).

Frictionless compaction of the bulk with the top line held, the line lowered
onto the bulk and pressed as a rigid piston, frictionless relaxation, then
friction switched on with zero history. Checked on N = 40, seeds 1-3:

* the top line stays on top: every top disk centre is above every bulk disk
  centre (the geometric criterion; N = 100 is checked by
  benchmarks/bench_relax.py);
* the equilibrium is one with friction on and every tangential
  displacement exactly zero, so K is symmetric to round-off and the spectrum
  at F_x = 0 is certified real and positive;
* the old frictional protocol stays selectable and leaves xi != 0.
"""
import numpy as np
import pytest

from remote_trigger.analysis.state.dumpfile import read_dump
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import RelaxConfig
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.stages.packing import generate, write_data
from remote_trigger.analysis.stability.verdict import stability_of_dump
from remote_trigger.analysis.stability.decision import Decision

N = 40


@pytest.fixture(scope="module", params=[1, 2, 3])
def relaxed40(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(f"proto{request.param}")
    data = str(out / "p.data")
    write_data(generate(N, seed=request.param), data)
    return stages.relax(RelaxConfig(datafile=data), str(out), quiet=True)


def test_top_line_stays_on_top(relaxed40):
    st = read_dump(relaxed40.dumpfile)
    top = st.external[:, 1] < 0
    y = st.positions[:, 1]
    assert np.min(y[top]) > np.max(y[~top]), (np.min(y[top]), np.max(y[~top]))
    assert relaxed40.top_clearance == pytest.approx(np.min(y[top]) - np.max(y[~top]))
    assert 0.7 < relaxed40.packing_fraction < 0.86


def test_friction_on_with_zero_history(relaxed40):
    st = read_dump(relaxed40.dumpfile)
    assert st.params.mu == 1.0                       # the equilibrium is frictional
    assert np.all(st.contact_xi == 0.0) and np.all(st.wall_xi == 0.0)
    assert relaxed40.residual < 1e-10
    assert relaxed40.antisymmetry < 1e-14            # ||K - K^T|| / ||K||
    assert relaxed40.history.phase[-1] == "friction-on"


def test_spectrum_real_and_positive_at_zero_load(relaxed40):
    res = stability_of_dump(relaxed40.dumpfile)
    assert res.decision is Decision.REAL and res.confidence > 1, (res.decision, res.confidence)
    assert not res.complex_pair and res.growth_rate == 0.0
    assert np.all(res.eigenvalues.imag == 0) and res.eigenvalues.real.min() > 0


def test_frictional_protocol_still_selectable(tmp_path, packing_file):
    cfg = RelaxConfig(datafile=packing_file, protocol="frictional", settle_steps=10000)
    res = stages.relax(cfg, str(tmp_path), quiet=True)
    st = read_dump(res.dumpfile)
    assert res.protocol == "frictional" and res.residual < 1e-10
    assert np.any(st.contact_xi != 0.0)              # history built up with friction
    assert res.antisymmetry > 1e-6


def test_bad_protocol_named():
    with pytest.raises(ConfigError, match="protocol = 'sticky'"):
        RelaxConfig.from_dict({"datafile": __file__, "protocol": "sticky"})
    with pytest.raises(ConfigError, match="top_gap = -0.1"):
        RelaxConfig.from_dict({"datafile": __file__, "top_gap": -0.1})


# --------------------------------------------------------------------------- clearance rules
def _line_state(x, y, top, L=10.0, dim=2):
    from types import SimpleNamespace

    pos = np.column_stack([x, y] + ([np.zeros(len(x))] if dim == 3 else []))
    lo = np.zeros(dim)
    hi = np.array([L, 100.0] + ([L] if dim == 3 else []))
    return SimpleNamespace(positions=pos, top=np.asarray(top, bool), dim=dim, box_lo=lo,
                           box_hi=hi, n=len(x))


def test_local_clearance_of_a_tilted_line():
    """A line that climbs along x, over a bulk that climbs with it: no bulk
    disk is above the line where it is, so 'local' is clear, while 'all'
    compares the line's low end with the bulk's high end and is not.
    Values by hand."""
    from remote_trigger.pywrap.stages.relax import top_clearance

    top_x, top_y = [1.0, 3.0, 5.0, 7.0, 9.0], [10.0, 10.5, 11.0, 11.5, 12.0]
    bulk_x, bulk_y = [1.2, 5.0, 8.9], [9.0, 10.0, 11.0]
    st = _line_state(top_x + bulk_x, top_y + bulk_y, [1] * 5 + [0] * 3)
    assert top_clearance(st, "all") == pytest.approx(10.0 - 11.0)
    # bulk at 1.2: top within 1.25 are 1.0 (10.0): 1.0; at 5.0: 5.0 (11.0): 1.0;
    # at 8.9: 9.0 (12.0) and 7.0 is 1.9 away: 1.0 -> min 1.0
    assert top_clearance(st, "local") == pytest.approx(1.0)
    assert top_clearance(st) == top_clearance(st, "all")        # disks: 'all' by default


def test_local_clearance_finds_a_disk_through_the_line_and_an_open_line():
    from remote_trigger.pywrap.stages.relax import top_clearance

    top_x, top_y = [1.0, 3.0, 5.0, 7.0, 9.0], [10.0] * 5
    # a bulk disk at x = 4.0 with its centre 0.3 above the line's (through it)
    st = _line_state(top_x + [4.0, 8.0], top_y + [10.3, 9.0], [1] * 5 + [0] * 2)
    assert top_clearance(st, "local") == pytest.approx(-0.3)
    # the periodic image: a bulk disk at x = 9.9 sees the top disk at 1.0
    # (0.9 + 0.1 = 1.1 < 1.25 across the boundary) and at 9.0
    st = _line_state([1.0, 9.0, 9.9], [10.0, 9.5, 9.8], [1, 1, 0])
    assert top_clearance(st, "local") == pytest.approx(0.2)
    # the line opened: no top centre within 1.25 of the bulk disk at 5.0
    st = _line_state([1.0, 9.0, 5.0], [10.0, 10.0, 5.0], [1, 1, 0])
    assert top_clearance(st, "local") == -np.inf
    with pytest.raises(ValueError, match="'some'"):
        top_clearance(st, "some")


def test_spheres_keep_their_local_rule():
    """Spheres: the default rule is 'local', over the horizontal (x, z) distance."""
    from remote_trigger.pywrap.stages.relax import top_clearance

    st = _line_state([1.0, 1.5, 6.0], [10.0, 9.0, 12.0], [1, 0, 1], dim=3)
    assert top_clearance(st) == top_clearance(st, "local") == pytest.approx(1.0)


@pytest.mark.parametrize("n,dim,rule", [(40, 2, "all"), (400, 2, "all"), (401, 2, "local"),
                                        (10000, 2, "local"), (160, 3, "local")])
def test_clearance_rule_auto(n, dim, rule):
    from remote_trigger.pywrap.stages.relax import clearance_rule

    assert clearance_rule(RelaxConfig(datafile=__file__), n, dim) == rule
    for given in ("all", "local"):
        assert clearance_rule(RelaxConfig(datafile=__file__, clearance=given), n, dim) == given


def test_clearance_rule_named_in_the_error():
    with pytest.raises(ConfigError, match="clearance = 'line'"):
        RelaxConfig(datafile=__file__, clearance="line")


def test_relax_records_its_clearance_rule(relaxed40):
    import h5py

    with h5py.File(relaxed40.h5, "r") as f:
        assert f.attrs["clearance_rule"] == "all" and f.attrs["clearance"] == "auto"


def test_a_buried_top_line_is_reported(packing_file, tmp_path, capsys):
    """relax --settle-steps 0 of a loose packing skips the compaction and the
    placements: the top line sinks into the bulk. The result is kept (the
    user asked for it) but the command line says so on stderr (it said
    nothing, exit status 0)."""
    from remote_trigger.pywrap import cli
    from remote_trigger.pywrap.runtime.results import read_all

    out = tmp_path / "o"
    assert cli.main(["relax", "--datafile", packing_file, "--out", str(out), "--quiet",
                     "--settle-steps", "0"]) == 0
    clear = float(read_all(str(out / "relax.h5"))[0]["top_clearance"])
    err = capsys.readouterr().err
    assert clear < 0
    assert "warning: the top line is not clear of the bulk" in err
    assert "settle_steps = 0 skips the compaction" in err
