"""Configuration of ``remote-trigger trigger-map`` (:class:`MapConfig`, the
``--quick`` preset, :func:`build_config`); the job is in
:mod:`remote_trigger.pywrap.jobs.trigger_map.job`, its design in docs/trigger_map.md."""
from dataclasses import dataclass

from remote_trigger.pywrap.config import (Config, ConfigError, check_int, check_number,
                                          layered_config)

#: onsets of f(t)
ONSETS = ("step", "smooth")


@dataclass(frozen=True)
class MapConfig(Config):
    """Configuration of the trigger map.

    Attributes
    ----------
    paper : str
        Output folder of a complete ``remote-trigger paper`` job (its
        ``paper.json``, ramps and Fig. 5 summary are read).
    fractions : list of float
        Loads in the window: F_x = F_x^c(mu_ss mu0) + f (F_x^c(mu0) -
        F_x^c(mu_ss mu0)), each f in (0, 1). Default [0.25, 0.5, 0.75].
    below : bool
        Add the load below the window of the paper's Fig. 5 (d) control
        (certified real after the friction drop). Default True.
    omega_p : list of float
        Angular frequencies of f(t), each > 0, non-empty.
        Default [1e-3, 1e-2, 1e-1, 1].
    natural : bool
        Add the packing's lowest natural frequency omega_1 = sqrt(lambda_1),
        half and twice it (measured at the load nearest the window's middle):
        with the default omega_p, 1e-3 ... 2 omega_1 spans 4 decades.
        Default True.
    tau_g : list of float
        Damping times in units of 1/g, g the growth rate after the friction
        drop at the load nearest the window's middle: tau = tau_g / g, each
        > 0. The undamped column is always there. Default [4, 1, 0.25].
    tau : list of float
        Explicit damping times (> 0); when given they replace ``tau_g``.
    onsets : list of str
        ``'step'`` and/or ``'smooth'`` (raised cosine over
        t_on = pi / (2 omega_p)). Default both.
    t_max : float
        Simulated time of a run, > 0. Default 1200.
    dt_fraction : float
        Time step as a fraction of the stability limit of the load's
        equilibrium, in (0, 1). Default 0.5 (checked by ``dt_check``).
    dt_check : int
        Number of map points redone at dt / 2 (the first points of the
        undamped column of the window's middle load), >= 0. Default 2.
    factor : float
        Bisection target a_hi / a_lo, > 1. Default 1.25.
    d_run_factor : float
        Runaway level D_run = d_run_factor x max(D_drop, (C a)^2), > 1.
        Default 100: twenty times the largest D of the untriggered runs
        measured (a friction drop below the window, or damped: 4-5 D_drop)
        and a decade below the level where the quick scene's instability
        saturates (~1e3 D_drop).
    a_max_factor : float
        Largest amplitude tried: a_max_factor x (F_x^c(mu0) - F_x) (the
        forcing's peak then reaches F_x^c(mu0) itself), > 0. Default 1.
    record_every : int or None
        Steps between records; None: about one time unit. Default None.
    kappa_steps : int or None
        Condition number kappa of the coalescing pair along the mu0 ramp:
        the ``kappa_steps`` steps nearest F_x^c (None: every step).
    np : int
        Ranks that run tasks, >= 1 (default 1). Above 1 the job re-launches
        itself under ``mpirun -np np+1``: rank 0 hands out the tasks
        (:func:`~remote_trigger.pywrap.runtime.taskfarm.run_tasks`).
    quick : bool
        The small test variant (:data:`QUICK`).
    """

    paper: str = ""
    fractions: tuple = (0.25, 0.5, 0.75)
    below: bool = True
    omega_p: tuple = (1e-3, 1e-2, 1e-1, 1.0)
    natural: bool = True
    tau_g: tuple = (4.0, 1.0, 0.25)
    tau: tuple = ()
    onsets: tuple = ONSETS
    t_max: float = 1200.0
    dt_fraction: float = 0.5
    dt_check: int = 2
    factor: float = 1.25
    d_run_factor: float = 1e2
    a_max_factor: float = 1.0
    record_every: int = None
    kappa_steps: int = None
    np: int = 1
    quick: bool = False

    def __post_init__(self):
        if not isinstance(self.paper, str) or not self.paper:
            raise ConfigError(f"paper (--paper DIR) must name the output folder of a paper "
                              f"job, got paper = {self.paper!r}")
        for name in ("fractions", "omega_p", "tau_g", "tau", "onsets"):
            v = getattr(self, name)
            if isinstance(v, (str, bytes)) or not hasattr(v, "__iter__"):
                raise ConfigError(f"{name} must be a list, got {name} = {v!r}")
            object.__setattr__(self, name, tuple(v))
        for f in self.fractions:
            if not 0.0 < check_number("fractions", f) < 1.0:
                raise ConfigError(f"fractions must each be in (0, 1) (inside the window), got "
                                  f"fractions = {list(self.fractions)!r}")
        if not self.fractions and not self.below:
            raise ConfigError("no load: fractions is empty and below = false")
        if not self.omega_p:
            raise ConfigError("omega_p must not be empty, got omega_p = []")
        for w in self.omega_p:
            if not check_number("omega_p", w) > 0:
                raise ConfigError(f"omega_p must each be > 0, got omega_p = "
                                  f"{list(self.omega_p)!r}")
        for name in ("tau_g", "tau"):
            for t in getattr(self, name):
                if not check_number(name, t) > 0:
                    raise ConfigError(f"{name} must each be > 0, got {name} = "
                                      f"{list(getattr(self, name))!r}")
        for o in self.onsets:
            if o not in ONSETS:
                raise ConfigError(f"onsets must be among {list(ONSETS)}, got onsets = "
                                  f"{list(self.onsets)!r}")
        if not self.onsets:
            raise ConfigError("onsets must not be empty, got onsets = []")
        if not check_number("t_max", self.t_max) > 0:
            raise ConfigError(f"t_max must be > 0, got t_max = {self.t_max!r}")
        if not 0.0 < check_number("dt_fraction", self.dt_fraction) < 1.0:
            raise ConfigError(f"dt_fraction must be in (0, 1), got dt_fraction = "
                              f"{self.dt_fraction!r}")
        check_int("dt_check", self.dt_check, 0)
        if not check_number("factor", self.factor) > 1.0:
            raise ConfigError(f"factor must be > 1, got factor = {self.factor!r}")
        if not check_number("d_run_factor", self.d_run_factor) > 1.0:
            raise ConfigError(f"d_run_factor must be > 1, got d_run_factor = "
                              f"{self.d_run_factor!r}")
        if not check_number("a_max_factor", self.a_max_factor) > 0:
            raise ConfigError(f"a_max_factor must be > 0, got a_max_factor = "
                              f"{self.a_max_factor!r}")
        if self.record_every is not None:
            check_int("record_every", self.record_every, 1)
        if self.kappa_steps is not None:
            check_int("kappa_steps", self.kappa_steps, 1)
        check_int("np", self.np, 1)



#: the ``--quick`` preset (a test on the ``paper --quick`` job)
QUICK = {"fractions": [0.6], "below": True, "omega_p": [1.0], "natural": False,
         "tau_g": [0.25], "onsets": ["step", "smooth"], "t_max": 300.0, "dt_check": 1,
         "factor": 1.5, "kappa_steps": 8}


def build_config(toml=None, overrides=None, quick=False):
    """Defaults < quick preset < TOML file < overrides; returns :class:`MapConfig`."""
    return MapConfig.from_dict(layered_config(toml, overrides, quick, QUICK))
