"""``remote-trigger ensemble``: F_x^c over packings, protocols, inertia and size.

The paper reports one packing of N = 100. This command measures the
distribution: for every seed of a list and every N of a list it generates a
packing (:func:`.packing.generate`), relaxes it with the driver's default
protocol (frictionless, then friction with zero history), ramps F_x at the
static friction mu0 and at the dynamic friction mu_ss mu0 (the ramp of
:func:`.stages.ramp`: certified decision at every equilibrium, bisection of
F_x^c), and records, per packing (docs/ensemble.md):

* the certified brackets [F_x_c_low, F_x_c_high] of F_x^c(mu0) and
  F_x^c(mu_ss mu0), their ratio and whether F_x^c(mu_ss mu0) < F_x^c(mu0)
  holds (certified: the brackets do not overlap);
* the packing fraction phi;
* the coalescing pair at the first certified complex point: lambda_c / lambda_max
  (real parts; lambda_max the stiffest eigenvalue of M^-1 K) and its mode index
  counted from the softest mode (1 = softest);
* the growth rate's slope s in g = s sqrt(F_x - F_x^c) just above onset,
  from the certified complex points within one ramp step of F_x^c: a least-
  squares line g^2 = s^2 (F_x - F_x0) (F_x0 is the extrapolated onset), or
  with one point s = g / sqrt(F_x - F_x^c) (F_x^c the bracket's midpoint);
* the **frictional** relaxation protocol (friction on during settling, as in
  the paper): stable at F_x = 0 or not, the number of certified complex
  pairs and max Im sqrt(lambda) there;
* the **I0 = 1 convention** (the paper's Jacobian): the equilibria of both
  ramps re-analysed with I = I0 m R^2, I0 = 1 in M (``read_dump(...,
  inertia_factor=1)``). The equilibria are those of the dynamics, which use
  I0 = 1/2: these rows are flagged ``dynamics_consistent = 0``. F_x^c under
  this convention is the bracket of the ramp's own equilibria with the
  certified decision recomputed (no new equilibria; if no pair is certified up
  to the ramp's last step only a lower bound is known).

One row of the table per packing and protocol/convention:

=========================  ===========  =====================================
protocol                   I0           what
=========================  ===========  =====================================
frictionless-then-friction 0.5          ramps, brackets, pair, slope
frictionless-then-friction 1.0          same equilibria, I0 = 1 analysis
frictional                 0.5          stability at F_x = 0
=========================  ===========  =====================================

Work is spread over MPI ranks: each rank runs its own LAMMPS instances on
``MPI.COMM_SELF``; packings are dealt round robin (largest N first). A
packing's result is written atomically to ``tasks/<key>.json`` when it is
finished; a job killed (also ``kill -9``) and run again with ``--resume``
keeps every finished packing and redoes the others from their start. One
packing's failure (no equilibrium, no certified bracket, any exception) is
recorded in its rows (``status``, ``reason``) and does not stop the others.
Rank 0 writes ``ensemble.h5``, ``ensemble.png`` and ``ensemble.md``.

.. warning::
   The I0 = 1 rows are an analysis convention, not a simulation: their
   eigenvalues do not predict the simulated motion (docs/model.md section 1).
"""
from dataclasses import dataclass, field, asdict
import json
import math
import os
import shutil
import time

import numpy as np

from .config import ConfigError, ContactModel, RelaxConfig, _int
from .paper_config import JobConfig, PaperConfig, PAPER, _num, layered_config
from remote_trigger.analysis.output import savefig_atomic, write_text_atomic
from .parallel import on_rank0
from .jobfolder import add_job_arguments, job_overrides

#: manifest of the job
MANIFEST = "ensemble.json"
#: file of the table
TABLE = "ensemble.h5"
#: moment of inertia factor of the dynamics (``fix nve/sphere ... disc``)
I0_DYNAMICS = 0.5
#: the paper's bracket of F_x^c(mu = 1) for its N = 100 packing
PAPER_BRACKET = (PAPER["F_x_c_mu1_low"], PAPER["F_x_c_mu1_high"])

_DEFAULT_SEEDS = (tuple(range(1, 21)), tuple(range(1, 6)))


# --------------------------------------------------------------------------- configuration
@dataclass(frozen=True)
class EnsembleConfig(JobConfig):
    """Configuration of ``remote-trigger ensemble``.

    Attributes
    ----------
    n : list of int
        System sizes N (disks, top line included), each even and >= 6, no
        repeats. Default [100, 400].
    seeds : list of int, or list of list of int
        Packing seeds (>= 0): one list used for every N, or one non-empty
        list per N. Default 1..20 for N = 100 and 1..5 for N = 400.
    phi : float
        Packing fraction of the generator's box, in (0.1, 0.91). Default 0.82.
    k_n, k_t, F_y, dt : float
        Model (docs/model.md; k_t None: 2 k_n / 7). Defaults as ``paper``.
    mu : float
        Static friction mu0, > 0. Default 1.
    mu_ss : float
        Dynamic friction as a fraction of mu0, in (0, 1]; the second ramp is
        at mu_ss mu0. Default 0.8 (paper).
    dF_x, tol, F_x_max : float
        Ramp step, bisection tolerance on F_x^c and largest F_x, > 0
        (``paper``'s defaults: 2.5e-4, 1e-7, 0.5).
    relax : dict
        Extra :class:`~remote_trigger.pywrap.config.RelaxConfig` fields for
        both relaxations (e.g. ``settle_steps``).
    frictional : bool
        Also relax every packing with the frictional protocol and analyse it
        at F_x = 0. Default True.
    frictional_relax : dict
        Extra RelaxConfig fields of the frictional relaxation only (applied
        after ``relax``); ``mu_settle`` defaults to ``mu`` (friction on
        during settling).
    inertia_I0 : float or None
        I0 of the alternative convention analysed (> 0, != 0.5); None: no
        such rows. Default 1 (the paper's Jacobian).
    inertia_extra_steps : int or None
        Largest number of ramp steps added above a ramp's end to find the
        onset under ``inertia_I0`` (:func:`inertia_points`), >= 0. Default
        None: 0.5 F_x_max / dF_x.
    keep_equilibria : bool
        Keep the ramps' equilibrium files (``ramp/step_*.data|dump``) after
        a packing is finished. Default False: only ``ramp.h5`` (every
        decision and eigenvalue) and the relaxed packings are kept (a ramp
        at N = 100 leaves ~25 MB of them).
    np : int
        MPI ranks (re-launch under mpirun), >= 1. Default 1.
    quick : bool
        The small test variant (:data:`QUICK`).

    Raises
    ------
    ConfigError
        Any bad value; the message names the key and the value.
    """

    n: tuple = (100, 400)
    seeds: tuple = _DEFAULT_SEEDS
    phi: float = PaperConfig.phi
    k_n: float = PaperConfig.k_n
    k_t: float = None
    F_y: float = PaperConfig.F_y
    dt: float = PaperConfig.dt
    mu: float = PaperConfig.mu
    mu_ss: float = PaperConfig.mu_ss
    dF_x: float = PaperConfig.dF_x
    tol: float = PaperConfig.tol
    F_x_max: float = PaperConfig.F_x_max
    relax: dict = field(default_factory=dict)
    frictional: bool = True
    frictional_relax: dict = field(default_factory=dict)
    inertia_I0: float = 1.0
    inertia_extra_steps: int = None
    keep_equilibria: bool = False
    np: int = 1
    quick: bool = False

    def __post_init__(self):
        n = self.n
        if isinstance(n, int) and not isinstance(n, bool):
            n = [n]
        if isinstance(n, (str, bytes)) or not hasattr(n, "__iter__") or not list(n):
            raise ConfigError(f"n must be a non-empty list of even integers >= 6, got "
                              f"n = {self.n!r}")
        n = list(n)
        for v in n:
            if isinstance(v, bool) or not isinstance(v, int) or v < 6 or v % 2:
                raise ConfigError(f"n must hold even integers >= 6 (equal numbers of both "
                                  f"radii), got n = {self.n!r}")
        if len(set(n)) != len(n):
            raise ConfigError(f"n must not repeat a size, got n = {self.n!r}")
        object.__setattr__(self, "n", tuple(n))
        object.__setattr__(self, "seeds", self._seeds(self.seeds, len(n)))
        if not 0.1 < _num("phi", self.phi) < 0.91:
            raise ConfigError(f"phi must be in (0.1, 0.91), got phi = {self.phi!r}")
        _num("mu", self.mu, 0, lo_open=True)          # the paper's model has friction
        object.__setattr__(self, "k_t", ContactModel.of(self).k_t)
        for name in ("dt", "dF_x", "tol", "F_x_max"):
            _num(name, getattr(self, name), 0, lo_open=True)
        if not 0.0 < _num("mu_ss", self.mu_ss) <= 1.0:
            raise ConfigError(f"mu_ss must be in (0, 1] (a fraction of mu), got "
                              f"mu_ss = {self.mu_ss!r}")
        if self.dF_x >= self.F_x_max:
            raise ConfigError(f"dF_x must be < F_x_max = {self.F_x_max!r}, got "
                              f"dF_x = {self.dF_x!r}")
        for name in ("frictional", "keep_equilibria", "quick"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name} must be true or false, got "
                                  f"{name} = {getattr(self, name)!r}")
        if self.inertia_I0 is not None:
            _num("inertia_I0", self.inertia_I0, 0, lo_open=True)
            if float(self.inertia_I0) == I0_DYNAMICS:
                raise ConfigError(f"inertia_I0 must differ from the dynamics' I0 = "
                                  f"{I0_DYNAMICS} (those rows are always there), got "
                                  f"inertia_I0 = {self.inertia_I0!r}")
        if self.inertia_extra_steps is not None:
            _int("inertia_extra_steps", self.inertia_extra_steps, 0)
        for name in ("relax", "frictional_relax"):
            self._check_relax(name, getattr(self, name))
        _int("np", self.np, 1)

    @staticmethod
    def _seeds(seeds, n_sizes):
        bad = ConfigError(f"seeds must be a non-empty list of integers >= 0, or one such "
                          f"list per N ({n_sizes}), got seeds = {seeds!r}")
        if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__iter__"):
            raise bad
        seeds = list(seeds)
        if not seeds:
            raise bad
        nested = all(isinstance(s, (list, tuple)) for s in seeds)
        per_n = [list(s) for s in seeds] if nested else [seeds] * n_sizes
        if len(per_n) != n_sizes:
            raise bad
        for lst in per_n:
            if not lst:
                raise bad
            for s in lst:
                if isinstance(s, bool) or not isinstance(s, int) or s < 0:
                    raise bad
            if len(set(lst)) != len(lst):
                raise ConfigError(f"seeds must not repeat a seed for one N, got "
                                  f"seeds = {seeds!r}")
        return tuple(tuple(lst) for lst in per_n)

    @staticmethod
    def _check_relax(name, extra):
        if not isinstance(extra, dict):
            raise ConfigError(f"{name} must be a table of RelaxConfig fields, got "
                              f"{name} = {extra!r}")
        reserved = sorted(set(extra) & {"datafile", "k_n", "k_t", "mu", "F_y", "dt", "F_x",
                                        "protocol"})
        if reserved:
            raise ConfigError(f"{name}.{reserved[0]} is set by the ensemble itself, got "
                              f"{name} = {extra!r}")
        # values are checked by RelaxConfig itself (any existing file stands in for
        # the data file, which is made later)
        RelaxConfig.from_dict(dict(extra, datafile=__file__))

    def to_dict(self):
        """Plain dict (lists for tuples)."""
        d = asdict(self)
        d["n"] = list(self.n)
        d["seeds"] = [list(s) for s in self.seeds]
        return d

    def packings(self):
        """The packings, in table order.

        Returns
        -------
        list of dict
            ``key`` (``'N<n>_s<seed>'``), ``n``, ``seed``.
        """
        return [{"key": f"N{n}_s{s}", "n": n, "seed": s}
                for n, ss in zip(self.n, self.seeds) for s in ss]


#: the ``--quick`` preset: three tiny packings, coarse ramps
QUICK = {"n": [16, 20], "seeds": [[1, 2], [1]], "dF_x": 1e-2, "tol": 2e-3,
         "relax": {"settle_steps": 10000}, "frictional_relax": {"max_steps": 50000},
         "inertia_extra_steps": 4}


def build_config(toml=None, overrides=None, quick=False):
    """Defaults < quick preset < TOML file < overrides; returns :class:`EnsembleConfig`.

    The tables ``relax`` and ``frictional_relax`` are merged key by key.

    Raises
    ------
    ConfigError
        Unknown key (named), bad value (named), unreadable file.
    """
    return EnsembleConfig.from_dict(layered_config(toml, overrides, quick, QUICK,
                                                    ("relax", "frictional_relax")))


# --------------------------------------------------------------------------- spectra
def spectrum(state):
    """Certified spectrum of one state (the ramp's dense path).

    Parameters
    ----------
    state : remote_trigger.analysis.state.State
        Its ``inertia`` sets the mass matrix M = diag(m, m, I / R^2).

    Returns
    -------
    dict
        ``decision`` (1 complex, 0 real, -1 undecided), ``confidence``,
        ``eigenvalues`` (complex, shape (M,), eigenvalues of M^-1 K after
        rattler removal, 1/time^2, sorted by real part), ``n_pairs`` (pairs
        certified complex), ``growth`` (max |Im sqrt(lambda)|, 1/time).
    """
    from remote_trigger.analysis.analyze import analyze
    from remote_trigger.analysis import eigen, exceptional, jacobian

    res = analyze(state, eigenvalues=False, decide=False)
    keep = res.rattlers.keep_dofs
    if keep.size == 0:
        return {"decision": 0, "confidence": math.inf, "eigenvalues": np.zeros(0, complex),
                "n_pairs": 0, "growth": 0.0}
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, keep)
    dec = exceptional.classify_spectrum(eigen.dynamical_matrix(Kr, mr).toarray())
    lam = np.asarray(dec.eigenvalues, np.complex128)
    lam = lam[np.lexsort((lam.imag, lam.real))]
    code = -1 if dec.complex_present is None else int(bool(dec.complex_present))
    n_pairs = sum(1 for p in dec.pairs
                  if p.method != "gershgorin" and p.is_complex and p.certified)
    return {"decision": code, "confidence": float(dec.confidence), "eigenvalues": lam,
            "n_pairs": int(n_pairs), "growth": float(eigen.growth_rate(lam))}


def read_ramp(h5):
    """Every equilibrium of a ramp, in increasing F_x.

    Parameters
    ----------
    h5 : str
        ``ramp.h5`` of :func:`.stages.ramp`.

    Returns
    -------
    list of dict
        ``F_x``, ``decision`` (1, 0, -1), ``growth`` (1/time), ``dump``
        (equilibrium dump), ``eigenvalues`` (complex, sorted by real part,
        I0 = 1/2). Bisection points without an equilibrium are left out.
    """
    import h5py

    pts = []
    with h5py.File(h5, "r") as fh:
        for kind, stem in (("steps", "step_{:05d}"), ("bisection", "bisect_{:03d}")):
            if kind not in fh:
                continue
            F = fh[f"{kind}/F_x"][()]
            dec = fh[f"{kind}/decision"][()]
            g = fh[f"{kind}/growth_rate"][()]
            files = [x.decode() if isinstance(x, bytes) else str(x)
                     for x in fh[f"{kind}/datafile"][()]]
            for k in range(len(F)):
                if not np.isfinite(dec[k]):
                    continue
                name = f"eigenvalues/{kind}/{stem.format(k)}"
                lam = np.asarray(fh[name][()], complex) if name in fh else np.zeros(0, complex)
                lam = lam[np.lexsort((lam.imag, lam.real))]
                pts.append({"F_x": float(F[k]), "decision": int(dec[k]), "growth": float(g[k]),
                            "dump": files[k][:-len(".data")] + ".dump", "eigenvalues": lam})
    pts.sort(key=lambda p: p["F_x"])
    return pts


def bracket(points):
    """Certified bracket of F_x^c from points with decisions (the ramp's rule).

    ``hi`` is the smallest F_x certified complex, ``lo`` the largest F_x
    certified real below it; undecided points are neither.

    Parameters
    ----------
    points : list of dict
        Each with ``F_x`` and ``decision`` (1, 0, -1).

    Returns
    -------
    lo, hi : float
        ``hi`` = inf when no point is certified complex (``lo`` is then the
        largest certified real F_x: a lower bound of F_x^c); NaN when there is
        no such point.
    """
    cx = [p["F_x"] for p in points if p["decision"] == 1]
    hi = min(cx) if cx else math.inf
    real = [p["F_x"] for p in points if p["decision"] == 0 and p["F_x"] < hi]
    lo = max(real) if real else math.nan
    return float(lo), float(hi)


def pair_position(eigenvalues):
    """Where the coalesced pair sits in the spectrum.

    Parameters
    ----------
    eigenvalues : ndarray of complex, shape (M,)
        Spectrum of M^-1 K with a complex pair.

    Returns
    -------
    dict
        ``lambda_c`` (the pair of largest |Im sqrt(lambda)|, [Re, |Im|]),
        ``pair_re_rel`` = Re lambda_c / max Re lambda, ``pair_index`` (1-based
        index of the pair counted from the softest mode: 1 + the number of
        eigenvalues with smaller real part), ``n_dof`` (M).
    """
    lam = np.asarray(eigenvalues, complex)
    g = np.abs(np.sqrt(lam).imag)
    c = lam[int(np.argmax(g))]
    below = int(np.count_nonzero(lam.real < c.real - 1e-12 * abs(c.real)))
    return {"lambda_c": [float(c.real), float(abs(c.imag))],
            "pair_re_rel": float(c.real / np.max(lam.real)), "pair_index": below + 1,
            "n_dof": int(lam.size)}


def growth_slope(F, g, lo, hi):
    """Slope s of the growth rate g = s sqrt(F_x - F_x^c) just above onset.

    Parameters
    ----------
    F, g : array_like, shape (P,)
        Loads certified complex near onset and their growth rates
        max |Im sqrt(lambda)| (1/time).
    lo, hi : float
        Certified bracket of F_x^c.

    Returns
    -------
    dict
        ``slope`` (1/(time sqrt(force))), ``F_x_onset_fit`` (onset F_x0 of
        the line g^2 = s^2 (F_x - F_x0); NaN with one point), ``n_points``.
        With two or more distinct loads, least squares on g^2; with one,
        s = g / sqrt(F_x - (lo + hi) / 2). NaN where undefined.
    """
    F, g = np.asarray(F, float), np.asarray(g, float)
    out = {"slope": math.nan, "F_x_onset_fit": math.nan, "n_points": int(F.size)}
    if F.size >= 2 and np.ptp(F) > 0:
        a, b = np.polyfit(F, g * g, 1)
        if a > 0:
            out.update(slope=float(math.sqrt(a)), F_x_onset_fit=float(-b / a))
    elif F.size == 1 and math.isfinite(lo) and math.isfinite(hi):
        d = F[0] - 0.5 * (lo + hi)
        if d > 0:
            out["slope"] = float(g[0] / math.sqrt(d))
    return out


def onset_numbers(points, dF_x):
    """Bracket, pair position and growth-rate slope of a ramp's points.

    Parameters
    ----------
    points : list of dict
        As from :func:`read_ramp` (decisions and eigenvalues of one
        convention).
    dF_x : float
        Ramp step: the slope uses the certified complex points within one
        step above F_x_c_high.

    Returns
    -------
    dict
        ``F_x_c_low``, ``F_x_c_high`` (see :func:`bracket`), ``n_undecided``,
        ``F_x_last`` (largest F_x analysed), the keys of :func:`pair_position`
        (NaN without a complex point) and of :func:`growth_slope`.
    """
    lo, hi = bracket(points)
    out = {"F_x_c_low": lo, "F_x_c_high": hi,
           "n_undecided": sum(1 for p in points if p["decision"] == -1),
           "F_x_last": max((p["F_x"] for p in points), default=math.nan),
           "lambda_c": [math.nan, math.nan], "pair_re_rel": math.nan, "pair_index": -1,
           "n_dof": -1, "slope": math.nan, "F_x_onset_fit": math.nan, "n_points": 0}
    if math.isfinite(hi):
        top = next(p for p in points if p["F_x"] == hi and p["decision"] == 1)
        out.update(pair_position(top["eigenvalues"]))
        near = [p for p in points if p["decision"] == 1 and p["F_x"] <= hi + dF_x * (1 + 1e-9)]
        out.update(growth_slope([p["F_x"] for p in near], [p["growth"] for p in near], lo, hi))
    return out


def reanalyse(points, I0):
    """The same equilibria with the moment of inertia I = I0 m R^2 in M.

    Only the mass matrix changes (K does not depend on the inertia); the
    certified decision is recomputed at every point.

    Parameters
    ----------
    points : list of dict
        From :func:`read_ramp` (their ``dump`` files must exist).
    I0 : float

    Returns
    -------
    list of dict
        Same keys, with ``decision``, ``growth`` and ``eigenvalues`` of the
        new convention.
    """
    from remote_trigger.analysis.state import read_dump

    out = []
    for p in points:
        s = spectrum(read_dump(p["dump"], require_contacts=False, inertia_factor=I0))
        out.append(dict(p, decision=s["decision"], growth=s["growth"],
                        eigenvalues=s["eigenvalues"]))
    return out


def _new_point(eng, rcfg, start_dump, F_x, prefix, I0):
    """Equilibrium at F_x from the equilibrium of ``start_dump`` (a ramp step), analysed
    with I0; returns the point dict, or None without an equilibrium."""
    from remote_trigger.analysis.state import read_dump
    from . import equilibrium as eq
    from .stages import load_relax_scene, save_equilibrium

    load_relax_scene(eng, rcfg, start_dump[:-len(".dump")] + ".data", F_x, deck="in.ramp_step")
    try:
        eq.equilibrate(eng, rcfg, F_x, newton_first=True)
    except eq.NoEquilibriumError:
        return None
    save_equilibrium(eng, rcfg, F_x, prefix)
    s = spectrum(read_dump(prefix + ".dump", require_contacts=False, inertia_factor=I0))
    return {"F_x": float(F_x), "decision": s["decision"], "growth": s["growth"],
            "dump": prefix + ".dump", "eigenvalues": s["eigenvalues"]}


def inertia_points(cfg, points, mu, I0, folder):
    """The ramp's equilibria under the convention I0, extended until F_x^c is bracketed.

    The ramp stops at its own first complex point (I0 = 1/2). Under another
    I0 the onset may lie above it: then the ramp is continued with the same
    step dF_x (new equilibria, each from the previous one, exactly as ramp
    steps) for at most ``inertia_extra_steps`` steps (default 0.5 F_x_max / dF_x),
    until a point is certified complex under I0. Inside the bracket the
    certified decision under I0 drives a bisection to ``tol``
    (:func:`.stages.next_bisection_point`, each point from the ``lo``
    equilibrium, as the ramp's).

    Parameters
    ----------
    cfg : EnsembleConfig
    points : list of dict
        :func:`read_ramp` of the ramp (I0 = 1/2).
    mu : float
        Friction of the ramp.
    I0 : float
    folder : str
        Where the new equilibria go (``I0_<I0>/``).

    Returns
    -------
    list of dict
        Every point (old and new), decisions and eigenvalues under I0, in
        increasing F_x; new ones have ``new`` = True.
    """
    from mpi4py import MPI
    from .engine import Engine
    from .paper import ramp_config
    from .stages import next_bisection_point

    pts = reanalyse(points, I0)
    if not pts:
        return pts
    lo, hi = bracket(pts)
    steps = [p for p in pts if p["F_x"] in {q["F_x"] for q in points}]
    if math.isfinite(hi) and (not math.isfinite(lo) or hi - lo <= cfg.tol):
        return pts
    rcfg = ramp_config(cfg, points[0]["dump"][:-len(".dump")] + ".data", mu)
    os.makedirs(folder, exist_ok=True)
    with Engine(comm=MPI.COMM_SELF) as eng:
        last = max(steps, key=lambda p: p["F_x"])
        k = 0
        k_max = (cfg.inertia_extra_steps if cfg.inertia_extra_steps is not None
                 else int(0.5 * cfg.F_x_max / cfg.dF_x))
        while not math.isfinite(hi) and k < k_max:
            k += 1
            F = last["F_x"] + cfg.dF_x
            p = _new_point(eng, rcfg, last["dump"], F, os.path.join(folder, f"ext_{k:04d}"),
                           I0)
            if p is None:
                break
            pts.append(dict(p, new=True))
            last = p
            lo, hi = bracket(pts)
        j = 0
        while math.isfinite(hi) and math.isfinite(lo):
            unknown = sorted(p["F_x"] for p in pts if p["decision"] == -1 and lo < p["F_x"] < hi)
            mid, _ = next_bisection_point(lo, hi, unknown, cfg.tol)
            if mid is None:
                break
            start = max((p for p in pts if p["F_x"] == lo and p["decision"] == 0),
                        key=lambda p: p["F_x"])
            p = _new_point(eng, rcfg, start["dump"], mid,
                           os.path.join(folder, f"bisect_{j:03d}"), I0)
            j += 1
            pts.append(dict(p, new=True) if p is not None else
                        {"F_x": mid, "decision": -1, "growth": math.nan, "dump": "",
                         "eigenvalues": np.zeros(0, complex), "new": True})
            lo, hi = bracket(pts)
    pts.sort(key=lambda p: p["F_x"])
    return pts


# --------------------------------------------------------------------------- one packing
def _relax(cfg, datafile, folder, protocol):
    """Relax ``datafile`` with ``protocol``; returns the RelaxResult."""
    from mpi4py import MPI
    from . import stages
    from .paper import relax_config

    rcfg = relax_config(cfg, datafile)
    if protocol == "frictional":
        extra = dict({"mu_settle": float(cfg.mu)}, **cfg.frictional_relax)
        rcfg = rcfg.replace(protocol="frictional", **extra)
    return stages.relax(rcfg, folder, comm=MPI.COMM_SELF, quiet=True)


def _ramp(cfg, datafile, mu, folder):
    """Ramp at friction ``mu`` from ``datafile``; returns the RampResult."""
    from mpi4py import MPI
    from . import stages
    from .paper import ramp_config

    return stages.ramp(ramp_config(cfg, datafile, mu), folder, comm=MPI.COMM_SELF, quiet=True)


def _ramp_part(cfg, relaxed, mu, folder):
    """One ramp and the onset numbers under both conventions (dict, JSON-ready)."""
    res = _ramp(cfg, relaxed, mu, folder)
    part = {"mu": float(mu), "ramp_status": res.status, "message": res.message,
            "n_steps": int(len(res.F_x)), "n_bisection": int(len(res.bisection_F_x)),
            "tol_reached": bool(res.tol_reached), "h5": res.h5}
    pts = read_ramp(res.h5)
    part["at_zero"] = ({"decision": pts[0]["decision"], "growth": pts[0]["growth"]}
                       if pts and pts[0]["F_x"] == 0.0 else None)
    part["I0_0.5"] = dict(onset_numbers(pts, cfg.dF_x), n_new=0,
                          tol_reached=bool(res.tol_reached))
    if cfg.inertia_I0 is not None and pts:
        I0 = float(cfg.inertia_I0)
        ipts = inertia_points(cfg, pts, mu, I0, os.path.join(folder, f"I0_{I0:g}"))
        o = onset_numbers(ipts, cfg.dF_x)
        o.update(n_new=sum(1 for p in ipts if p.get("new")),
                 tol_reached=bool(o["F_x_c_high"] - o["F_x_c_low"] <= cfg.tol))
        part[f"I0_{I0:g}"] = o
    return part


def _frictional_part(cfg, datafile, folder):
    """Frictional relaxation and its spectrum at F_x = 0 (dict, JSON-ready)."""
    from remote_trigger.analysis.state import read_dump

    rel = _relax(cfg, datafile, folder, "frictional")
    s = spectrum(read_dump(rel.dumpfile, require_contacts=False))
    return {"phi": rel.packing_fraction, "residual": rel.residual,
            "antisymmetry": rel.antisymmetry, "decision": s["decision"],
            "confidence": s["confidence"], "n_pairs": s["n_pairs"],
            "n_complex_eigenvalues": int(np.count_nonzero(s["eigenvalues"].imag != 0)),
            "growth": s["growth"]}


def _failure(exc):
    return f"{type(exc).__name__}: {exc}"


def run_packing(cfg, n, seed, folder):
    """Everything measured on one packing; failures are recorded, not raised.

    Parameters
    ----------
    cfg : EnsembleConfig
    n, seed : int
    folder : str
        Work folder (created; its previous content is removed).

    Returns
    -------
    dict
        ``default`` (relaxation summary and ``ramps``: one part per friction,
        see :func:`_ramp_part`), ``frictional`` (:func:`_frictional_part`),
        each with ``error`` (None or the reason), and ``wall`` (s).
    """
    from .packing import generate, write_data

    t0 = time.perf_counter()
    if os.path.isdir(folder):
        shutil.rmtree(folder)
    os.makedirs(folder)
    datafile = os.path.join(folder, "packing.data")
    result = {"n": n, "seed": seed, "default": {"error": None, "ramps": {}},
              "frictional": None}
    d = result["default"]
    try:
        write_data(generate(n, seed=seed, phi=cfg.phi), datafile)
        rel = _relax(cfg, datafile, os.path.join(folder, "default"), "frictionless-then-friction")
        d.update(phi=rel.packing_fraction, residual=rel.residual,
                 antisymmetry=rel.antisymmetry)
        for key, mu in (("mu0", cfg.mu), ("mu_ss", cfg.mu * cfg.mu_ss)):
            d["ramps"][key] = _ramp_part(cfg, rel.datafile, mu,
                                         os.path.join(folder, f"ramp_{key}"))
    except Exception as exc:  # noqa: BLE001 - recorded: one packing does not stop the others
        d["error"] = _failure(exc)
    if cfg.frictional:
        try:
            if not os.path.isfile(datafile):
                raise RuntimeError("no generated packing (see the default protocol's error)")
            result["frictional"] = dict(_frictional_part(
                cfg, datafile, os.path.join(folder, "frictional")), error=None)
        except Exception as exc:  # noqa: BLE001 - recorded
            result["frictional"] = {"error": _failure(exc)}
    if not cfg.keep_equilibria:
        for key in ("mu0", "mu_ss"):
            shutil.rmtree(os.path.join(folder, f"ramp_{key}", "ramp"), ignore_errors=True)
            if cfg.inertia_I0 is not None:
                shutil.rmtree(os.path.join(folder, f"ramp_{key}", f"I0_{cfg.inertia_I0:g}"),
                              ignore_errors=True)
    result["wall"] = time.perf_counter() - t0
    return result


# --------------------------------------------------------------------------- rows
#: string columns of the table
STR_COLS = ("key", "protocol", "status", "reason", "ramp_status_mu0", "ramp_status_mu_ss")
#: columns of the table, in order (numbers are float64; -1 / NaN = not measured)
COLUMNS = ("key", "n", "seed", "protocol", "I0", "dynamics_consistent", "status", "reason",
           "phi", "residual", "antisymmetry",
           "F_x_c_low", "F_x_c_high", "F_x_c", "F_x_c_ss_low", "F_x_c_ss_high", "F_x_c_ss",
           "ratio", "ratio_low", "ratio_high", "order", "pair_re_rel", "pair_index", "n_dof",
           "lambda_c_re", "lambda_c_im", "growth_slope", "F_x_onset_fit", "slope_points",
           "n_undecided", "n_steps", "n_bisection", "n_extra", "ramp_status_mu0", "ramp_status_mu_ss",
           "decision_at_zero", "n_pairs_at_zero", "growth_at_zero", "wall")


def _mid(lo, hi):
    return 0.5 * (lo + hi) if math.isfinite(lo) and math.isfinite(hi) else math.nan


def order_code(lo0, hi0, lo1, hi1):
    """Is F_x^c(mu_ss mu0) < F_x^c(mu0)? From the two certified brackets.

    Returns
    -------
    int
        1 certified (hi1 < lo0), 0 certified reversed (lo1 > hi0), -1 not
        decided (brackets overlap or missing).
    """
    if math.isfinite(hi1) and math.isfinite(lo0) and hi1 < lo0:
        return 1
    if math.isfinite(lo1) and math.isfinite(hi0) and lo1 > hi0:
        return 0
    return -1


def _empty_row(task, protocol, I0):
    row = {c: math.nan for c in COLUMNS}
    row.update(key=task["key"], n=task["n"], seed=task["seed"], protocol=protocol, I0=I0,
               dynamics_consistent=float(I0 == I0_DYNAMICS), status="failed", reason="",
               ramp_status_mu0="", ramp_status_mu_ss="", pair_index=-1, n_dof=-1,
               slope_points=0, order=-1, decision_at_zero=math.nan, n_extra=0)
    return row


def rows_of(task, result, cfg):
    """Table rows of one packing (see the module docstring).

    Returns
    -------
    list of dict
        Keys :data:`COLUMNS`. ``status``: ``'ok'`` (every bracket certified
        to ``tol``), ``'incomplete'`` (a bracket wider than tol, only a lower
        bound, or the second ramp missing: ``reason`` says which) or
        ``'failed'`` (``reason``).
    """
    rows = []
    d = result["default"]
    convs = [I0_DYNAMICS] + ([float(cfg.inertia_I0)] if cfg.inertia_I0 is not None else [])
    for I0 in convs:
        row = _empty_row(task, "frictionless-then-friction", I0)
        row["wall"] = result["wall"]
        for k in ("phi", "residual", "antisymmetry"):
            row[k] = d.get(k, math.nan)
        ck = f"I0_{I0:g}"
        r0, r1 = d["ramps"].get("mu0"), d["ramps"].get("mu_ss")
        why = []
        if d.get("error"):
            why.append(d["error"])
        for name, r in (("mu0", r0), ("mu_ss", r1)):
            if r is None:
                continue
            row[f"ramp_status_{name}"] = r["ramp_status"]
            if r["ramp_status"] != "complete":
                why.append(f"ramp {name} (mu = {r['mu']:g}): {r['ramp_status']}"
                           + (f" ({r['message']})" if r["message"] else ""))
            elif not r["tol_reached"]:
                why.append(f"ramp {name}: {r['message']}")
        if r0 is not None and ck in r0:
            o = r0[ck]
            row.update(F_x_c_low=o["F_x_c_low"], F_x_c_high=o["F_x_c_high"],
                       F_x_c=_mid(o["F_x_c_low"], o["F_x_c_high"]),
                       pair_re_rel=o["pair_re_rel"], pair_index=o["pair_index"],
                       n_dof=o["n_dof"], lambda_c_re=o["lambda_c"][0],
                       lambda_c_im=o["lambda_c"][1], growth_slope=o["slope"],
                       F_x_onset_fit=o["F_x_onset_fit"], slope_points=o["n_points"],
                       n_undecided=o["n_undecided"], n_steps=r0["n_steps"],
                       n_bisection=r0["n_bisection"])
            if r0.get("at_zero") and I0 == I0_DYNAMICS:
                row.update(decision_at_zero=r0["at_zero"]["decision"], n_pairs_at_zero=math.nan,
                           growth_at_zero=r0["at_zero"]["growth"])
            if I0 != I0_DYNAMICS:
                row["n_extra"] = o["n_new"] + r1.get(ck, {}).get("n_new", 0) if r1 else \
                    o["n_new"]
                if r0["ramp_status"] == "complete" and not math.isfinite(o["F_x_c_high"]):
                    why.append(f"I0 = {I0:g}: no pair certified complex up to F_x = "
                               f"{o['F_x_last']:.6g} at mu0 (F_x^c above it)")
                elif not o["tol_reached"] and r0["tol_reached"]:
                    why.append(f"I0 = {I0:g}: mu0 bracket wider than tol")
        if r1 is not None and ck in r1:
            o1 = r1[ck]
            row.update(F_x_c_ss_low=o1["F_x_c_low"], F_x_c_ss_high=o1["F_x_c_high"],
                       F_x_c_ss=_mid(o1["F_x_c_low"], o1["F_x_c_high"]))
            if I0 != I0_DYNAMICS and r1["ramp_status"] == "complete":
                if not math.isfinite(o1["F_x_c_high"]):
                    why.append(f"I0 = {I0:g}: no pair certified complex up to F_x = "
                               f"{o1['F_x_last']:.6g} at mu_ss mu0 (F_x^c above it)")
                elif not o1["tol_reached"] and r1["tol_reached"]:
                    why.append(f"I0 = {I0:g}: mu_ss mu0 bracket wider than tol")
        row["ratio"] = row["F_x_c_ss"] / row["F_x_c"] if row["F_x_c"] else math.nan
        if row["F_x_c_low"] > 0 and row["F_x_c_high"] > 0:
            row["ratio_low"] = row["F_x_c_ss_low"] / row["F_x_c_high"]
            row["ratio_high"] = row["F_x_c_ss_high"] / row["F_x_c_low"]
        row["order"] = order_code(row["F_x_c_low"], row["F_x_c_high"], row["F_x_c_ss_low"],
                                  row["F_x_c_ss_high"])
        if I0 != I0_DYNAMICS:
            why.append(f"analysis only: I0 = {I0:g} is inconsistent with the dynamics "
                       f"(I0 = {I0_DYNAMICS})")
        if not (math.isfinite(row["F_x_c_low"]) or math.isfinite(row["F_x_c_high"])):
            row["status"] = "failed"
        elif math.isfinite(row["F_x_c"]) and math.isfinite(row["F_x_c_ss"]) and \
                not d.get("error") and all(r is not None and r["tol_reached"]
                                           and r.get(ck, {}).get("tol_reached", False)
                                           for r in (r0, r1)):
            row["status"] = "ok"
        else:
            row["status"] = "incomplete"
        row["reason"] = "; ".join(why)
        rows.append(row)
    f = result.get("frictional")
    if f is not None:
        row = _empty_row(task, "frictional", I0_DYNAMICS)
        row["wall"] = result["wall"]
        if f.get("error"):
            row["reason"] = f["error"]
        else:
            row.update(status="ok", phi=f["phi"], residual=f["residual"],
                       antisymmetry=f["antisymmetry"], decision_at_zero=f["decision"],
                       n_pairs_at_zero=f["n_pairs"], growth_at_zero=f["growth"])
        rows.append(row)
    return rows


# --------------------------------------------------------------------------- statistics
def quartiles(x):
    """(count, q25, median, q75) of the finite values of x (NaN if none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not x.size:
        return 0, math.nan, math.nan, math.nan
    q = np.percentile(x, [25, 50, 75])
    return int(x.size), float(q[0]), float(q[1]), float(q[2])


def percentile_of(value, x):
    """Percentage of the finite values of x below ``value`` (NaN if none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(100.0 * np.mean(x < value)) if x.size else math.nan


def select(rows, protocol, I0, n=None, usable=True):
    """Rows of one protocol/convention (and size); ``usable``: status not 'failed'."""
    return [r for r in rows if r["protocol"] == protocol and r["I0"] == I0
            and (n is None or r["n"] == n) and (not usable or r["status"] != "failed")]


def statistics(rows, cfg):
    """The numbers of ``ensemble.md``.

    Returns
    -------
    dict
        ``per_n`` (per N and convention: quartiles of F_x^c(mu0), of the
        ratio, of phi, of the slope), ``order`` (per convention: counts of
        certified holds / reversed / undecided), ``frictional`` (per N:
        unstable fraction at F_x = 0), ``paper_percentile`` (per
        convention: percentiles of 0.0091 and 0.012 among F_x^c(mu0) at
        N = 100, or at every N if 100 is not in the ensemble),
        ``n_exponent`` (per convention: d ln median F_x^c / d ln N between
        the smallest and largest N).
    """
    ft = "frictionless-then-friction"
    convs = [I0_DYNAMICS] + ([float(cfg.inertia_I0)] if cfg.inertia_I0 is not None else [])
    st = {"per_n": [], "order": {}, "frictional": [], "paper_percentile": {},
          "n_exponent": {}}
    for I0 in convs:
        for n in cfg.n:
            sel = select(rows, ft, I0, n)
            st["per_n"].append({
                "n": n, "I0": I0, "n_packings": len(select(rows, ft, I0, n, usable=False)),
                "n_usable": len(sel),
                "F_x_c": quartiles([r["F_x_c"] for r in sel]),
                "F_x_c_ss": quartiles([r["F_x_c_ss"] for r in sel]),
                "ratio": quartiles([r["ratio"] for r in sel]),
                "phi": quartiles([r["phi"] for r in sel]),
                "slope": quartiles([r["growth_slope"] for r in sel]),
                "pair_re_rel": quartiles([r["pair_re_rel"] for r in sel]),
                "pair_index": quartiles([r["pair_index"] for r in sel if r["pair_index"] > 0])})
        codes = [r["order"] for r in select(rows, ft, I0, usable=False)]
        st["order"][I0] = {"holds": codes.count(1), "reversed": codes.count(0),
                           "undecided": codes.count(-1), "total": len(codes)}
        ref = [100] if 100 in cfg.n else list(cfg.n)
        x = [r["F_x_c"] for r in select(rows, ft, I0) if r["n"] in ref]
        st["paper_percentile"][I0] = {"n": ref, "count": int(np.sum(np.isfinite(x))),
                                      "low": percentile_of(PAPER_BRACKET[0], x),
                                      "high": percentile_of(PAPER_BRACKET[1], x)}
        meds = [(p["n"], p["F_x_c"][2]) for p in st["per_n"] if p["I0"] == I0
                and math.isfinite(p["F_x_c"][2]) and p["F_x_c"][2] > 0]
        if len(meds) >= 2 and meds[0][0] != meds[-1][0]:
            (n1, m1), (n2, m2) = meds[0], meds[-1]
            st["n_exponent"][I0] = math.log(m2 / m1) / math.log(n2 / n1)
    for n in cfg.n:
        fr = [r for r in rows if r["protocol"] == "frictional" and r["n"] == n]
        ok = [r for r in fr if r["status"] == "ok"]
        st["frictional"].append({
            "n": n, "n_packings": len(fr), "n_relaxed": len(ok),
            "unstable": sum(1 for r in ok if r["decision_at_zero"] == 1),
            "undecided": sum(1 for r in ok if r["decision_at_zero"] == -1),
            "pairs": quartiles([r["n_pairs_at_zero"] for r in ok]),
            "growth": quartiles([r["growth_at_zero"] for r in ok
                                 if r["decision_at_zero"] == 1])})
    return st


# --------------------------------------------------------------------------- outputs
def write_table(path, rows, cfg):
    """``ensemble.h5``: one dataset per column under ``rows/`` (docs/ensemble.md)."""
    from .results import write_atomic

    ds = {}
    for c in COLUMNS:
        vals = [r[c] for r in rows]
        ds[f"rows/{c}"] = (np.array([str(v) for v in vals], dtype=object) if c in STR_COLS
                           else np.asarray(vals, dtype=float))
    attrs = {"stage": "ensemble", "config": json.dumps(cfg.to_dict(), sort_keys=True),
             "I0_dynamics": I0_DYNAMICS,
             "note": "rows with dynamics_consistent = 0 analyse the equilibria with "
                     "another moment of inertia than the dynamics used (analysis only)",
             "paper_bracket": list(PAPER_BRACKET)}
    write_atomic(path, attrs, ds)


def read_table(path):
    """Rows of ``ensemble.h5`` as a dict of column arrays (strings decoded)."""
    import h5py

    with h5py.File(path, "r") as fh:
        cols = {c: fh["rows/" + c][()] for c in fh["rows"]}
    for c in STR_COLS:
        if c in cols:
            cols[c] = np.array([x.decode() if isinstance(x, bytes) else str(x)
                                for x in cols[c]])
    return cols


def plot(path, rows, cfg):
    """``ensemble.png``: F_x^c(mu0) histograms per N, the ratio, F_x^c vs N."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ft = "frictionless-then-friction"
    convs = [I0_DYNAMICS] + ([float(cfg.inertia_I0)] if cfg.inertia_I0 is not None else [])
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    allx = [r["F_x_c"] for r in rows if math.isfinite(r["F_x_c"]) and r["F_x_c"] > 0
            and r["status"] != "failed"]
    lo_b = min(allx + [PAPER_BRACKET[0]]) / 1.3
    hi_b = max(allx + [PAPER_BRACKET[1]]) * 1.3
    bins = np.geomspace(lo_b, hi_b, 25)
    allr = [r["ratio"] for r in rows if math.isfinite(r["ratio"]) and r["status"] != "failed"]
    rbins = np.linspace(min(allr + [1.0]) - 0.05, max(allr + [1.0]) + 0.05, 25)
    for k, n in enumerate(cfg.n):
        for I0, ls, fill in ((I0_DYNAMICS, "-", True), (cfg.inertia_I0, "--", False)):
            if I0 is None:
                continue
            x = [r["F_x_c"] for r in select(rows, ft, float(I0), n)]
            x = [v for v in x if math.isfinite(v)]
            if x:
                ax[0].hist(x, bins=bins, histtype="stepfilled" if fill else "step",
                           alpha=0.35 if fill else 1.0, ls=ls, color=colors[k % len(colors)],
                           label=f"N = {n}, I0 = {I0:g}")
            y = [r["ratio"] for r in select(rows, ft, float(I0), n)]
            y = [v for v in y if math.isfinite(v)]
            if y:
                ax[1].hist(y, bins=rbins, histtype="stepfilled" if fill else "step",
                           alpha=0.35 if fill else 1.0, ls=ls, color=colors[k % len(colors)],
                           label=f"N = {n}, I0 = {I0:g}")
    ax[0].axvspan(*PAPER_BRACKET, color="k", alpha=0.15, label="paper (N = 100)")
    ax[0].set_xscale("log")
    ax[0].set_xlabel("F_x^c(mu0) (bracket midpoint)")
    ax[0].set_ylabel("packings")
    ax[0].legend(fontsize=7)
    ax[1].axvline(1.0, color="k", lw=0.8)
    ax[1].set_xlabel(f"F_x^c(mu_ss mu0) / F_x^c(mu0), mu_ss = {cfg.mu_ss:g}")
    ax[1].legend(fontsize=7)
    for j, I0 in enumerate(convs):
        for n in cfg.n:
            x = [r["F_x_c"] for r in select(rows, ft, I0, n) if math.isfinite(r["F_x_c"])]
            if not x:
                continue
            shift = 1.0 + 0.04 * j
            ax[2].plot([n * shift] * len(x), x, ".", color=colors[j], alpha=0.5)
            c, q1, m, q3 = quartiles(x)
            ax[2].errorbar([n * shift], [m], yerr=[[m - q1], [q3 - m]], fmt="o",
                           color=colors[j], capsize=4,
                           label=f"I0 = {I0:g}" + (" (analysis only)" if I0 != I0_DYNAMICS
                                                   else "") if n == cfg.n[0] else None)
    ax[2].fill_between([90, 110], *PAPER_BRACKET, color="k", alpha=0.15, label="paper")
    ax[2].set_xscale("log")
    ax[2].set_yscale("log")
    ax[2].set_xlabel("N")
    ax[2].set_ylabel("F_x^c(mu0): packings, median and quartiles")
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    savefig_atomic(fig, path, dpi=110)
    plt.close(fig)


def _f(x, f=".4g"):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return format(x, f)


def _q(q, f=".4g"):
    c, a, m, b = q
    return "-" if not c else f"{_f(m, f)} [{_f(a, f)}, {_f(b, f)}]"


def write_summary(path, rows, cfg, st, wall, size, computed):
    """``ensemble.md``: the distributions, the checks and every failure."""
    ft = "frictionless-then-friction"
    n_pk = len(cfg.packings())
    L = ["# Ensemble of packings", "",
         f"{n_pk} packings: " + ", ".join(f"N = {n}: seeds {list(s)}"
                                          for n, s in zip(cfg.n, cfg.seeds))
         + f". mu0 = {cfg.mu:g}, mu_ss mu0 = {cfg.mu * cfg.mu_ss:g}; ramp dF_x = {cfg.dF_x:g},"
         f" bisection to tol = {cfg.tol:g}, F_x_max = {cfg.F_x_max:g}. F_x^c is the midpoint "
         f"of the certified bracket. Values: median [first quartile, third quartile] over the"
         f" packings whose row is not 'failed'.", ""]
    if cfg.inertia_I0 is not None:
        L += [f"**I0 = {cfg.inertia_I0:g} rows are an analysis convention only**: the same "
              f"equilibria (made by dynamics with I0 = {I0_DYNAMICS}) analysed with "
              f"I = {cfg.inertia_I0:g} m R^2 in M; their eigenvalues do not predict the "
              f"simulated motion.", ""]
    L += ["## F_x^c by size and convention", "",
          "| N | I0 | packings (usable) | F_x^c(mu0) | F_x^c(mu_ss mu0) | ratio | phi | "
          "slope s | Re lambda_c / lambda_max | pair index |",
          "|---|---|---|---|---|---|---|---|---|---|"]
    for p in st["per_n"]:
        L.append(f"| {p['n']} | {p['I0']:g} | {p['n_packings']} ({p['n_usable']}) | "
                 f"{_q(p['F_x_c'])} | {_q(p['F_x_c_ss'])} | {_q(p['ratio'])} | "
                 f"{_q(p['phi'])} | {_q(p['slope'])} | {_q(p['pair_re_rel'], '.3g')} | "
                 f"{_q(p['pair_index'], '.3g')} |")
    L += ["", "slope s: g = s sqrt(F_x - F_x^c) just above onset (g = max Im sqrt(lambda)).",
          "", "## N dependence", ""]
    for I0, e in st["n_exponent"].items():
        L.append(f"- I0 = {I0:g}: median F_x^c(mu0) ~ N^{e:.3g} between N = {min(cfg.n)} "
                 f"and N = {max(cfg.n)} (two medians).")
    if not st["n_exponent"]:
        L.append("- one size only (or no usable median): no N dependence measured.")
    L += ["", "## Does F_x^c(mu_ss mu0) < F_x^c(mu0) hold for every packing?", "",
          "Certified: the two brackets do not overlap.", "",
          "| I0 | holds | reversed | not decided | packings | every packing? |",
          "|---|---|---|---|---|---|"]
    for I0, o in st["order"].items():
        every = "yes" if o["holds"] == o["total"] and o["total"] else "no"
        L.append(f"| {I0:g} | {o['holds']} | {o['reversed']} | {o['undecided']} | "
                 f"{o['total']} | {every} |")
    L += ["", "## The paper's bracket in our distribution", ""]
    for I0, p in st["paper_percentile"].items():
        L.append(f"- I0 = {I0:g}, N = {p['n']} ({p['count']} packings): F_x^c = "
                 f"{PAPER_BRACKET[0]:g} is at the {_f(p['low'], '.3g')}th percentile, "
                 f"{PAPER_BRACKET[1]:g} at the {_f(p['high'], '.3g')}th.")
    if cfg.frictional:
        L += ["", "## Frictional relaxation (friction on during settling)", "",
              "| N | packings | relaxed | unstable at F_x = 0 | undecided | fraction unstable "
              "| certified complex pairs | max Im sqrt(lambda) (unstable ones) |",
              "|---|---|---|---|---|---|---|---|"]
        for f in st["frictional"]:
            frac = f["unstable"] / f["n_relaxed"] if f["n_relaxed"] else math.nan
            L.append(f"| {f['n']} | {f['n_packings']} | {f['n_relaxed']} | {f['unstable']} |"
                     f" {f['undecided']} | {_f(frac, '.3g')} | {_q(f['pairs'], '.3g')} | "
                     f"{_q(f['growth'], '.3g')} |")
        dz = [r for r in select(rows, ft, I0_DYNAMICS) if r["decision_at_zero"] == 1]
        L += ["", f"Default protocol: {len(dz)} packing(s) certified complex at F_x = 0."]
    L += ["", "## Packings", "",
          "| key | protocol | I0 | status | phi | F_x^c(mu0) bracket | F_x^c(mu_ss mu0) "
          "bracket | order | at F_x = 0 | reason |", "|---|---|---|---|---|---|---|---|---|---|"]
    dec = {1: "complex", 0: "real", -1: "undecided"}
    for r in rows:
        az = r["decision_at_zero"]
        L.append(f"| {r['key']} | {r['protocol']} | {r['I0']:g} | {r['status']} | "
                 f"{_f(r['phi'])} | [{_f(r['F_x_c_low'], '.6g')}, {_f(r['F_x_c_high'], '.6g')}]"
                 f" | [{_f(r['F_x_c_ss_low'], '.6g')}, {_f(r['F_x_c_ss_high'], '.6g')}] | "
                 f"{ {1: 'holds', 0: 'reversed', -1: '-'}[int(r['order'])] } | "
                 f"{dec.get(int(az), '-') if math.isfinite(az) else '-'} | "
                 f"{r['reason'] or ''} |")
    cpu = sum({r["key"]: r["wall"] for r in rows}.values())
    L += ["", "## Cost", "",
          f"{n_pk} packings; {cpu:.0f} s of packing time in total; this session computed {len(computed)} packing(s) on {size} "
          f"rank(s) in {wall:.0f} s of wall time."]
    write_text_atomic(path, "\n".join(L) + "\n")


# --------------------------------------------------------------------------- job
def check_out(cfg, out, resume):
    """Refuse an --out that is a file or holds other results; check --resume's config.

    Creates ``out`` and writes ``config.json`` for a new job (rank 0 only).

    Raises
    ------
    ConfigError
        ``out`` is a file; it holds files of another kind; it holds an
        ensemble and ``resume`` is False; or that ensemble's configuration
        differs (every differing key is named; ``np`` may differ).
    """
    from .jobfolder import check_job_folder

    check_job_folder(out, cfg.to_dict(), resume, "an ensemble")


def _task_path(out, key):
    return os.path.join(out, "tasks", key + ".json")


def load_task(out, task):
    """The finished result of a packing, or None (missing, unreadable, other task)."""
    try:
        with open(_task_path(out, task["key"])) as fh:
            d = json.load(fh)
    except (OSError, ValueError):
        return None
    if d.get("status") != "complete" or d.get("task") != task:
        return None
    return d["result"]


def _jsonable(x):
    """Result dict with NaN/inf kept as floats and numpy types as Python ones."""
    return json.loads(json.dumps(x, default=_np_default))


def _np_default(o):
    if isinstance(o, np.ndarray):
        if np.iscomplexobj(o):
            return [[float(v.real), float(v.imag)] for v in o]
        return o.tolist()
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.bool_,)):
        return bool(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def run_ensemble(cfg, out, comm=None, speak=True, resume=False):
    """The whole ensemble; every rank of ``comm`` calls it.

    Parameters
    ----------
    cfg : EnsembleConfig
    out : str
        Output folder (see :func:`check_out`).
    comm : mpi4py communicator, optional
        Default ``MPI.COMM_WORLD``; packings are dealt round robin over its
        ranks (largest N first), each rank runs LAMMPS on ``MPI.COMM_SELF``.
    speak : bool
        Progress lines (rank 0 only).
    resume : bool
        Continue the ensemble in ``out``: finished packings
        (``tasks/<key>.json``) are kept, the others are redone from their
        start.

    Returns
    -------
    str
        Path of ``ensemble.md`` (on every rank).

    Raises
    ------
    ConfigError
        From :func:`check_out` (on every rank; nothing written).
    """
    from mpi4py import MPI
    from .paper import write_json

    comm = comm or MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    out = os.path.abspath(out)
    t_start = time.perf_counter()

    def say(msg):
        if speak and rank == 0:
            print(f"[ensemble {time.perf_counter() - t_start:7.1f} s] {msg}", flush=True)

    def prepare():
        check_out(cfg, out, resume)
        os.makedirs(os.path.join(out, "tasks"), exist_ok=True)
        os.makedirs(os.path.join(out, "packings"), exist_ok=True)

    on_rank0(comm, prepare)
    tasks = cfg.packings()
    order = sorted(range(len(tasks)), key=lambda i: (-tasks[i]["n"], i))
    mine = [tasks[i] for i in order[rank::size]]
    say(f"{len(tasks)} packings on {size} rank(s)")
    computed = []
    for t in mine:
        if load_task(out, t) is not None:
            continue
        res = run_packing(cfg, t["n"], t["seed"], os.path.join(out, "packings", t["key"]))
        write_json(_task_path(out, t["key"]), {"task": t, "status": "complete",
                                               "result": _jsonable(res)})
        computed.append(t["key"])
        if speak and (rank == 0 or size == 1):
            d = res["default"]
            r0 = d["ramps"].get("mu0", {}).get("I0_0.5", {})
            say(f"rank 0: {t['key']}: F_x^c(mu0) in [{r0.get('F_x_c_low', math.nan):.6g}, "
                f"{r0.get('F_x_c_high', math.nan):.6g}]"
                + (f"; error: {d['error']}" if d["error"] else "")
                + f" ({res['wall']:.0f} s)")
    computed = comm.gather(computed, root=0)
    path = os.path.join(out, "ensemble.md")
    err = None
    if rank == 0:
        try:
            computed = sorted(k for part in computed for k in part)
            rows = []
            for t in tasks:
                res = load_task(out, t)
                if res is None:
                    raise RuntimeError(f"packing {t['key']} has no result in "
                                       f"{_task_path(out, t['key'])}")
                rows.extend(rows_of(t, res, cfg))
            st = statistics(rows, cfg)
            write_table(os.path.join(out, TABLE), rows, cfg)
            plot(os.path.join(out, "ensemble.png"), rows, cfg)
            wall = time.perf_counter() - t_start
            write_summary(path, rows, cfg, st, wall, size, computed)
            mpath = os.path.join(out, MANIFEST)
            sessions = []
            if os.path.isfile(mpath):
                with open(mpath) as fh:
                    sessions = json.load(fh).get("sessions", [])
            sessions.append({"n_ranks": size, "computed": computed, "wall": wall,
                             "resume": bool(resume)})
            write_json(mpath, {"config": cfg.to_dict(), "out": out, "status": "complete",
                               "n_packings": len(tasks), "sessions": sessions,
                               "statistics": _jsonable(
                                   {k: v for k, v in st.items()
                                    if k not in ("order", "paper_percentile", "n_exponent")})})
            say(f"done: {len(rows)} rows, {len(computed)} packing(s) computed now")
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank
            err = exc
    err = comm.bcast(err, root=0)
    if err is not None:
        raise err
    return path


# --------------------------------------------------------------------------- command line
def register(subparsers):
    """Add the ``ensemble`` subcommand."""
    p = subparsers.add_parser(
        "ensemble", help="F_x^c over packings: seeds x N, relax protocols, inertia convention",
        description="For every seed and N: generate, relax, ramp F_x at mu0 and mu_ss mu0 "
                    "(certified brackets of F_x^c), the coalescing pair, the growth-rate "
                    "slope, the frictional relax protocol at F_x = 0 and the I0 = 1 "
                    "analysis convention; ensemble.h5, ensemble.png and ensemble.md under "
                    "--out. docs/ensemble.md.")
    add_job_arguments(p, "ensemble", "EnsembleConfig",
                      "small test variant (3 packings of N = 16 and 20, coarse ramps)",
                      "continue an interrupted ensemble in --out (same configuration; "
                      "finished packings are kept)", "--set n=[100] --set seeds=[1,2,3]")
    p.set_defaults(func=main)


def config_from_args(args):
    """EnsembleConfig from parsed arguments."""
    return build_config(args.config, job_overrides(args), quick=bool(args.quick))


def main(args):
    """``remote-trigger ensemble``; returns the exit status."""
    cfg = config_from_args(args)
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if cfg.np > 1 and world.Get_size() == 1 and not os.environ.get("REMOTE_TRIGGER_ENS_CHILD"):
        out = os.path.abspath(args.out)
        if os.path.isdir(out) and os.listdir(out) or os.path.isfile(out):
            check_out(cfg, out, args.resume)       # refuse before mpirun starts
        from .relaunch import relaunch

        return relaunch("ensemble", args, cfg.np, "REMOTE_TRIGGER_ENS_CHILD")
    path = run_ensemble(cfg, args.out, comm=world, speak=not args.quiet, resume=args.resume)
    if world.Get_rank() == 0:
        print(f"ensemble: {path}")
    return 0
