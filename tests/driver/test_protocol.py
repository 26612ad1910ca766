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
    assert res.decision == "real" and res.confidence > 1, (res.decision, res.confidence)
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
