"""Configuration of ``remote-trigger ensemble`` (:class:`EnsembleConfig`, the
``--quick`` preset, :func:`build_config`); the job is in
:mod:`remote_trigger.pywrap.jobs.ensemble.job`, its design in docs/ensemble.md."""
import dataclasses
from dataclasses import dataclass, field, asdict

from remote_trigger.pywrap.config import (
    Config, ConfigError, ContactModel, check_bool, check_int, check_number, check_table,
    layered_config)
from remote_trigger.pywrap.stages.config import RampConfig, RelaxConfig
from remote_trigger.pywrap.jobs.paper.config import PaperConfig, DIM3 as PAPER_DIM3
from remote_trigger.analysis.state.state import DISC_INERTIA
from remote_trigger.analysis.state.state3d import SPHERE_INERTIA

#: keys of the ``relax`` and ``frictional_relax`` tables that the ensemble sets
#: itself: the top-level key of the same name (None), or what sets it
RELAX_SET_BY_JOB = {
    "datafile": "the ensemble generates each packing from the top-level keys n, seeds "
                "and phi",
    "k_n": None, "k_t": None, "mu": None, "F_y": None, "dt": None,
    "F_x": "the ensemble relaxes at F_x = 0 and its ramps set F_x",
    "protocol": "the table gives it (relax: the default protocol, frictional_relax: "
                "'frictional'); the top-level key frictional = true adds the frictional rows",
}

#: moment of inertia factor of the dynamics of disks (``fix nve/sphere ... disc``)
I0_DYNAMICS = DISC_INERTIA
#: moment of inertia factor of the dynamics, per dimension (spheres: I = 2/5 m R^2)
I0_OF_DIM = {2: DISC_INERTIA, 3: SPHERE_INERTIA}

#: the parts of the ensemble that are 2D only: key -> (its value with spheres, why)
ONLY_2D = {
    "frictional": (False, "its compaction with friction runs damped dynamics, which do "
                          "not bring a loaded 3D packing to rest; the relax stage refuses "
                          "protocol = 'frictional' for spheres"),
    "frictional_relax": ({}, "it configures the frictional relaxation, which spheres do "
                             "not have"),
    "inertia_I0": (None, "the I0 rows re-analyse disks with the paper's Jacobian "
                         "convention I = I0 m R^2; the paper has no spheres, so there is "
                         "no other convention to compare with"),
    "inertia_extra_steps": (None, "it bounds the I0 continuation, which spheres do not "
                                  "have"),
}

_DEFAULT_SEEDS = (tuple(range(1, 21)), tuple(range(1, 6)))


# --------------------------------------------------------------------------- configuration
@dataclass(frozen=True)
class EnsembleConfig(Config):
    """Configuration of ``remote-trigger ensemble``.

    Attributes
    ----------
    dim : {2, 3}
        2: disks (the paper; default), 3: spheres, with the defaults of
        :data:`DIM3` (``n`` = [160], ``seeds`` 1..12, ``phi`` = 0.64) and
        without the 2D-only parts (:data:`ONLY_2D`: the frictional protocol
        and the I0 re-analysis; giving them is refused).
    n : list of int
        System sizes N (disks, top line included), each even and >= 6, no
        repeats. Default [100, 400]. Spheres: each large enough for the
        generator's top layer and a box of width >= 5 (N >= 82 at phi = 0.64).
    seeds : list of int, or list of list of int
        Packing seeds (>= 0): one list used for every N, or one non-empty
        list per N. Default 1..20 for N = 100 and 1..5 for N = 400.
    phi : float
        Packing fraction of the generator's box, in (0.1, 0.91) (spheres:
        (0.1, 0.74)). Default 0.82.
    k_n, k_t, F_y, dt : float
        Model (docs/model.md; k_t None: 2 k_n / 7). Defaults as ``paper``.
    mu : float
        Static friction mu0, > 0. Default 1.
    mu_ss : float
        Dynamic friction as a fraction of mu0, in (0, 1]; the second ramp is
        at mu_ss mu0. Default 0.8 (paper).
    dF_x, tol : float, or list of float
        Ramp step and bisection tolerance on F_x^c, > 0 (``paper``'s
        defaults: 2.5e-4, 1e-7): one number for every N, or one per N (the
        median F_x^c falls from 0.026 at N = 100 to ~5e-4 at N = 10^4: a step
        of 2.5e-4 is ~1 % of it at N = 100 and about F_x^c itself at
        N = 6400 and 10^4). :meth:`for_size` gives the
        configuration of one N.
    F_x_max : float
        Largest F_x, > 0 (default 0.5).
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
    saddle_escape : bool
        Re-equilibrate by damped dynamics a ramp point whose Newton
        equilibrium is a saddle (``RampConfig.saddle_escape``, docs/driver.md
        "Saddles"). Default True. Recorded per packing (``tasks/<key>.json``,
        result ``saddle_escape``): ``--resume`` refuses a folder whose
        packings recorded the other value, and ``--combine`` refuses to mix
        packings with and without the escape (packings of runs made before
        the option record nothing and count as without; ``--resume`` does
        not check those).
    pairs : str
        Which complex pairs end a ramp (``RampConfig.pairs``): ``'all'``
        (default) or ``'collective'`` (soft pairs, |Re lambda| < 1e-4
        lambda_max, do not; the pair's place is that of the first pair that
        is not soft). The I0 re-analysis and the frictional protocol's
        decision at F_x = 0 then decide on the pairs that are not soft too.
        Written to ``config.json`` only when 'collective' (a folder of
        earlier runs resumes as 'all').
    between : int, or list of int
        Loads decided between the ramp's steps (``RampConfig.between``): 1
        (default) none; m >= 2: m - 1 between every two steps below the
        first complex one, before the bisection (a complex window narrower
        than a step looked for at dF_x / m). One integer for every N, or one
        per N (as ``dF_x``). Written to ``config.json`` only when not 1.
    part_size : int or None
        None (default): a sliced verdict (above 3000 dofs, N >~ 1100 disks)
        is one scan on the packing's rank. An integer >= 60 (the slice size):
        the scan in parts of about this many eigenvalues
        (``RampConfig.part_size``), and ranks left without a packing join
        the parts of the running packings' points
        (:mod:`~remote_trigger.pywrap.runtime.joining`). The verdicts do not
        depend on it; the eigenvalues' last bits do, never on the number of
        ranks or helpers. Written to ``config.json`` only when set.
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

    dim: int = 2
    n: tuple = (100, 400)
    seeds: tuple = _DEFAULT_SEEDS
    phi: float = PaperConfig.phi
    k_n: float = PaperConfig.k_n
    k_t: float = None
    F_y: float = PaperConfig.F_y
    dt: float = PaperConfig.dt
    mu: float = PaperConfig.mu
    mu_ss: float = PaperConfig.mu_ss
    dF_x: object = PaperConfig.dF_x
    tol: object = PaperConfig.tol
    F_x_max: float = PaperConfig.F_x_max
    dF_x_max: float = None
    relax: dict = field(default_factory=dict)
    frictional: bool = True
    frictional_relax: dict = field(default_factory=dict)
    inertia_I0: float = 1.0
    inertia_extra_steps: int = None
    keep_equilibria: bool = False
    saddle_escape: bool = True
    pairs: str = "all"
    between: int = 1
    part_size: int = None
    np: int = 1
    quick: bool = False

    def __post_init__(self):
        if self.dim not in (2, 3) or isinstance(self.dim, bool):
            raise ConfigError(f"dim must be 2 or 3, got dim = {self.dim!r}")
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
        if self.dim == 3:
            self._check_spheres()
        elif not 0.1 < check_number("phi", self.phi) < 0.91:
            raise ConfigError(f"phi must be in (0.1, 0.91), got phi = {self.phi!r}")
        check_number("mu", self.mu, 0, lo_open=True)          # the paper's model has friction
        object.__setattr__(self, "k_t", ContactModel.of(self).k_t)
        for name in ("dt", "F_x_max"):
            check_number(name, getattr(self, name), 0, lo_open=True)
        for name in ("dF_x", "tol"):
            object.__setattr__(self, name, self._per_size(name, getattr(self, name), n))
        if not 0.0 < check_number("mu_ss", self.mu_ss) <= 1.0:
            raise ConfigError(f"mu_ss must be in (0, 1] (a fraction of mu), got "
                              f"mu_ss = {self.mu_ss!r}")
        steps = self.dF_x if isinstance(self.dF_x, tuple) else (self.dF_x,)
        if max(steps) >= self.F_x_max:
            raise ConfigError(f"dF_x must be < F_x_max = {self.F_x_max!r}, got "
                              f"dF_x = {self.dF_x!r}")
        if self.dF_x_max is not None and not check_number("dF_x_max", self.dF_x_max) > max(steps):
            raise ConfigError(f"dF_x_max must be > dF_x = {self.dF_x!r} (or null: fine "
                              f"ramps), got dF_x_max = {self.dF_x_max!r}")
        for name in ("frictional", "keep_equilibria", "saddle_escape", "quick"):
            check_bool(name, getattr(self, name))
        if self.inertia_I0 is not None:
            check_number("inertia_I0", self.inertia_I0, 0, lo_open=True)
            if float(self.inertia_I0) == I0_DYNAMICS:
                raise ConfigError(f"inertia_I0 must differ from the dynamics' I0 = "
                                  f"{I0_DYNAMICS} (those rows are always there), got "
                                  f"inertia_I0 = {self.inertia_I0!r}")
        if self.inertia_extra_steps is not None:
            check_int("inertia_extra_steps", self.inertia_extra_steps, 0)
        if self.pairs not in RampConfig.PAIRS:
            raise ConfigError(f"pairs must be one of {', '.join(map(repr, RampConfig.PAIRS))}"
                              f", got pairs = {self.pairs!r}")
        object.__setattr__(self, "between",
                           self._per_size("between", self.between, n, integer=True))
        for name in ("relax", "frictional_relax"):
            check_table(name, getattr(self, name), RELAX_SET_BY_JOB, "the ensemble",
                        RelaxConfig)
        layer = (self.relax or {}).get("top_layer", "free")
        if self.dim == 2 and layer != "free":
            raise ConfigError(f"relax.top_layer = {layer!r} is for spheres (dim = 3); disks "
                              f"keep the paper's free top line")
        check_int("np", self.np, 1)
        if self.part_size is not None:
            from remote_trigger.analysis.stability.sliced.scan import SLICE_SIZE

            check_int("part_size", self.part_size, SLICE_SIZE)

    def _check_spheres(self):
        """dim = 3: phi, sizes the generator can fill, no 2D-only part."""
        from remote_trigger.pywrap.stages.packing import RADII, box_width, top_count

        for key, (off, why) in ONLY_2D.items():
            if getattr(self, key) != off:
                raise ConfigError(f"{key} = {getattr(self, key)!r} is 2D only (dim = 3: "
                                  f"spheres): {why}; leave it out or set {key} = "
                                  f"{_toml(off)}")
        if not 0.1 < check_number("phi", self.phi) < 0.74:
            raise ConfigError(f"phi must be in (0.1, 0.74) for spheres (dim = 3), got "
                              f"phi = {self.phi!r}")
        for v in self.n:
            # a box narrower than 5 (a 2 x 2 top layer) lets a sphere touch two
            # periodic images of another (the pair refuses it)
            width = box_width(v, self.phi, RADII, 3)
            if width < 5.0 or top_count(width, RADII, 3) >= v - 2:
                raise ConfigError(f"n must hold sizes whose box of spheres is at least 5 "
                                  f"wide (N >= 82 at phi = 0.64; dim = 3), got n = "
                                  f"{list(self.n)!r} (N = {v}: width {width:g})")

    @staticmethod
    def _per_size(name, val, n, integer=False):
        """A number > 0 (float; ``integer``: an integer >= 1), or a list of one
        per N (tuple)."""
        def one(v):
            if integer:
                check_int(name, v, 1)
                return v
            return check_number(name, v, 0, lo_open=True)

        if isinstance(val, (list, tuple)):
            if len(val) != len(n):
                raise ConfigError(f"{name} holds {len(val)} values for {len(n)} size(s) N "
                                  f"{list(n)}: give one {'integer' if integer else 'number'}, "
                                  f"or one per N, got {name} = {list(val)!r}")
            return tuple(one(v) for v in val)
        return one(val)

    def for_size(self, n):
        """The configuration of the packings of size ``n`` (one of ``self.n``):
        ``dF_x``, ``tol`` and ``between`` the numbers of that N.

        Raises
        ------
        ConfigError
            If ``n`` is not one of the sizes.
        """
        if n not in self.n:
            raise ConfigError(f"N = {n!r} is not one of the ensemble's sizes {list(self.n)}")
        k = self.n.index(n)
        pick = {name: getattr(self, name)[k] for name in ("dF_x", "tol", "between")
                if isinstance(getattr(self, name), tuple)}
        return dataclasses.replace(self, **pick) if pick else self

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
            raise ConfigError(
                f"seeds holds {len(per_n)} lists of seeds for {n_sizes} size(s) N: give one "
                f"list per N, or one list for every N (the default seeds, 1..20 and 1..5, "
                f"are those of n = [100, 400]), got seeds = {seeds!r}")
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
        """Plain dict (lists for tuples).

        ``dim`` is there only for spheres: the configuration of disks is
        written as before ``dim`` existed, so a folder of disks written
        then resumes (``--resume`` compares ``config.json``) and its files
        are unchanged. Likewise ``pairs`` only when 'collective',
        ``between`` only when not 1, ``part_size`` only when set, and
        ``saddle_escape`` only when False; whether
        a packing escaped saddles is recorded in its result (``tasks/``,
        missing: not) and checked by ``--resume`` and ``--combine``.
        """
        d = asdict(self)
        d["n"] = list(self.n)
        d["seeds"] = [list(s) for s in self.seeds]
        if isinstance(self.between, tuple):
            d["between"] = list(self.between)
        if self.dim == 2:
            del d["dim"]
        if self.saddle_escape:
            del d["saddle_escape"]
        if self.pairs == "all":
            del d["pairs"]
        if self.between == 1:
            del d["between"]
        if self.part_size is None:
            del d["part_size"]
        return d

    @property
    def I0_dynamics(self):
        """The moment of inertia factor of the dynamics, I = I0 m R^2 (1/2 disks,
        2/5 spheres): the convention of the ramps' decisions."""
        return I0_OF_DIM[self.dim]

    def conventions(self):
        """The I0 of the table's rows of the default protocol: the dynamics' own,
        then ``inertia_I0`` (if any)."""
        return [self.I0_dynamics] + ([float(self.inertia_I0)] if self.inertia_I0 is not None
                                     else [])

    def packings(self):
        """The packings, in table order.

        Returns
        -------
        list of dict
            ``key`` (``'N<n>_s<seed>'``), ``n``, ``seed``.
        """
        return [{"key": f"N{n}_s{s}", "n": n, "seed": s}
                for n, ss in zip(self.n, self.seeds) for s in ss]


def _toml(v):
    return {False: "false", None: "null"}.get(v, repr(v)) if not isinstance(v, dict) else "{}"


#: the ``--quick`` preset: three tiny packings, coarse ramps
QUICK = {"n": [16, 20], "seeds": [[1, 2], [1]], "dF_x": 1e-2, "tol": 2e-3,
         "relax": {"settle_steps": 10000}, "frictional_relax": {"max_steps": 50000},
         "inertia_extra_steps": 4}

#: the defaults of spheres (``dim = 3``) that differ from those of disks: the
#: paper job's N and phi of spheres (:data:`.paper.config.DIM3`), 12 seeds, and
#: the 2D-only parts off (:data:`ONLY_2D`)
DIM3 = dict({"n": [PAPER_DIM3["n"]], "seeds": list(range(1, 13)), "phi": PAPER_DIM3["phi"]},
            **{k: off for k, (off, _) in ONLY_2D.items()})

#: the ``--quick`` preset of spheres: :data:`QUICK`'s coarse ramps and short
#: compaction, two packings of N = 96 (the smallest box of the paper's
#: ``--quick``, a 4 x 4 top layer), nothing of the 2D-only parts
QUICK3D = dict({k: v for k, v in QUICK.items() if k not in ONLY_2D},
               n=[96], seeds=[1, 3])


def build_config(toml=None, overrides=None, quick=False):
    """Defaults < quick preset < TOML file < overrides; returns :class:`EnsembleConfig`.

    The tables ``relax`` and ``frictional_relax`` are merged key by key.
    With ``dim = 3`` (from the file or the overrides) the defaults of
    :data:`DIM3` come first and the quick preset is :data:`QUICK3D`.

    Raises
    ------
    ConfigError
        Unknown key (named), bad value (named), unreadable file.
    """
    tables = ("relax", "frictional_relax")
    d = layered_config(toml, overrides, quick, QUICK, tables)
    if d.get("dim") == 3:
        d = dict(DIM3, **layered_config(toml, overrides, quick, QUICK3D, tables))
    return EnsembleConfig.from_dict(d)
