"""The model parameters that travel with a state: the sidecar JSON.

Every equilibrium the driver writes is ``X.data``, ``X.dump`` and
``X.dump.json`` (docs/conventions.md section 3); the sidecar holds the
parameters a state cannot carry: ``k_n, k_t, mu, wall_y, F_x, F_y, dt``.
A stage or an analysis started from ``X.data`` or ``X.dump`` takes the model
(:data:`MODEL_KEYS`) from that sidecar when the user gives none, and refuses
a value that contradicts it unless asked to override (:func:`merge_model`):
a state is an equilibrium only of the model it was made with.
"""
import math
import os

from remote_trigger.analysis.errors import InputError, is_real

__all__ = ["MODEL_KEYS", "sidecar_path", "read_sidecar", "merge_model", "default_k_t"]

#: parameters a stage or analysis takes from the start file's sidecar
MODEL_KEYS = ("F_x", "F_y", "mu", "k_n", "k_t")

def default_k_t(k_n):
    """The model's default tangential stiffness, k_t = 2 k_n / 7 (docs/model.md).

    The one place of this convention (LAMMPS' granular default ratio);
    every configuration whose ``k_t`` is None takes it from here.
    """
    return 2.0 * float(k_n) / 7.0


#: relative difference below which a given value agrees with the sidecar's
#: (a ramp's loads are F_x0 + k dF_x, e.g. 0.009000000000000001 for 0.009)
AGREE_RTOL = 1e-9


def sidecar_path(path):
    """The sidecar of a start file, or None if it has none.

    ``X.data`` -> ``X.dump.json``; ``X.dump`` -> ``X.dump.json``; the
    sidecar must exist.
    """
    path = os.fspath(path)
    stem = path[:-len(".data")] if path.endswith(".data") else path
    for cand in (stem + ".dump.json", path + ".json"):
        if os.path.isfile(cand):
            return cand
    return None


def read_sidecar(path):
    """The model values of a start file's sidecar (empty dict if it has none).

    Raises
    ------
    InputError
        If the sidecar is not valid JSON or a value is not a number.
    """
    from remote_trigger.analysis.state.dumpfile import load_sidecar

    side = sidecar_path(path)
    if side is None:
        return {}
    try:
        return load_sidecar(side[:-len(".json")])
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _agree(a, b):
    return math.isclose(float(a), float(b), rel_tol=AGREE_RTOL, abs_tol=0.0)


def merge_model(given, start, flags=None, override=False, keys=MODEL_KEYS):
    """Model values of a run: given values checked against the start file's sidecar.

    Parameters
    ----------
    given : dict
        Values the user gave (keys of ``keys``; None or absent = not given).
    start : str
        The start file (data file or dump); its sidecar is
        :func:`sidecar_path` ``(start)``.
    flags : dict, optional
        Option name of each key for messages (default ``--KEY``).
    override : bool
        Use given values even where they differ from the sidecar.
    keys : tuple of str
        The keys to merge.

    Returns
    -------
    values : dict
        For each key: the given value, else the sidecar's; keys in neither
        are absent (the caller's defaults apply). ``k_t`` is not taken from
        the sidecar when ``k_n`` is given and differs from the sidecar's (the
        default k_t = 2 k_n / 7 then follows the new k_n).
    source : str or None
        The sidecar used.

    Raises
    ------
    InputError
        A given value differs from the sidecar's (relative difference above
        :data:`AGREE_RTOL`) and ``override`` is False; the message names the
        option, both values and the sidecar. A key of ``given`` not in
        ``keys`` (``'Fx'`` was ignored) or a value that is not a real number.
    """
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise InputError(f"merge_model: unknown key(s) {', '.join(map(repr, unknown))}; "
                         f"the keys are {', '.join(keys)}")
    for key, val in given.items():
        if val is not None and not is_real(val):
            raise InputError(f"merge_model: {key} must be a real number, got {key} = {val!r}")
    flags = flags or {}
    side_file = sidecar_path(start)
    side = read_sidecar(start)
    values = {}
    for key in keys:
        val = given.get(key)
        old = side.get(key)
        if val is not None:
            if old is not None and not override and not _agree(val, old):
                flag = flags.get(key, f"--{key}")
                given_text = f"{flag}{val!r}" if flag.endswith("=") else f"{flag} {val!r}"
                raise InputError(
                    f"{given_text} contradicts {key} = {old!r} of the start state "
                    f"(sidecar {side_file}); leave {flag} out to use {old!r}, or give "
                    f"--override to use {val!r} anyway")
            values[key] = val
        elif old is not None:
            values[key] = old
    if ("k_t" in keys and given.get("k_t") is None and given.get("k_n") is not None
            and "k_n" in side and not _agree(given["k_n"], side["k_n"])):
        values.pop("k_t", None)
    return values, (side_file if side else None)
