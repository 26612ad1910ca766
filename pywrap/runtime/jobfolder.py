"""The output folder of a resumable job (``trigger-map``, ``ensemble``).

A job folder holds ``config.json`` (the job's configuration, written when
the job starts) and the job's files. :func:`check_job_folder` is run on
rank 0 before anything else is written.
"""
import json
import os

import numpy as np

from remote_trigger.analysis.output import write_json_atomic
from remote_trigger.pywrap.config import ConfigError, parse_set

#: the configuration file of a job folder
CONFIG_FILE = "config.json"

#: a config.json with this many keys unknown to the job, and as many of the job's
#: keys missing, is another job's (an ensemble's for a trigger map, or the
#: reverse), not an older version of this job's (which lacks a key or two)
OTHER_JOB_KEYS = 3


def check_job_folder(out, config, resume, kind):
    """Refuse an ``--out`` that is a file or holds other results; check ``--resume``.

    Parameters
    ----------
    out : str
        The output folder (created, with ``config.json``, for a new job).
    config : dict
        The job's configuration (JSON-serialisable); ``np`` may differ on
        ``--resume``.
    resume : bool
        Continue the job in ``out``.
    kind : str
        What the job is called in messages ("a trigger map", "an ensemble").

    Raises
    ------
    ConfigError
        ``out`` is a file; it holds files but no ``config.json``; it holds
        another job's results; it holds this job and ``resume`` is False; or
        that job's configuration differs
        (every differing key is named with both values). Nothing is written
        then.
    """
    from remote_trigger.analysis.errors import InputError
    from remote_trigger.analysis.output import output_dir

    try:
        output_dir(out, "--out")      # a file, or a folder that cannot be created
    except InputError as exc:
        raise ConfigError(str(exc)) from None
    cfgfile = os.path.join(out, CONFIG_FILE)
    if os.listdir(out):
        if not os.path.isfile(cfgfile):
            raise ConfigError(f"--out {out!r} holds other files; choose an empty or new folder")
        old = dict(read_json(cfgfile), np=None)
        new = dict(json.loads(json.dumps(config)), np=None)
        only_old, only_new = sorted(set(old) - set(new)), sorted(set(new) - set(old))
        if len(only_old) >= OTHER_JOB_KEYS and len(only_new) >= OTHER_JOB_KEYS:
            # (another job's folder was taken for this one's: "add --resume", and then
            # a list of every key as differing)
            raise ConfigError(f"--out {out!r} holds the results of another job, not {kind} "
                              f"(its config.json has keys such as {', '.join(only_old[:3])}); "
                              f"choose another folder")
        if not resume:
            raise ConfigError(f"--out {out!r} holds {kind}; add --resume to continue it or "
                              f"choose another folder")
        diff = [k for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
        if diff:
            raise ConfigError(f"cannot resume {out!r}: its configuration differs in "
                              + ", ".join(f"{k} = {old.get(k)!r} (then) vs {new.get(k)!r} "
                                          f"(now)" for k in diff))
        return
    write_json(cfgfile, config)


def add_job_arguments(p, out, config_class, quick_help, resume_help, set_example):
    """The options every job subcommand (``trigger-map``, ``ensemble``) shares.

    ``--out`` (default ``out``), ``--config FILE`` (TOML, or JSON), ``--quick``, ``--resume``,
    ``--np``, ``--set KEY=VALUE`` (repeatable) and ``--quiet``; read back by
    :func:`job_overrides`.
    """
    p.add_argument("--out", default=out, help=f"output folder (default {out})")
    p.add_argument("--config", metavar="FILE",
                   help=f"TOML file with any {config_class} key (or JSON: a job's config.json)")
    p.add_argument("--quick", action="store_true", default=None, help=quick_help)
    p.add_argument("--resume", action="store_true", help=resume_help)
    p.add_argument("--np", type=int, default=None,
                   help="ranks that run tasks: re-launch under mpirun -np NP+1 (one more "
                        "rank hands out the tasks and writes the results)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help=f"any configuration key (repeatable), e.g. {set_example}")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def describe_keys(p, config_class):
    """The --help of a job whose keys are given by --set and --config: its
    description wrapped as argparse would, and an epilog with every key of
    ``config_class`` and its help (:meth:`~remote_trigger.pywrap.config.Config.field_help`)."""
    import argparse
    import textwrap

    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.description = textwrap.fill(p.description, 79)
    helps = config_class.field_help()
    lines = ["configuration keys (--set KEY=VALUE, or a --config file):"]
    for key in config_class.names():
        lines.append(textwrap.fill(helps[key].replace("%%", "%"), 79,
                                   initial_indent=f"  {key}: ", subsequent_indent="      "))
    p.epilog = "\n".join(lines)


def job_overrides(args, **more):
    """Configuration overrides from :func:`add_job_arguments`'s options: every
    ``--set``, ``--np`` and the keyword arguments that are not None."""
    over = parse_set(args.set)
    for key, val in dict(more, np=args.np).items():
        if val is not None:
            if key in over:         # the option silently won over --set
                raise ConfigError(f"--set {key}={over[key]!r} and --{key.replace('_', '-')} "
                                  f"{val!r} both set {key}; give one of them")
            over[key] = val
    return over


def stored_path(folder, path):
    """``path`` as a job's records keep it: relative to ``folder`` when inside
    it (so that the folder can be moved or copied and resumed there), else
    absolute.

    Parameters
    ----------
    folder, path : str
        Absolute or relative to the working directory.

    Returns
    -------
    str
    """
    path = os.path.abspath(str(path))
    rel = os.path.relpath(path, os.path.abspath(folder))
    return path if rel == os.pardir or rel.startswith(os.pardir + os.sep) else rel


def resolved_path(folder, stored):
    """A path of a job's records usable from here: a relative one (written by
    :func:`stored_path`) joined to ``folder``, an absolute one (records of
    older versions, or files outside ``folder``) as it is."""
    return stored if os.path.isabs(stored) else os.path.join(folder, stored)


def read_json(path):
    """The JSON record ``path`` of a job (``config.json``, ``loads.json``, ...).

    Returns
    -------
    dict
        Every record is a JSON object.

    Raises
    ------
    ConfigError
        Not valid JSON, or not an object (a damaged record: the file is
        named; it was ``Expecting property name ...: line 2 column 1 (char
        2)`` alone).
    OSError
        As :func:`open`.
    """
    with open(path, "rb") as fh:
        try:
            data = json.loads(fh.read())
            if not isinstance(data, dict):
                kind = {list: "an array", str: "a string", bool: "a boolean",
                        type(None): "null"}.get(type(data), "a number")
                raise ValueError(f"{kind}, not an object")
        except ValueError as exc:       # JSONDecodeError, UnicodeDecodeError, the above
            raise ConfigError(f"{path} is not readable JSON ({exc}); it was damaged: "
                              f"restore it or start the job in another folder") from None
    return data


def write_json(path, data):
    """Write JSON atomically (temporary file + rename), NumPy scalars and arrays as JSON.

    Parameters
    ----------
    path : str
        The file; replaced whole (:func:`remote_trigger.analysis.output.write_json_atomic`).
    data : object
        JSON-serialisable, NumPy integers, floats, booleans and arrays included.

    Raises
    ------
    TypeError
        Anything else that JSON cannot hold, named by type.
    """
    write_json_atomic(path, data, indent=1, sort_keys=True, default=json_default)


def json_default(obj):
    """``json.dump``'s ``default``: NumPy integers, floats, booleans and arrays as
    Python numbers and lists; anything else raises ``TypeError``."""
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
