"""Configuration of ``remote-trigger ensemble`` (:class:`EnsembleConfig`, the
``--quick`` preset, :func:`build_config`); the job is in
:mod:`remote_trigger.pywrap.jobs.ensemble.job`, its design in docs/ensemble.md."""
from dataclasses import dataclass, field, asdict

from remote_trigger.pywrap.config import (
    Config, ConfigError, ContactModel, _int, _num, check_bool, check_table, layered_config)
from remote_trigger.pywrap.stages.config import RelaxConfig
from remote_trigger.pywrap.jobs.paper.config import PaperConfig

#: keys of the ``relax`` and ``frictional_relax`` tables that the ensemble sets itself
RELAX_SET_BY_JOB = ("datafile", "k_n", "k_t", "mu", "F_y", "dt", "F_x", "protocol")

#: moment of inertia factor of the dynamics (``fix nve/sphere ... disc``)
I0_DYNAMICS = 0.5

_DEFAULT_SEEDS = (tuple(range(1, 21)), tuple(range(1, 6)))


# --------------------------------------------------------------------------- configuration
@dataclass(frozen=True)
class EnsembleConfig(Config):
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
    dF_x_max : float or None
        None (default): fine ramps, every step dF_x. A number > dF_x:
        adaptive ramps (``ramp --dF-x-max``, docs/driver.md) and adaptive
        steps for the I0 continuation above a ramp's end.
    relax : dict
        Extra :class:`~remote_trigger.pywrap.stages.config.RelaxConfig` fields for
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
        Ranks that run packings, >= 1 (default 1). Above 1 the job re-launches
        itself under ``mpirun -np np+1``: rank 0 hands out the packings
        (:func:`~remote_trigger.pywrap.runtime.taskfarm.run_tasks`).
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
    dF_x_max: float = None
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
        if self.dF_x_max is not None and not _num("dF_x_max", self.dF_x_max) > self.dF_x:
            raise ConfigError(f"dF_x_max must be > dF_x = {self.dF_x!r} (or null: fine "
                              f"ramps), got dF_x_max = {self.dF_x_max!r}")
        for name in ("frictional", "keep_equilibria", "quick"):
            check_bool(name, getattr(self, name))
        if self.inertia_I0 is not None:
            _num("inertia_I0", self.inertia_I0, 0, lo_open=True)
            if float(self.inertia_I0) == I0_DYNAMICS:
                raise ConfigError(f"inertia_I0 must differ from the dynamics' I0 = "
                                  f"{I0_DYNAMICS} (those rows are always there), got "
                                  f"inertia_I0 = {self.inertia_I0!r}")
        if self.inertia_extra_steps is not None:
            _int("inertia_extra_steps", self.inertia_extra_steps, 0)
        for name in ("relax", "frictional_relax"):
            check_table(name, getattr(self, name), RELAX_SET_BY_JOB, "the ensemble",
                        RelaxConfig)
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
