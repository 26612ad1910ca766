"""``RampConfig.between``: loads between the ramp's steps, a complex window
narrower than a step found, and the bracket moved to it.

The analyzer is made to answer 'complex' inside a planted window [a, b] that
lies within one step below the small packing's F_x^c (as a collective window
passed over by the coarse ramp at N = 400, docs/results/ensemble.md): without
``between`` the ramp brackets the later onset; with ``between = 4`` it finds
the window and bisects its lower edge. Interrupted inside the check and
resumed: bitwise the uninterrupted ramp; without the equilibria
(``keep_equilibria = False``) the starts of the loads still to check stay.
"""
import dataclasses

import numpy as np
import pytest

from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.runtime.results import read_all
from remote_trigger.pywrap.stages import ramp_file as rf
from remote_trigger.pywrap.stages.config import RampConfig
from remote_trigger.pywrap.stages.ramp import between_loads

DF = 0.01
TOL = 1e-5
M = 4


@pytest.fixture(scope="module")
def window(relaxed, tmp_path_factory):
    """(cfg, the ramp without the check, a, b): the window [a, b] inside the
    second step interval, between the loads 0.25 and 0.5 of it."""
    out = tmp_path_factory.mktemp("ramp_plain")
    cfg = RampConfig(datafile=relaxed.datafile, dF_x=DF, tol=TOL)
    plain = stages.ramp(cfg, str(out), quiet=True)
    assert plain.F_x.size >= 4, plain.F_x               # two real intervals below F_x^c
    a, b = plain.F_x[1] + 0.4 * DF, plain.F_x[1] + 0.6 * DF
    return cfg, plain, a, b


def planted(mp, a, b):
    """The analyzer answers complex for a <= F_x <= b (and as it does elsewhere)."""
    from remote_trigger.analysis.stability import verdict as stability

    real = stability.decide

    def decide(system, *args, **kw):
        res = real(system, *args, **kw)
        if a <= system.state.F_x <= b:
            return dataclasses.replace(res, decision=Decision.COMPLEX, confidence=2.0)
        return res

    mp.setattr(stability, "decide", decide)


def test_the_loads_between_steps_are_planned_lowest_first():
    from types import SimpleNamespace

    rows = {"F_x": [0.0, 0.1, 0.2, 0.3, 0.4], "decision": [0.0, 0.0, -1.0, 0.0, 1.0]}
    rlog = SimpleNamespace(rows={"steps": rows}, files={"steps": ["s0", "s1", "s2", "s3", "s4"]})
    got = between_loads(rlog, 4)
    # interval 2 starts at an undecided step: not checked; the last ends at the complex one
    want = [(0.025, "s0"), (0.05, "s0"), (0.075, "s0"), (0.125, "s1"), (0.15, "s1"),
            (0.175, "s1"), (0.325, "s3"), (0.35, "s3"), (0.375, "s3")]
    assert [f for _, f in got] == [f for _, f in want]
    np.testing.assert_allclose([F for F, _ in got], [F for F, _ in want], rtol=0, atol=1e-15)
    assert between_loads(rlog, 1) == []


@pytest.mark.parametrize("bad", [0, 1.5, True])
def test_a_bad_between_is_refused(relaxed, bad):
    with pytest.raises(ConfigError, match=f"between must be .*got between = {bad!r}"):
        RampConfig(datafile=relaxed.datafile, between=bad)


def test_a_window_inside_a_step_is_found_and_bisected(window, tmp_path):
    cfg, plain, a, b = window
    with pytest.MonkeyPatch.context() as mp:
        planted(mp, a, b)
        passed = stages.ramp(cfg, str(tmp_path / "passed"), quiet=True)
        found = stages.ramp(cfg.replace(between=M), str(tmp_path / "found"), quiet=True)
    # the coarse ramp passes over the window: its bracket is the later onset's
    assert (passed.F_x_c_low, passed.F_x_c_high) == (plain.F_x_c_low, plain.F_x_c_high)
    # with the check: the window's lower edge, to the tolerance
    assert found.status == "complete" and found.F_x_c_low < a <= found.F_x_c_high
    assert found.F_x_c_high - found.F_x_c_low <= TOL
    np.testing.assert_array_equal(found.F_x, passed.F_x)          # the same steps
    # the checked loads, lowest first, as bisection rows: 3 in the first interval,
    # then 0.25 (real) and 0.5 (complex) of the second; then the bisection inside
    F0, F1, F2 = found.F_x[:3]
    checked = found.bisection_F_x[:5]
    want = [F0 + j * (F1 - F0) / M for j in (1, 2, 3)] + [F1 + j * (F2 - F1) / M for j in (1, 2)]
    np.testing.assert_array_equal(checked, want)
    attrs, data = read_all(found.h5)
    assert list(data["bisection/decision"][:5]) == [0, 0, 0, 0, 1]
    assert np.all((found.bisection_F_x[5:] > checked[3]) & (found.bisection_F_x[5:] < checked[4]))
    assert attrs["between"] == M


def test_interrupted_inside_the_check_and_resumed_is_bitwise(window, tmp_path):
    cfg, _, a, b = window
    bcfg = cfg.replace(between=M)
    with pytest.MonkeyPatch.context() as mp:
        planted(mp, a, b)
        full = stages.ramp(bcfg, str(tmp_path / "full"), quiet=True)
        k = full.F_x.size + 2                        # two of the checked loads
        part = stages.ramp(bcfg, str(tmp_path / "part"), quiet=True, stop_after=k)
        assert part.status == "interrupted"
        res = stages.ramp(bcfg, str(tmp_path / "part"), quiet=True, resume=True)
        # without the equilibria: the starts of the loads still to check are kept
        pruned = stages.ramp(bcfg.replace(keep_equilibria=False), str(tmp_path / "pruned"),
                             quiet=True)
    _, x = read_all(full.h5)
    for other in (res, pruned):
        _, y = read_all(other.h5)
        assert set(x) == set(y)
        for key in x:
            if key.endswith("/datafile") or key.rsplit("/", 1)[-1] in rf.TIME_COLUMNS:
                continue
            np.testing.assert_array_equal(y[key], x[key], err_msg=key)
        assert (other.F_x_c_low, other.F_x_c_high) == (full.F_x_c_low, full.F_x_c_high)


def test_pruning_keeps_the_load_between_that_may_become_the_lower_end(tmp_path):
    """``keep_equilibria = False`` at a checkpoint inside the check between
    steps: the highest load certified real below the next load to check is
    kept, even when it is itself a load between, since that next load may be
    complex and make it the bracket's lower end (the start of the bisection).
    (Found on an N = 6400 ramp, where every point writes ramp.h5 and so
    prunes: its bisection asked for a load between that had been removed.)"""
    from types import SimpleNamespace

    from remote_trigger.pywrap.stages.ramp import _prune_equilibria

    def files(names):
        out = []
        for name in names:
            for ext in (".data", ".dump", ".dump.json"):
                (tmp_path / (name + ext)).write_text("")
            out.append(str(tmp_path / (name + ".data")))
        return out

    # steps 0 .. 0.3 real, 0.4 complex (the bracket [0.3, 0.4]); m = 3: loads
    # between 0.0333, 0.0667 (from step 0) and 0.1333 (from step 0.1) checked
    # real; 0.1667 (from step 0.1) next
    steps = {"F_x": [0.0, 0.1, 0.2, 0.3, 0.4], "decision": [0.0, 0.0, 0.0, 0.0, 1.0]}
    between = {"F_x": [0.1 / 3, 0.2 / 3, 0.4 / 3], "decision": [0.0, 0.0, 0.0]}
    rlog = SimpleNamespace(rows={"steps": steps, "bisection": between},
                           files={"steps": files([f"step_{k}" for k in range(5)]),
                                  "bisection": files(["bisect_0", "bisect_1", "bisect_2"])},
                           cfg=SimpleNamespace(between=3))
    _prune_equilibria(rlog)
    kept = sorted(p.name for p in tmp_path.glob("*.data"))
    # step_1, step_2: starts of loads still to check; step_3: the last step and the
    # bracket's lower end; step_4: its upper end; bisect_2 (0.1333): the lower end
    # should 0.1667 be complex
    assert kept == ["bisect_2.data", "step_1.data", "step_2.data", "step_3.data",
                    "step_4.data"], kept
