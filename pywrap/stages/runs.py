"""The undamped runs: perturb (Fig. 5 scenes a, b, c) and instability (Fig. 4).

Part of :mod:`remote_trigger.pywrap.stages`.
"""
from dataclasses import dataclass, field
import os

import numpy as np

from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import DynamicsConfig
from remote_trigger.pywrap.bindings.engine import Engine
from remote_trigger.pywrap.stages import equilibrium as eq
from remote_trigger.pywrap.runtime.results import SeriesWriter, read_all
from remote_trigger.pywrap.runtime.parallel import on_rank0
from remote_trigger.analysis.dynamics.series import growth_fit
from remote_trigger.pywrap.stages.common import (
    DECK_FIELDS, RESULT_VERSION, StableStartError, check_resume_config, decide_on_rank0,
    deck_vars, dynamics_relax_config, ensure_dir, equilibrium_files, load_equilibrium_scene,
    load_relax_scene, prepare_out, progress_bar, restore_saved_history3d, save_equilibrium,
    start_sha256, start_timestep)

#: the undamped deck of each dimension (disks, spheres)
PERTURB_DECKS = {2: "in.perturb", 3: "in.perturb3d"}


@dataclass
class SeriesResult:
    """Time series of one undamped run.

    Attributes
    ----------
    t, D, v_top, mu : ndarray
        Time, MSD D(t) (Eq. 8, from the starting equilibrium), mean x-velocity
        of ``top`` (signed), friction coefficient in force.
    h5 : str
    extra : dict
        Stage-specific numbers (e.g. ``v0``, ``measured_growth_rate``).
    """

    t: np.ndarray
    D: np.ndarray
    v_top: np.ndarray
    mu: np.ndarray
    h5: str
    extra: dict = field(default_factory=dict)


def undamped_run(eng, cfg, datafile, h5, variables, desc, quiet, stop=None, attrs=None,
                  dim=2):
    """Run ``in.perturb``'s scene from ``datafile`` and record every record_every steps.

    ``dim`` = 3: ``in.perturb3d``, with the history of the dump beside ``datafile``."""
    eng.clear()
    v = deck_vars(cfg, datafile, cfg.F_x)
    for var, _ in DECK_FIELDS:        # the relaxing decks' variables
        v.pop(var, None)
    v.update(ton=float(cfg.t_on), visc=0.0 if cfg.tau is None else 1.0 / float(cfg.tau))
    v.update(variables)
    eng.load_deck(PERTURB_DECKS[dim], v, ("scene", "dynamics"))
    if dim == 3:
        restore_saved_history3d(eng, datafile)
    n = cfg.record_every
    # records every n steps (the variables are evaluated only then). fix vmax:
    # running min and max of v_top over EVERY step (ave/histo's global vector
    # [3], [4]; 'ave running' keeps them over the run), max |v_top| = max(max,
    # -min); the mean of vx over `top` is vcm(top,x) bit for bit (masses 1,
    # the same sum), without evaluating a variable every step. No thermo
    # output but the step (the driver reads none).
    eng.commands("compute msd all msd\n"
                 f"fix rec all ave/time {n} 1 {n} c_msd[4] v_vtop v_mu_now\n"
                 "compute vx top reduce ave vx\n"
                 f"fix vmax all ave/histo 1 {n} {n} 0.0 1.0 1 c_vx mode scalar "
                 "ave running\n"
                 "thermo_style custom step\nthermo 0\n")
    nsteps = int(round(cfg.t_max / cfg.dt))
    nrec = max(1, nsteps // n)
    # v_top_max: running max of |v_top| over every step up to the record
    cols = ("t", "D", "v_top", "mu", "v_top_max")
    writer = None
    if eng.rank == 0:
        # attribute a: the amplitude this run applied (in.perturb's default 0), not
        # the configuration's (run (a) of perturb stored a = 1e-12)
        rec = dict(cfg.to_attrs(), a=float(variables.get("a", 0.0)))
        # v0_margin only where it made v0 (perturb's run (c) passes it in attrs;
        # the paper job and the trigger map set v0 their own way)
        rec.pop("v0_margin", None)
        rec.update(attrs or {}, version=RESULT_VERSION, n_ranks=eng.size)
        writer = SeriesWriter(h5, rec, cols)
    out = {c: [] for c in cols}

    def add(row):
        for c in cols:
            out[c].append(row[c])
        if writer is not None:
            writer.append(row)

    add({"t": 0.0, "D": 0.0, "v_top": 0.0, "mu": eng.equal("mu_now"), "v_top_max": 0.0})
    bar = progress_bar(nrec, desc, quiet, eng.rank, unit=" records")
    status = "failed"               # until the loop ends normally
    vmax = 0.0
    try:
        for k in range(nrec):
            eng.run(n, pre=(k == 0))
            vals = [eng.lmp.extract_fix("rec", 0, 1, i) for i in range(3)]
            vmax = max(float(eng.lmp.extract_fix("vmax", 0, 1, 3)),
                       -float(eng.lmp.extract_fix("vmax", 0, 1, 2)))
            add({"t": (k + 1) * n * cfg.dt, "D": vals[0], "v_top": vals[1], "mu": vals[2],
                 "v_top_max": vmax})
            bar.update(1)
            if stop is not None and stop(out):
                status = "stopped"
                break
        else:
            status = "complete"
    finally:
        bar.close()
        if writer is not None:
            writer.close(attrs={"v_top_max": vmax}, status=status)
    return SeriesResult(*(np.asarray(out[c]) for c in cols[:4]), h5=h5,
                        extra={"v_top_max": vmax, "v_top_running_max": np.asarray(out[cols[4]])})


def _equilibrium_for(eng, cfg, out, name, quiet):
    """Equilibrate cfg.datafile at cfg.F_x; save ``out/name/equilibrium.*``."""
    folder = os.path.join(out, name)
    ensure_dir(eng, folder)
    rcfg = dynamics_relax_config(cfg, cfg.F_x)
    if eng.dimension == 3:      # (the start's scene is loaded) its history from its dump
        load_equilibrium_scene(eng, rcfg, cfg.datafile, cfg.F_x, 3)
    else:
        load_relax_scene(eng, rcfg, cfg.datafile, cfg.F_x)
    r, _, _ = eq.equilibrate(eng, rcfg, cfg.F_x, newton_first=True)
    prefix = os.path.join(folder, "equilibrium")
    save_equilibrium(eng, rcfg, cfg.F_x, prefix)
    return prefix, r


#: the runs of :func:`perturb`
PERTURB_RUNS = "abc"


def check_runs(runs):
    """Validate the ``runs`` of :func:`perturb`; returns them in the order a, b, c.

    Raises
    ------
    ConfigError
        ``runs`` is empty or has a letter other than a, b, c (named).
    """
    if not isinstance(runs, str) or not runs:
        raise ConfigError(f"runs must be a non-empty subset of 'abc', got runs = {runs!r}")
    bad = sorted(set(runs) - set(PERTURB_RUNS))
    if bad:
        raise ConfigError(f"runs: unknown run letter(s) {', '.join(map(repr, bad))} in "
                          f"runs = {runs!r} (the runs are a, b, c)")
    return "".join(r for r in PERTURB_RUNS if r in runs)


def _perturb_resume_state(cfg, out, sha):
    """What an interrupted ``perturb`` in ``out`` left that this one may keep (rank 0).

    Returns
    -------
    residual : float or None
        Residual of the kept equilibrium ``out/perturb/equilibrium.*``; None
        if it is to be recomputed (then no run is kept either).
    complete : dict
        ``{run: SeriesResult}`` of the runs finished with this configuration.

    Raises
    ------
    ConfigError
        A run file in ``out`` was made with another configuration or from a
        data file with other contents (its key and both values named).
    """
    residual, complete = None, {}
    for run in PERTURB_RUNS:
        path = os.path.join(out, f"perturb_{run}.h5")
        if not os.path.exists(path):
            continue
        try:
            attrs, data = read_all(path)
        except OSError:                 # unreadable: redone
            continue
        if attrs.get("datafile_sha256") != sha:
            raise ConfigError(f"cannot resume {path}: it ran from a data file with other "
                              f"contents than datafile = {cfg.datafile!r} (nothing was "
                              f"changed)")
        # run (c) stores the v0 it measured where the configuration says None
        unset = {k for k, v in cfg.to_attrs().items() if v == "None"} if run == "c" else set()
        # run (a) applies no f(t): its a is 0 (older files: the configuration's);
        # v0_margin made only run (c)'s measured v0
        skip = (unset & {"v0", "v_ss"}) | ({"a"} if run == "a" else set())
        if not (run == "c" and cfg.v0 is None):
            skip.add("v0_margin")
        check_resume_config(path, cfg, attrs, skip=skip, suffix=" (nothing was changed)")
        residual = float(attrs["equilibrium_residual"])
        if attrs.get("status") == "complete":
            complete[run] = SeriesResult(
                data["t"], data["D"], data["v_top"], data["mu"], h5=path,
                extra={"v_top_max": float(attrs["v_top_max"]),
                       "v_top_running_max": data["v_top_max"]})
    if residual is None or not all(os.path.exists(os.path.join(out, f))
                                   for f in equilibrium_files("perturb")):
        return None, {}
    return residual, complete


def perturb(cfg, out, comm=None, quiet=False, log="none", runs="abc", overwrite=False,
            resume=False):
    """The three undamped runs of Fig. 5 from the equilibrium at cfg.F_x.

    (a) unperturbed; (b) f(t) = a cos(omega_p t) added to F_x on ``top``;
    (c) like (b) with mu(v) (Eq. 4) on every contact and the wall; v0 is
    ``cfg.v0_margin`` times the largest |v_top| of run (a) over every step
    (``fix ave/histo``'s running max, not only the recorded steps: mu(v) is
    evaluated every step) unless
    ``cfg.v0`` is given, v_ss = v0 unless
    ``cfg.v_ss`` is given.

    Parameters
    ----------
    cfg : DynamicsConfig
    out : str
        Output folder: ``perturb_{a,b,c}.h5`` and ``perturb/equilibrium.*``.
    comm : mpi4py communicator, optional
    quiet : bool
    log : str
    runs : str
        Subset of ``'abc'`` (run (a) is also done when ``cfg.v0`` is None
        and (c) is asked for: it measures v0).
    overwrite : bool
        Replace earlier perturb results in ``out`` (default: refuse).
    resume : bool
        Continue an interrupted perturb in ``out`` with the same
        configuration and data file (compared with the run files'
        attributes, ``datafile_sha256`` included): its equilibrium and the
        runs finished (status ``'complete'``) are kept, the others are run
        again from the same equilibrium data file, so the results are
        bitwise those of an uninterrupted perturb. A folder without a run
        file starts anew.

    Returns
    -------
    dict
        ``{'a': SeriesResult, 'b': ..., 'c': ...}`` for the runs done;
        ``extra`` holds ``residual`` (of the equilibrium), ``v0`` and ``v_ss``.

    Raises
    ------
    ConfigError
        Unknown run letters, ``out`` not a writable folder or holding
        perturb results (unless ``overwrite`` or ``resume``), a bad data
        file, or a ``resume`` whose configuration or data file differs.
    """
    if not isinstance(cfg, DynamicsConfig):
        raise ConfigError(f"perturb needs a DynamicsConfig, got {type(cfg).__name__}")
    runs = check_runs(runs)
    results = {}
    with Engine(comm=comm, log=log) as eng:
        cfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "perturb")
        dim = eng.dimension
        prepare_out(eng, out, equilibrium_files("perturb")
                    + [f"perturb_{k}.h5" for k in PERTURB_RUNS], overwrite or resume,
                    "perturb")

        def resume_state():
            sha_ = start_sha256(cfg.datafile)
            r_, done_ = _perturb_resume_state(cfg, out, sha_) if resume else (None, {})
            return sha_, r_, done_

        sha, r, done = on_rank0(eng.comm, resume_state)
        if r is None:
            prefix, r = _equilibrium_for(eng, cfg, out, "perturb", quiet)
        else:
            prefix = os.path.join(out, "perturb", "equilibrium")
        data = prefix + ".data"
        v0 = cfg.v0
        base = {"equilibrium": data, "equilibrium_residual": r, "stage": "perturb",
                "datafile_sha256": str(sha), **dtinfo}
        if "a" in runs or v0 is None:
            res = done.get("a") or undamped_run(
                eng, cfg, data, os.path.join(out, "perturb_a.h5"), {"a": 0.0, "muv": 0},
                "perturb (a)", quiet, attrs=dict(base, run="a"), dim=dim)
            results["a"] = res
            if v0 is None:              # max |v_top| over every step, not only records
                v0 = float(cfg.v0_margin) * float(res.extra["v_top_max"])
                if not v0 > 0:
                    v0 = np.finfo(float).tiny
        vss = cfg.v_ss if cfg.v_ss is not None else v0
        if "b" in runs:
            results["b"] = done.get("b") or undamped_run(
                eng, cfg, data, os.path.join(out, "perturb_b.h5"),
                {"a": float(cfg.a), "wp": float(cfg.omega_p), "muv": 0}, "perturb (b)", quiet,
                attrs=dict(base, run="b"), dim=dim)
        if "c" in runs:
            results["c"] = done.get("c") or undamped_run(
                eng, cfg, data, os.path.join(out, "perturb_c.h5"),
                {"a": float(cfg.a), "wp": float(cfg.omega_p), "muv": 1, "v0": float(v0),
                 "vss": float(vss), "B": float(cfg.B), "w": float(cfg.w),
                 "muss": float(cfg.mu_ss)}, "perturb (c)", quiet,
                attrs=dict(base, run="c", v0=v0, v_ss=vss,
                           **({"v0_margin": cfg.v0_margin} if cfg.v0 is None else {})),
                dim=dim)
        for res in results.values():
            res.extra.update(residual=r, v0=v0, v_ss=vss, timestep=dict(dtinfo))
    return results


def instability(cfg, out, comm=None, quiet=False, log="none", overwrite=False,
                allow_stable=True):
    """Undamped run from the equilibrium at F_x > F_x^c until D(t) saturates.

    Stops when D exceeds ``cfg.d_sat`` or at ``cfg.t_max``. Also analyses the
    starting equilibrium (predicted growth rate max Im sqrt(lambda), Eq. 6)
    and fits the measured rate of D ~ exp(2 g t).

    Parameters
    ----------
    cfg : DynamicsConfig
    out : str
        Output folder: ``instability.h5`` and ``instability/equilibrium.*``.
    comm : mpi4py communicator, optional
    quiet : bool
    log : str
    overwrite : bool
        Replace earlier instability results in ``out`` (default: refuse).
    allow_stable : bool
        Run also from an equilibrium without a certified complex pair (D
        then stays at the noise level). False: refuse it
        (:class:`StableStartError`, the equilibrium files are removed).

    Returns
    -------
    SeriesResult
        ``extra``: ``predicted_growth_rate``, ``measured_growth_rate``,
        ``complex_pair``, ``decision``, ``residual``, ``saturated``. The
        measured rate is the fit of
        :func:`~remote_trigger.analysis.dynamics.series.growth_fit` below
        ``d_sat / 100`` (NaN with fewer than 5 records there: a ``d_sat``
        within ~5 decades of the noise level leaves none); it is not in
        ``instability.h5``, which holds the series.

    Raises
    ------
    ConfigError
        ``out`` not a writable folder or holding instability results, a bad
        data file.
    StableStartError
        The equilibrium has no certified complex pair and ``allow_stable``
        is False.
    """
    if not isinstance(cfg, DynamicsConfig):
        raise ConfigError(f"instability needs a DynamicsConfig, got {type(cfg).__name__}")
    with Engine(comm=comm, log=log) as eng:
        cfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "instability")
        dim = eng.dimension
        prepare_out(eng, out, ["instability.h5"] + equilibrium_files("instability"),
                    overwrite, "instability")
        prefix, r = _equilibrium_for(eng, cfg, out, "instability", quiet)
        st = decide_on_rank0(eng, prefix + ".dump")
        if not st.complex_pair and not allow_stable:
            if eng.rank == 0:
                for f in equilibrium_files("instability"):
                    os.remove(os.path.join(out, f))
                try:
                    os.rmdir(os.path.join(out, "instability"))
                except OSError:
                    pass
            eng.comm.Barrier()
            what = ("every eigenvalue certified real" if st.decision is Decision.REAL else
                    f"the complex-pair test is {st.decision.label}")
            raise StableStartError(
                f"the equilibrium at F_x = {cfg.F_x!r} is linearly stable "
                f"({what}, margin {st.confidence:.3g}): D(t) would stay at the noise level "
                f"and there is no growth rate to measure; start from a state above F_x^c "
                f"(a ramp step at or after the first complex one) or use perturb "
                f"(--allow-stable runs it anyway; nothing was written)")
        res = undamped_run(
            eng, cfg, prefix + ".data", os.path.join(out, "instability.h5"),
            {"a": 0.0, "muv": 0}, "instability", quiet,
            stop=lambda o: o["D"][-1] > cfg.d_sat,
            attrs={"stage": "instability", "equilibrium": prefix + ".data",
                   "equilibrium_residual": r, "predicted_growth_rate": st.growth_rate,
                   "complex_pair": st.complex_pair, **dtinfo}, dim=dim)
        res.extra.update(predicted_growth_rate=st.growth_rate, complex_pair=st.complex_pair,
                         decision=st.decision,
                         residual=r, saturated=bool(res.D[-1] > cfg.d_sat),
                         timestep=dict(dtinfo),
                         measured_growth_rate=growth_fit(res.t, res.D, hi=cfg.d_sat / 1e2))
    return res
