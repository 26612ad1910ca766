"""One ramp point: the equilibrium at a load, saved, off saddles, and decided.

Part of :mod:`remote_trigger.pywrap.stages`; used by the ramp
(:func:`remote_trigger.pywrap.stages.ramp`) and the paper job's friction
bisection.

Newton from the previous equilibrium converges to whatever zero of the
force is nearest, and past a fold of one weakly held particle that can be a
*saddle*: an equilibrium with a negative eigenvalue, which the damped
dynamics never stays in (measured: N = 400, seed 8, F_x = 0.001, the
lowest eigenvalue -0.042 where the step before had 6.39; at N = 6400, up
to 17 of 66 ramp points; docs/driver.md "Saddles"). So after Newton the point is
screened (``analysis.stability.analyze.negative_modes``: one LDL^T
factorization, and where that does not exclude it, the eigenvalues of
M^-1 K nearest 0) and, with ``cfg.saddle_escape``, a saddle is replaced by the
equilibrium the damped dynamics reach from the same start, Newton only
polishing at the end (first below 1e-4 newton_start, then, if that too is
a saddle, below 1e-6). Disks only: a planar packing of spheres is
unstable out of its plane by construction (tests/driver/test_planar3d.py),
and saddles of sphere packings were not measured.
"""
import math
import time

from remote_trigger.analysis.stability.analyze import NEGATIVE_REL
from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.analysis.stability.verdict import VerdictOptions
from remote_trigger.pywrap.runtime.parallel import on_rank0
from remote_trigger.pywrap.stages import equilibrium as eq
from remote_trigger.pywrap.stages.common import (decide_on_rank0, load_equilibrium_scene,
                                                 save_equilibrium)

__all__ = ["ramp_point", "verdict_progress", "held_system"]

#: the escapes from a saddle: damped dynamics from the start until the
#: residual is below newton_start x factor, then Newton (one try per factor)
ESCAPE_NEWTON_START = (1e-4, 1e-6)


def verdict_progress(bar, F_x):
    """A ``progress`` for :func:`ramp_point` that shows a sliced verdict's advance
    in the postfix of the tqdm ``bar`` ("F_x 0.00025: verdict 11830/28836
    eigenvalues"); None for a disabled bar (quiet, or not rank 0)."""
    if bar.disable:
        return None

    def show(done, n):
        bar.set_postfix_str(f"F_x {F_x:.6g}: verdict {done}/{n} eigenvalues", refresh=True)

    return show


def held_system(eng, cfg, F_x):
    """The reduced system of the equilibrium LAMMPS holds, built once, on rank 0.

    The per-atom arrays are gathered (on every rank: a collective call) and
    turned into the analysis State as Newton's are
    (:func:`~remote_trigger.pywrap.stages.newton_solve.analysis_state`):
    the same positions, contact history, loads and masses that
    :func:`~remote_trigger.pywrap.stages.common.save_equilibrium` writes to
    the dump (``%.17g``, which float64 reads back bitwise), so the State,
    K and the verdict are those of the dump (tests/driver/test_held_system.py
    and test_ramp3d.py check K, M, the kept dofs and the residual bitwise).

    Returns
    -------
    callable
        ``system()`` on rank 0: the
        :class:`~remote_trigger.analysis.stability.system.ReducedSystem`,
        built at its first call and kept.
    """
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.pywrap.stages.newton_solve import analysis_state

    atoms = eng.gather_state()
    kept = []

    def system():
        if not kept:
            kept.append(reduced_system(analysis_state(
                atoms, cfg.k_n, cfg.k_t, cfg.mu, F_x, cfg.F_y,
                top_layer=getattr(cfg, "top_layer", "free"))))
        return kept[0]

    return system


def _screen(eng, system):
    """Rank 0's count of negative modes of ``system()`` (rank 0), on all ranks."""
    def run():
        from remote_trigger.analysis.stability.analyze import negative_modes

        return negative_modes(system())

    return on_rank0(eng.comm, run)


def ramp_point(eng, cfg, start_file, F_x, prefix, basis=None, dim=2, progress=None,
               checkpoint_dir=None):
    """Equilibrate at F_x from ``start_file``, save ``prefix.*``, analyse.

    Parameters
    ----------
    eng : Engine
    cfg : RampConfig
        ``saddle_escape`` (default True where the config has none): redo a
        Newton equilibrium of disks that screens as a saddle by damped
        dynamics.
    start_file : str
        Equilibrium ``.data`` to start from (its history beside it).
    F_x : float
    prefix : str
        Output ``prefix.{data,dump,dump.json}``.
    basis : SpectrumBasis, optional
        The previous point's verified spectrum basis (rank 0), tried first by
        the certified decision.
    dim : int
        3 for spheres (their history comes from the dump beside
        ``start_file``).
    progress : callable, optional
        ``progress(done, n)`` on rank 0 after each slice of a sliced verdict
        (``analysis.stability.sliced.classify_sliced``).
    checkpoint_dir : str, optional
        Folder of a sliced verdict's saved scan and verdict (rank 0; see
        ``classify_sliced``): a point redone after a kill resumes its scan,
        and a point whose matrix is bitwise one already decided there
        (possibly the F_x = 0 point of a second ramp from the same packing)
        is not decided again.

    Returns
    -------
    vals : dict
        The ramp.h5 row (:data:`remote_trigger.pywrap.stages.ramp_file.COLUMNS`).
        ``saddle_escaped`` the number of escapes made (0: Newton's
        equilibrium screened stable, or no escape tried), ``n_negative`` the
        eigenvalues of M^-1 K with Re lambda < -NEGATIVE_REL lambda_max (0
        on a stable equilibrium): LAPACK's of the dense verdict, or the
        screen's where the verdict is sliced (its list holds the symmetric
        part's Ritz values); -1 if the screen could not count. With
        ``cfg.pairs`` = 'collective', ``decision`` and ``complex`` are those
        of the pairs that are not soft (``StabilityResult.collective``) and
        ``soft_pairs`` counts the soft ones (NaN otherwise). ``eigen_time``
        and ``decision_time``: the verdict's own split of its seconds
        (``StabilityResult.timing``: the eigenvalues, dgeev or the sliced
        scan's shift-invert slices; the rest, its strips and pairs), summed
        over the parts of a scan in parts; a scan resumed from its
        checkpoint counts the time before the kill too.
    res : StabilityResult
        The decision; a ramp needs only that, so a sliced scan stops at its
        first complex strip (``scanned_below``; with 'collective' the first
        that is not soft).

    Raises
    ------
    NoEquilibriumError
        From :func:`~remote_trigger.pywrap.stages.equilibrium.equilibrate` of
        the Newton-first equilibrium (a failed escape keeps the saved one).
    """
    import numpy as np

    t0 = time.perf_counter()
    load_equilibrium_scene(eng, cfg, start_file, F_x, dim)
    r, t_sim, rec = eq.equilibrate(eng, cfg, F_x, newton_first=True)
    save_equilibrium(eng, cfg, F_x, prefix)
    system = held_system(eng, cfg, F_x)
    escaped = 0.0
    counted = None              # the screen's count of the saved equilibrium, once made
    if getattr(cfg, "saddle_escape", True) and dim == 2:
        for factor in ESCAPE_NEWTON_START:
            counted = _screen(eng, system)
            if counted <= 0:
                break
            load_equilibrium_scene(eng, cfg, start_file, F_x, dim)
            try:
                r, t_damped, rec = eq.equilibrate(
                    eng, cfg.replace(newton_start=cfg.newton_start * factor), F_x)
            except eq.NoEquilibriumError:
                break           # the saved equilibrium (Newton's or an escape's) stays
            t_sim += t_damped
            save_equilibrium(eng, cfg, F_x, prefix)
            system = held_system(eng, cfg, F_x)
            escaped += 1.0
            counted = None
    options = VerdictOptions(pairs=getattr(cfg, "pairs", "all"), stop_at_complex=True,
                             checkpoint_dir=checkpoint_dir,
                             part_size=getattr(cfg, "part_size", None))
    res = decide_on_rank0(eng, system, options, basis, progress)
    # with pairs = 'collective' a point whose only complex pairs are soft is real
    code = res.policy_decision
    if res.method == "sliced":
        # the sliced verdict lists the symmetric part's Ritz values for its
        # one-eigenvalue strips: a free rotation would count; the screen counts
        # M^-1 K's own eigenvalues (-1: no count)
        neg = float(_screen(eng, system) if counted is None else counted)
    else:
        lam = np.asarray(res.eigenvalues)
        scale = np.max(lam.real, initial=0.0)
        neg = float(np.count_nonzero(lam.real < -NEGATIVE_REL * scale))
    vals = {"F_x": F_x, "residual": r, "complex": float(code == Decision.COMPLEX),
            "from_basis": float(res.start == "basis"), "decision": float(code),
            "confidence": float(res.confidence), "growth_rate": res.growth_rate,
            "max_imag": res.max_imag, "n_rattlers": float(res.n_rattlers),
            "wall_time": time.perf_counter() - t0, "damped_time": t_sim,
            "newton_steps": float(max(0, sum(p == "newton" for p in rec.phase) - 1)),
            "n_dof": float(res.n_dof), "lambda_max": res.lambda_max,
            "scanned_below": res.scanned_below, "saddle_escaped": escaped,
            "n_negative": neg,
            "soft_pairs": float(res.soft_pairs) if res.collective is not None else math.nan,
            "eigen_time": float(res.timing.get("eigen", math.nan)),
            "decision_time": float(res.timing.get("decision", math.nan))}
    return vals, res
