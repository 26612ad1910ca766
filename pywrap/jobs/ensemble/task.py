"""One task of ``remote-trigger ensemble``: everything measured on one packing
(:func:`run_packing`), run on a worker rank with its own LAMMPS instances on
``MPI.COMM_SELF``; the job that hands the packings out is
:mod:`remote_trigger.pywrap.jobs.ensemble.job`, the design docs/ensemble.md.

Per packing: generate (disks, or spheres with ``dim = 3``), relax with the
default protocol, ramp F_x at mu0 and at mu_ss mu0 (the ``ramp`` stage), the
onset numbers of each ramp (:mod:`.onset`); for disks also the I0 = 1
re-analysis with its continuation above a ramp's end (:func:`inertia_points`)
and the frictional relaxation at F_x = 0. Each finished stage is recorded in
the packing's ``progress.json``, so a killed packing resumes from it.
"""
import dataclasses
import json
import math
import os
import shutil
import time

import numpy as np

from remote_trigger.pywrap.jobs.ensemble.onset import (
    spectrum, read_ramp, bracket, onset_numbers, reanalyse, pair_shape)
from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.pywrap.runtime.jobfolder import resolved_path, stored_path

__all__ = ["PROGRESS", "run_packing", "run_ramp", "record_ramp", "ramp_frictions",
           "inertia_points", "task_path", "load_task"]


def _new_point(eng, rcfg, start_dump, F_x, prefix, I0, pairs="all"):
    """Equilibrium at F_x from the equilibrium of ``start_dump`` (a ramp step), analysed
    with I0; returns the point dict, or None without an equilibrium."""
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages import load_relax_scene, save_equilibrium

    load_relax_scene(eng, rcfg, start_dump[:-len(".dump")] + ".data", F_x, deck="in.ramp_step")
    try:
        eq.equilibrate(eng, rcfg, F_x, newton_first=True)
    except eq.NoEquilibriumError:
        return None
    save_equilibrium(eng, rcfg, F_x, prefix)
    s = spectrum(read_dump(prefix + ".dump", require_contacts=False, inertia_factor=I0),
                 pairs=pairs)
    s.pop("basis")
    return {"F_x": float(F_x), "decision": s["decision"], "growth": s["growth"],
            "dump": prefix + ".dump", "eigenvalues": s["eigenvalues"], "reason": s["reason"]}


def inertia_points(cfg, points, mu, I0, folder):
    """The ramp's equilibria under the convention I0, extended until F_x^c is bracketed.

    The ramp stops at its own first complex point (I0 = 1/2). Under another
    I0 the onset may lie above it: then the ramp is continued with the same
    step dF_x, or the adaptive step under I0 if ``cfg.dF_x_max`` is set
    (:func:`.ramp.adaptive_step`; new equilibria, each from the previous one,
    exactly as ramp steps) for at most ``inertia_extra_steps`` steps (default 0.5 F_x_max / dF_x),
    until a point is certified complex under I0. Inside the bracket the
    certified decision under I0 drives a bisection to ``tol``
    (:func:`.stages.next_bisection_point`, each point from the ``lo``
    equilibrium, as the ramp's).

    Parameters
    ----------
    cfg : EnsembleConfig
    points : list of dict
        :func:`read_ramp` of the ramp (I0 = 1/2).
    mu : float
        Friction of the ramp.
    I0 : float
    folder : str
        Where the new equilibria go (``I0_<I0>/``).

    Returns
    -------
    list of dict
        Every point (old and new), decisions and eigenvalues under I0, in
        increasing F_x; new ones have ``new`` = True.
    """
    from mpi4py import MPI
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.jobs.paper import ramp_config
    from remote_trigger.pywrap.stages.ramp import adaptive_step
    from remote_trigger.pywrap.stages import next_bisection_point

    pairs = _pairs(cfg)
    pts = reanalyse(points, I0, pairs)
    if not pts:
        return pts
    lo, hi = bracket(pts)
    steps = [p for p in pts if p["F_x"] in {q["F_x"] for q in points}]
    if math.isfinite(hi) and (not math.isfinite(lo) or hi - lo <= cfg.tol):
        return pts
    rcfg = ramp_config(cfg, points[0]["dump"][:-len(".dump")] + ".data", mu)
    os.makedirs(folder, exist_ok=True)
    with Engine(comm=MPI.COMM_SELF) as eng:
        last = max(steps, key=lambda p: p["F_x"])
        k = 0
        k_max = (cfg.inertia_extra_steps if cfg.inertia_extra_steps is not None
                 else int(0.5 * cfg.F_x_max / cfg.dF_x))
        while not math.isfinite(hi) and k < k_max:
            k += 1
            h = cfg.dF_x
            if cfg.dF_x_max is not None:
                # the predictor's second load at least half a step below (not a
                # bisection point next to the ramp's end)
                prev = max((p for p in pts if p["F_x"] < last["F_x"] - 0.5 * cfg.dF_x),
                           key=lambda p: p["F_x"], default=None)
                if prev is not None:
                    h = adaptive_step(cfg.dF_x, cfg.dF_x_max,
                                      *((p["F_x"], p["decision"], p["eigenvalues"])
                                        for p in (prev, last)))
            F = last["F_x"] + h
            p = _new_point(eng, rcfg, last["dump"], F, os.path.join(folder, f"ext_{k:04d}"),
                           I0, pairs)
            if p is None:
                break
            pts.append(dict(p, new=True))
            last = p
            lo, hi = bracket(pts)
        j = 0
        while math.isfinite(hi) and math.isfinite(lo):
            unknown = sorted(p["F_x"] for p in pts
                             if p["decision"] == Decision.UNDECIDED and lo < p["F_x"] < hi)
            mid, _ = next_bisection_point(lo, hi, unknown, cfg.tol)
            if mid is None:
                break
            start = max((p for p in pts if p["F_x"] == lo and p["decision"] == Decision.REAL),
                        key=lambda p: p["F_x"])
            p = _new_point(eng, rcfg, start["dump"], mid,
                           os.path.join(folder, f"bisect_{j:03d}"), I0, pairs)
            j += 1
            pts.append(dict(p, new=True) if p is not None else
                        {"F_x": mid, "decision": -1, "growth": math.nan, "dump": "",
                         "eigenvalues": np.zeros(0, complex), "new": True})
            lo, hi = bracket(pts)
    pts.sort(key=lambda p: p["F_x"])
    return pts


# --------------------------------------------------------------------------- one packing
def _relax(cfg, datafile, folder, protocol):
    """Relax ``datafile`` with ``protocol``; returns the RelaxResult."""
    from mpi4py import MPI
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.jobs.paper import relax_config

    rcfg = relax_config(cfg, datafile)
    if protocol == "frictional":
        extra = dict({"mu_settle": float(cfg.mu)}, **cfg.frictional_relax)
        rcfg = rcfg.replace(protocol="frictional", **extra)
    # the folder is the packing's own: a relaxation killed in an earlier
    # run of the job (--resume) left its files there
    return stages.relax(rcfg, folder, comm=MPI.COMM_SELF, quiet=True, overwrite=True)


def _ramp(cfg, datafile, mu, folder, resume=False, verdict_dir=None):
    """Ramp at friction ``mu`` from ``datafile`` (``resume``: continue the
    ramp.h5 a killed run left, bitwise as uninterrupted); returns the
    RampResult. Unless ``keep_equilibria`` (or the I0 re-analysis, which
    reads every point's dump), the ramp keeps only the equilibria it still
    needs while it runs (``RampConfig.keep_equilibria``). ``verdict_dir``:
    the sliced verdicts' folder (``stages.ramp``), shared by a packing's
    ramps."""
    from mpi4py import MPI
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.jobs.paper import ramp_config

    keep = bool(cfg.keep_equilibria or cfg.inertia_I0 is not None)
    rcfg = ramp_config(cfg, datafile, mu).replace(keep_equilibria=keep)
    return stages.ramp(rcfg, folder, comm=MPI.COMM_SELF, quiet=True, resume=resume,
                       verdict_dir=verdict_dir)


def _ramp_part(cfg, relaxed, mu, folder, resume=False, verdict_dir=None):
    """One ramp and the onset numbers under both conventions (dict, JSON-ready);
    ``folder``: the ramp's, inside the packing's folder; ``h5`` is stored
    relative to the packing's folder
    (:func:`~remote_trigger.pywrap.runtime.jobfolder.stored_path`);
    ``environment``: that of the process that ran the ramp (it may be another
    rank, or another machine, than the one that finishes the packing)."""
    from remote_trigger.pywrap.runtime.environment import environment

    res = _ramp(cfg, relaxed, mu, folder, resume, verdict_dir)
    part = {"mu": float(mu), "ramp_status": res.status, "message": res.message,
            "n_steps": int(len(res.F_x)), "n_bisection": int(len(res.bisection_F_x)),
            "tol_reached": bool(res.tol_reached),
            "h5": stored_path(os.path.dirname(os.path.abspath(folder)), res.h5),
            "environment": environment()}
    pts = read_ramp(res.h5)
    part["at_zero"] = ({"decision": pts[0]["decision"], "growth": pts[0]["growth"]}
                       if pts and pts[0]["F_x"] == 0.0 else None)
    o = onset_numbers(pts, cfg.dF_x, _pairs(cfg))
    part[f"I0_{cfg.I0_dynamics:g}"] = dict(o, **pair_shape(pts, o), n_new=0,
                                           tol_reached=bool(res.tol_reached))
    if cfg.inertia_I0 is not None and pts:
        I0 = float(cfg.inertia_I0)
        ifolder = os.path.join(folder, f"I0_{I0:g}")
        shutil.rmtree(ifolder, ignore_errors=True)     # a killed run's points
        ipts = inertia_points(cfg, pts, mu, I0, ifolder)
        o = onset_numbers(ipts, cfg.dF_x, _pairs(cfg))
        o.update(pair_shape(ipts, o, inertia_factor=I0),
                 n_new=sum(1 for p in ipts if p.get("new")),
                 tol_reached=bool(o["F_x_c_high"] - o["F_x_c_low"] <= cfg.tol))
        part[f"I0_{I0:g}"] = o
    return part


def _pairs(cfg):
    """The ensemble's soft-pair policy (``VerdictOptions.pairs``): its ``pairs``,
    'all' for an older configuration without one."""
    return getattr(cfg, "pairs", "all")


#: what :func:`.onset.pair_shape` measures of the pair's mode
SHAPE_KEYS = ("pair_pr", "pair_particles", "pair_longwave")


def _shape_missing(cfg, part):
    o = part.get(f"I0_{cfg.I0_dynamics:g}")
    return o is not None and "pair_longwave" not in o


def _with_shape(cfg, part, folder, onset=True):
    """The part with ``pair_pr``/``pair_particles``/``pair_longwave`` of its default
    convention (:func:`.onset.pair_shape`; NaN where the equilibria are gone,
    a value already recorded kept), and with ``onset`` its onset numbers
    recomputed from its ``ramp.h5`` (an older version took a negative real
    eigenvalue for the pair; a resumed packing's ramp part); without, the
    recorded ones are kept (a finished packing's). ``folder``: the packing's
    (``part["h5"]`` is relative to it,
    :func:`~remote_trigger.pywrap.runtime.jobfolder.stored_path`)."""
    key = f"I0_{cfg.I0_dynamics:g}"
    h5 = resolved_path(folder, part["h5"])
    if not os.path.isfile(h5):
        return dict(part, **{key: dict({k: math.nan for k in SHAPE_KEYS}, **part[key])})
    pts = read_ramp(h5)
    o = dict(part[key], **onset_numbers(pts, cfg.dF_x, _pairs(cfg))) if onset else dict(part[key])
    shape = {k: v for k, v in pair_shape(pts, o).items()
             if not (math.isnan(v) and math.isfinite(part[key].get(k, math.nan)))}
    return dict(part, **{key: dict(o, **shape)})


def add_missing_shape(cfg, result, folder):
    """Add the pair's shape to the ramp parts of a finished packing's ``result``
    that a version without it recorded (:func:`_with_shape`, in place; NaN
    where the ramp's equilibria are gone). Its onset numbers are left as
    recorded. ``folder``: the packing's folder.

    Returns
    -------
    added, measured : int
        Ramp parts completed, and among them those whose long-wave fraction
        could be measured (their equilibria still on disk).
    """
    ramps = (result.get("default") or {}).get("ramps") or {}
    key = f"I0_{cfg.I0_dynamics:g}"
    missing = [k for k, part in ramps.items() if part is not None
               and _shape_missing(cfg, part)]
    for k in missing:
        ramps[k] = _with_shape(cfg, ramps[k], folder, onset=False)
    return len(missing), sum(1 for k in missing
                             if math.isfinite(ramps[k][key].get("pair_longwave", math.nan)))


def _frictional_part(cfg, datafile, folder):
    """Frictional relaxation and its spectrum at F_x = 0 (dict, JSON-ready; with
    the ``environment`` of the process that ran it)."""
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.pywrap.runtime.environment import environment

    rel = _relax(cfg, datafile, folder, "frictional")
    s = spectrum(read_dump(rel.dumpfile, require_contacts=False), pairs=_pairs(cfg))
    return {"phi": rel.packing_fraction, "residual": rel.residual,
            "antisymmetry": rel.antisymmetry, "decision": s["decision"],
            "confidence": s["confidence"], "n_pairs": s["n_pairs"],
            "n_complex_eigenvalues": int(np.count_nonzero(s["eigenvalues"].imag != 0)),
            "growth": s["growth"], "environment": environment()}


def _failure(exc):
    return f"{type(exc).__name__}: {exc}"


def ramp_frictions(cfg):
    """A packing's ramps: (key, friction) for mu0 and mu_ss mu0, in that order."""
    return (("mu0", float(cfg.mu)), ("mu_ss", float(cfg.mu * cfg.mu_ss)))


def run_ramp(cfg, folder, key):
    """One ramp part of a relaxed packing, as a task of its own (``ramps_apart``
    of :func:`run_packing`); failures are returned, not raised.

    The ramp continues a ``ramp.h5`` a killed run left (bitwise as
    uninterrupted). Its sliced verdicts go to ``verdicts/<key>`` (the other
    ramp may run at the same time; a folder serves one scan). Nothing is
    recorded here: the job records the part with :func:`record_ramp`.

    Parameters
    ----------
    cfg : EnsembleConfig
    folder : str
        The packing's folder, its relaxation recorded in ``progress.json``.
    key : {'mu0', 'mu_ss'}

    Returns
    -------
    dict
        ``part`` (:func:`_ramp_part`; None after a failure), ``error`` (None
        or the reason; the packing's final call then runs the ramp again and
        records the error as the sequential path does), ``warnings`` (the
        distinct warnings raised meanwhile).
    """
    import warnings

    mu = dict(ramp_frictions(cfg))[key]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            relaxed = resolved_path(folder, load_progress(folder)["relax"]["datafile"])
            part = jsonable(_ramp_part(cfg, relaxed, mu, os.path.join(folder, f"ramp_{key}"),
                                        True, os.path.join(folder, VERDICTS, key)))
            err = None
        except Exception as exc:  # noqa: BLE001 - returned: the final call records it
            part, err = None, _failure(exc)
    return {"part": part, "error": err, "warnings": _warning_lines(caught)}


def record_ramp(folder, key, res):
    """Record a :func:`run_ramp` result in the packing's ``progress.json`` (the
    job's rank 0, one result at a time; its warnings kept, a failed part not
    recorded)."""
    from remote_trigger.pywrap.runtime.jobfolder import write_json

    done = load_progress(folder)
    done["warnings"] = _warning_lines((), done["warnings"] + res["warnings"])
    if res["part"] is not None:
        done["ramps"][key] = res["part"]
    write_json(os.path.join(folder, PROGRESS), done)


def run_packing(cfg, n, seed, folder, resume=False, ramps_apart=False):
    """Everything measured on one packing; failures are recorded, not raised.

    Each finished stage (the default relaxation, each friction's ramp part,
    the frictional part) is recorded in ``folder/progress.json`` (atomically)
    as soon as it is done.

    With ``ramps_apart`` the ramps not yet recorded are left to
    :func:`run_ramp` (one task each, so that a packing's two ramps run side
    by side on two ranks): the call ends after the relaxation and returns
    ``{"ramps_apart": [keys], "wall": s}``; once the job has recorded both
    parts (:func:`record_ramp`), a second call (``resume``, without
    ``ramps_apart``) finds them and finishes the packing.

    Parameters
    ----------
    cfg : EnsembleConfig
        Its ``dim`` chooses disks or spheres (:func:`.packing.generate`;
        the stages take the dimension from the data file).
    n, seed : int
    folder : str
        Work folder (created; its previous content is removed unless
        ``resume``).
    resume : bool
        Continue the packing a killed run left in ``folder``: the stages
        recorded in its ``progress.json`` are kept, an interrupted ramp
        continues from its ``ramp.h5`` (bitwise as uninterrupted), any other
        interrupted stage is redone. Without a ``progress.json`` the packing
        starts afresh.

    Returns
    -------
    dict
        ``default`` (relaxation summary and ``ramps``: one part per friction,
        see :func:`_ramp_part`), ``frictional`` (:func:`_frictional_part`;
        None when ``cfg.frictional`` is False, always for spheres),
        each with ``error`` (None or the reason), ``wall`` (s) and
        ``warnings`` (the distinct warnings raised meanwhile, recorded, not
        printed; for a resumed packing also those its kept stages recorded).
        ``wall`` is this call's time for the packing. ``environment``: the
        source commit, versions, BLAS kernels and CPU of the rank that ran
        this call (:func:`~remote_trigger.pywrap.runtime.environment.environment`);
        each stage records its own besides (``default["environment"]``: the
        relaxation's; each ramp part's and the frictional part's
        ``environment``), since a packing's stages may run on several ranks
        or, resumed, in several runs.
    """
    import warnings

    from remote_trigger.pywrap.runtime.environment import environment

    # the analysis warns per equilibrium (e.g. a history entry without overlap);
    # on a rank other than 0 that would print, so every rank records them in the
    # packing's result (tasks/<key>.json) instead
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = _run_packing(cfg.for_size(n), n, seed, folder, resume, caught, ramps_apart)
    if "ramps_apart" in result:
        return result
    result["warnings"] = _warning_lines(caught, result.pop("earlier_warnings"))
    result["environment"] = environment()
    return result


PROGRESS = "progress.json"
#: a packing's folder of sliced verdicts, shared by its two ramps (``stages.ramp``'s
#: ``verdict_dir``; read by ``ensemble --status``)
VERDICTS = "verdicts"
#: a packing's generated data file (its time: when its relaxation began; read
#: by ``ensemble --status``)
PACKING = "packing.data"


def _warning_lines(caught, earlier=()):
    return sorted(set(earlier) | {f"{w.category.__name__}: {w.message}" for w in caught})


def load_progress(folder):
    """The stages a killed run finished (``progress.json``), or None."""
    try:
        with open(os.path.join(folder, PROGRESS)) as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _run_packing(cfg, n, seed, folder, resume=False, caught=(), ramps_apart=False):
    """:func:`run_packing` without the warning capture."""
    from remote_trigger.pywrap.stages.packing import generate, write_data
    from remote_trigger.pywrap.runtime.environment import environment
    from remote_trigger.pywrap.runtime.jobfolder import write_json

    t0 = time.perf_counter()
    done = load_progress(folder) if resume else None
    if done is None:
        if os.path.isdir(folder):
            shutil.rmtree(folder)
        os.makedirs(folder)
        done = {"relax": None, "ramps": {}, "frictional": None, "warnings": []}
    earlier = list(done["warnings"])

    def record(stage, key, value):
        """A finished stage, on disk before the next one starts."""
        if key is None:
            done[stage] = jsonable(value)
        else:
            done[stage][key] = jsonable(value)
        done["warnings"] = _warning_lines(caught, earlier)
        write_json(os.path.join(folder, PROGRESS), done)

    datafile = os.path.join(folder, PACKING)
    result = {"n": n, "seed": seed, "default": {"error": None, "ramps": {}},
              "frictional": None, "earlier_warnings": earlier}
    d = result["default"]
    try:
        if not os.path.isfile(datafile):    # written atomically: complete if present
            write_data(generate(n, seed=seed, phi=cfg.phi, dim=cfg.dim), datafile)
        if done["relax"] is None:
            rel = _relax(cfg, datafile, os.path.join(folder, "default"),
                         "frictionless-then-friction")
            record("relax", None, {"phi": rel.packing_fraction, "residual": rel.residual,
                                   "antisymmetry": rel.antisymmetry,
                                   "clearance_rule": rel.clearance_rule,
                                   "datafile": stored_path(folder, rel.datafile),
                                   "environment": environment()})
        d.update({k: v for k, v in done["relax"].items() if k != "datafile"})
        # the ramps' sliced verdicts, in one folder: a killed scan resumes, and
        # the second ramp's F_x = 0 point takes the first's verdict where the
        # two K agree to the last bit (not where Newton left round-off
        # tangential displacements, whose stiffness depends on mu)
        vdir = os.path.join(folder, VERDICTS)
        apart = [key for key, _ in ramp_frictions(cfg) if key not in done["ramps"]]
        if ramps_apart and apart:
            return {"ramps_apart": apart, "wall": time.perf_counter() - t0}
        for key, mu in ramp_frictions(cfg):
            if key not in done["ramps"]:
                record("ramps", key, _ramp_part(
                    cfg, resolved_path(folder, done["relax"]["datafile"]), mu,
                    os.path.join(folder, f"ramp_{key}"), resume, vdir))
            elif _shape_missing(cfg, done["ramps"][key]):
                # a part recorded by a version without the pair's shape: added
                # from the ramp's equilibria while they are still on disk
                record("ramps", key, _with_shape(cfg, done["ramps"][key], folder))
            d["ramps"][key] = done["ramps"][key]
        shutil.rmtree(vdir, ignore_errors=True)
    except Exception as exc:  # noqa: BLE001 - recorded: one packing does not stop the others
        d["error"] = _failure(exc)
    if cfg.frictional:
        try:
            if not os.path.isfile(datafile):
                raise RuntimeError("no generated packing (see the default protocol's error)")
            if done["frictional"] is None:
                record("frictional", None, dict(_frictional_part(
                    cfg, datafile, os.path.join(folder, "frictional")), error=None))
            result["frictional"] = done["frictional"]
        except Exception as exc:  # noqa: BLE001 - recorded
            result["frictional"] = {"error": _failure(exc)}
    if not cfg.keep_equilibria and d["error"] is None:
        # (a packing that failed keeps them, so that its ramp can be continued:
        # docs/ensemble.md, "Parallelism, checkpoints, resume")
        for key in ("mu0", "mu_ss"):
            shutil.rmtree(os.path.join(folder, f"ramp_{key}", "ramp"), ignore_errors=True)
            if cfg.inertia_I0 is not None:
                shutil.rmtree(os.path.join(folder, f"ramp_{key}", f"I0_{cfg.inertia_I0:g}"),
                              ignore_errors=True)
    result["wall"] = time.perf_counter() - t0
    return result


def jsonable(x):
    """Result dict with NaN/inf kept as floats and numpy types as Python ones."""
    return json.loads(json.dumps(x, default=_np_default))


def _np_default(o):
    if isinstance(o, np.ndarray):
        if np.iscomplexobj(o):
            return [[float(v.real), float(v.imag)] for v in o]
        return o.tolist()
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.bool_,)):
        return bool(o)
    if dataclasses.is_dataclass(o) and not isinstance(o, type):    # e.g. a PowerLawFit
        return dataclasses.asdict(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def task_path(out, key):
    """``<out>/tasks/<key>.json``: the result file of packing ``key``."""
    return os.path.join(out, "tasks", key + ".json")


def saddle_escape_of(result):
    """Whether a packing's ramps escaped saddles: its result's ``saddle_escape``,
    or None for a result written before the option (its ramps had none)."""
    v = result.get("saddle_escape")
    return None if v is None else bool(v)


def clearance_rule_of(result):
    """The clearance test ('all' or 'local') a finished packing's relaxation used.

    A result without the record was relaxed before the test ``'local'``
    existed, by ``'all'``.
    """
    return (result.get("default") or {}).get("clearance_rule") or "all"


def packing_failed(result):
    """True if a finished packing's result records an error (of the default
    protocol or of the frictional part): what ``--retry-failed`` runs again."""
    return bool((result.get("default") or {}).get("error")
                or (result.get("frictional") or {}).get("error"))


def load_task(out, task):
    """The finished result of a packing, or None (missing, unreadable, other task)."""
    try:
        with open(task_path(out, task["key"])) as fh:
            d = json.load(fh)
    except (OSError, ValueError):
        return None
    if d.get("status") != "complete" or d.get("task") != task:
        return None
    return d["result"]
