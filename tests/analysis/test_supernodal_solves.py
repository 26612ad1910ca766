"""Shift-invert solves with SuperLU's supernodal LU where the factor is dense
(analysis.stability.sliced.inertia.SymmetricLU, Shifts.factor_checked): the
solves of a new factorization at the same shift whatever came before, a zero
pivot refused, and the same verdict and eigenvalues as QDLDL's solves."""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.sliced import inertia
from remote_trigger.analysis.stability.sliced.inertia import Shifts, SymmetricLU, shifted
from remote_trigger.analysis.stability.sliced.numerics import SliceFailure
from remote_trigger.analysis.stability.sliced.supernodal import SupernodalLDL


def random_symmetric(n, seed):
    rng = np.random.default_rng(seed)
    C = sp.random(n, n, density=6.0 / n, random_state=rng)
    return sp.csc_matrix(C + C.T + sp.diags(np.linspace(-5, 5, n)))


def test_solves_in_one_order_whatever_was_factorized_before():
    """Solves at a shift: residual at round-off, the same row and column
    order; given the order, bitwise the same whether another shift came
    first or not; an exactly zero diagonal pivot (the first pivot S_pp - a)
    is refused with the matrix named."""
    S = random_symmetric(300, 3)
    n = S.shape[0]
    b = np.random.default_rng(1).standard_normal(n)
    first = SymmetricLU(shifted(S, 0.1))
    order = first.perm
    assert sorted(order) == list(range(n)) and np.array_equal(first.lu.perm_r, first.lu.perm_c)
    for a in (0.1, -2.3, 4.05):
        x = SymmetricLU(shifted(S, a), order).solve(b)
        assert np.linalg.norm(shifted(S, a) @ x - b) < 1e-10 * np.linalg.norm(b) * np.linalg.norm(x)
    x1 = SymmetricLU(shifted(S, 1.7), order).solve(b)
    SymmetricLU(shifted(S, -4.0), order)
    assert np.array_equal(SymmetricLU(shifted(S, 1.7), order).solve(b), x1)
    zero = float(S.diagonal()[order[0]])
    with pytest.raises(SliceFailure, match=r"no LDL\^T factorization of S - sigma I.*zero pivot"):
        SymmetricLU(shifted(S, zero), order, "S - sigma I")


def test_shifts_choose_supernodal_solves_by_the_fill(monkeypatch):
    """Shifts.factor_checked: QDLDL's factorization (the counts' object) below
    SUPERNODAL_FILL entries per row, a SymmetricLU above it; the counts then
    those of a SupernodalLDL in SuperLU's order (the same count as QDLDL's,
    the fuzz of that order; no QDLDL factorization made)."""
    S = random_symmetric(300, 4)
    b = np.random.default_rng(2).standard_normal(S.shape[0])
    sparse_ = Shifts(S)
    fac = sparse_.factor_checked(0.3)
    assert sparse_.solves == "qdldl" and fac is sparse_.solver
    monkeypatch.setattr(inertia, "SUPERNODAL_FILL", 0.0)
    dense = Shifts(S)
    lu = dense.factor_checked(0.3)
    assert dense.solves == "superlu" and isinstance(lu, SymmetricLU) and dense.probe < 1e-10
    x = fac.solve(b)
    assert np.linalg.norm(lu.solve(b) - x) < 1e-9 * np.linalg.norm(x)
    cnt, fz = dense.count_below(1.1)
    assert cnt == sparse_.count_below(1.1)[0]
    assert (cnt, fz) == SupernodalLDL(S, dense.order).count_below(1.1)
    assert dense.perm is dense.order and dense.solver is None


@pytest.mark.parametrize("pairs", [[(100, 1.5)], []])
def test_the_verdict_with_supernodal_solves(monkeypatch, pairs):
    """A whole sliced verdict (n = 300, a planted complex pair or none) with
    every shift-invert solve by SuperLU (SUPERNODAL_FILL = 0): the same
    decision and strips as with QDLDL's, the eigenvalues within 1e-9
    of the largest (the solves differ in their rounding only), counts left
    out between counted runs (no count is at hand at a shift); with the
    threshold kept, the probe of the fill changes no bit (against a scan
    with the probe switched off)."""
    from remote_trigger.analysis.stability.decision import Decision
    from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced

    from .test_sliced import planted

    K, mass = planted(n=300, pairs=pairs, seed=1)

    def run():
        st = SlicedStats()
        return classify_sliced(K, mass, stats=st, slice_size=20), st

    made = []
    real_lu = inertia.SymmetricLU

    def counted(*args, **kw):
        made.append(1)
        return real_lu(*args, **kw)

    def probe_off(*args, **kw):                   # no fill measured: QDLDL's solves
        raise SliceFailure("probe off")

    monkeypatch.setattr(inertia, "SymmetricLU", counted)
    dq, st_q = run()
    probes = len(made)                            # one probe of the fill a Shifts
    monkeypatch.setattr(inertia, "SymmetricLU", probe_off)
    dq2, _ = run()
    monkeypatch.setattr(inertia, "SymmetricLU", counted)
    monkeypatch.setattr(inertia, "SUPERNODAL_FILL", 0.0)
    ds, st_s = run()
    assert probes > 0 and len(made) - probes >= st_s.lanczos_runs > 0   # every solve a SymmetricLU
    # each count a factorization of its own there: chains of runs leave counts out
    assert st_s.deferred_counts > 0 and st_q.deferred_counts == 0
    assert ds.decision is dq.decision is Decision.certified(bool(pairs))
    assert st_s.strips == st_q.strips          # the slices may differ: edges in other gaps
    lq, ls = np.sort_complex(dq.eigenvalues), np.sort_complex(ds.eigenvalues)
    assert lq.size == ls.size == 300
    assert np.max(np.abs(lq - ls)) < 1e-9 * np.max(np.abs(lq))
    assert np.array_equal(np.asarray(dq2.eigenvalues), np.asarray(dq.eigenvalues))


def test_parts_with_supernodal_solves_resume_to_the_same_bits(monkeypatch, tmp_path):
    """With SuperLU's solves (SUPERNODAL_FILL = 0) a scan in parts gives the
    same bits run through and killed in its second part then resumed from
    its checkpoint (the parts before it not run again): each part chooses
    and orders its factorizations from its own matrix, never from what ran
    before it, which is also what makes the bits independent of the ranks
    (test_sliced_parts: a process pool)."""
    from .test_sliced import planted
    from .test_sliced_parts import fingerprint, run

    monkeypatch.setattr(inertia, "SUPERNODAL_FILL", 0.0)
    K, mass = planted(n=300, pairs=[(100, 1.5), (220, 0.9)], seed=1)
    seq = fingerprint(*run(K, mass, part_size=100))

    class Killed(Exception):
        pass

    def killing_map(fn, tasks):
        for t in tasks:
            if fn.__name__ == "scan_part" and t.j > 0 and kill:
                raise Killed
            yield fn(t)

    kill = True
    with pytest.raises(Killed):
        run(K, mass, part_size=100, checkpoint_dir=str(tmp_path), map_tasks=killing_map)
    kill = False
    assert fingerprint(*run(K, mass, part_size=100, checkpoint_dir=str(tmp_path),
                            map_tasks=killing_map)) == seq


def test_the_choice_does_not_depend_on_what_comes_first(monkeypatch):
    """Shifts decide their factorizations at the first shift, a count or a
    factorization for solves, from the pattern: the same choice, order,
    counts and solves either way (SUPERNODAL_FILL = 0: SuperLU's path)."""
    monkeypatch.setattr(inertia, "SUPERNODAL_FILL", 0.0)
    S = random_symmetric(250, 6)
    b = np.random.default_rng(3).standard_normal(S.shape[0])
    first_count, first_solve = Shifts(S), Shifts(S)
    c1 = first_count.count_below(0.4)
    x1 = first_count.factor_checked(-1.1).solve(b)
    x2 = first_solve.factor_checked(-1.1).solve(b)
    c2 = first_solve.count_below(0.4)
    assert first_count.solves == first_solve.solves == "superlu"
    assert np.array_equal(first_count.order, first_solve.order)
    assert c1 == c2 and np.array_equal(x1, x2)
