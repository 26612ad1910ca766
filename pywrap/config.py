"""Configuration: the one mechanism of every stage and job, and the stages' configurations.

Every stage and every job (``paper``, ``trigger-map``, ``ensemble``) takes
one frozen dataclass deriving from :class:`Config`, which builds it from a
mapping and names unknown keys (:meth:`Config.from_dict`). Values are
validated in ``__post_init__`` by the checks of this module
(:func:`check_number`, :func:`check_int`, :func:`check_bool`,
:func:`check_numbers`, :func:`check_table`): a :class:`ConfigError`, a
``ValueError``, names the field and the bad value. Jobs layer their sources
with :func:`layered_config` (defaults < ``--quick`` preset < TOML file
(:func:`read_config_file`; a job's ``config.json`` too) < ``--set KEY=VALUE`` (:func:`parse_set`) and flags).

The model's four parameters have one type and one validator,
:class:`ContactModel`; the stages' configurations are in
:mod:`remote_trigger.pywrap.stages.config`.

Units are LAMMPS ``lj`` units of the model (mass m = 1, length 2 R1 = 1).
"""
from dataclasses import dataclass, fields, asdict
import functools
import json
import math
import os

import numpy as np

from remote_trigger.analysis.errors import InputError
from remote_trigger.analysis.state.sidecar import default_k_t


class ConfigError(InputError):
    """A configuration value is invalid; the message names field and value.

    A ``ValueError`` and a :class:`~remote_trigger.analysis.errors.RemoteTriggerError`
    (command-line exit status 2).
    """


def check_number(name, val, lo=None, lo_open=False, hi=None, allow_inf=False):
    """The one numeric validator of every configuration; returns ``float(val)``.

    Parameters
    ----------
    name : str
        Field name, used in the message.
    val : object
        The value; ``bool`` is not a number here.
    lo, hi : float, optional
        Bounds: ``val >= lo`` (``> lo`` with ``lo_open``), ``val <= hi``.
    allow_inf : bool
        Accept +-inf (e.g. an infinite damping time); NaN is never accepted.

    Raises
    ------
    ConfigError
        One line naming the field and the value: not a number, NaN, infinite
        (unless allowed), or outside the bounds.
    """
    if isinstance(val, bool) or not isinstance(val, (int, float)):
        raise ConfigError(f"{name} must be a number, got {name} = {val!r}")
    val = float(val)
    if math.isnan(val):
        raise ConfigError(f"{name} must be a number, got {name} = {val!r}")
    if math.isinf(val) and not allow_inf:
        raise ConfigError(f"{name} must be finite, got {name} = {val!r}")
    if lo is not None and (val < lo or (lo_open and val == lo)):
        op = ">" if lo_open else ">="
        raise ConfigError(f"{name} must be {op} {lo:g}, got {name} = {val!r}")
    if hi is not None and val > hi:
        raise ConfigError(f"{name} must be <= {hi:g}, got {name} = {val!r}")
    return val




def check_lammps_path(name, path):
    """Refuse a path that reaches a LAMMPS command if it holds whitespace.

    LAMMPS splits each command into words at whitespace after substituting
    its variables, so ``read_data ${datafile}`` of ``my packing.data`` reads
    ``my``, and a ``write_dump`` into ``out dir/`` fails after the whole run.

    Raises
    ------
    ConfigError
        Naming ``name`` (a field, or an option of the command line) and the path.
    """
    text = os.fspath(path) if isinstance(path, os.PathLike) else path
    if isinstance(text, str) and any(c.isspace() for c in text):
        raise ConfigError(f"{name} {text!r}: LAMMPS splits its commands at whitespace, so a "
                          f"path with a space cannot be passed to it; choose one without spaces")


def check_positive(name, val):
    """A number > 0 (:func:`check_number` with an open lower bound 0)."""
    return check_number(name, val, 0, lo_open=True)


def check_nonnegative(name, val):
    """A number >= 0 (:func:`check_number` with lower bound 0)."""
    return check_number(name, val, 0)


def check_int(name, val, lo):
    """An integer ``>= lo`` (``bool`` is not an integer here).

    Raises
    ------
    ConfigError
        Naming the field and the value.
    """
    if isinstance(val, bool) or not isinstance(val, int):
        raise ConfigError(f"{name} must be an integer, got {name} = {val!r}")
    if val < lo:
        raise ConfigError(f"{name} must be >= {lo}, got {name} = {val!r}")




def check_bool(name, val):
    """``True`` or ``False`` (TOML ``true``/``false``); raises :class:`ConfigError`."""
    if not isinstance(val, bool):
        raise ConfigError(f"{name} must be true or false, got {name} = {val!r}")


def check_numbers(name, val):
    """A non-empty list of numbers (a single number is a list of one; ``'inf'`` is inf).

    Returns
    -------
    tuple of float

    Raises
    ------
    ConfigError
        Empty, not a list, or an element that is not a number (NaN included).
    """
    if isinstance(val, (int, float)) and not isinstance(val, bool):
        val = [val]
    if not isinstance(val, (list, tuple)) or not val:
        raise ConfigError(f"{name} must be a non-empty list of numbers, got "
                          f"{name} = {val!r}")
    out = []
    for v in val:
        if isinstance(v, str) and v.strip().lower() in ("inf", "infinity"):
            v = math.inf
        if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
            raise ConfigError(f"{name} must be a list of numbers, got {name} = {val!r}")
        out.append(float(v))
    return tuple(out)


def check_table(name, extra, reserved, owner, config_class=None):
    """A TOML table of extra fields of another configuration (e.g. ``[relax]``).

    Parameters
    ----------
    name : str
        Key of the table (``relax``, ``frictional_relax``).
    extra : object
        Its value: must be a mapping.
    reserved : iterable of str, or mapping of str to str or None
        Keys the job sets itself (refused here, named in the message). A
        mapping gives, per key, what sets it instead (named in the message);
        None, or a plain iterable, says the top-level key of that name does.
    owner : str
        Who sets them, for the message (``'the paper job'``).
    config_class : type, optional
        A :class:`StageConfig` class that checks the values now (any existing
        file stands in for its data file, which is made later).

    Raises
    ------
    ConfigError
        Not a table, a reserved key, or (through ``config_class``) an unknown
        key or a bad value, each named.
    """
    if not isinstance(extra, dict):
        cls = config_class.__name__ if config_class else "configuration"
        raise ConfigError(f"{name} must be a table of {cls} fields, got {name} = {extra!r}")
    bad = sorted(set(extra) & set(reserved))
    if bad:
        why = reserved.get(bad[0]) if isinstance(reserved, dict) else None
        instead = why or f"use the top-level key {bad[0]!r} instead"
        raise ConfigError(f"{name}.{bad[0]} is set by {owner} itself; {instead}, "
                          f"got {name} = {extra!r}")
    if config_class is not None:
        config_class.from_dict(dict(extra, datafile=__file__))


def plain_value(val):
    """``val`` with NumPy scalars made Python scalars (``np.int64(3)`` -> ``3``),
    inside lists, tuples and dicts too, and a NumPy array a list
    (``np.arange(1, 4)`` -> ``[1, 2, 3]``); anything else unchanged.

    So that a value taken from an array (a loop over ``np.arange``) passes
    the checks as the same Python number would, and ``config.json`` holds
    plain numbers.
    """
    if isinstance(val, np.generic):
        return val.item()
    if isinstance(val, np.ndarray):
        return val.tolist()
    if isinstance(val, (list, tuple)):
        return type(val)(plain_value(v) for v in val)
    if isinstance(val, dict):
        return {k: plain_value(v) for k, v in val.items()}
    return val


def _narrow_float(val):
    """A NumPy float narrower than float64 inside ``val`` (scalar, array, or in
    a list, tuple or dict) whose float64 value is not the number it prints
    as (``np.float32(1e-3)``, not ``np.float32(2e5)``), else None."""
    if isinstance(val, (np.floating, np.ndarray)) and val.dtype.kind == "f" and \
            val.dtype.itemsize < 8:
        flat = np.ravel(val)
        if any(float(x) != float(str(x)) for x in flat):
            return val
        return None
    if isinstance(val, (list, tuple)):
        return next((v for v in map(_narrow_float, val) if v is not None), None)
    if isinstance(val, dict):
        return _narrow_float(list(val.values()))
    return None


def _plain_fields(obj):
    """Set every field of the frozen dataclass ``obj`` to its :func:`plain_value`.

    A float32 (or narrower) value that float64 does not hold as it prints is
    refused: its rounding would enter every load and the Jacobian
    (``np.float32(1e-3)`` became 0.0010000000474974513).
    """
    for f in fields(obj):
        val = getattr(obj, f.name)
        narrow = _narrow_float(val)
        if narrow is not None:
            raise ConfigError(f"{f.name} must be float64 (or a Python float), got a "
                              f"{narrow.dtype} value that float64 holds as another number: "
                              f"{f.name} = {val!r}")
        new = plain_value(val)
        if new is not val:
            object.__setattr__(obj, f.name, new)


class Config:
    """What every configuration dataclass shares: its field names, building
    from a mapping that may not hold unknown keys, and a plain dict.

    NumPy scalars among the values are made Python scalars before the
    subclass's checks run (:func:`plain_value`).
    """

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        post = cls.__dict__.get("__post_init__")
        if post is None:
            return

        @functools.wraps(post)
        def __post_init__(self):
            _plain_fields(self)
            post(self)

        cls.__post_init__ = __post_init__

    @classmethod
    def names(cls):
        """Names of all fields."""
        return [f.name for f in fields(cls)]

    @classmethod
    def field_help(cls):
        """One line of help per field, from the class's numpydoc ``Attributes``
        section (the docstring is the one source): the description's first
        sentence and its ``Default ...`` sentence, without reST markup; a
        shared entry (``B, w, mu_ss : float``) names its fields. For the
        command line's --help.

        Returns
        -------
        dict
            Field name -> text (a literal % doubled, as argparse needs).
        """
        import inspect
        import re

        doc = inspect.getdoc(cls).split("Attributes\n----------\n", 1)[1]
        out, names, lines = {}, [], []

        def flush():
            # plain text: no reST roles (:data:`DIM3` -> DIM3) or literals (``top``)
            text = re.sub(r":\w+:`~?([^`]+)`", r"\1", " ".join(lines)).replace("``", "")
            sentences = re.split(r"(?<=[.)])\s+(?=[A-Z])", text)
            default = next((t for t in sentences[1:]
                            if t.startswith(("Default", "None (default)"))), None)
            which = f" ({', '.join(names)})" if len(names) > 1 else ""
            for name in names:
                out[name] = (sentences[0] + (" " + default if default else "")
                             + which).replace("%", "%%")

        for line in doc.splitlines():
            if line and not line.startswith(" "):            # "name : type"
                if names:
                    flush()
                names, lines = [n.strip() for n in line.split(" : ")[0].split(",")], []
            elif line.strip():
                lines.append(line.strip())
        if names:
            flush()
        return out

    @classmethod
    def from_dict(cls, data):
        """Build from a mapping, validated.

        Raises
        ------
        ConfigError
            An unknown key (named, with the known ones) or a bad value.
        """
        names = set(cls.names())
        unknown = sorted(set(data) - names)
        if unknown:
            raise ConfigError(f"unknown configuration key {unknown[0]!r}"
                              + (f" (and {', '.join(map(repr, unknown[1:]))})"
                                 if len(unknown) > 1 else "")
                              + f" for {cls.__name__}; known keys: "
                              + ", ".join(sorted(names)))
        return cls(**dict(data))

    def to_dict(self):
        """Plain dict of all fields (tuples as lists)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def parse_set(items):
    """``--set KEY=VALUE`` items as overrides: VALUE as JSON, else ``true``,
    ``false``, ``inf`` or the text itself.

    Raises
    ------
    ConfigError
        An item without ``=``.
    """
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


def read_config_file(path):
    """Read a configuration file into a dict (keys checked later): TOML, or
    JSON where the name ends in ``.json`` (the ``config.json`` a job writes,
    whose ``null`` values TOML cannot write).

    Parameters
    ----------
    path : str
        File name.

    Returns
    -------
    dict

    Raises
    ------
    ConfigError
        If the file is missing, not valid TOML or JSON, or a JSON file whose
        top level is not an object (the message names the file).
    """
    if os.path.isdir(path):
        raise ConfigError(f"config file is a folder, not a TOML or JSON file: {path!r}")
    if not os.path.isfile(path):
        raise ConfigError(f"config file does not exist: {path!r}")
    if path.lower().endswith(".json"):
        try:
            with open(path) as fh:
                d = json.load(fh)
        except ValueError as exc:
            raise ConfigError(f"config file {path!r} is not valid JSON: {exc}") from None
        if not isinstance(d, dict):
            raise ConfigError(f"config file {path!r} holds a JSON {type(d).__name__}, not "
                              "an object of configuration keys")
        return d
    try:
        import tomllib
    except ImportError:  # Python 3.10
        try:
            import tomli as tomllib
        except ImportError:
            raise ConfigError("reading a TOML config needs Python >= 3.11 (tomllib) or the "
                              "tomli package") from None
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"config file {path!r} is not valid TOML: {exc}") from None


def layered_config(toml, overrides, quick, preset, tables=()):
    """Defaults < ``preset`` (with ``quick``) < TOML file < ``overrides``, as one dict.

    ``quick`` is also taken from the overrides or the file; the keys in
    ``tables`` (TOML tables such as ``relax``) are merged key by key.

    Raises
    ------
    ConfigError
        Unreadable or malformed configuration file.
    """
    from_file = read_config_file(toml) if toml else {}
    overrides = dict(overrides or {})
    quick = bool(quick or overrides.get("quick") or from_file.get("quick") is True)
    d = {}
    if quick:
        d.update({k: (dict(v) if isinstance(v, dict) else v) for k, v in preset.items()})
    for src in (from_file, overrides):
        for k, v in src.items():
            if k in tables and isinstance(v, dict) and isinstance(d.get(k), dict):
                d[k] = dict(d[k], **v)
            else:
                d[k] = v
    if quick:
        d["quick"] = True
    return d


@dataclass(frozen=True)
class ContactModel:
    """The model's parameters: one type and one validator for every configuration.

    Every stage configuration (:class:`StageConfig`), the paper's
    (:class:`~remote_trigger.pywrap.jobs.paper.config.PaperConfig`) and the
    ensemble's carry these four fields under the same names, validate them
    with this class and get the same defaults from it (docs/model.md).

    Attributes
    ----------
    k_n : float
        Normal stiffness (Eq. 1), > 0. Default 2e5.
    k_t : float or None
        Tangential stiffness (Eq. 3), >= 0; None means 2 k_n / 7
        (:func:`~remote_trigger.analysis.state.sidecar.default_k_t`), filled in.
    mu : float
        Friction coefficient (Eq. 2, static mu_0), >= 0. Default 1.
    F_y : float
        Downward load on each ``top`` disk, > 0. Default 3.

    Raises
    ------
    ConfigError
        A value out of range, named with its value.
    """

    k_n: float = 2e5
    k_t: float = None
    mu: float = 1.0
    F_y: float = 3.0

    def __post_init__(self):
        _plain_fields(self)
        check_positive("k_n", self.k_n)
        if self.k_t is None:
            object.__setattr__(self, "k_t", default_k_t(self.k_n))
        check_nonnegative("k_t", self.k_t)
        check_nonnegative("mu", self.mu)
        check_positive("F_y", self.F_y)

    @classmethod
    def of(cls, cfg):
        """The model of any configuration object with these four fields."""
        return cls(k_n=cfg.k_n, k_t=cfg.k_t, mu=cfg.mu, F_y=cfg.F_y)

    def as_dict(self):
        """``{'k_n', 'k_t', 'mu', 'F_y'}`` as floats."""
        return {"k_n": float(self.k_n), "k_t": float(self.k_t), "mu": float(self.mu),
                "F_y": float(self.F_y)}
