"""``remote-trigger ensemble --combine DIR [DIR ...] --out OUT``: one table from several runs.

An F_x^c(N) study is naturally run size by size (one run per N, resumed as
often as needed, perhaps on different machines). :func:`collect_runs` puts
the finished packings of several ensemble folders into a new one: its
``config.json`` lists every size and seed taken, ``tasks/`` holds copies of
the packings' result files. :func:`~remote_trigger.pywrap.jobs.ensemble.job.combine_runs`
then completes the job there with ``--resume`` semantics (nothing is
recomputed), so the table, figure and summary (fits over every size
included) are those a single run with the combined configuration writes.
"""
import json
import os

from remote_trigger.pywrap.config import ConfigError

__all__ = ["collect_runs"]

#: keys that may differ between the runs: the sizes, the seeds, the ranks used,
#: the part size of the sliced points (their verdicts do not depend on it, only
#: the eigenvalues' last bits) (``saddle_escape`` is compared per packing, below)
_FREE = ("n", "seeds", "np", "part_size", "saddle_escape")
#: keys that may be one number per N (EnsembleConfig.for_size): compared per N
_PER_SIZE = ("dF_x", "tol", "between")
#: the key of ``relax`` that may differ: the clearance test is compared per
#: packing (what each packing's relaxation used), below
_RELAX_PER_PACKING = "clearance"


def _without_clearance(relax):
    """A run's ``relax`` settings but the clearance test (a dict; None: {})."""
    return {k: v for k, v in (relax or {}).items() if k != _RELAX_PER_PACKING}


def read_run(path, flag="--combine"):
    """(config dict, EnsembleConfig) of the ensemble folder ``path``; errors name
    ``flag`` and the folder."""
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig

    cfgfile = os.path.join(path, "config.json")
    if not os.path.isdir(path):
        raise ConfigError(f"{flag} {path!r}: no such folder")
    try:
        with open(cfgfile) as fh:
            d = json.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{flag} {path!r}: no config.json there (not an ensemble "
                          "folder)") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{flag} {path!r}: config.json unreadable ({exc})") from None
    try:
        return d, EnsembleConfig.from_dict(d)
    except ConfigError as exc:
        if "unknown configuration key" in str(exc):   # e.g. a trigger map's folder
            raise ConfigError(f"{flag} {path!r} is not an ensemble folder: its config.json "
                              f"is another job's ({exc})") from None
        raise ConfigError(f"{flag} {path!r}: {exc}") from None


def _per_size_values(name, runs):
    """``{N: value}`` of a key of :data:`_PER_SIZE` over the runs' sizes: a
    run's number holds for each of its own sizes, its list one per size (a
    run of N <= 1600 with dF_x = 2.5e-4 and one of N = 6400 with 1e-4
    combine into one value per N).

    Raises
    ------
    ConfigError
        Two runs that give one N two values (named, with both).
    """
    seen = {}
    for d, _, cfg in runs:
        v = getattr(cfg, name)
        for n, val in (zip(cfg.n, v) if isinstance(v, tuple) else ((n, v) for n in cfg.n)):
            if n in seen and seen[n][1] != val:
                raise ConfigError(f"--combine: {seen[n][0]!r} and {d!r} differ in {name} "
                                  f"({seen[n][1]!r} vs {val!r}) for N = {n}; only n, seeds, "
                                  "np and part_size may differ (dF_x, tol and between may be "
                                  "one per N)")
            seen.setdefault(n, (d, val))
    return {n: val for n, (_, val) in seen.items()}


def collect_runs(dirs, out, speak=True):
    """The finished packings of ensemble folders ``dirs``, put into the new folder ``out``.

    Parameters
    ----------
    dirs : sequence of str
        Ensemble output folders (each with ``config.json`` and ``tasks/``),
        at least two. Their configurations must agree in every key but
        ``n``, ``seeds`` and ``np``; ``dF_x``, ``tol`` and ``between`` per N
        (a run's number for each of its sizes, its list one per size; two
        runs of one N must agree); ``relax`` but
        in its ``clearance``, which is compared per packing (the test each
        packing's relaxation used, the same for every packing of one N) and
        left out of the combined ``relax`` where the runs set it differently.
    out : str
        A new (or empty) folder.
    speak : bool
        Progress lines (which packings are taken, which are left out).

    Returns
    -------
    (EnsembleConfig, list of str, list of str)
        The combined configuration (written to ``out/config.json``), the
        folders (absolute paths), the packings left out (finished in no
        folder), as ``'<key> (<folder>)'``.

    Raises
    ------
    ConfigError
        Fewer than two folders; a folder without a readable ``config.json``;
        configurations that differ in another key (named, with both values);
        packings run with and without the saddle escape (two named); packings
        of one N relaxed by different clearance tests (two named); a
        packing finished in two folders; no finished packing at all; an
        ``out`` that is a file or not empty. Nothing is written then.
    """
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig
    from remote_trigger.pywrap.jobs.ensemble.task import (
        clearance_rule_of, load_task, saddle_escape_of, task_path)
    from remote_trigger.pywrap.runtime.jobfolder import check_job_folder, write_json

    dirs = [os.path.abspath(d) for d in dirs]
    if len(dirs) < 2:
        raise ConfigError(f"--combine needs at least two ensemble folders, got {len(dirs)}")
    runs = [(d,) + read_run(d) for d in dirs]
    d0, c0, _ = runs[0]
    for d, c, _ in runs[1:]:
        diff = []                   # (every key, not the first alone)
        for k in sorted((set(c0) | set(c)) - set(_FREE) - set(_PER_SIZE)):
            a, b = c0.get(k), c.get(k)
            if k == "relax":
                a, b = _without_clearance(a), _without_clearance(b)
            if a != b:
                diff.append(f"{k} ({c0.get(k)!r} vs {c.get(k)!r})")
        if diff:
            raise ConfigError(f"--combine: {d0!r} and {d!r} differ in {'; '.join(diff)}; "
                              "only n, seeds, np and part_size may differ")
    per_size = {name: _per_size_values(name, runs) for name in _PER_SIZE}
    found, missing = {}, []
    for d, _, cfg in runs:
        for t in cfg.packings():
            res = load_task(d, t)
            if res is None:
                missing.append((t["key"], d))
            elif t["key"] in found:
                raise ConfigError(f"--combine: packing {t['key']} is finished in both "
                                  f"{found[t['key']][0]!r} and {d!r}")
            else:
                found[t["key"]] = (d, t, saddle_escape_of(res), clearance_rule_of(res))
    if not found:
        raise ConfigError("--combine: no finished packing in " + ", ".join(map(repr, dirs)))
    # a packing unfinished in one folder and finished in another (a seed run
    # again in a folder of its own) is taken, not left out
    missing = [f"{k} ({d})" for k, d in missing if k not in found]
    # a packing without the record (None) ran before the escape existed: False
    esc = {k: bool(v[2]) for k, v in found.items()}
    if len(set(esc.values())) > 1:
        a = min(k for k, v in esc.items() if v)
        b = min(k for k, v in esc.items() if not v)
        raise ConfigError(f"--combine: packing {a} ({found[a][0]!r}) was run with "
                          f"saddle_escape = True, {b} ({found[b][0]!r}) without it "
                          "(runs made before the saddle escape had none); combine runs of "
                          "one protocol")
    for n in sorted({v[1]["n"] for v in found.values()}):
        rules = {k: v[3] for k, v in found.items() if v[1]["n"] == n}
        if len(set(rules.values())) > 1:
            order = sorted(rules, key=lambda k: (rules[k], k))
            a, b = order[0], order[-1]          # two of different rules
            raise ConfigError(f"--combine: packing {a} ({found[a][0]!r}) was relaxed with the "
                              f"clearance test {rules[a]!r}, {b} ({found[b][0]!r}) with "
                              f"{rules[b]!r} (runs made before 'local' existed used 'all'); "
                              "combine packings of one N relaxed by one rule")
    recorded = {v[2] for v in found.values()} - {None}
    sizes = sorted({v[1]["n"] for v in found.values()})
    seeds = [sorted(v[1]["seed"] for v in found.values() if v[1]["n"] == n) for n in sizes]
    merged = dict(c0, n=sizes, seeds=seeds, np=1)
    merged.pop("part_size", None)   # (how each run split its points; nothing to resume)
    clearances = {(c.get("relax") or {}).get(_RELAX_PER_PACKING) for _, c, _ in runs}
    if len(clearances) > 1:     # runs that set it differently: per packing only
        merged["relax"] = _without_clearance(c0.get("relax"))
    for name, values in per_size.items():
        v = [values[n] for n in sizes]
        merged[name] = v[0] if len(set(v)) == 1 else v
    if recorded:                # packings of runs that record it: their setting
        merged["saddle_escape"] = recorded.pop()
    cfg = EnsembleConfig.from_dict(merged)
    out = os.path.abspath(out)
    if os.path.isfile(os.path.join(out, "config.json")):    # (--resume is no way out)
        raise ConfigError(f"--out {out!r} holds a job already: --combine writes a new "
                          "folder; choose another --out (nothing was changed)")
    check_job_folder(out, cfg.to_dict(), False, "an ensemble")     # writes config.json
    os.makedirs(os.path.join(out, "tasks"), exist_ok=True)
    for key, (d, t, _, _) in sorted(found.items()):
        with open(task_path(d, key)) as fh:
            write_json(task_path(out, key), json.load(fh))
    if speak:
        print(f"[ensemble] combined {len(found)} finished packing(s) of {len(dirs)} runs: "
              + ", ".join(f"N = {n}: {len(s)}" for n, s in zip(sizes, seeds)), flush=True)
        for m in missing:
            print(f"[ensemble] left out (not finished): {m}", flush=True)
    return cfg, dirs, missing
