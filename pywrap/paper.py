"""``remote-trigger paper``: the paper end to end, with figures and a report.

One command reproduces Charan, Pomyalov & Procaccia, *Generic Mechanism for
Remote Triggering of Earthquakes*, on the default scene (N = 100, the
paper's parameters; MODEL.md) and writes everything under one folder
(``--out``, default ``demo-out``); docs/paper.md describes it in full.

Steps (each a stage of :mod:`remote_trigger.pywrap.stages`):

1. ``generate`` a seeded packing and ``relax`` it (default protocol of the
   driver); packing fraction and residual go to the report.
2. ``ramp`` F_x for mu and mu_low from the same relaxed packing, with the
   eigenvalues of M^-1 K at every equilibrium and F_x^c by bisection; then a
   short *continuation* above F_x^c (:func:`continue_ramp`) so that Fig. 3
   shows the pair after its birth and Fig. 4 starts from an equilibrium.
3. Fig. 4: ``instability`` at F_x = fig4_ratio * F_x^c(mu).
4. Fig. 5: ``perturb`` (a, b, c) at F_x = fig5_ratio * F_x^c(mu).
5. The normal form (``remote_trigger.analysis.normal_form``).
6. Figures (:mod:`.figures`) and ``report.md`` (:mod:`.report`), both made
   from the files alone.

With two or more MPI ranks the independent stages run side by side (task
parallelism: ranks split into two groups; the two ramps, then the
instability run + normal form against the perturbation runs); within a
group LAMMPS decomposes the domain as usual.
"""
import json
import math
import os
import shutil
import sys
import time

import numpy as np

from .config import ConfigError
from .paper_config import PaperConfig, PAPER, build_config

#: files and folders the job writes under --out (removed when it is re-run there)
OUTPUTS = ("paper.json", "packing.data", "relax.h5", "relax", "instability.h5", "instability",
           "perturb_a.h5", "perturb_b.h5", "perturb_c.h5", "perturb", "normal_form.h5",
           "report.md", "report.json", "logs")
OUTPUT_GLOBS = ("ramp_mu", "fig")
MANIFEST = "paper.json"


def ramp_dir(out, mu):
    """Folder of the ramp at friction ``mu``: ``out/ramp_mu<mu>``."""
    return os.path.join(out, f"ramp_mu{mu:g}")


# --------------------------------------------------------------------------- output folder
def prepare_out(out):
    """Make ``out`` ready for a new run (rank 0 only).

    An empty or missing folder is used as is. A folder that holds a previous
    run of this job (``paper.json``) has exactly the outputs of that job
    removed (:data:`OUTPUTS`, ``ramp_mu*``, ``fig*.png``); anything else in
    it is left alone. A non-empty folder without ``paper.json`` is refused.

    Raises
    ------
    ConfigError
        If ``out`` is a file, or a non-empty folder not written by this job.
    """
    if os.path.exists(out) and not os.path.isdir(out):
        raise ConfigError(f"--out must be a folder, got a file: out = {out!r}")
    os.makedirs(out, exist_ok=True)
    entries = os.listdir(out)
    if not entries:
        return
    if MANIFEST not in entries:
        raise ConfigError(f"output folder {out!r} is not empty and was not written by "
                          f"`remote-trigger paper` (no {MANIFEST}); choose another --out")
    for name in entries:
        path = os.path.join(out, name)
        ours = name in OUTPUTS or any(name.startswith(g) for g in OUTPUT_GLOBS)
        if name.startswith("fig") and not name.endswith(".png"):
            ours = False
        if not ours:
            continue
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        else:
            os.remove(path)


def write_json(path, data):
    """Write JSON atomically (temporary file + rename)."""
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as fh:
        json.dump(data, fh, indent=1, sort_keys=True, default=_json_default)
    os.replace(tmp, path)


def _json_default(obj):
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


class _Clock:
    """Wall-clock phases and brief progress lines (printed by a group leader)."""

    def __init__(self, speak):
        self.t0 = time.perf_counter()
        self.speak = speak
        self.phases = {}

    def say(self, msg):
        if self.speak:
            print(f"[paper {time.perf_counter() - self.t0:7.1f} s] {msg}", flush=True)

    def phase(self, name, seconds):
        self.phases[name] = float(seconds)


# --------------------------------------------------------------------------- stages
def model_fields(cfg):
    """The model parameters every stage configuration shares."""
    return {"k_n": float(cfg.k_n), "k_t": float(cfg.k_t), "F_y": float(cfg.F_y),
            "dt": float(cfg.dt)}


def relax_config(cfg, datafile):
    """RelaxConfig of the relaxation: the model, mu, F_x = 0 and ``cfg.relax``."""
    from .config import RelaxConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(cfg.mu), F_x=0.0)
    d.update(cfg.relax)
    return RelaxConfig.from_dict(d)


def ramp_config(cfg, datafile, mu):
    """RampConfig of the ramp at friction ``mu`` (from F_x = 0)."""
    from .config import RampConfig, RelaxConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(mu), F_x=0.0,
             dF_x=float(cfg.dF_x), tol=float(cfg.tol), F_x_max=float(cfg.F_x_max))
    ramp_fields = set(RampConfig.__dataclass_fields__) - {"settle_steps", "g_settle",
                                                           "mu_settle", "top_gap"}
    d.update({k: v for k, v in cfg.relax.items() if k in ramp_fields
              and k in RelaxConfig.__dataclass_fields__})
    return RampConfig.from_dict(d)


def dynamics_config(cfg, datafile, F_x, t_max, **extra):
    """DynamicsConfig of an undamped run at F_x with friction ``cfg.mu``."""
    from .config import DynamicsConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(cfg.mu), F_x=float(F_x),
             t_max=float(t_max), record_every=int(cfg.record_every), a=float(cfg.a),
             omega_p=float(cfg.omega_p), B=float(cfg.B), w=float(cfg.w),
             mu_ss=float(cfg.mu_ss), d_sat=float(cfg.d_sat))
    d.update(extra)
    return DynamicsConfig.from_dict(d)


def analyze_on_root(comm, dump):
    """Eigen-analysis of an equilibrium dump on rank 0 of ``comm``, broadcast.

    Returns
    -------
    StabilityResult
    """
    from .stability import analyze_dump

    res, err = None, None
    if comm.Get_rank() == 0:
        try:
            res = analyze_dump(dump)
        except Exception as exc:  # noqa: BLE001 - re-raised on all ranks
            err = f"{type(exc).__name__}: {exc}"
    res, err = comm.bcast((res, err), root=0)
    if err:
        raise RuntimeError(f"analysis of {dump} failed: {err}")
    return res


def continue_ramp(rcfg, start_file, loads, folder, comm):
    """Equilibria above F_x^c: the continuation of the ramp for Figs. 3 and 4.

    Each load starts from the previous equilibrium (the first from
    ``start_file``), is equilibrated exactly as a ramp step (``in.ramp_step``
    scene, Newton first, damped dynamics if needed), written to
    ``folder/ext_NN.*`` and analysed. Stops at the first load without an
    equilibrium.

    Parameters
    ----------
    rcfg : RampConfig
        Model and friction of the ramp.
    start_file : str
        Data file of an equilibrium just above F_x^c.
    loads : sequence of float
        Increasing loads F_x.
    folder : str
        Output folder (created).
    comm : mpi4py communicator

    Returns
    -------
    list of dict
        One per equilibrium reached: ``F_x``, ``residual``, ``complex``,
        ``growth_rate``, ``confidence``, ``eigenvalues``, ``datafile``.
    """
    from .engine import Engine
    from . import equilibrium as eq
    from .stages import load_relax_scene, save_equilibrium

    if comm.Get_rank() == 0:
        os.makedirs(folder, exist_ok=True)
    comm.Barrier()
    rows = []
    start = start_file
    with Engine(comm=comm) as eng:
        for k, F in enumerate(loads):
            prefix = os.path.join(folder, f"ext_{k:02d}")
            load_relax_scene(eng, rcfg, start, F, deck="in.ramp_step")
            try:
                r, _, _ = eq.equilibrate(eng, rcfg, F, newton_first=True)
            except eq.NoEquilibriumError as exc:
                rows.append({"F_x": float(F), "error": str(exc)})
                break
            save_equilibrium(eng, rcfg, F, prefix)
            res = analyze_on_root(comm, prefix + ".dump")
            rows.append({"F_x": float(F), "residual": float(r),
                         "complex": bool(res.complex_pair),
                         "growth_rate": float(res.growth_rate),
                         "confidence": float(getattr(res, "confidence", float("nan"))),
                         "eigenvalues": np.asarray(res.eigenvalues, complex),
                         "datafile": prefix + ".data"})
            start = prefix + ".data"
    if comm.Get_rank() == 0:
        from .results import write_atomic

        ok = [r for r in rows if "error" not in r]
        ds = {"F_x": np.array([r["F_x"] for r in ok], float),
              "residual": np.array([r["residual"] for r in ok], float),
              "complex": np.array([float(r["complex"]) for r in ok]),
              "growth_rate": np.array([r["growth_rate"] for r in ok], float),
              "confidence": np.array([r["confidence"] for r in ok], float),
              "datafile": np.array([r["datafile"] for r in ok], dtype=object)}
        for k, r in enumerate(ok):
            ds[f"eigenvalues/ext_{k:02d}"] = r["eigenvalues"]
        err = [r["error"] for r in rows if "error" in r]
        write_atomic(os.path.join(folder, "..", "extend.h5"),
                     dict(rcfg.to_attrs(), stage="extend", status="complete",
                          message=err[0] if err else ""), ds)
    comm.Barrier()
    return rows


def extension_loads(F_lo, F_hi, F_c, cfg, main):
    """Loads of the continuation above F_x^c.

    ``extend_steps`` loads evenly spaced from F_hi (first unstable ramp step)
    to extend_factor * F_c; for the main friction also exactly
    fig4_ratio * F_c (the start of Fig. 4) and, if larger, up to it.
    """
    top = cfg.extend_factor * F_c
    F4 = cfg.fig4_ratio * F_c
    if main:
        top = max(top, F4)
    loads = list(np.linspace(F_hi, top, cfg.extend_steps + 1)[1:])
    if main:
        loads.append(F4)
    loads = sorted(set(round(float(F), 15) for F in loads if F > F_hi))
    return loads


def run_ramp(cfg, out, mu, relaxed, comm, clock, main):
    """Ramp at friction ``mu`` plus its continuation; returns a summary dict."""
    from . import stages

    rcfg = ramp_config(cfg, relaxed, mu)
    folder = ramp_dir(out, mu)
    t0 = time.perf_counter()
    clock.say(f"ramp mu = {mu:g}: dF_x = {cfg.dF_x:g}, bisection to {cfg.tol:g}")
    res = stages.ramp(rcfg, folder, comm=comm, quiet=True)
    t_ramp = time.perf_counter() - t0
    summ = {"mu": float(mu), "status": res.status, "message": res.message,
            "F_x_c_low": res.F_x_c_low, "F_x_c_high": res.F_x_c_high,
            "n_steps": int(len(res.F_x)), "n_bisection": int(len(res.bisection_F_x)),
            "wall_ramp": t_ramp, "h5": res.h5, "extension": []}
    if res.status != "complete":
        clock.say(f"ramp mu = {mu:g}: {res.status} ({res.message})")
        return summ
    clock.say(f"ramp mu = {mu:g}: F_x^c in [{res.F_x_c_low:.7g}, {res.F_x_c_high:.7g}] "
              f"({len(res.F_x)} steps + {len(res.bisection_F_x)} bisections, "
              f"{t_ramp:.0f} s)")
    F_c = 0.5 * (res.F_x_c_low + res.F_x_c_high)
    first_complex = int(np.flatnonzero(res.complex_pair)[0])
    start = os.path.join(folder, "ramp", f"step_{first_complex:05d}.data")
    loads = extension_loads(res.F_x_c_low, float(res.F_x[first_complex]), F_c, cfg, main)
    t1 = time.perf_counter()
    rows = continue_ramp(rcfg, start, loads, os.path.join(folder, "extend"), comm)
    summ["wall_extend"] = time.perf_counter() - t1
    summ["extension"] = [{k: v for k, v in r.items() if k != "eigenvalues"} for r in rows]
    return summ


def run_instability(cfg, out, F_c, ext_rows, ramp_summary, comm, clock):
    """Fig. 4: the undamped run at fig4_ratio * F_x^c from its equilibrium."""
    from . import stages

    F4 = cfg.fig4_ratio * F_c
    ok = [r for r in ext_rows if "error" not in r]
    match = [r for r in ok if abs(r["F_x"] - F4) <= 1e-12 * max(1.0, F4)]
    if match:
        start, g = match[0]["datafile"], match[0]["growth_rate"]
    else:   # continuation did not reach F4: start from the first unstable ramp step
        folder = ramp_dir(out, cfg.mu)
        start = ok[-1]["datafile"] if ok else None
        if start is None:
            with_c = os.path.join(folder, "ramp")
            steps = sorted(f for f in os.listdir(with_c) if f.startswith("step_")
                           and f.endswith(".data"))
            start = os.path.join(with_c, steps[-1])
        g = ok[-1]["growth_rate"] if ok else 0.0
    t_max = cfg.t_instability
    if g > 0:
        t_max = min(t_max, cfg.instability_span / g)
    dcfg = dynamics_config(cfg, start, F4, t_max, a=0.0)
    clock.say(f"Fig. 4: undamped run at F_x = {F4:.6g} = {cfg.fig4_ratio:.4g} F_x^c, "
              f"predicted growth rate {g:.4g}, t_max = {t_max:.4g}")
    t0 = time.perf_counter()
    res = stages.instability(dcfg, out, comm=comm, quiet=True)
    wall = time.perf_counter() - t0
    e = res.extra
    from .report import growth_window, noise_level

    _, g_meas = growth_window(res.t, res.D, noise_level(res.t, res.D))
    clock.say(f"Fig. 4: D from {res.D[1]:.2e} to {res.D.max():.2e} in t = {res.t[-1]:.4g}; "
              f"growth rate measured {g_meas:.4g}, predicted "
              f"{e['predicted_growth_rate']:.4g} ({wall:.0f} s)")
    return {"F_x": F4, "t_max": t_max, "start": start, "wall": wall,
            "predicted_growth_rate": float(e["predicted_growth_rate"]),
            "measured_growth_rate": float(g_meas),
            "stage_growth_fit": float(e["measured_growth_rate"]),
            "saturated": bool(e["saturated"]), "h5": res.h5}


def run_perturb(cfg, out, F_c, comm, clock):
    """Fig. 5: the three undamped runs at fig5_ratio * F_x^c, from the nearest lower step."""
    import h5py
    from . import stages

    F5 = cfg.fig5_ratio * F_c
    folder = ramp_dir(out, cfg.mu)
    start = None
    if comm.Get_rank() == 0:
        with h5py.File(os.path.join(folder, "ramp.h5"), "r") as fh:
            F = fh["steps/F_x"][()]
            files = [s.decode() if isinstance(s, bytes) else str(s)
                     for s in fh["steps/datafile"][()]]
        below = np.flatnonzero(F <= F5)
        start = files[int(below[-1])] if below.size else files[0]
    start = comm.bcast(start, root=0)
    dcfg = dynamics_config(cfg, start, F5, cfg.t_perturb)
    clock.say(f"Fig. 5: runs (a), (b), (c) at F_x = {F5:.6g} = {cfg.fig5_ratio:.4g} F_x^c, "
              f"t = {cfg.t_perturb:g} each")
    t0 = time.perf_counter()
    res = stages.perturb(dcfg, out, comm=comm, quiet=True)
    wall = time.perf_counter() - t0
    eqres = analyze_on_root(comm, os.path.join(out, "perturb", "equilibrium.dump"))
    c = res.get("c")
    clock.say(f"Fig. 5: max D (a) {res['a'].D.max():.2e}, (b) {res['b'].D.max():.2e}, "
              f"(c) {c.D.max():.2e}; min mu (c) {c.mu.min():.4g} ({wall:.0f} s)")
    return {"F_x": F5, "start": start, "wall": wall,
            "equilibrium_complex": bool(eqres.complex_pair),
            "equilibrium_growth_rate": float(eqres.growth_rate),
            "v0": float(c.extra.get("v0", float("nan"))),
            "v_ss": float(c.extra.get("v_ss", float("nan")))}


def run_normal_form(cfg, out, clock):
    """Normal form (MODEL.md section 8): A vs eps for several tau; HDF5 + PNG."""
    from remote_trigger.analysis import normal_form as nf
    from .results import write_atomic

    t0 = time.perf_counter()
    eps = np.array(sorted(cfg.nf_eps, reverse=True), float)
    taus = np.array(cfg.nf_tau, float)
    amp = nf.amplitude_scan(cfg.nf_delta, eps, taus)
    est = np.array([[nf.damped_estimate(cfg.nf_delta, e, t) for e in eps] for t in taus])
    td = np.array([nf.beat_time(cfg.nf_delta, e) for e in eps])
    write_atomic(os.path.join(out, "normal_form.h5"),
                 {"delta": cfg.nf_delta, "source": "paper Eqs. 9-17; "
                  "remote_trigger.analysis.normal_form"},
                 {"eps": eps, "tau": taus, "amplitude": amp, "estimate": est,
                  "beat_time": td})
    nf.plot_amplitude(eps, taus, amp, est, cfg.nf_delta,
                      os.path.join(out, "fig_normal_form.png"))
    wall = time.perf_counter() - t0
    clock.say(f"normal form: A sqrt(eps) = {amp[np.isinf(taus)][0, -1] * math.sqrt(eps[-1]):.4g}"
              f" at eps = {eps[-1]:g} (no damping) ({wall:.0f} s)"
              if np.any(np.isinf(taus)) else f"normal form done ({wall:.0f} s)")
    return {"wall": wall}


# --------------------------------------------------------------------------- the job
def _guarded(fn):
    """Run fn(); return the exception it raised (None if none), so that all
    ranks can learn of it before any of them raises (no rank left waiting)."""
    try:
        fn()
    except Exception as exc:  # noqa: BLE001 - re-raised by the caller on every rank
        return exc
    return None


def run_paper(cfg, out, comm=None, speak=True):
    """Run the whole job; all ranks of ``comm`` call it.

    Parameters
    ----------
    cfg : PaperConfig
    out : str
        Output folder (see :func:`prepare_out`).
    comm : mpi4py communicator, optional
        Default ``MPI.COMM_WORLD``. With >= 2 ranks the independent stages
        run in two groups at once.
    speak : bool
        Print progress lines.

    Returns
    -------
    str
        Path of ``report.md`` (on every rank).
    """
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    rank, size = comm.Get_rank(), comm.Get_size()
    out = os.path.abspath(out)
    err = None
    if rank == 0:
        try:
            prepare_out(out)
            write_json(os.path.join(out, MANIFEST), {
                "job": "remote-trigger paper", "status": "running",
                "config": cfg.to_dict(), "n_ranks": size, "argv": sys.argv})
        except (ConfigError, OSError) as exc:
            err = str(exc)
    err = comm.bcast(err, root=0)
    if err:
        raise ConfigError(err)
    if size >= 2:
        color = rank % 2
        group = comm.Split(color, rank)
    else:
        color, group = 0, comm
    leader = group.Get_rank() == 0
    clock = _Clock(speak and leader)
    t_job = time.perf_counter()
    summary = {"config": cfg.to_dict(), "n_ranks": size, "paper": PAPER,
               "task_parallel": size >= 2}

    # 1. packing + relaxation: on world rank 0 alone, so that the packing does not
    #    depend on the number of ranks (a domain-decomposed compaction is not
    #    bitwise equal to a serial one, and the compaction amplifies round-off)
    from .packing import generate, write_data
    from . import stages

    wclock = _Clock(speak and rank == 0)
    datafile = os.path.join(out, "packing.data")
    t0 = time.perf_counter()
    rel, err = None, None
    if rank == 0:
        wclock.say(f"relax: N = {cfg.n}, seed {cfg.seed}")
        solo = comm.Split(0, 0) if size > 1 else comm
        try:
            write_data(generate(cfg.n, seed=cfg.seed, phi=cfg.phi), datafile)
            rel = stages.relax(relax_config(cfg, datafile), out, comm=solo, quiet=True)
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank below
            err = exc
        finally:
            if size > 1:
                solo.Free()
    elif size > 1:
        comm.Split(MPI.UNDEFINED, rank)
    if size > 1:
        rel, err = comm.bcast((rel, err), root=0)
    if err is not None:
        raise err
    wclock.phase("relax", time.perf_counter() - t0)
    wclock.say(f"relax: phi = {rel.packing_fraction:.4f}, residual {rel.residual:.2e} "
               f"({time.perf_counter() - t0:.0f} s)")
    summary["relax"] = {"residual": rel.residual, "packing_fraction": rel.packing_fraction,
                        "converged": rel.converged, "wall": rel.wall_time,
                        "datafile": rel.datafile, "protocol": getattr(rel, "protocol", "")}

    # 2. ramps (one per group when task-parallel)
    mus = (cfg.mu, cfg.mu_low)
    ramps = {}

    def do_ramps():
        for k, mu in enumerate(mus):
            if size >= 2 and k % 2 != color:
                continue
            t0 = time.perf_counter()
            ramps[k] = run_ramp(cfg, out, mu, rel.datafile, group, clock, main=(k == 0))
            clock.phase(f"ramp_mu{mu:g}", time.perf_counter() - t0)

    err = _guarded(do_ramps)
    if size >= 2:
        merged, errs = {}, []
        for part, e in comm.allgather((ramps if leader else {}, err)):
            merged.update(part)
            errs.append(e)
        ramps = merged
        err = next((e for e in errs if e is not None), None)
    if err is not None:
        raise err
    summary["ramps"] = [ramps[0], ramps[1]]
    main = ramps[0]
    F_c = (0.5 * (main["F_x_c_low"] + main["F_x_c_high"])
           if main["status"] == "complete" else None)

    # 3.-5. dynamics and normal form
    jobs = {}
    if F_c is None:
        wclock.say(f"no F_x^c for mu = {cfg.mu:g} ({main['status']}): Figs. 4 and 5 skipped")

    def do_jobs():
        if F_c is not None:
            if color == 0:
                t0 = time.perf_counter()
                jobs["instability"] = run_instability(cfg, out, F_c, main["extension"], main,
                                                      group, clock)
                clock.phase("instability", time.perf_counter() - t0)
            if color == (1 if size >= 2 else 0):
                t0 = time.perf_counter()
                jobs["perturb"] = run_perturb(cfg, out, F_c, group, clock)
                clock.phase("perturb", time.perf_counter() - t0)
        if color == 0 and leader:
            t0 = time.perf_counter()
            jobs["normal_form"] = run_normal_form(cfg, out, clock)
            clock.phase("normal_form", time.perf_counter() - t0)

    err = _guarded(do_jobs)
    phases = dict(wclock.phases, **clock.phases)
    if size >= 2:
        merged, ph, errs = {}, {}, []
        for part, p, e in comm.allgather((jobs if leader else {}, phases if leader else {},
                                          err)):
            merged.update(part)
            ph.update(p)
            errs.append(e)
        jobs, phases = merged, ph
        err = next((e for e in errs if e is not None), None)
    if err is not None:
        raise err
    summary.update(jobs)

    # 6. figures and report (rank 0)
    path = os.path.join(out, "report.md")
    if rank == 0:
        from . import figures, report

        t0 = time.perf_counter()
        figs = figures.make_all(out, summary)
        phases["figures"] = time.perf_counter() - t0
        phases["total"] = time.perf_counter() - t_job
        summary["phases"] = phases
        summary["figures"] = figs
        summary["status"] = "complete"
        write_json(os.path.join(out, MANIFEST), dict(summary, job="remote-trigger paper",
                                                     argv=sys.argv))
        report.write_report(out, summary)
        wclock.say(f"done in {phases['total']:.0f} s")
    if size >= 2:
        group.Free()
    comm.Barrier()
    return path


# --------------------------------------------------------------------------- command line
_FLAG_HELP = {
    "n": "number of disks (100)", "seed": "packing seed (1)", "mu": "friction of the main "
    "ramp and Figs. 4-5 (1)", "mu_low": "friction of the second ramp (0.8)",
    "dF_x": "ramp step (2.5e-4)", "tol": "bisection tolerance on F_x^c (1e-7)",
    "np": "MPI ranks: re-launch under the environment's mpirun (1)",
}


def register(subparsers):
    """Add the ``paper`` subcommand."""
    import argparse

    p = subparsers.add_parser(
        "paper", help="reproduce the paper end to end: HDF5, figures, report.md",
        description="Generate and relax the default packing, ramp F_x for mu and mu_low "
                    "with eigenvalues and F_x^c, run the instability (Fig. 4) and the "
                    "perturbation runs (Fig. 5), the normal form, and write PNG figures and "
                    "report.md under --out. Values: defaults < --quick < --config TOML < "
                    "flags. docs/paper.md describes everything.")
    p.add_argument("--out", default="demo-out", help="output folder (default demo-out)")
    p.add_argument("--config", metavar="TOML", help="TOML file with any of the keys below")
    p.add_argument("--quick", action="store_true", default=None,
                   help="small, fast variant (N = 40, coarse steps, short runs)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any configuration key (repeatable), e.g. --set nf_eps=[0.1,0.01]")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--resolved-config", help=argparse.SUPPRESS)
    for f in PaperConfig.names():
        if f in ("quick", "relax", "nf_eps", "nf_tau"):
            continue
        default = PaperConfig.__dataclass_fields__[f].default
        typ = int if isinstance(default, int) and not isinstance(default, bool) else float
        flags = [f"--{f}"] + ([f"--{f.replace('_', '-')}"] if "_" in f else [])
        p.add_argument(*flags, dest=f"opt_{f}", type=typ, metavar=typ.__name__.upper(),
                       help=_FLAG_HELP.get(f, f"see docs/paper.md ({default!r})"
                                           if default is not None else "see docs/paper.md"))
    p.set_defaults(func=main)


def _parse_set(items):
    out = {}
    for item in items:
        if "=" not in item:
            raise ConfigError(f"--set expects KEY=VALUE, got {item!r}")
        k, v = item.split("=", 1)
        k = k.strip()
        try:
            out[k] = json.loads(v)
        except json.JSONDecodeError:
            low = v.strip().lower()
            out[k] = {"true": True, "false": False, "inf": math.inf}.get(low, v)
    return out


def config_from_args(args):
    """PaperConfig from parsed arguments (defaults < quick < TOML < flags)."""
    if args.resolved_config:
        with open(args.resolved_config) as fh:
            d = json.load(fh)
        d["nf_tau"] = [math.inf if v is None else v for v in d.get("nf_tau", [])]
        return PaperConfig.from_dict(d)
    over = _parse_set(args.set)
    for f in PaperConfig.names():
        v = getattr(args, f"opt_{f}", None)
        if v is not None:
            over[f] = v
    return build_config(args.config, over, quick=bool(args.quick))


def _relaunch(cfg, args):
    """Run the job under ``mpirun -np cfg.np`` of this environment; returns its status."""
    import subprocess
    import tempfile

    here = os.path.dirname(sys.executable)
    mpirun = os.path.join(here, "mpirun")
    if not os.path.exists(mpirun):
        mpirun = shutil.which("mpirun")
    if not mpirun:
        raise ConfigError(f"np = {cfg.np} needs mpirun, found none next to {sys.executable} "
                          f"or on PATH; run `mpirun -np {cfg.np} remote-trigger paper` yourself")
    d = cfg.to_dict()
    d["nf_tau"] = [None if math.isinf(v) else v for v in d["nf_tau"]]
    fd, path = tempfile.mkstemp(prefix="paper-config-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(d, fh)
    cmd = [mpirun, "-np", str(cfg.np), sys.executable, "-m", "remote_trigger.pywrap.cli",
           "paper", "--out", args.out, "--resolved-config", path]
    if args.quiet:
        cmd.append("--quiet")
    env = dict(os.environ, REMOTE_TRIGGER_PAPER_CHILD="1")
    try:
        return subprocess.call(cmd, env=env)
    finally:
        os.unlink(path)


def main(args):
    """``remote-trigger paper``; returns the exit status."""
    cfg = config_from_args(args)
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if cfg.np > 1 and world.Get_size() == 1 and not os.environ.get(
            "REMOTE_TRIGGER_PAPER_CHILD"):
        return _relaunch(cfg, args)
    from .equilibrium import NoEquilibriumError

    try:
        path = run_paper(cfg, args.out, comm=world, speak=not args.quiet)
    except NoEquilibriumError as exc:
        if world.Get_rank() == 0:
            print(f"remote-trigger paper: {exc}", file=sys.stderr)
        return 3
    if world.Get_rank() == 0:
        print(f"report: {path}")
    return 0
