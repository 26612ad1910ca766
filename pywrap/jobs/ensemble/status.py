"""``ensemble --status``: how far an ensemble has come, read from its folder.

Part of :mod:`remote_trigger.pywrap.jobs.ensemble` (docs/ensemble.md). A job
at N = 10^4 runs for hours with one progress line per finished packing;
this reads what the job has already written -- ``config.json``, the
finished packings' ``tasks/<key>.json``, each started packing's
``progress.json``, its ramps' ``ramp.h5`` (all written atomically, at
every ramp point) and the scan a sliced verdict saves every 5 min -- and
says for each packing where it is. It writes
nothing and starts no LAMMPS or MPI, so it is safe beside the running job
(on a cluster, from a login node on the shared file system).
"""
import math
import os
import time

__all__ = ["ensemble_status"]


def _ramp_line(name, folder, part):
    """One ramp's state: finished (its part), running (its ramp.h5), or not started."""
    from remote_trigger.pywrap.jobs.ensemble.onset import bracket, bracket_words, read_ramp

    if part is not None:
        o = next((v for k, v in part.items() if k.startswith("I0_")), {})
        lo, hi = o.get("F_x_c_low", math.nan), o.get("F_x_c_high", math.nan)
        return f"{name} {part.get('ramp_status', '?')}, {bracket_words(lo, hi)}"
    h5 = os.path.join(folder, f"ramp_{name}", "ramp.h5")
    if not os.path.isfile(h5):
        # the ramp's folder is made at its start, ramp.h5 at its first point
        return (f"{name} running, no point recorded yet"
                if os.path.isdir(os.path.join(folder, f"ramp_{name}")) else f"{name} not started")
    try:
        pts = read_ramp(h5)
    except (OSError, KeyError, ValueError) as exc:
        return f"{name} ramp.h5 unreadable ({exc})"
    if not pts:
        return f"{name} started, no point yet"
    lo, hi = bracket(pts)       # hi = inf: no certified complex point yet
    return f"{name} running: {len(pts)} point(s), {bracket_words(lo, hi)}"


def _utc(t):
    """A file time as the status lines write it."""
    return time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(t))


def _scan_note(folder):
    """A running point's sliced verdict as its last save left it (the
    packing's ``verdicts`` folder, N >= 1600), or ''."""
    from remote_trigger.analysis.stability.sliced import saved_scans
    from remote_trigger.pywrap.jobs.ensemble.task import VERDICTS

    vdir = os.path.join(folder, VERDICTS)
    # the packing's folder, or one per ramp where its ramps run side by side
    dirs = [vdir] + sorted(os.path.join(vdir, d) for d in
                           (os.listdir(vdir) if os.path.isdir(vdir) else ())
                           if os.path.isdir(os.path.join(vdir, d)))
    return "".join(
        f"; a point's verdict in progress{' (' + os.path.basename(d) + ')' if d != vdir else ''}"
        f": {done}/{n} eigenvalues at its last save ({_utc(mtime)})"
        for d in dirs for _, done, n, mtime in saved_scans(d))


def _since(folder):
    """' since <time>' of a packing's relaxation: the time of its generated
    file (written when the packing's stages start, and again when a killed
    one starts afresh), or ''."""
    from remote_trigger.pywrap.jobs.ensemble.task import PACKING

    try:
        mtime = os.path.getmtime(os.path.join(folder, PACKING))
    except OSError:
        return ""
    return f" since {_utc(mtime)} ({(time.time() - mtime) / 60:.0f} min)"


def ensemble_status(out):
    """How far the ensemble in ``out`` has come, one line per packing.

    Parameters
    ----------
    out : str
        An ensemble output folder (``config.json`` there), running, killed
        or finished.

    Returns
    -------
    list of str
        A header (packings finished / started / not started), then per
        packing its key and state: ``finished`` with its F_x^c(mu0)
        bracket (or its error, and how to run it again); ``relaxing`` (no
        relaxed packing yet; since when, from the time of its
        ``packing.data``); or
        relaxed (phi) with each ramp finished (its bracket), running (its
        points so far and the certified bracket they give) or not started,
        and a sliced verdict in progress with its count of eigenvalues at
        its last save (``analysis.stability.sliced.saved_scans``).

    Raises
    ------
    ConfigError
        If ``out`` has no readable ensemble ``config.json`` (the message
        names ``--status`` and the folder).
    """
    from remote_trigger.pywrap.jobs.ensemble.combine import read_run
    from remote_trigger.pywrap.jobs.ensemble.onset import bracket_words
    from remote_trigger.pywrap.jobs.ensemble.task import (
        PROGRESS, load_progress, load_task, packing_failed)

    out = os.path.abspath(out)
    _, cfg = read_run(out, flag="--status")
    key0 = f"I0_{cfg.I0_dynamics:g}"
    lines, counts = [], {"finished": 0, "started": 0, "not started": 0}
    for t in cfg.packings():
        folder = os.path.join(out, "packings", t["key"])
        res = load_task(out, t)
        if res is not None:
            counts["finished"] += 1
            d = res.get("default", {})
            o = ((d.get("ramps") or {}).get("mu0") or {}).get(key0, {})
            fr = (res.get("frictional") or {}).get("error")
            lo, hi = o.get("F_x_c_low", math.nan), o.get("F_x_c_high", math.nan)
            lines.append(f"{t['key']}: finished, {bracket_words(lo, hi, 'F_x^c(mu0)')}"
                         + (f"; error: {d['error']}" if d.get("error") else "")
                         + (f"; frictional part's error: {fr}" if fr else "")
                         + (" (--resume --retry-failed runs it again)"
                            if packing_failed(res) else ""))
            continue
        prog = load_progress(folder) if os.path.isfile(os.path.join(folder, PROGRESS)) \
            else None
        if prog is None and not os.path.isdir(folder):
            counts["not started"] += 1
            lines.append(f"{t['key']}: not started")
            continue
        counts["started"] += 1
        relax = (prog or {}).get("relax")
        if not relax:
            lines.append(f"{t['key']}: relaxing" + _since(folder))
            continue
        ramps = prog.get("ramps") or {}
        lines.append(f"{t['key']}: relaxed (phi {relax.get('phi', math.nan):.4f}); "
                     + "; ".join(_ramp_line(k, folder, ramps.get(k)) for k in ("mu0", "mu_ss"))
                     + _scan_note(folder))
    head = (f"ensemble {out}: {len(lines)} packing(s), " + ", ".join(
        f"{v} {k}" for k, v in counts.items()))
    return [head] + lines
