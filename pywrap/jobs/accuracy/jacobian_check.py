"""The ``jacobian`` section of ``remote-trigger accuracy`` (docs/accuracy.md).

The analytic K (``jacobian.stiffness_matrix``) against a complex-step
derivative of the independent reference law (``forcelaw_ref``) and against
central finite differences *through LAMMPS* (:class:`_LammpsFD`) at several
steps h, plus Richardson extrapolation; rows for
:func:`remote_trigger.pywrap.jobs.accuracy.job.run_accuracy`.
"""
from __future__ import annotations

import math
import time

import numpy as np

from remote_trigger.pywrap.jobs.accuracy.report import Row


class _LammpsFD:
    """Central differences of G = (F_x, F_y, T/R) through a live LAMMPS instance.

    No integrator is defined: displacing q_k by h sets x += h and v = h/dt
    (or omega = h/(R dt) for phi = R theta), ``run 1`` lets the pair style and
    the wall fix advance the history by their own rule (nothing moves the
    atoms), then positions, velocities and history are restored.
    """

    NAMES = ("x", "v", "omega", "i2_mindlin_partner", "d2_mindlin_t", "d_mindlin_wall_t")

    def __init__(self, lmp, dt):
        self.lmp = lmp
        self.dt = dt
        self.nl = lmp.extract_global("nlocal")
        ex = lmp.numpy.extract_atom
        self.order = np.argsort(np.asarray(ex("id"))[:self.nl])
        self.R = np.asarray(ex("radius"))[:self.nl].copy()
        self.saved = {k: np.array(ex(k)[:self.nl]).copy() for k in self.NAMES}
        self.saved["v"][:] = 0.0
        self.saved["omega"][:] = 0.0
        self._restore()
        lmp.command("run 0")

    def _restore(self):
        for k in self.NAMES:
            self.lmp.numpy.extract_atom(k)[:self.nl] = self.saved[k]

    def _g(self, dof, h):
        ex = self.lmp.numpy.extract_atom
        loc = self.order[dof // 3]
        c = dof % 3
        if c < 2:
            ex("x")[loc, c] += h
            ex("v")[loc, c] = h / self.dt
        else:
            ex("omega")[loc, 2] = h / (self.R[loc] * self.dt)
        self.lmp.command("run 1 pre no post no")
        f = np.asarray(ex("f"))[:self.nl]
        tq = np.asarray(ex("torque"))[:self.nl]
        g = np.column_stack([f[:, 0], f[:, 1], tq[:, 2] / self.R])[self.order].reshape(-1)
        self._restore()
        return g

    def stiffness(self, h):
        n = 3 * self.nl
        K = np.empty((n, n))
        for q in range(n):
            K[:, q] = -(self._g(q, h) - self._g(q, -h)) / (2.0 * h)
        return K


def section_jacobian(ctx):
    """Analytic K vs complex step (reference law) and LAMMPS finite differences."""
    from remote_trigger.analysis import forcelaw_ref as fr
    from remote_trigger.analysis.stability.jacobian import stiffness_matrix
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.pywrap.bindings.engine import Engine

    st = read_dump(ctx.equilibrium + ".dump")
    reps = 20
    t0 = time.perf_counter()
    for _ in range(reps):
        K = stiffness_matrix(st)
    t_an = (time.perf_counter() - t0) / reps
    K = K.toarray()
    nK = np.linalg.norm(K)
    t0 = time.perf_counter()
    ref = fr.ReferenceSystem.from_state(st)
    K_cs = -fr.complex_step_jacobian(lambda q: fr.reference_forces(ref, q), ref.q0)
    t_cs = time.perf_counter() - t0
    e_cs = float(np.linalg.norm(K - K_cs) / nK)
    rows = [Row("jacobian", "analytic (stiffness_matrix)", f"N = {st.n}", e_cs, t_an,
                note="error = distance to the complex-step K"),
            Row("jacobian", "complex step (forcelaw_ref)", "h = 1e-30", e_cs, t_cs,
                note="independent implementation")]
    hs = (1e-5, 1e-7, 1e-9) if ctx.quick else (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
    Kfd = {}
    with Engine() as eng:
        eng.load_deck("in.relax", {"datafile": ctx.equilibrium + ".data", "kn": ctx.k_n,
                                   "kt": ctx.k_t, "mu": ctx.mu, "Fx": 0.0, "Fy": ctx.F_y,
                                   "dt": ctx.dt}, ("scene",))
        fd = _LammpsFD(eng.lmp, ctx.dt)
        for h in hs:
            t0 = time.perf_counter()
            Kfd[h] = fd.stiffness(h)
            w = time.perf_counter() - t0
            rows.append(Row("jacobian", "LAMMPS central FD", f"h = {h:.0e}",
                            float(np.linalg.norm(Kfd[h] - K) / nK), w, value=h))
    for a, b in zip(hs[:-1], hs[1:]):
        if a / b == 10.0:
            R = (10.0 * Kfd[b] - Kfd[a]) / 9.0        # removes the O(h) kink term
            rows.append(Row("jacobian", "LAMMPS FD, Richardson", f"h = {a:.0e}, {b:.0e}",
                            float(np.linalg.norm(R - K) / nK),
                            sum(x.wall_time for x in rows if x.value in (a, b)), value=b))
    best = min(rows, key=lambda x: (round(math.log10(max(x.error, 1e-300)), 1), x.wall_time))
    best.recommended = True
    return rows
