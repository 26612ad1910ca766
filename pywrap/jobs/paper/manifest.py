"""The ``paper`` job's output folder and manifest: what the job writes under
``--out`` (:func:`prepare_out`), the manifest ``paper.json`` (atomic JSON) and
what ``--resume`` reads back from it (:func:`load_manifest`,
:func:`finished_phases`). The job itself is :mod:`remote_trigger.pywrap.jobs.paper`.
"""
import json
import os
import re
import shutil
import time

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.runtime.jobfolder import json_default

#: files and folders the job writes under --out (removed when it is re-run there)
OUTPUTS = ("paper.json", "packing.data", "relax.h5", "relax", "instability.h5", "instability",
           "perturb_a.h5", "perturb_b.h5", "perturb_c.h5", "perturb_d.h5", "perturb_e.h5",
           "perturb_p.h5", "perturb", "normal_form.h5",
           "report.md", "report.json", "logs")
OUTPUT_GLOBS = ("ramp_mu", "fig")
MANIFEST = "paper.json"


def ramp_dir(out, mu):
    """Folder of the ramp at friction ``mu``: ``out/ramp_mu<mu>``."""
    return os.path.join(out, f"ramp_mu{mu:g}")


# --------------------------------------------------------------------------- output folder
def earlier_job_refusal(out):
    """The one-line refusal of a new job in ``out``, a folder of an earlier job."""
    return (f"output folder {out!r} holds an earlier `remote-trigger paper` job "
            f"({MANIFEST}): give --resume to continue it, --overwrite to replace its "
            f"outputs, or another --out (nothing was deleted)")


def prepare_out(out, overwrite=False):
    """Make ``out`` ready for a new run (rank 0 only).

    An empty or missing folder is used as is. A folder that holds a previous
    run of this job (``paper.json``) is refused unless ``overwrite``; with it,
    exactly the outputs of that job are removed (:data:`OUTPUTS`,
    ``ramp_mu*``, ``fig*.png``, and the temporary ``NAME.tmpPID`` files of
    writes cut short) and anything else in it is left alone. A non-empty
    folder without ``paper.json`` is refused. (``--resume`` with a
    ``paper.json`` in ``out`` deletes nothing and does not call this; see
    :func:`run_paper`.)

    Parameters
    ----------
    out : str
        The output folder.
    overwrite : bool
        Replace the outputs of an earlier job in ``out`` (``--overwrite``).

    Raises
    ------
    ConfigError
        If ``out`` is a file, cannot be created, is a non-empty folder not
        written by this job, or holds an earlier job and ``overwrite`` is
        false (nothing is deleted then).
    """
    from remote_trigger.analysis.errors import InputError
    from remote_trigger.analysis.output import output_dir

    try:
        output_dir(out, "--out")
    except InputError as exc:
        raise ConfigError(str(exc)) from None
    entries = os.listdir(out)
    if not entries:
        return
    if MANIFEST not in entries:
        raise ConfigError(f"output folder {out!r} is not empty and was not written by "
                          f"`remote-trigger paper` (no {MANIFEST}); choose another --out")
    if not overwrite:
        raise ConfigError(earlier_job_refusal(out))
    for name in entries:
        path = os.path.join(out, name)
        base = re.sub(r"\.tmp\d+$", "", name)   # temporary file of a killed write
        ours = base in OUTPUTS or any(base.startswith(g) for g in OUTPUT_GLOBS)
        if base.startswith("fig") and not base.endswith(".png"):
            ours = False
        if not ours:
            continue
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        else:
            os.remove(path)


# --------------------------------------------------------------------------- manifest, resume
def json_normalised(d):
    """``d`` after a JSON round trip (tuples -> lists, numpy -> Python), for comparisons."""
    return json.loads(json.dumps(d, default=json_default))


#: configuration keys that may differ between the sessions of one job (they
#: do not change any result: serial and two-rank runs are bitwise identical)
RESUME_FREE_KEYS = ("np",)

#: configuration keys that only the Fig. 5 phase reads (the choice of its
#: load): they may change on ``--resume`` while that phase has not begun (no
#: ``perturb`` summary in the manifest, no ``perturb/`` folder), e.g. to give
#: ``fig5_F_x`` to a job whose packing has no window, keeping its
#: relaxation and ramps
RESUME_BEFORE_FIG5_KEYS = ("fig5_F_x", "fig5_window")


def fig5_begun(man, out):
    """The Fig. 5 phase of the job in ``out`` has begun (or finished)."""
    return bool(man.get("perturb")) or os.path.exists(os.path.join(out, "perturb"))


def config_difference(stored, cfg):
    """Keys whose values differ between a stored configuration and ``cfg``.

    Parameters
    ----------
    stored : dict
        ``config`` of a manifest (``paper.json``).
    cfg : PaperConfig

    Returns
    -------
    list of (str, object, object)
        ``(key, stored value, value of cfg)``, sorted by key; keys of
        :data:`RESUME_FREE_KEYS` are ignored. A key missing on one side has
        the value ``'<missing>'`` there (but ``dim`` missing in ``stored`` is 2).
    """
    a, b = json_normalised(stored), json_normalised(cfg.to_dict())
    a.setdefault("dim", 2)      # a manifest written before spheres: disks
    missing = "<missing>"
    return [(k, a.get(k, missing), b.get(k, missing)) for k in sorted(set(a) | set(b))
            if k not in RESUME_FREE_KEYS and a.get(k, missing) != b.get(k, missing)]


def load_manifest(out, cfg):
    """The manifest of the job in ``out`` to resume, checked against ``cfg``.

    Parameters
    ----------
    out : str
        Absolute path of the output folder; ``out/paper.json`` must exist.
    cfg : PaperConfig
        Configuration of this run of the job.

    Returns
    -------
    dict
        The manifest (see :func:`run_paper`).

    Raises
    ------
    ConfigError
        If ``paper.json`` is unreadable or its configuration differs from
        ``cfg`` (the message names every differing key with both values),
        except in :data:`RESUME_FREE_KEYS`, and in
        :data:`RESUME_BEFORE_FIG5_KEYS` while Fig. 5 has not begun
        (:func:`fig5_begun`; the resumed job then uses and records the new
        values).
        Nothing is deleted. A manifest written in another folder (the job's
        folder was moved) is returned with its paths moved to ``out``
        (:func:`rebased`).
    """
    path = os.path.join(out, MANIFEST)
    try:
        with open(path) as fh:
            man = json.load(fh)
        if not isinstance(man, dict) or not isinstance(man.get("config"), dict):
            raise ValueError("no 'config' object")
    except (OSError, ValueError) as exc:
        raise ConfigError(f"cannot resume from {path}: unreadable manifest ({exc}); "
                          f"run with --overwrite in place of --resume to start the job over") from None
    diff = config_difference(man["config"], cfg)
    if not fig5_begun(man, out):
        diff = [d for d in diff if d[0] not in RESUME_BEFORE_FIG5_KEYS]
    if diff:
        what = "; ".join(f"{k} = {old!r} in {MANIFEST}, {k} = {new!r} now"
                         for k, old, new in diff)
        raise ConfigError(f"cannot resume {out}: its configuration differs: {what}. Resume "
                          f"with the options of the interrupted job, or give --overwrite in place of "
                          f"--resume to start over (nothing was deleted)")
    old_out = man.get("out")
    if isinstance(old_out, str) and os.path.realpath(old_out) != os.path.realpath(out):
        man = rebased(man, old_out, out)
    return man


def rebased(obj, old, new):
    """``obj`` (a manifest, or any part of one) with every path under the folder
    ``old`` moved under ``new``: a job folder moved (or mounted elsewhere)
    after it was killed resumes there. The files inside a phase's folder
    name theirs relative to it (``ramp.h5``: ``ramp_file.RELATIVE_PATHS``)."""
    if isinstance(obj, dict):
        return {k: rebased(v, old, new) for k, v in obj.items()}
    if isinstance(obj, list):
        return [rebased(v, old, new) for v in obj]
    if isinstance(obj, str) and (obj == old or obj.startswith(old.rstrip(os.sep) + os.sep)):
        return new + obj[len(old.rstrip(os.sep)):]
    return obj


def _files_of(out, name, entry):
    """Files a finished phase leaves behind (its summary is trusted only if they exist)."""
    if name == "relax":
        return [entry["datafile"], os.path.join(out, "relax.h5")]
    if name.startswith("ramp"):
        files = [entry["h5"]]
        ok = [r for r in entry.get("extension", []) if "error" not in r]
        if entry.get("status") == "complete":
            files.append(os.path.join(os.path.dirname(entry["h5"]), "extend.h5"))
        return files + [r["datafile"] for r in ok]
    if name == "instability":
        return [entry["h5"]]
    if name == "perturb":
        return (list((entry.get("files") or {}).values())
                + [os.path.join(out, "perturb", "equilibrium.dump")])
    if name == "normal_form":
        return [os.path.join(out, "normal_form.h5"), os.path.join(out, "fig_normal_form.png")]
    return []


def finished_phases(man, out, check_files=True):
    """Summaries of the phases a manifest records as finished (and whose files exist).

    Parameters
    ----------
    man : dict
        Manifest (``paper.json``).
    out : str
        Output folder.
    check_files : bool
        Keep only phases whose output files (HDF5, data files, PNG) all exist,
        so that deleting a phase's files makes ``--resume`` run it again.

    Returns
    -------
    dict
        ``relax``, ``ramp0``, ``ramp1`` (main mu, mu_low), ``instability``,
        ``perturb``, ``normal_form`` -> summary, for those that are done.
    """
    found = {}
    if man.get("relax"):
        found["relax"] = man["relax"]
    for k, r in enumerate((man.get("ramps") or [])[:2]):
        if r:
            found[f"ramp{k}"] = r
    for name in ("instability", "perturb", "normal_form"):
        if man.get(name):
            found[name] = man[name]
    if not check_files:
        return found
    return {k: v for k, v in found.items()
            if all(os.path.exists(f) for f in _files_of(out, k, v))}


def report_done(out, man):
    """The manifest says complete, and the report and every figure it lists exist."""
    figs = [f for f in (man.get("figures") or {}).values()
            if not str(f).startswith("error")]
    return (man.get("status") == "complete" and
            all(os.path.isfile(os.path.join(out, f)) for f in ("report.md", "report.json"))
            and all(os.path.isfile(f) for f in figs))


def utc_now():
    """The present time, UTC, ISO 8601 to the second (``2026-11-27T05:30:00Z``)."""
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def ordered_phases(phases, cfg):
    """Phase timings in the order of the job (unknown names last)."""
    order = ["relax", f"ramp_mu{cfg.mu:g}", f"ramp_mu{cfg.mu_low:g}", "instability",
             "perturb", "normal_form", "figures", "total"]
    out = {k: phases[k] for k in order if k in phases}
    out.update({k: v for k, v in phases.items() if k not in out})
    return out
