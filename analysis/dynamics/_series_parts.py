"""Private parts of :mod:`~remote_trigger.analysis.dynamics.series`: the check of
its inputs (times and series of one run: 1-D, of one length, finite, t
increasing) and the constant-rate cut of its growth window."""
import numpy as np


def check_series(func, t, **series):
    """``t`` and each named series: 1-D arrays of one length, every value
    finite, ``t`` increasing (the records of one run, in time order).

    Returns the float64 arrays, ``t`` first, then the series in their order.

    Raises
    ------
    ValueError
        Naming ``func``, the arguments and their shapes, the first
        non-finite value, or the first time not after its predecessor.
    """
    arrays = {}
    for name, a in dict(t=t, **series).items():
        try:
            arrays[name] = np.asarray(a, np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{func}: {name} must be a 1-D array of numbers, got "
                             f"{type(a).__name__} {str(a)[:40]}") from None
    shapes = [a.shape for a in arrays.values()]
    if any(len(sh) != 1 for sh in shapes) or len(set(shapes)) != 1:
        # (growth_window(t, D[:10], ...) returned (None, nan); growth_fit and
        # exp_rate were raw broadcasting / indexing errors)
        names = list(arrays)
        raise ValueError(f"{func}: {', '.join(names[:-1])} and {names[-1]} must be 1-D arrays "
                         f"of one length, got shapes "
                         f"{', '.join(str(sh) for sh in shapes[:-1])} and {shapes[-1]}")
    for name, a in arrays.items():
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ValueError(f"{func}: {name} must be finite, got {bad.size} non-finite "
                             f"value(s), the first {float(a[bad[0]])!r} at index {int(bad[0])}")
    t = arrays["t"]
    # (a reversed or shuffled t gave a growth rate of the wrong sign, or NaN)
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        i = int(back[0]) + 1
        raise ValueError(f"{func}: t must be increasing (records in time order), got "
                         f"t[{i}] = {float(t[i])!r} after t[{i - 1}] = {float(t[i - 1])!r}")
    return tuple(arrays.values())


def constant_rate_end(t, D, i0, i1, chunks, rtol):
    """Last index of the constant-rate part of [i0, i1] (see
    :func:`~remote_trigger.analysis.dynamics.series.growth_window`)."""
    if not (D[i0] > 0 and np.log10(D[i1] / D[i0]) >= chunks):
        return i1                     # pieces of less than a decade: rates too noisy
    edges = np.linspace(t[i0], t[i1], chunks + 1)
    rates, ends = [], []
    for k in range(chunks):
        sel = (t >= edges[k]) & (t <= edges[k + 1]) & (D > 0)
        sel[:i0] = False
        sel[i1 + 1:] = False
        if np.count_nonzero(sel) < 3:
            return i1
        rates.append(float(np.polyfit(t[sel], np.log(D[sel]), 1)[0] / 2.0))
        ends.append(int(np.flatnonzero(sel)[0]))
    for k in range(1, chunks):
        ref = float(np.median(rates[:k]))
        if ref > 0 and abs(rates[k] - ref) > rtol * ref:
            return max(i0, ends[k] - 1)
    return i1
