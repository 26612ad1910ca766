"""The sliced verdict's bookkeeping: the buffer of Ritz vectors (slices added
and dropped without copying the others) and the shift-invert factorizations
made with the counting's ordering (analysis.stability.sliced: .buffer, .inertia)."""
import pickle

import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.sliced import checkpoint
from remote_trigger.analysis.stability.sliced.buffer import RitzBuffer
from remote_trigger.analysis.stability.sliced.slices import Slice


def _slice(rng, n, k, lo, W):
    Q = np.linalg.qr(rng.standard_normal((n, k)))[0]
    theta = lo + np.sort(rng.uniform(0.1, 0.9, k))
    return Slice(lo, lo + 1.0, theta, Q, W @ Q, 1e-9, np.full(k, 1e-10), 1e-15)


def test_the_buffer_keeps_its_slices_through_growth_and_drops():
    """Slices of 3-9 vectors added and the oldest dropped, many times over (the
    store fills, moves its vectors to its start, and grows): Q is always the
    kept slices' vectors side by side, Q^T W Q, ||W q||, the overlaps and the
    values are those computed from them anew, and a pickled buffer holds no
    vector but their shape and sha256, and takes them back."""
    rng = np.random.default_rng(7)
    n = 40
    C = sp.random(n, n, density=0.2, random_state=rng)
    W = sp.csr_matrix(C - C.T)
    buf, kept = RitzBuffer(n), []
    moves = grows = pieces = 0
    for sid in range(60):
        sl = _slice(rng, n, int(rng.integers(3, 10)), float(sid), W)
        store, q0, m = buf._store, buf._q0, buf._q1 - buf._q0
        buf.add(sl, sid)
        kept.append((sid, sl))
        if buf._store is not store:
            grows += 1
        elif q0 > 0 and buf._q0 == 0:
            moves += 1
            pieces += q0 < m        # Q moved in pieces (its old and new place overlap)
        if sid % 4 == 3:            # drop the slices wholly below a point
            x = kept[-1][1].lo - float(rng.integers(0, 4)) + 0.5
            buf.drop_below(x)
            kept = [(i, s) for i, s in kept[:-1] if s.hi >= x] + [kept[-1]]
        Q = np.hstack([s.Q for _, s in kept])
        assert np.array_equal(buf.Q, Q)
        assert [e[0] for e in buf.edges] == [i for i, _ in kept]
        assert np.array_equal(buf.th, np.concatenate([s.theta for _, s in kept]))
        np.testing.assert_allclose(buf.Wn, Q.T @ (W @ Q), atol=1e-13)
        np.testing.assert_allclose(buf.wqn, np.linalg.norm(W @ Q, axis=0), rtol=1e-13)
        for (i, si) in kept:
            for (j, sj) in kept:
                if i < j:
                    assert buf.cross[(i, j)] == pytest.approx(np.linalg.norm(si.Q.T @ sj.Q),
                                                              rel=1e-12)
    assert grows >= 2 and moves >= 2 and pieces >= 1
    state = pickle.loads(pickle.dumps(buf))
    assert state.Q is None and "_store" not in buf.__getstate__()
    assert state.q_shape == buf.Q.shape and state.q_sha == checkpoint.sha(Q)
    state.Q = Q
    assert np.array_equal(state.Q, buf.Q) and state.Q.flags.f_contiguous


def test_shift_invert_solves_are_those_of_a_new_factorization():
    """The shift-invert solves of a slice use the counting's ordering
    (sliced.inertia.Shifts.factor): bitwise the solves of a new factorization at
    that shift. At a shift where the factorization meets a zero pivot, which
    QDLDL's update does not report (it stops there, leaving the rest of the
    previous shift's factors), the probe solve's residual is large and a new
    factorization refuses the shift, as before."""
    import qdldl

    from remote_trigger.analysis.stability import jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.sliced import SlicedStats, scaled_parts
    from remote_trigger.analysis.stability.sliced.inertia import Shifts, shifted
    from remote_trigger.analysis.stability.sliced.numerics import SliceFailure
    from remote_trigger.analysis.stability.sliced.slices import shift_invert

    from .builders import random_packing

    res = analyze(random_packing(5, nx=20, ny=15), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    S = scaled_parts(Kr, mr)[1]
    lam = np.linalg.eigvalsh(S.toarray())
    shifts = Shifts(S)
    rng = np.random.default_rng(3)
    b = rng.standard_normal(S.shape[0])
    for a in (lam[40] + 1e-3, lam[200] - 1e-3, 0.5 * (lam[-3] + lam[-2])):
        fac = shifts.factor(a)
        assert np.array_equal(fac.solve(b), qdldl.Solver(shifted(S, a)).solve(b))
        got = shift_invert(S, shifts, a, 6, rng, SlicedStats())[0]
        near = lam[np.argsort(np.abs(lam - a))[:6]]
        np.testing.assert_allclose(np.sort(got), np.sort(near), rtol=1e-9)
    p0 = int(shifts.solver.factors()[2][0])     # the first pivot is S_pp - a
    with pytest.raises(SliceFailure, match=r"no LDL\^T factorization of S - sigma I"):
        shift_invert(S, shifts, float(S.diagonal()[p0]), 6, rng, SlicedStats())


def test_a_shift_at_a_tiny_pivot_is_moved_before_the_eigen_solver_runs(monkeypatch):
    """A shift 1e-13 (relative) from an eigenvalue of a leading block of the
    permuted S - sigma I makes the elimination without pivoting meet a tiny
    pivot: the probe solve's relative residual exceeds 1e-7, and
    ``shift_invert`` moves the shift down by ``step`` before the eigen-solver
    runs; the Frobenius norm of its pairs' residuals is then below 1e-2 of
    the eigen-solver's own bound (``slices.stopping_bound``). With the move turned off
    (``_PROBE_LIMIT`` = inf) the same call returns pairs whose residuals
    exceed that bound (what makes the slice be computed again): the check
    can fail. A clean shift is not moved; a shift at a zero pivot (no
    factorization; without ``step`` the call raises, the test above) is
    moved like a tiny one."""
    from remote_trigger.analysis.stability import jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.sliced import SlicedStats, scaled_parts
    from remote_trigger.analysis.stability.sliced import slices
    from remote_trigger.analysis.stability.sliced.inertia import Shifts, shifted
    from remote_trigger.analysis.stability.sliced.strips import norm1

    from .builders import random_packing

    res = analyze(random_packing(5, nx=20, ny=15), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    S = scaled_parts(Kr, mr)[1]
    n = S.shape[0]
    lam = np.linalg.eigvalsh(S.toarray())
    shifts = Shifts(S)
    shifts.factor(0.0)
    perm = shifts.solver.factors()[2]
    P = shifted(S, 0.0)[perm][:, perm].toarray()
    mu = np.linalg.eigvalsh(P[:n // 2, :n // 2])
    tiny = float(mu[np.argmin(np.abs(mu - lam[n // 2]))]) * (1 + 1e-13)
    clean = 0.5 * (lam[n // 2] + lam[n // 2 + 1])
    step = 0.2 * float(np.median(np.diff(lam)))
    bound = slices.stopping_bound(20, norm1(S), tiny)

    def run(a):
        st = SlicedStats()
        got, V, used = slices.shift_invert(S, shifts, a, 20, np.random.default_rng(1), st, step)
        return st.moved, used, float(np.linalg.norm(S @ V - V * got))

    moved, used, worst = run(clean)
    assert moved == 0 and used == clean and worst < 1e-2 * bound
    shifts.factor_checked(tiny)
    assert shifts.probe > 1e-7
    moved, used, worst = run(tiny)
    assert moved == 1 and used == tiny - step and worst < 1e-2 * bound
    assert shifts.probe < 1e-10
    p0 = int(shifts.solver.factors()[2][0])     # the first pivot is S_pp - a: a zero pivot
    zero = float(S.diagonal()[p0])
    moved, used, worst = run(zero)
    assert moved == 1 and used == zero - step and worst < 1e-2 * bound
    monkeypatch.setattr(slices, "_PROBE_LIMIT", np.inf)
    moved, used, worst = run(tiny)
    assert moved == 0 and used == tiny and worst > bound


def test_the_first_slice_is_computed_about_a_shift_just_below_the_spectrum(tmp_path,
                                                                          monkeypatch):
    """The first slice of a scan starts at the Gershgorin bound, far below the
    spectrum of a relaxed packing (N = 400, n = 1176: -23 551 against a lowest
    eigenvalue near 0). Its shift is put just below the lowest eigenvalue by
    bisection on the count, and the eigen-solver takes about as many solves for it as
    for the slices above it (at most 1.5 x their median). With the shift at
    the Gershgorin bound (``_bottom_shift`` turned off, as before), the first
    slice takes more than 3 x their median (the Lanczos's solves and, where it
    has not converged within its steps, ARPACK's after it): the check can
    fail. The slices
    computed hold the same eigenvalues (to their Kahan radii) either way."""
    import scipy.sparse.linalg as spla

    from remote_trigger.analysis.stability.sliced import SlicedStats, scaled_parts, slices
    from remote_trigger.analysis.stability.sliced.scan import _bottom
    from remote_trigger.analysis.stability.sliced.strips import StripContext
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from tests.data import unpack

    unpack("free_rotation_N400_s5_step_00002.dump.json", str(tmp_path))
    dump = unpack("free_rotation_N400_s5_step_00002", str(tmp_path))
    system = reduced_system(read_equilibrium(dump))
    A, S, W = scaled_parts(system.K, system.mass)
    ctx = StripContext.of(A, S, W, 2.0 ** -53, 10.0)
    lo0 = _bottom(S, ctx, 2.0 ** -53)
    lam = np.linalg.eigvalsh(S.toarray())
    assert lam[0] - lo0 > 1e4
    real_pairs, real_eigsh = slices.nearest_pairs, spla.eigsh

    def scan(bottom):
        solves, shifts = [], []

        def nearest_pairs(solve, sigma, *args):     # counts the solves of each run
            count = [0]

            def counted(v):
                count[0] += 1
                return solve(v)
            out = real_pairs(counted, sigma, *args)
            solves.append(count[0])
            shifts.append(float(sigma))
            return out

        def eigsh(*args, OPinv=None, **kw):         # ARPACK where the Lanczos did not
            count = [0]                             # converge: its solves added to the run's

            def counted(v):
                count[0] += 1
                return OPinv.matvec(v)
            out = real_eigsh(*args, OPinv=spla.LinearOperator(OPinv.shape, matvec=counted,
                                                              dtype=np.float64), **kw)
            solves[-1] += count[0]
            return out

        monkeypatch.setattr(slices, "nearest_pairs", nearest_pairs)
        monkeypatch.setattr(slices.spla, "eigsh", eigsh)
        if not bottom:
            monkeypatch.setattr(slices, "_bottom_shift", lambda *args: None)
        st = SlicedStats()
        got = slices.ritz_slices(S, W, 60, ctx.normS, slices.start_position(S, lo0, st), st)
        sl = [next(got) for _ in range(5)]
        monkeypatch.undo()
        return solves, shifts, sl

    solves, shifts, sl = scan(True)
    assert lo0 < shifts[0] < lam[0]
    assert solves[0] <= 1.5 * np.median(solves[1:])
    old, old_shifts, old_sl = scan(False)
    assert old_shifts[0] == lo0
    assert old[0] > 3 * np.median(old[1:])
    for run in (sl, old_sl):            # every eigenvalue of S up to the fifth slice, in order
        theta = np.concatenate([s.theta for s in run])
        assert theta.size == np.count_nonzero(lam < run[-1].hi) > 200
        assert np.all(np.abs(theta - lam[:theta.size]) <= max(s.radius for s in run))
