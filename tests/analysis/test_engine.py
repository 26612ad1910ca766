"""The engine (``analysis.stability.verdict``): one entry point, ``decide(system,
VerdictOptions)``, whose two paths give the same Decision; the options are
checked where they are made; the path is chosen in one place."""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.errors import TooLargeError
from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.analysis.stability.jacobian import RattlerResult
from remote_trigger.analysis.stability.system import ReducedSystem
from remote_trigger.analysis.stability.verdict import (VerdictOptions, choose_method, decide,
                                                       SOFT_MODE_REL)

from tests.analysis.test_sliced import planted


def system_of(K, mass):
    """A ReducedSystem of a bare K and M (no particle removed, zero residual)."""
    n = K.shape[0]
    rat = RattlerResult(np.zeros(0, np.int64), np.zeros(0, np.int64), np.arange(n), 0, 2)
    return ReducedSystem(None, K, np.asarray(mass, float), rat, np.zeros(n), sp.csr_matrix(K),
                         np.asarray(mass, float))


@pytest.mark.parametrize("kw, msg", [
    ({"method": "fast"}, "method must be one of auto, dense, sliced, got method = 'fast'"),
    ({"pairs": "soft"}, "pairs must be one of all, collective, got pairs = 'soft'"),
    ({"stop_at_complex": 1}, "stop_at_complex must be True or False, got stop_at_complex = 1"),
    ({"slice_size": 1}, "slice_size must be an integer >= 2, got slice_size = 1"),
    ({"part_size": 1}, r"part_size must be None or an integer >= the slice size \(60\), "
                       r"got part_size = 1"),
    ({"part_size": 59}, r"part_size must be None or an integer >= the slice size \(60\), "
                        r"got part_size = 59"),
    ({"part_size": 30, "slice_size": 40}, r"part_size must be None or an integer >= the "
                                          r"slice size \(40\), got part_size = 30"),
    ({"part_size": 100.0}, "got part_size = 100.0"),
    ({"part_size": True}, "got part_size = True"),
])
def test_options_are_checked_where_they_are_made(kw, msg):
    with pytest.raises(ValueError, match=msg):
        VerdictOptions(**kw)


def test_the_path_is_chosen_in_one_place():
    from remote_trigger.analysis.stability.eigen import DENSE_MAX

    assert choose_method(DENSE_MAX, available=10**12) == "dense"
    assert choose_method(DENSE_MAX + 1) == "sliced"
    assert choose_method(10, VerdictOptions(method="sliced")) == "sliced"
    with pytest.raises(TooLargeError, match="n = 2000 dofs"):
        choose_method(2000, VerdictOptions(method="dense"), available=1000)


@pytest.mark.parametrize("ratio", [1.5, 0.6])
def test_both_paths_give_the_same_decision(ratio):
    """A planted pair, complex (ratio > 1) or real, at n = 150: dense, sliced and
    sliced stopped at the first complex strip agree; so does the count of
    units certified complex."""
    K, mass = planted(n=150, pairs=[(60, ratio)], seed=3)
    system = system_of(K, mass)
    want = Decision.certified(ratio > 1)
    dense = decide(system, VerdictOptions(method="dense"))
    sliced = decide(system, VerdictOptions(method="sliced"))
    stopped = decide(system, VerdictOptions(method="sliced", stop_at_complex=True))
    for res, method in ((dense, "dense"), (sliced, "sliced"), (stopped, "sliced")):
        assert res.decision is want and res.method == method, (method, res.reason)
        assert res.confidence > 1 and res.n_dof == 150
        assert res.policy_decision is want and res.collective is None and res.soft_pairs == -1
        assert (res.complex_units >= 1) is (want is Decision.COMPLEX)
    assert dense.complex_pair is (want is Decision.COMPLEX)
    assert bool(np.isfinite(stopped.scanned_below)) is (want is Decision.COMPLEX)
    assert np.isinf(sliced.scanned_below) and sliced.eigenvalues.size == 150


def test_the_collective_policy_adds_its_decision(monkeypatch):
    """pairs = 'collective': the decision on the pairs that are not soft; with the
    threshold above the planted pair's |Re lambda| / lambda_max that pair is soft
    and the collective decision is real, the decision on all pairs still complex."""
    from remote_trigger.analysis.stability import verdict

    K, mass = planted(n=150, pairs=[(60, 1.5)], seed=3)
    system = system_of(K, mass)
    res = decide(system, VerdictOptions(pairs="collective"))
    assert res.collective is Decision.COMPLEX and res.soft_pairs == 0
    monkeypatch.setattr(verdict, "SOFT_MODE_REL", 0.9)
    res = decide(system, VerdictOptions(pairs="collective"))
    assert res.decision is Decision.COMPLEX and res.collective is Decision.REAL
    assert res.soft_pairs == 1 and res.policy_decision is Decision.REAL
    assert VerdictOptions(pairs="collective").soft_rel == 0.9
    monkeypatch.undo()
    assert VerdictOptions(pairs="collective").soft_rel == SOFT_MODE_REL
    assert VerdictOptions().soft_rel is None


def test_nothing_to_decide_and_bad_arguments():
    empty = system_of(sp.csr_matrix((0, 0)), np.zeros(0))
    empty.residual = np.zeros(3)             # (one disk, a rattler)
    res = decide(empty)
    assert res.decision is Decision.REAL and res.n_dof == 0 and res.eigenvalues.size == 0
    K, mass = planted(n=30, seed=1)
    with pytest.raises(ValueError, match="options must be a VerdictOptions, got dict"):
        decide(system_of(K, mass), {"method": "dense"})
    with pytest.raises(ValueError, match="basis must be a SpectrumBasis .* got str"):
        decide(system_of(K, mass), basis="x")


def test_decision_codes_and_labels_round_trip():
    for d in Decision:
        assert Decision.of(int(d)) is d and Decision.of(float(d)) is d
        assert Decision.of(d.label) is d and str(d) == d.label
    with pytest.raises(ValueError, match="not a decision code: 2"):
        Decision.of(2)


def test_parts_through_the_engine():
    """part_size through the options and a map_tasks through decide: the
    decision, eigenvalues and margin of the parts run by a counting map are
    those of the builtin map, bit for bit, and the whole scan's decision; a
    part_size below the scan's slice size is refused by the scan in one line;
    a map_tasks that is not callable is refused."""
    K, mass = planted(n=300, pairs=[(100, 1.5)], seed=1)
    system = system_of(K, mass)
    opts = VerdictOptions(method="sliced", slice_size=20, part_size=100)
    ran = []

    def counting_map(fn, tasks):
        for t in tasks:
            ran.append(fn.__name__)
            yield fn(t)

    seq = decide(system, opts)
    par = decide(system, opts, map_tasks=counting_map)
    whole = decide(system, VerdictOptions(method="sliced", slice_size=20))
    assert ran.count("scan_part") == 3 and ran.count("find_cut") == 2
    assert par.decision is seq.decision is whole.decision is Decision.COMPLEX
    assert par.confidence == seq.confidence
    assert par.eigenvalues.tobytes() == seq.eigenvalues.tobytes()
    with pytest.raises(ValueError, match=r"^part_size must be None or an integer >= the slice "
                                         r"size \(60\), got part_size = 50$"):
        decide(system, VerdictOptions(method="sliced", part_size=50))
    with pytest.raises(ValueError, match="map_tasks must be callable or None, got map_tasks = 3"):
        decide(system, opts, map_tasks=3)
