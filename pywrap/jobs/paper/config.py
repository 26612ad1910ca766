"""Configuration of ``remote-trigger paper``: one frozen, validated dataclass.

Sources, in increasing priority: the defaults below (the paper's parameters,
docs/model.md), the ``--quick`` preset (:data:`QUICK`), a TOML file
(``--config FILE``, Python 3.11 ``tomllib``) and command-line flags. Every
field has a flag of the same name with ``-`` for ``_`` (``--dF-x`` style
capitals kept: ``--dF_x`` and ``--dF-x`` both work); ``--set KEY=VALUE``
sets any field as well. Unknown keys are errors that name the key.

The optional TOML table ``[relax]`` passes extra fields to the relaxation
(:class:`remote_trigger.pywrap.stages.config.RelaxConfig`, e.g. ``settle_steps``,
``g_settle``, ``protocol``); its keys are checked by that class.

Units are LAMMPS ``lj`` units (m = 1, 2 R1 = 1, time from k_n).
"""
from dataclasses import dataclass, field
import math

from remote_trigger.pywrap.config import (
    Config, ConfigError, ContactModel, check_bool, check_int, check_number, check_numbers,
    check_table, layered_config)
from remote_trigger.pywrap.stages.config import DynamicsConfig, RelaxConfig

#: keys of the ``[relax]`` table that the job sets itself: the top-level key
#: of the same name (None), or what sets it
RELAX_SET_BY_JOB = {
    "datafile": "the job generates its packing from the top-level keys n, seed and phi",
    "k_n": None, "k_t": None, "mu": None, "F_y": None, "dt": None,
    "F_x": "the job relaxes at F_x = 0 and its ramps set F_x",
}

#: paper's reference values (Charan, Pomyalov & Procaccia), for the report only
PAPER = {
    "packing_fraction": 0.8171,           # Section III.B
    "f_min": 1e-15,                        # Section III.B
    "F_x_c_mu1_low": 0.0091,               # Fig. 3 inset / Section III.C.3: stable
    "F_x_c_mu1_high": 0.012,               # Fig. 4: unstable
    "F_x_fig4": 0.012,                     # Fig. 4
    "F_x_fig5": 0.0091,                    # Fig. 5
    "msd_decades_fig4": 15.0,              # Fig. 4 "some 15 orders of magnitude"
    "msd_level_fig5a": 1e-20,              # Fig. 5 (a) blue line
    "msd_max_fig5b": 1e-17,                # Fig. 5 (a) green line
    "msd_decades_fig5c": 12.0,             # Fig. 5 (a) red line, "more than 12"
    "velocity_decades_fig5c": 7.0,         # Fig. 5 (b), "more than 7"
}

#: midpoint of the paper's bracket 0.0091 < F_x^c(mu=1) < 0.012, used to define
#: "the same relative distance" from F_x^c (docs/paper.md)
PAPER_F_X_C_MID = 0.5 * (PAPER["F_x_c_mu1_low"] + PAPER["F_x_c_mu1_high"])


@dataclass(frozen=True)
class PaperConfig(Config):
    """Everything ``remote-trigger paper`` needs.

    Attributes
    ----------
    dim : {2, 3}
        Disks (2, the paper) or spheres (3, docs/model.md section 9; N = 160
        and phi = 0.64 unless given). Default 2. With 3, :func:`build_config` starts from :data:`DIM3` (N, phi) and its
        ``--quick`` preset from :data:`QUICK3D`.
    n : int
        Number of disks (spheres), even, >= 6. Default 100 (paper); spheres
        160 (:data:`DIM3`).
    seed : int
        Seed of the packing generator, >= 0. Default 1.
    phi : float
        Packing fraction that sets the box width L (generator), in (0.1, 0.91)
        for disks, (0.1, 0.74) for spheres. Default 0.82 (spheres 0.64).
    k_n : float
        Normal stiffness, > 0. Default 2e5 (paper).
    k_t : float or None
        Tangential stiffness, >= 0; None means 2 k_n / 7 (paper).
    F_y : float
        Downward load per ``top`` disk, > 0. Default 3 (paper).
    dt : float
        Time step (lj), > 0. Default 1e-3.
    mu : float
        Friction coefficient of the main ramp and of Figs. 4-5 (mu0), > 0.
        Default 1.
    mu_low : float
        Friction coefficient of the second ramp, > 0, != mu. Default 0.8.
    dF_x : float
        Ramp step, > 0. Default 2.5e-4 (the paper used 1e-4; see docs/paper.md).
    tol : float
        Bisection tolerance on F_x^c, > 0. Default 1e-7.
    F_x_max : float
        Largest F_x of a ramp, > 0. Default 0.5.
    extend_factor : float
        The eigenvalue tracking of Fig. 3 is continued above F_x^c up to
        extend_factor * F_x^c (and at least to the load of Fig. 4), > 1.
        Default 1.2.
    extend_steps : int
        Equilibria of that continuation, >= 1. Default 8.
    fig4_ratio : float
        F_x of Fig. 4 = fig4_ratio * F_x^c(mu), > 1. Default 0.012 / 0.01055
        (the paper's F_x over the midpoint of its bracket of F_x^c).
    fig5_window : float
        F_x of Fig. 5 = F_x^c(mu_ss mu) + fig5_window (F_x^c(mu) - F_x^c(mu_ss mu)),
        in (0, 1): inside the window where the state is stable with the
        static friction mu and unstable once it has dropped to mu_ss mu
        (the paper's design, Fig. 3's vertical line). The window's ends are
        the ramps' brackets (mu_low is the ramp of the lower friction).
        Default 0.6.
    fig5_F_x : float or None
        An explicit F_x of Fig. 5 instead (must be below F_x^c(mu), checked
        once the ramp is done). Default None.
    t_instability : float
        Longest time of the Fig. 4 run, > 0. The run lasts
        min(t_instability, instability_span / g) with g the predicted growth
        rate, and stops once D exceeds ``d_sat``. Default 20000 (spheres
        3000, :data:`DIM3`).
    instability_span : float
        See ``t_instability``, > 0. Default 35 (D grows by e^70 = 30 decades).
    d_sat : float
        Stop the Fig. 4 run once D(t) exceeds this, > 0. Default 1.
    t_perturb : float
        Time of each Fig. 5 run, > 0 (a run stops earlier once D passes
        ``fig5_d_run`` or saturates). Default 1200 (1.9 periods of f(t));
        spheres 5000 (:data:`DIM3`).
    record_every : int
        Steps between records of D, v and mu, >= 1. Default 500.
    a : float or None
        Amplitude of f(t) = a cos(omega_p t) in Fig. 5 runs (b)-(d), >= 0.
        None (default): measured, a = fig5_forcing_margin v0 / (omega_p C)
        with C = d<x_top>/dF_x of the ramp, so that the quasi-static velocity
        of the top line under f(t), omega_p C a, is fig5_forcing_margin x v0.
    a_paper : float
        The paper's amplitude, run as its own row (p), >= 0. Default 1e-12.
    omega_p : float
        Angular frequency of f(t) in 1/(lj time), > 0. Default 0.01 (paper;
        interpretation in docs/paper.md).
    t_on : float or None
        Onset of f(t), >= 0: 0 = step at t = 0; > 0 = raised-cosine ramp over
        t_on. None (default): a quarter period, pi / (2 omega_p).
    fig5_v0_margin : float
        v0 of mu(v) = fig5_v0_margin x the largest |v_top| over every step of
        the first half of run (a), >= 1. Default 10.
    fig5_forcing_margin : float
        See ``a``, > 0. Default 10.
    fig5_dt_fraction : float
        Time step of the Fig. 5 runs as a fraction of the stability limit
        2 / omega_max of the Fig. 5 equilibrium, in (0, 1). Default 0.2
        (growth-rate error 2.7 % vs dt -> 0, docs/accuracy.md).
    fig5_d_run : float
        Runaway level of D: a run stops once D exceeds it, > 0. Default 1e-3
        (``remote_trigger.analysis.dynamics.series.D_RUNAWAY``).
    fig5_settle_tol : float
        mu(v) counts as settled at mu_ss mu once the median of mu over 50 tau
        is within this of it, > 0. Default 0.01.
    fig5_sat_span : float
        A run whose friction has switched stops once it has saturated: max D
        above 1e3 x its level right after the switch and grown less than 2x
        over the last span (``analysis.series.saturated``); the span is
        fig5_sat_span, lengthened to ln 8 / (2 g) where the certified
        growth rate g after the friction drop is below 0.0104
        (``analysis.series.saturation_span``), > 0. Default 100.
    mu_star_tol : float
        Bisection tolerance of mu* (the friction at which the Fig. 5 state
        turns unstable), > 0. Default 1e-3.
    B, w, mu_ss : float
        mu(v) law (Eq. 4), >= 0. Defaults 0.2, 0.4, 0.8 (paper).
    nf_delta : float
        delta of the normal form, in (0, 1). Default 0.1.
    nf_eps : list of float
        eps values of the normal-form scan, each in (0, 1].
    nf_tau : list of float
        Damping times of the scan (inf allowed: no damping), each > 0.
    relax : dict
        Extra fields of the relaxation's ``RelaxConfig`` (checked there).
    np : int
        MPI ranks, >= 1. Default 1. With np > 1 the job re-launches itself
        under the environment's ``mpirun`` (docs/paper.md).
    quick : bool
        The small, fast variant (:data:`QUICK`) was requested.
    """

    dim: int = 2
    n: int = 100
    seed: int = 1
    phi: float = 0.82
    k_n: float = ContactModel.k_n
    k_t: float = None
    F_y: float = ContactModel.F_y
    dt: float = 1e-3
    mu: float = ContactModel.mu
    mu_low: float = 0.8
    dF_x: float = 2.5e-4
    tol: float = 1e-7
    F_x_max: float = 0.5
    extend_factor: float = 1.2
    extend_steps: int = 8
    fig4_ratio: float = PAPER["F_x_fig4"] / PAPER_F_X_C_MID
    fig5_window: float = 0.6
    fig5_F_x: float = None
    t_instability: float = 20000.0
    instability_span: float = 35.0
    d_sat: float = 1.0
    t_perturb: float = 1200.0
    record_every: int = 500
    a: float = None
    # forcing and mu(v) law: the driver's defaults (one source, docs/model.md 4-5)
    a_paper: float = DynamicsConfig.a
    omega_p: float = DynamicsConfig.omega_p
    t_on: float = None
    fig5_v0_margin: float = 10.0
    fig5_forcing_margin: float = 10.0
    fig5_dt_fraction: float = 0.2
    fig5_d_run: float = 1e-3
    fig5_settle_tol: float = 0.01
    fig5_sat_span: float = 100.0
    mu_star_tol: float = 1e-3
    B: float = DynamicsConfig.B
    w: float = DynamicsConfig.w
    mu_ss: float = DynamicsConfig.mu_ss
    nf_delta: float = 0.1
    nf_eps: tuple = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4)
    nf_tau: tuple = (math.inf, 3e3, 3e2, 3e1)
    relax: dict = field(default_factory=dict)
    np: int = 1
    quick: bool = False

    def __post_init__(self):
        if self.dim not in (2, 3) or isinstance(self.dim, bool):
            raise ConfigError(f"dim must be 2 or 3, got dim = {self.dim!r}")
        check_int("n", self.n, 6)
        if self.n % 2:
            raise ConfigError(f"n must be even (equal numbers of both radii), got n = {self.n}")
        check_int("seed", self.seed, 0)
        phi_max = 0.91 if self.dim == 2 else 0.74
        if not 0.1 < check_number("phi", self.phi) < phi_max:
            raise ConfigError(f"phi must be in (0.1, {phi_max})"
                              + (" for spheres (dim = 3)" if self.dim == 3 else "")
                              + f", got phi = {self.phi!r}")
        check_number("mu", self.mu, 0, lo_open=True)          # the paper's model has friction
        object.__setattr__(self, "k_t", ContactModel.of(self).k_t)
        check_number("dt", self.dt, 0, lo_open=True)
        check_number("mu_low", self.mu_low, 0, lo_open=True)
        if self.mu_low == self.mu:
            raise ConfigError(f"mu_low must differ from mu = {self.mu!r}, got "
                              f"mu_low = {self.mu_low!r}")
        check_number("dF_x", self.dF_x, 0, lo_open=True)
        check_number("tol", self.tol, 0, lo_open=True)
        check_number("F_x_max", self.F_x_max, 0, lo_open=True)
        if self.dF_x >= self.F_x_max:
            raise ConfigError(f"dF_x must be < F_x_max = {self.F_x_max!r}, got "
                              f"dF_x = {self.dF_x!r}")
        check_number("extend_factor", self.extend_factor, 1, lo_open=True)
        check_int("extend_steps", self.extend_steps, 1)
        check_number("fig4_ratio", self.fig4_ratio, 1, lo_open=True)
        if not 0 < check_number("fig5_window", self.fig5_window) < 1:
            raise ConfigError(f"fig5_window must be in (0, 1), got "
                              f"fig5_window = {self.fig5_window!r}")
        if self.fig5_F_x is not None:
            check_number("fig5_F_x", self.fig5_F_x, 0, lo_open=True)
        if not 0 < check_number("fig5_dt_fraction", self.fig5_dt_fraction) < 1:
            raise ConfigError(f"fig5_dt_fraction must be in (0, 1), got "
                              f"fig5_dt_fraction = {self.fig5_dt_fraction!r}")
        check_number("fig5_v0_margin", self.fig5_v0_margin, 1)
        for name in ("fig5_forcing_margin", "fig5_d_run", "fig5_settle_tol", "mu_star_tol",
                     "fig5_sat_span",
                     "omega_p"):
            check_number(name, getattr(self, name), 0, lo_open=True)
        if self.a is not None:
            check_number("a", self.a, 0)
        if self.t_on is not None:
            check_number("t_on", self.t_on, 0)
        for name in ("t_instability", "instability_span", "d_sat", "t_perturb"):
            check_number(name, getattr(self, name), 0, lo_open=True)
        check_int("record_every", self.record_every, 1)
        for name in ("a_paper", "B", "w", "mu_ss"):
            check_number(name, getattr(self, name), 0)
        if self.fig5_F_x is None and \
                abs(float(self.mu_low) - float(self.mu_ss) * float(self.mu)) > 1e-12 * self.mu:
            raise ConfigError(f"the Fig. 5 window needs the second ramp at the dynamic "
                              f"friction, mu_low = mu_ss * mu = {self.mu_ss * self.mu:g}, got "
                              f"mu_low = {self.mu_low!r} (or give fig5_F_x)")
        if not 0 < check_number("nf_delta", self.nf_delta) < 1:
            raise ConfigError(f"nf_delta must be in (0, 1), got nf_delta = {self.nf_delta!r}")
        object.__setattr__(self, "nf_eps", check_numbers("nf_eps", self.nf_eps))
        object.__setattr__(self, "nf_tau", check_numbers("nf_tau", self.nf_tau))
        for e in self.nf_eps:
            if not 0 < e <= 1:
                raise ConfigError(f"nf_eps values must be in (0, 1], got nf_eps = "
                                  f"{list(self.nf_eps)!r}")
        for t in self.nf_tau:
            if not t > 0:
                raise ConfigError(f"nf_tau values must be > 0 (inf: no damping), got "
                                  f"nf_tau = {list(self.nf_tau)!r}")
        # checked now, before a re-run removes the outputs of the last one
        check_table("relax", self.relax, RELAX_SET_BY_JOB, "the paper job", RelaxConfig)
        check_int("np", self.np, 1)
        check_bool("quick", self.quick)

    def to_attrs(self):
        """Flat dict for HDF5 attributes (None -> 'None', lists kept, relax as JSON)."""
        import json

        out = {}
        for k, v in self.to_dict().items():
            if v is None:
                v = "None"
            elif k == "relax":
                v = json.dumps(v, sort_keys=True)
            out[k] = v
        return out


#: the ``--quick`` preset: a small packing, coarse steps, short runs
QUICK = {
    "n": 40,
    "dF_x": 2e-3,
    "tol": 2e-5,
    "extend_steps": 3,
    "t_instability": 6000.0,
    "t_perturb": 500.0,
    # dt = 0.5 x the stability limit in the Fig. 5 runs (the default job: 0.2);
    # measured on the quick scene: the same verdict in every Fig. 5 row as at
    # 0.2, and the trigger map's a_c bracket at dt / 2 overlaps the one at dt
    "fig5_dt_fraction": 0.5,
    "record_every": 500,
    "nf_eps": [1e-1, 1e-2, 1e-3],
    "nf_tau": [math.inf, 3e2],
    "relax": {"settle_steps": 15000},
}


#: the defaults of spheres that differ from those of disks (``dim = 3``): the
#: generator's N and phi; Fig. 5 runs of 5000 tau instead of 1200 (after the
#: friction drop the default packing grows at 0.0053 only: (c) needs ~2000 tau
#: to grow from the re-equilibration's level to its saturation, then stops) and
#: the Fig. 4 run at most 3000 tau (its growth rate at N = 160, seed 1, is
#: 0.0069, so instability_span / g alone would be 5047; a step of spheres costs
#: several times one of disks): docs/paper.md "Spheres", the job within 15 min
#: on 2 cores
DIM3 = {"n": 160, "phi": 0.64, "t_perturb": 5000.0, "t_instability": 3000.0}

#: the ``--quick`` preset of spheres: :data:`QUICK` (coarse ramp steps) with
#: N = 96 (the smallest N with the 5 x 5 cross-section of N = 160) and short runs
QUICK3D = {"n": 96, "t_instability": 400.0, "t_perturb": 300.0}


def build_config(toml=None, overrides=None, quick=False):
    """Merge defaults, the quick preset, a TOML file and overrides.

    With ``dim = 3`` (from the file or the overrides) the defaults of
    :data:`DIM3` come first and the quick preset is :data:`QUICK` updated
    with :data:`QUICK3D`.

    Parameters
    ----------
    toml : str, optional
        TOML file; its ``quick = true`` has the same effect as ``quick``.
    overrides : dict, optional
        Values from the command line (highest priority).
    quick : bool
        Apply :data:`QUICK` before the file and the overrides.

    Returns
    -------
    PaperConfig

    Raises
    ------
    ConfigError
        Unknown key (named), bad value (named), unreadable file.
    """
    d = layered_config(toml, overrides, quick, QUICK, ("relax",))
    if d.get("dim") == 3:
        preset = dict(QUICK, **QUICK3D) if d.get("quick") else {}
        d = dict(DIM3, **layered_config(toml, overrides, quick, preset, ("relax",)))
    return PaperConfig.from_dict(d)
