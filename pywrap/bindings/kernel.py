"""The C++ contact-law kernel, called through ctypes.

This is the very code the pair style and the wall fix run
(``pair_mindlin_smooth/mindlin_smooth_kernel.h``), built into
``libmindlin_smooth_kernel.so`` next to the plugin. It exists for tests and
cross-checks: the analyzer's vectorized Jacobian is compared with it, and it
is compared with hand-evaluated values and finite differences.

Sign conventions are those of ``docs/conventions.md``: ``xi`` is the signed
tangential displacement along s = (n_y, -n_x); forces are on disk i. The
functions ending in 3 are the 3D law (``mindlin_smooth_kernel_3d.h``), with
the tangential displacement a vector t.
"""
import ctypes
from functools import lru_cache

import numpy as np

from remote_trigger.pywrap.bindings._plugin import KERNEL_LIBRARY

_D = ctypes.c_double
_P = ctypes.POINTER(ctypes.c_double)


@lru_cache(maxsize=1)
def _lib():
    lib = ctypes.CDLL(KERNEL_LIBRARY)
    for name, nargs in [("ms_evaluate", 5), ("ms_derivatives", 5), ("ms_pair_force", 8),
                        ("ms_pair_stiffness", 8), ("ms_wall_force", 5),
                        ("ms_wall_stiffness", 5)]:
        fn = getattr(lib, name)
        fn.argtypes = [_D] * nargs + [_P]
        fn.restype = None
    lib.ms_evaluate3.argtypes = [_D] * 7 + [_P]
    lib.ms_step3.argtypes = [_D] * 4 + [_P] * 4 + [_D, _P]
    lib.ms_pair_force3.argtypes = [_D] * 3 + [_P, _D, _D, _P, _P]
    for name in ("ms_evaluate3", "ms_step3", "ms_pair_force3"):
        getattr(lib, name).restype = None
    return lib


def _call(name, n_out, *args):
    out = np.zeros(n_out, dtype=np.float64)
    getattr(_lib(), name)(*[float(a) for a in args], out.ctypes.data_as(_P))
    return out


def evaluate(kn, kt, mu, delta, xi_trial):
    """Contact response after the Coulomb cap (Eq. 3).

    Parameters
    ----------
    kn, kt : float
        Normal and tangential stiffness, force/length^{3/2}.
    mu : float
        Friction coefficient.
    delta : float
        Overlap (length), > 0.
    xi_trial : float
        Trial tangential displacement (length).

    Returns
    -------
    dict
        ``xi`` (capped), ``fn`` = k_n delta^{3/2}, ``ft`` (force along s on i),
        ``u`` = |xi|/t*, ``sliding`` (bool).
    """
    o = _call("ms_evaluate", 5, kn, kt, mu, delta, xi_trial)
    return {"xi": o[0], "fn": o[1], "ft": o[2], "u": o[3], "sliding": bool(o[4])}


def derivatives(kn, kt, mu, delta, xi_trial):
    """Return ``(dfn/ddelta, dft/ddelta, dft/dxi)`` with xi following the cap."""
    return tuple(_call("ms_derivatives", 3, kn, kt, mu, delta, xi_trial))


def pair_force(kn, kt, mu, dx, dy, ri, rj, xi):
    """Generalized force (F_x, F_y, T_i/R_i) on disk i; shape (3,)."""
    return _call("ms_pair_force", 3, kn, kt, mu, dx, dy, ri, rj, xi)


def pair_stiffness(kn, kt, mu, dx, dy, ri, rj, xi):
    """Rows of disk i of K = -dG/dq, q = (x_i, y_i, phi_i, x_j, y_j, phi_j); shape (3, 6)."""
    return _call("ms_pair_stiffness", 18, kn, kt, mu, dx, dy, ri, rj, xi).reshape(3, 6)


def wall_force(kn, kt, mu, delta, xi):
    """Generalized force (F_x, F_y, T/R) of the flat wall on a disk; shape (3,)."""
    return _call("ms_wall_force", 3, kn, kt, mu, delta, xi)


def wall_stiffness(kn, kt, mu, delta, xi):
    """K = -dG/dq of one wall contact, q = (x, y, phi); shape (3, 3)."""
    return _call("ms_wall_stiffness", 9, kn, kt, mu, delta, xi).reshape(3, 3)


def _vec(a):
    return np.ascontiguousarray(a, dtype=np.float64).reshape(3)


def _response3(o):
    return {"t": o[0:3].copy(), "fn": o[3], "ft": o[4:7].copy(), "u": o[7],
            "sliding": bool(o[8])}


def evaluate3(kn, kt, mu, delta, t_trial):
    """3D contact response after the Coulomb cap (Eq. 3 with a vector t).

    Parameters
    ----------
    kn, kt, mu, delta : float
        As in :func:`evaluate`.
    t_trial : array_like, shape (3,)
        Trial tangential displacement (length), in the tangent plane.

    Returns
    -------
    dict
        ``t`` (capped, shape (3,)), ``fn``, ``ft`` (tangential force on i,
        shape (3,)), ``u`` = |t|/t*, ``sliding`` (bool).
    """
    t = _vec(t_trial)
    return _response3(_call("ms_evaluate3", 9, kn, kt, mu, delta, *t))


def step3(kn, kt, mu, delta, n, stored, dv, w, dt):
    """One advancing 3D step: ``stored`` projected onto the plane normal to the
    unit vector ``n`` (length kept), plus ``dt`` times the slip velocity of
    ``dv`` = v_i - v_j and ``w`` = R_i omega_i + R_j omega_j, then capped.

    Returns the dict of :func:`evaluate3` with ``slip`` (shape (3,)) added.
    """
    out = np.zeros(12, dtype=np.float64)
    args = [_vec(a) for a in (n, stored, dv, w)]
    _lib().ms_step3(float(kn), float(kt), float(mu), float(delta),
                    *[a.ctypes.data_as(_P) for a in args], float(dt), out.ctypes.data_as(_P))
    res = _response3(out)
    res["slip"] = out[9:12].copy()
    return res


def pair_force3(kn, kt, mu, d, ri, rj, t):
    """Force and torque on sphere i, ``d`` = x_i - x_j, stored history ``t``
    (projected onto the current tangent plane); shape (6,) = (F, T_i)."""
    out = np.zeros(6, dtype=np.float64)
    dd, tt = _vec(d), _vec(t)
    _lib().ms_pair_force3(float(kn), float(kt), float(mu), dd.ctypes.data_as(_P), float(ri),
                          float(rj), tt.ctypes.data_as(_P), out.ctypes.data_as(_P))
    return out
