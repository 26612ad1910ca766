r"""Normal form of the oscillatory instability (paper Eqs. 9-17, Section IV).

.. math::

   \ddot{\mathbf x} = -J\mathbf x + \mathbf f\cos\omega t - \frac{1}{\tau}\dot{\mathbf x},
   \qquad J = \begin{pmatrix}1-\delta & \eta\\ -\eta & 1+\delta\end{pmatrix},

with :math:`\nu = \eta/\delta`, eigenvalues :math:`\lambda_{1,2} = 1 \mp
\delta\sqrt{1-\nu^2}` (Eq. 11) and distance to the exceptional point
:math:`\epsilon = 1 - \nu`: real eigenvalues for :math:`\epsilon > 0`, a
complex pair for :math:`\epsilon < 0`. The forcing is
:math:`\mathbf f = F(1,-1)/\sqrt 2`, orthogonal to the coalescing
eigenvector :math:`(1,1)/\sqrt 2` (Eq. 15).

For :math:`\mathbf x(0) = (1,-1)/\sqrt 2`, :math:`\dot{\mathbf x}(0) = 0`,
no forcing and no damping, the amplitude
:math:`A = \max_t \max_k |x_k(t)|` obeys :math:`A\sqrt\epsilon \to 1` as
:math:`\epsilon \to 0` (Eq. 17; with the Euclidean norm the limit is
:math:`\sqrt 2`). The growth happens on the beat time
:math:`\tau_d = \sqrt 2/(\delta\sqrt\epsilon)` of Eq. (16). With damping
the paper's estimate is

.. math::

   A \approx \max_t \frac{1}{\sqrt\epsilon}\sin(t/\tau_d)\,e^{-t/\tau}
     = \frac{1}{\sqrt\epsilon}\,\frac{r}{\sqrt{1+r^2}}\,e^{-\arctan(r)/r},
   \qquad r = \tau/\tau_d ,

(Eq. 20-21)

so the giant amplification survives only while :math:`\tau_d \ll \tau`.

.. warning::

   The paper writes the damped solution with :math:`e^{-t/\tau}`, but the
   damping force :math:`-\dot{\mathbf x}/\tau` makes amplitudes decay as
   :math:`e^{-t/(2\tau)}` (roots :math:`s = -1/(2\tau) \pm i\sqrt\lambda`).
   :func:`damped_estimate` therefore uses :math:`r = 2\tau/\tau_d`; with the
   paper's :math:`r = \tau/\tau_d` the estimate is low by a factor 2 for
   :math:`\tau \lesssim \tau_d` (measured: 2.01 at :math:`\tau = \tau_d/30`).
   For :math:`\tau \ll \tau_d`, :math:`A \to 2\tau\delta/(\sqrt2\,e)`,
   independent of :math:`\epsilon`.

Pitfall: for small :math:`\epsilon` the homogeneous solution is a slow beat
(period ~ :math:`\tau_d`) of a fast oscillation (period :math:`2\pi`), so an
integration must cover many fast periods accurately; :func:`exact_solution`
gives the unforced solution in closed (modal) form as a reference.
"""
import math
from dataclasses import dataclass

import numpy as np
from remote_trigger.analysis.errors import is_integer
from remote_trigger.analysis.output import savefig_atomic

X0 = np.array([1.0, -1.0]) / math.sqrt(2.0)


def _check(delta, eps, tau=math.inf, allow_negative_eps=False):
    if not (np.isfinite(delta) and 0.0 < delta < 1.0):
        raise ValueError(f"delta must be in (0, 1), got {float(delta)!r}")
    if not np.isfinite(eps) or eps > 1.0 or (eps <= 0.0 and not allow_negative_eps):
        bound = "a finite number <= 1" if allow_negative_eps else "in (0, 1]"
        raise ValueError(f"eps must be {bound}, got {float(eps)!r}")
    if not (tau > 0.0):
        raise ValueError(f"tau must be > 0 (inf for no damping), got {float(tau)!r}")


def normal_form_matrix(delta, eps):
    """The matrix J of Eq. (9) at distance ``eps`` from the exceptional point.

    Parameters
    ----------
    delta : float
        Splitting parameter (half the splitting of the paper's Eqs. 9-10),
        0 < delta < 1.
    eps : float
        eps = 1 - eta/delta <= 1 (eta >= 0); the eigenvalues
        1 -+ delta sqrt(1 - (1 - eps)^2) (Eq. 11) are real for 0 <= eps <= 1
        and a complex pair for eps < 0.

    Returns
    -------
    ndarray, shape (2, 2)
        J = [[1 - delta, eta], [-eta, 1 + delta]], eta = delta (1 - eps).

    Raises
    ------
    ValueError
        If delta is not in (0, 1) or eps is not a finite number <= 1.
    """
    _check(delta, eps, allow_negative_eps=True)
    eta = delta * (1.0 - eps)
    return np.array([[1.0 - delta, eta], [-eta, 1.0 + delta]])


def eigenvalues(delta, eps):
    """Eigenvalues 1 -/+ delta sqrt(1 - nu^2) of J (Eq. 11), complex for eps < 0."""
    _check(delta, eps, allow_negative_eps=True)
    nu = 1.0 - eps
    root = np.sqrt(complex(1.0 - nu * nu))
    return np.array([1.0 - delta * root, 1.0 + delta * root])


def beat_time(delta, eps):
    """tau_d = sqrt(2)/(delta sqrt(eps)), the slow time of Eq. (16)."""
    _check(delta, eps)
    return math.sqrt(2.0) / (delta * math.sqrt(eps))


def damped_estimate(delta, eps, tau, paper=False):
    """Estimate of A with damping, max_t eps^-1/2 sin(t/tau_d) e^(-t/(2 tau)).

    Parameters
    ----------
    delta, eps, tau : float
    paper : bool, optional
        Use the paper's decay e^(-t/tau) (Eq. 20) instead of the correct
        e^(-t/(2 tau)) of the damping force -v/tau (see the module warning).

    Returns
    -------
    float
        (1/sqrt(eps)) r/sqrt(1+r^2) exp(-arctan(r)/r) with r = 2 tau/tau_d
        (tau/tau_d if ``paper``); 1/sqrt(eps) for tau = inf.
    """
    _check(delta, eps, tau)
    if math.isinf(tau):
        return 1.0 / math.sqrt(eps)
    r = (1.0 if paper else 2.0) * tau / beat_time(delta, eps)
    return r / math.sqrt(1.0 + r * r) * math.exp(-math.atan(r) / r) / math.sqrt(eps)


def exact_solution(delta, eps, tau, t):
    """Unforced solution from x(0) = (1,-1)/sqrt 2, v(0) = 0, in modal form.

    Uses the eigen-decomposition of the first-order 4 x 4 system (exact up
    to round-off and the conditioning of the eigenvectors, which grows like
    1/sqrt(eps) near the exceptional point).

    Parameters
    ----------
    delta, eps : float
    tau : float
        Damping time (inf for none).
    t : array_like, shape (nt,)

    Returns
    -------
    ndarray, shape (2, nt)
    """
    _check(delta, eps, tau, allow_negative_eps=True)
    J = normal_form_matrix(delta, eps)
    gamma = 0.0 if math.isinf(tau) else 1.0 / tau
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-J, -gamma * np.eye(2)]])
    w, V = np.linalg.eig(A)
    c = np.linalg.solve(V, np.concatenate([X0, [0.0, 0.0]]))
    t = np.asarray(t, dtype=np.float64)
    return (V[:2] @ (c[:, None] * np.exp(np.outer(w, t)))).real


@dataclass(frozen=True)
class NormalFormRun:
    """Result of :func:`integrate`.

    Attributes
    ----------
    t : ndarray, shape (nt,)
        Sample times (units of the fast period / 2 pi).
    x : ndarray, shape (2, nt)
        Solution at the sample times.
    amplitude : float
        A = max_t max_k |x_k(t)|, maximum of the dense output refined to
        round-off around the largest samples.
    nfev : int
        Right-hand-side evaluations used by the integrator.
    """
    t: np.ndarray
    x: np.ndarray
    amplitude: float
    nfev: int


def integrate(delta, eps, tau=math.inf, force=0.0, omega=0.01, t_max=None,
              method="DOP853", rtol=1e-10, atol=1e-12, samples_per_period=32):
    """Integrate the forced, damped normal form with scipy's ``solve_ivp``.

    Parameters
    ----------
    delta : float
        0 < delta < 1.
    eps : float
        Distance to the exceptional point, 0 < eps <= 1 (for eps < 0 the
        solution grows without bound: see :func:`exact_solution`).
    tau : float, optional
        Damping time; inf (default) for none.
    force : float, optional
        F of f = F (1,-1)/sqrt 2 (Eq. 15), finite; default 0.
    omega : float, optional
        Forcing frequency, finite, >= 0 (default 0.01, far from the natural
        frequency 1).
    t_max : float, optional
        End time; default min(2 tau_d, 40 tau) + 20: the undamped maximum is
        reached near (pi/2) tau_d, and by 40 tau amplitudes have decayed by
        e^-20 (decay rate 1/(2 tau)).
    method : {'DOP853', 'RK45', 'Radau', 'LSODA', ...}
        ``solve_ivp`` method.
    rtol, atol : float
        Tolerances of ``solve_ivp``.
    samples_per_period : int
        Dense-output samples per fast period 2 pi used to measure A, >= 2.

    Returns
    -------
    NormalFormRun

    Raises
    ------
    ValueError
        For parameters out of range or a failed integration.
    """
    from scipy.integrate import solve_ivp

    _check(delta, eps, tau)
    if not math.isfinite(force):
        raise ValueError(f"force must be a finite number, got force = {float(force)!r}")
    if not (math.isfinite(omega) and omega >= 0.0):
        raise ValueError(f"omega must be a finite number >= 0, got omega = {float(omega)!r}")
    if not is_integer(samples_per_period) or samples_per_period < 2:
        # (0 sampled t = [0, t_max] only, and the amplitude was that of two points)
        raise ValueError(f"samples_per_period must be an integer >= 2, got "
                         f"samples_per_period = {samples_per_period!r}")
    J = normal_form_matrix(delta, eps)
    gamma = 0.0 if math.isinf(tau) else 1.0 / tau
    fvec = force * X0
    if t_max is None:
        t_max = min(2.0 * beat_time(delta, eps), 40.0 * tau) + 20.0
    if not t_max > 0:
        raise ValueError(f"t_max must be > 0, got {t_max!r}")

    def rhs(t, y):
        x, v = y[:2], y[2:]
        a = -J @ x - gamma * v + fvec * math.cos(omega * t)
        return np.concatenate([v, a])

    sol = solve_ivp(rhs, (0.0, t_max), np.concatenate([X0, [0.0, 0.0]]), method=method,
                    rtol=rtol, atol=atol, dense_output=True)
    if not sol.success:
        raise ValueError(f"solve_ivp ({method}) failed: {sol.message}")
    n = int(samples_per_period * t_max / (2 * math.pi)) + 2
    t = np.linspace(0.0, t_max, n)
    x = sol.sol(t)[:2]
    return NormalFormRun(t=t, x=x, amplitude=_refined_max(sol.sol, t, x), nfev=int(sol.nfev))


def _refined_max(dense, t, x, ncand=8):
    """max_t max_k |x_k(t)|: refine the largest samples with bounded Brent.

    Sampling alone underestimates the maximum of an oscillation sampled
    m times per period by up to 1 - cos(pi/m) (5e-3 for m = 32).
    """
    from scipy.optimize import minimize_scalar

    absx = np.abs(x)
    flat = np.argsort(absx, axis=None)[-ncand:]
    best = float(absx.max())
    dt = t[1] - t[0]
    for k, i in zip(*np.unravel_index(flat, absx.shape)):
        lo, hi = max(t[0], t[i] - dt), min(t[-1], t[i] + dt)
        res = minimize_scalar(lambda s: -abs(dense(s)[k]), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-10 * max(1.0, abs(t[i]))})
        best = max(best, -float(res.fun))
    return best


def amplitude_scan(delta, eps_values, taus, **kw):
    """A for each (tau, eps) pair: array of shape (len(taus), len(eps_values))."""
    out = np.empty((len(taus), len(eps_values)))
    for a, tau in enumerate(taus):
        for b, eps in enumerate(eps_values):
            out[a, b] = integrate(delta, eps, tau=tau, **kw).amplitude
    return out


def register(subparsers):
    """Add the ``normal-form`` subcommand."""
    p = subparsers.add_parser(
        "normal-form", help="amplitude of the normal form vs distance to the exceptional point",
        description="Integrate the normal form (Eqs. 9-17) for a range of eps and damping "
                    "times tau; compare with A ~ eps^-1/2 and the damped estimate; plot.")
    p.add_argument("--delta", type=float, default=0.1, help="delta (default 0.1)")
    p.add_argument("--eps", type=float, nargs="+",
                   default=[1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4],
                   help="values of eps > 0 (default 1e-1 ... 1e-4)")
    p.add_argument("--tau", type=float, nargs="+", default=[math.inf, 3e3, 3e2, 3e1],
                   help="damping times (inf = none; default inf 3e3 3e2 3e1)")
    p.add_argument("--force", type=float, default=0.0, help="forcing amplitude F (default 0)")
    p.add_argument("--omega", type=float, default=0.01, help="forcing frequency (default 0.01)")
    p.add_argument("-o", "--out", default="normal-form", help="output folder (default normal-form)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an earlier normal_form.h5 in --out (default: refuse, exit "
                        "status 2)")
    p.set_defaults(func=main, serial=True)


def main(args):
    """``remote-trigger normal-form``; returns 0.

    Raises
    ------
    InputError
        ``--out`` is a file or cannot be made, or holds ``normal_form.h5``
        (without ``--overwrite``).
    """
    import os

    from remote_trigger.analysis.errors import InputError
    from remote_trigger.analysis.output import output_dir, write_h5_atomic

    output_dir(args.out, "-o/--out")
    if os.path.exists(os.path.join(args.out, "normal_form.h5")) and not args.overwrite:
        raise InputError(f"-o/--out {args.out!r} already holds normal_form.h5; give another "
                         "folder or --overwrite (nothing was overwritten)")
    eps = np.array(sorted(args.eps, reverse=True), dtype=np.float64)
    taus = np.array(args.tau, dtype=np.float64)
    amp = amplitude_scan(args.delta, eps, taus, force=args.force, omega=args.omega)
    est = np.array([[damped_estimate(args.delta, e, t) for e in eps] for t in taus])
    path = os.path.join(args.out, "normal_form.h5")
    write_h5_atomic(path, {"eps": eps, "tau": taus, "amplitude": amp, "estimate": est},
                    attrs={"delta": args.delta, "force": args.force, "omega": args.omega,
                           "source": "paper Eqs. 9-17"})
    png = os.path.join(args.out, "normal_form_amplitude.png")
    plot_amplitude(eps, taus, amp, est, args.delta, png)
    print(f"normal form, delta = {args.delta}: A sqrt(eps) (estimate) for each tau")
    cells = [[f"{amp[a, b] * np.sqrt(e):.4g} ({est[a, b] * np.sqrt(e):.3g})"
              for b, e in enumerate(eps)] for a in range(len(taus))]
    heads = [f"eps = {e:g}" for e in eps]
    width = [max(len(h), *(len(r[b]) for r in cells)) for b, h in enumerate(heads)]
    print(" " * 18 + "  ".join(h.ljust(w) for h, w in zip(heads, width)).rstrip())
    for a, tau in enumerate(taus):
        row = "  ".join(c.ljust(w) for c, w in zip(cells[a], width)).rstrip()
        print(f"  tau = {tau:>8g}: {row}")
    print(f"wrote {path} and {png}")
    return 0


def plot_amplitude(eps, taus, amp, est, delta, path):
    """Log-log plot of A vs eps for each tau, with the estimates dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    for a, tau in enumerate(taus):
        lab = r"$\tau=\infty$" if math.isinf(tau) else rf"$\tau={tau:g}$"
        line, = ax.loglog(eps, amp[a], "o-", label=lab)
        ax.loglog(eps, est[a], "--", color=line.get_color(), lw=1)
    ax.loglog(eps, eps ** -0.5, "k:", lw=1, label=r"$\epsilon^{-1/2}$")
    ax.set_xlabel(r"distance to the exceptional point $\epsilon = 1 - \eta/\delta$")
    ax.set_ylabel(r"amplitude $A = \max_t \max_k |x_k|$")
    ax.set_title(rf"normal form, $\delta = {delta:g}$ (dashed: damped estimate)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    savefig_atomic(fig, path, dpi=120)
    plt.close(fig)
