"""The loads of the trigger map: the paper job they come from, their spectra
(growth rates after the friction drop, with damping), the ramp's compliance
kappa and the equilibria the runs start from (``remote-trigger trigger-map``,
docs/trigger_map.md).
"""
import json
import math
import os

import numpy as np

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.runtime.parallel import on_rank0
from remote_trigger.pywrap.stages import ramp_file

# --------------------------------------------------------------------------- the paper job
def load_paper_job(folder):
    """Configuration and manifest of a complete paper job.

    Returns
    -------
    (PaperConfig, dict)

    Raises
    ------
    ConfigError
        If ``folder/paper.json`` is missing, unreadable, not complete, or
        lacks the Fig. 5 phase, or its second ramp is not at mu_ss mu0.
    """
    from remote_trigger.pywrap.jobs.paper.config import PaperConfig

    path = os.path.join(folder, "paper.json")
    try:
        with open(path) as fh:
            man = json.load(fh)
    except (OSError, ValueError) as exc:
        raise ConfigError(f"paper = {folder!r} is not a paper job's output folder "
                          f"({path}: {exc})") from None
    if man.get("status") != "complete" or not man.get("perturb") or not man.get("ramps"):
        raise ConfigError(f"paper = {folder!r}: the paper job is not complete "
                          f"(status {man.get('status')!r}); finish it with "
                          f"`remote-trigger paper --out {folder} --resume`")
    d = dict(man["config"])
    d["nf_tau"] = [math.inf if v is None else v for v in d.get("nf_tau", [])]
    pcfg = PaperConfig.from_dict(d)
    mu_ss = float(pcfg.mu_ss) * float(pcfg.mu)
    if abs(float(pcfg.mu_low) - mu_ss) > 1e-12 * float(pcfg.mu):
        # its second ramp is not at the friction the drop reaches
        raise ConfigError(f"paper = {folder!r} ramped mu_low = {pcfg.mu_low:g}, not "
                          f"mu_ss mu0 = {mu_ss:g}: the window [F_x^c(mu_ss mu0), F_x^c(mu0)] of "
                          f"the map is not known; map a paper job with mu_low = mu_ss mu")
    return pcfg, man


def _msd(a, b):
    """Mean over disks or spheres of |r_a - r_b|^2 (minimum image along the
    periodic x, and z for spheres)."""
    d = a.positions - b.positions                   # shape (N, 2) or (N, 3)
    for ax in ((0, 2) if d.shape[1] == 3 else (0,)):
        L = a.box_hi[ax] - a.box_lo[ax]
        d[:, ax] -= L * np.round(d[:, ax] / L)
    return float(np.mean(np.sum(d * d, axis=1)))


def spectrum_numbers(dump_mu0, dump_drop, taus):
    """Spectral numbers of one load: natural frequencies, kappa, damped rates.

    Parameters
    ----------
    dump_mu0, dump_drop : str
        Dumps of the equilibrium with mu0 and after the friction drop (disks
        or spheres).
    taus : list of float
        Damping times (``fix viscous``: gamma = 1/tau on the translations,
        x and y of disks, x, y and z of spheres; rotations undamped).

    Returns
    -------
    dict
        ``omega_1``, ``omega_2`` (lowest natural frequencies with mu0),
        ``growth`` (after the drop), ``pair`` (its eigenvalue),
        ``kappa_drop`` (condition number of the complex pair after the
        drop), ``kappa_mu0`` and ``gap_mu0`` (condition number and relative
        distance to the nearest eigenvalue of the mu0 eigenvalue nearest the
        pair: the spectral distance to the exceptional point), ``growth_tau``
        (max Re s with damping, per tau), ``D_drop``.
    """
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.stability import eigen

    out = {}
    s0, s1 = read_equilibrium(dump_mu0), read_equilibrium(dump_drop)
    out["D_drop"] = _msd(s1, s0)
    # dofs per particle: disks x, y, theta (rotation: dof 2); spheres x, y, z
    # and three rotations (dofs 3-5)
    per, first_rot = (6, 3) if s0.positions.shape[1] == 3 else (3, 2)
    res = {}
    for key, st in (("mu0", s0), ("drop", s1)):
        an = reduced_system(st)
        Kr, mr = an.K, an.mass
        rot = (an.keep_dofs % per) >= first_rot
        res[key] = (eigen.dense_eigen(Kr, mr, vectors=True), Kr, mr, rot)
    e0, e1 = res["mu0"][0], res["drop"][0]
    w0 = np.sort(np.sqrt(np.abs(e0.eigenvalues.real)))
    out["omega_1"], out["omega_2"] = float(w0[0]), float(w0[1])
    gr = np.abs(np.sqrt(e1.eigenvalues).imag)
    i = int(np.argmax(gr))
    out["growth"] = float(gr[i])
    out["pair"] = [float(e1.eigenvalues[i].real), float(e1.eigenvalues[i].imag)]
    out["kappa_drop"] = float(e1.kappa[i])
    lam0 = e0.eigenvalues
    j = int(np.argmin(np.abs(lam0 - e1.eigenvalues[i].real)))
    others = np.delete(lam0, j)
    out["kappa_mu0"] = float(e0.kappa[j])
    out["gap_mu0"] = float(np.min(np.abs(others - lam0[j])) / abs(lam0[j]))
    _, Kr, mr, rot = res["drop"]
    out["growth_tau"] = [eigen.damped_growth_rate(Kr, mr, np.where(rot, 0.0, 1.0 / t))
                         for t in taus]
    return out


def predicted_rate(setup, ld, tau):
    """Growth rate of the load's state after the friction drop, damped by ``tau``.

    max Re s of the (damped) quadratic eigenproblem after the drop to
    mu_ss mu0 (``growth``, or ``growth_tau`` of this tau): <= 0 means no
    runaway is predicted (no complex pair, or damping faster than its growth).
    """
    if tau is None:
        return float(ld["growth"])
    return float(ld["growth_tau"][list(setup["taus"]).index(tau)])


def ramp_kappa(ramp_h5, limit=None):
    """Eigenvalue condition number of the coalescing pair along a ramp.

    The pair is the complex pair of largest growth rate at the ramp's first
    complex point (the high end of the F_x^c bracket); below it, at each step
    from F_x^c downwards, the two real eigenvalues nearest the pair's position
    at the step above (tracking). kappa = ||y|| ||x|| / |y^H x| from LAPACK's
    left and right eigenvectors (:func:`remote_trigger.analysis.stability.eigen.condition_numbers`).

    Parameters
    ----------
    ramp_h5 : str
        ``ramp.h5`` (its step dumps are read).
    limit : int, optional
        Only the ``limit`` steps nearest F_x^c.

    Returns
    -------
    dict
        ``F_x``, ``kappa`` (max of the pair's two), ``gap`` (|lambda_i -
        lambda_j| / |lambda|: the spectral distance to the exceptional point),
        ``kappa_max`` (largest over the spectrum), lists in increasing F_x;
        ``lambda_c`` (the pair at the first complex point).
    """
    import h5py
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.stability import eigen

    def spec(datafile):
        an = reduced_system(read_equilibrium(datafile[:-len(".data")] + ".dump"))
        return eigen.dense_eigen(an.K, an.mass, vectors=True)

    with h5py.File(ramp_h5, "r") as fh:
        hi = float(fh.attrs["F_x_c_high"])
    F, files = ramp_file.read_points(ramp_h5, ramp_file.STEPS)
    bF, bfiles = ramp_file.read_points(ramp_h5, ramp_file.BISECTION)
    pts = sorted(zip(list(F) + list(bF), files + bfiles))
    top = [f for x, f in pts if x == hi]
    e = spec(top[0])
    g = np.abs(np.sqrt(e.eigenvalues).imag)
    lam_c = e.eigenvalues[int(np.argmax(g))]
    below = [(x, f) for x, f in pts if x < hi and x in set(F)][::-1]
    if limit is not None:
        below = below[:limit]
    target = lam_c.real
    rows = []
    for x, f in below:
        e = spec(f)
        lam = e.eigenvalues
        idx = np.argsort(np.abs(lam - target))[:2]
        i, j = int(idx[0]), int(idx[1])
        rows.append((x, float(max(e.kappa[i], e.kappa[j])),
                     float(abs(lam[i] - lam[j]) / abs(0.5 * (lam[i] + lam[j]))),
                     float(np.max(e.kappa))))
        target = 0.5 * (lam[i].real + lam[j].real)
    rows.sort()
    return {"F_x": [r[0] for r in rows], "kappa": [r[1] for r in rows],
            "gap": [r[2] for r in rows], "kappa_max": [r[3] for r in rows],
            "lambda_c": [float(lam_c.real), float(lam_c.imag)], "F_x_c_high": hi}


def prepare_loads(cfg, pcfg, man, out, comm):
    """Equilibria, friction-drop analyses and spectral numbers of the map's loads.

    Runs on rank 0 of ``comm`` (its own LAMMPS instance); the result is
    written to ``out/loads.json`` and broadcast.

    Returns
    -------
    dict
        ``loads`` (list of dict), ``taus``, ``omegas``, ``v0``, ``mu0``,
        ``mu_ss``, ``g_ref``.
    """
    path = os.path.join(out, "loads.json")
    job = paper_fingerprint(pcfg, man)

    def load_or_prepare():
        from remote_trigger.pywrap.runtime.jobfolder import read_json, write_json

        if os.path.isfile(path):
            result = read_json(path)
            then = result.get("paper_job")          # None: a map of an older version
            if then is not None and then != job:
                flat = {**then.get("config", {}), "brackets": then.get("brackets"),
                        "v0": then.get("v0")}
                now = {**job["config"], "brackets": job["brackets"], "v0": job["v0"]}
                what = [k for k in now if flat.get(k) != now[k]][:3]
                raise ConfigError(
                    f"cannot resume: the paper job {cfg.paper!r} changed since this map began "
                    f"({'; '.join(f'{k} = {flat.get(k)!r} then, {now[k]!r} now' for k in what)})"
                    f"; map it into another --out (nothing was changed)")
            return result
        result = dict(_prepare_loads(cfg, pcfg, man, out), paper_job=job)
        write_json(path, result)
        return result

    return on_rank0(comm, load_or_prepare)


def paper_fingerprint(pcfg, man):
    """What the map takes from its paper job: the job's configuration, the
    brackets of its ramps and the v0 of its Fig. 5 (JSON values), compared on
    ``--resume`` so that a paper job run again in its folder is not mixed in."""
    cfg = json.loads(json.dumps(pcfg.to_dict(), default=str))
    brackets = [[r.get("F_x_c_low"), r.get("F_x_c_high")] for r in man["ramps"]]
    v0 = man.get("perturb", {}).get("v0")
    return json.loads(json.dumps({"config": cfg, "brackets": brackets, "v0": v0},
                                 default=str))


def _prepare_loads(cfg, pcfg, man, out):
    from mpi4py import MPI
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.jobs.paper import ramp_config
    from remote_trigger.pywrap.jobs.paper import fig5
    from remote_trigger.analysis.stability.timestep import stability_limit
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    ramps = man["ramps"]
    fig = man["perturb"]
    mu0 = float(pcfg.mu)
    mu_ss = float(pcfg.mu_ss) * mu0
    lo = float(ramps[1]["F_x_c_high"])
    hi = float(ramps[0]["F_x_c_low"])
    F_steps, files = ramp_file.read_points(ramps[0]["h5"])
    loads = [{"kind": f"window {f:g}", "fraction": float(f), "F_x": lo + f * (hi - lo)}
             for f in cfg.fractions]
    if cfg.below:
        ctrl = fig.get("control")
        if not ctrl:
            raise ConfigError(f"paper = {cfg.paper!r}: its Fig. 5 has no control load below "
                              f"the window; set below = false")
        loads.append({"kind": "below", "fraction": (ctrl["F_x"] - lo) / (hi - lo),
                      "F_x": float(ctrl["F_x"])})
    folder = os.path.join(out, "loads")
    os.makedirs(folder, exist_ok=True)
    with Engine(comm=MPI.COMM_SELF) as eng:
        for k, ld in enumerate(loads):
            F = ld["F_x"]
            below = np.flatnonzero(F_steps <= F)
            start = files[int(below[-1])] if below.size else files[0]
            rcfg = ramp_config(pcfg, start, mu0)
            pre = os.path.join(folder, f"load{k}")
            eq = fig5.friction_drop(eng, rcfg, start, F, mu0, pre)
            dr = fig5.friction_drop(eng, rcfg, eq["datafile"], F, mu_ss, pre + "_drop")
            ld.update(equilibrium=eq["datafile"], decision_mu0=eq["decision"],
                      margin_mu0=eq["confidence"], decision_drop=dr["decision"],
                      margin_drop=dr["confidence"], residual=eq["residual"],
                      dt_max=float(stability_limit(read_equilibrium(pre + ".dump"))),
                      compliance=float(fig5.top_compliance(ramps[0]["h5"], F)),
                      a_max=float(cfg.a_max_factor * (hi - F)))
    # the reference load (growth rate g of the tau_g column): nearest the middle
    inside = [ld for ld in loads if ld["kind"] != "below"] or loads
    ref = min(inside, key=lambda ld: abs(ld["fraction"] - 0.5))
    pre_ref = os.path.join(folder, f"load{loads.index(ref)}")
    g_ref = spectrum_numbers(pre_ref + ".dump", pre_ref + "_drop.dump", [])["growth"]
    if cfg.tau:
        taus = [float(t) for t in cfg.tau]
    elif g_ref > 0:
        taus = [float(t) / g_ref for t in cfg.tau_g]
    else:
        raise ConfigError("tau_g needs a growth rate after the friction drop at the "
                          "window's middle load, which is 0 there; give tau explicitly")
    for k, ld in enumerate(loads):
        pre = os.path.join(folder, f"load{k}")
        ld.update(spectrum_numbers(pre + ".dump", pre + "_drop.dump", taus))
    return {"loads": loads, "taus": taus, "omegas": map_omegas(cfg, loads),
            "v0": float(fig["v0"]),
            "mu0": mu0, "mu_ss": mu_ss, "g_ref": float(g_ref), "window": [lo, hi],
            "B": float(pcfg.B), "w": float(pcfg.w), "mu_ss_ratio": float(pcfg.mu_ss),
            "k_n": float(pcfg.k_n), "k_t": float(pcfg.k_t), "F_y": float(pcfg.F_y),
            "a_paper": float(pcfg.a_paper), "dim": int(pcfg.dim)}


def map_omegas(cfg, loads):
    """The map's omega_p: ``cfg.omega_p``, and with ``cfg.natural`` omega_1 / 2,
    omega_1 and 2 omega_1 of the reference load (the inside load nearest the
    window's middle), sorted. Recomputed from the loads on ``--resume``, so a
    resumed map asks the current grid (new columns get new task keys).
    """
    omegas = [float(w) for w in cfg.omega_p]
    if cfg.natural:
        inside = [ld for ld in loads if ld["kind"] != "below"] or loads
        ref = min(inside, key=lambda ld: abs(ld["fraction"] - 0.5))
        omegas += [0.5 * ref["omega_1"], ref["omega_1"], 2.0 * ref["omega_1"]]
    return sorted(set(omegas))
