"""Configuration of the driver stages: frozen, validated dataclasses.

Every stage takes one configuration object (:class:`RelaxConfig`,
:class:`RampConfig`, :class:`DynamicsConfig`, all :class:`StageConfig`).
All fields have defaults (the paper's values, docs/model.md), are validated
in ``__post_init__`` by the checks of :mod:`remote_trigger.pywrap.config`
(a :class:`~remote_trigger.pywrap.config.ConfigError` names the field and
the bad value), and round-trip through HDF5 attributes
(:meth:`StageConfig.to_attrs`, :meth:`StageConfig.from_attrs`);
:meth:`StageConfig.from_dict` rejects unknown keys.

Units are LAMMPS ``lj`` units of the model (mass m = 1, length 2 R1 = 1).
"""
from dataclasses import dataclass, fields, asdict
import json
import os

from remote_trigger.analysis.state.dumpfile import TOP_LAYERS  # (RelaxConfig.top_layer)
from remote_trigger.pywrap.config import (
    Config, ConfigError, ContactModel, check_int, check_lammps_path, check_nonnegative, check_number,
    check_positive)


#: relaxation protocols of :class:`RelaxConfig` (docs/driver.md)
PROTOCOLS = ("frictionless-then-friction", "frictional")
#: dynamics of the frictionless relaxation of the default protocol (``RelaxConfig.relax_dynamics``)
RELAX_DYNAMICS = ("auto", "damped", "fire")
#: ``relax_dynamics = 'auto'`` is ``'damped'`` up to this many disks, ``'fire'`` above
RELAX_DYNAMICS_AUTO_N = 400
#: when a placement of the top line is clear (``RelaxConfig.clearance``)
CLEARANCE_RULES = ("auto", "all", "local")


@dataclass(frozen=True)
class StageConfig(Config):
    """Model parameters shared by every stage.

    Attributes
    ----------
    datafile : str
        LAMMPS data file to start from (must exist).
    k_n : float
        Normal stiffness (Eq. 1), > 0. Default 2e5.
    k_t : float or None
        Tangential stiffness (Eq. 3), >= 0; None means 2 k_n / 7.
    mu : float
        Friction coefficient (Eq. 2, static mu_0), >= 0. Default 1.
    F_y : float
        Downward load on each ``top`` disk, > 0. Default 3.
    dt : float or 'auto'
        Time step, > 0, or ``'auto'``: SAFETY_FACTOR (0.1) x the
        velocity-Verlet stability limit 2/omega_max of the state the stage
        starts from (:mod:`remote_trigger.pywrap.stages.timestep`). Default 1e-3
        (0.10-0.11 of the limit for the default model). Every stage refuses a
        dt at or above the limit (:class:`TimestepError`, message gives the
        limit) before it runs a step.
    """

    datafile: str = ""
    k_n: float = ContactModel.k_n
    k_t: float = None
    mu: float = ContactModel.mu
    F_y: float = ContactModel.F_y
    dt: float | str = 1e-3

    def __post_init__(self):
        if not isinstance(self.datafile, (str, os.PathLike)) or not str(self.datafile):
            raise ConfigError(f"datafile must be a file name, got datafile = {self.datafile!r}")
        object.__setattr__(self, "datafile", os.fspath(self.datafile))
        if os.path.isdir(self.datafile):
            raise ConfigError(f"datafile is a folder, not a data file: datafile = "
                              f"{self.datafile!r}")
        if not os.path.isfile(self.datafile):
            raise ConfigError(f"datafile does not exist: datafile = {self.datafile!r}")
        check_lammps_path("datafile", self.datafile)
        object.__setattr__(self, "k_t", self.model.k_t)
        if isinstance(self.dt, str):
            if self.dt != "auto":
                raise ConfigError(f"dt must be a number > 0 or 'auto', got dt = {self.dt!r}")
        else:
            check_positive("dt", self.dt)
        self.validate()

    @property
    def model(self):
        """The :class:`ContactModel` of this configuration (validated)."""
        return ContactModel.of(self)

    def validate(self):
        """Stage-specific checks (overridden)."""

    # ------------------------------------------------------------ conversion
    def replace(self, **changes):
        """Copy with some fields changed (validated again)."""
        d = asdict(self)
        d.update(changes)
        return type(self).from_dict(d)

    def to_attrs(self):
        """Dict for HDF5 attributes: None becomes the string ``'None'``."""
        out = {"config_class": type(self).__name__}
        for k, v in asdict(self).items():
            out[k] = "None" if v is None else v
        return out

    @classmethod
    def from_attrs(cls, attrs, check_file=True):
        """Inverse of :meth:`to_attrs` (extra attributes are ignored; a field of
        ``LATER_FIELDS`` that the attributes lack has the value given there)."""
        names = {f.name for f in fields(cls)}
        d = {k: v for k, v in getattr(cls, "LATER_FIELDS", {}).items() if k not in attrs}
        for k in names:
            if k in attrs:
                v = attrs[k]
                if hasattr(v, "item"):
                    v = v.item()
                if isinstance(v, bytes):
                    v = v.decode()
                d[k] = None if v == "None" else v
        return cls.from_dict(d)

    def to_json(self):
        """JSON text of the configuration."""
        return json.dumps(asdict(self), sort_keys=True)


@dataclass(frozen=True)
class RelaxConfig(StageConfig):
    """Relaxation to mechanical equilibrium (docs/model.md section 6, step 1).

    Attributes
    ----------
    F_x : float
        Horizontal load on each ``top`` disk (any sign). Default 0.
    f_min : float
        Target residual max_i max(|F_i|, |T_i|/R_i), > 0. Default 1e-15 (paper).
    f_accept : float or None
        Largest residual accepted as "equilibrium at round-off level" when
        Newton stagnates above f_min (double precision cannot resolve forces
        below ~ k_eff eps |x|); >= f_min. Default None: max(1e-10,
        4 eps X k_eff), the round-off floor scaled with the stiffness
        k_eff = 1.5 k_n^(2/3) F_y^(1/3) and the packing size X
        (:func:`remote_trigger.pywrap.stages.equilibrium.accept_level`); 1e-10 for
        the default model, 1.6e-8 at k_n = 2e9 (N = 20).
    gamma, gamma_rot : float
        Damping of the over-damped dynamics: ``fix viscous`` rate (1/time,
        m = 1) and ``fix viscous/sphere`` coefficient; > 0. Defaults 2, 0.1.
    protocol : str
        ``'frictionless-then-friction'`` (default, **choice**, docs/driver.md):
        (i) compact the bulk only, frictionless, with gravity ``g_settle``
        for ``settle_steps`` steps while the ``top`` disks are held (not
        integrated); (ii) lower the ``top`` line rigidly until its lowest
        point is ``top_gap`` above the highest bulk point; (iii) gravity off,
        relax frictionless (mu = 0, history stays 0) under the loads
        (over-damped + Newton); (iv) switch friction on (``mu``): the
        history is zero, so the state is still an equilibrium (checked).
        ``'frictional'``: the former protocol (compaction of all disks with
        ``mu_settle`` and gravity, then relaxation with friction ``mu``).
    relax_dynamics : {'auto', 'damped', 'fire'}
        How the default protocol's frictionless steps (iii) reach rest:
        ``'damped'``, over-damped dynamics (``gamma``, ``gamma_rot``; the
        piston until every speed is below ``v_stop``); ``'fire'``, LAMMPS's
        FIRE minimizer (``min_style fire``; the piston, then the free
        relaxation, each until the largest force is below
        :data:`~remote_trigger.pywrap.stages.relax.FIRE_FTOL` x F_y), with
        damped dynamics after it only if Newton does not finish. Both end
        with the same Newton polish and the same residual test.
        ``'auto'`` (default): ``'damped'`` for N <= 400 disks (the results
        of N <= 400 are those of ``'damped'``, bitwise), ``'fire'`` above.
        Used by the default protocol only.
    settle_steps : int
        Compaction steps with gravity (0 = no compaction, e.g. for a data
        file that is already an equilibrium), >= 0. Default 30000.
    g_settle : float
        Gravity of the compaction, >= 0. Default 0.5.
    mu_settle : float
        Friction during the compaction of the ``'frictional'`` protocol,
        >= 0. Default 0 (the default protocol compacts with mu = 0).
    top_gap : float
        Gap between the lowest point of the lowered ``top`` line and the
        highest point of the compacted bulk, > 0. Default 0.05.
    top_attempts : int
        Placements of the ``top`` line tried, >= 1 (default 4): if after the
        frictionless relaxation the placement is not clear (``clearance``),
        the relaxation is repeated from the same compacted bulk with the
        line shifted along x by k/top_attempts of its spacing; the first
        clear placement is kept (else the one with the largest clearance,
        reported).
    clearance : {'auto', 'all', 'local'}
        When a placement is clear (the test of ``top_attempts``,
        :func:`~remote_trigger.pywrap.stages.relax.top_clearance`):
        ``'all'``, every top centre above every bulk centre (min over top of
        y minus max over bulk of y > 0); ``'local'``, every bulk centre
        below the highest top centre within a horizontal distance 1.25 of
        it (no bulk disk came up through or over the line, wherever the
        line's height varies along the box). ``'auto'`` (default):
        ``'all'`` for N <= 400 disks (the results of N <= 400 are those of
        ``'all'``, bitwise), ``'local'`` above and for spheres.
    top_layer : {'free', 'rigid'}
        The loading of the top layer. ``'free'`` (default; the paper's):
        every top particle carries its loads on its own. ``'rigid'``
        (spheres only): the layer stays the piston it is in step (iii a), a
        rigid plate that translates as one body (``fix aveforce 0.0 0.0
        0.0`` on ``top``), every sphere carrying its loads (F_x, -F_y) and
        turning on its own; Newton and the Jacobian tie the layer's x, y and
        z into three dofs (docs/model.md section 9.1). A free layer of
        frictionless spheres sinks into the bulk, more often the larger it
        is (docs/ensemble.md "Not done here"). Recorded in the equilibrium's
        sidecar; a ramp must be given the value its start state was relaxed
        with.
    check_every : int
        Damped steps between residual checks, >= 1. Default 1000.
    max_steps : int
        Give up after this many damped steps, >= 1. Default 5,000,000.
    newton : bool
        Polish with Newton steps (analytic stiffness). Default True. Without
        them the damped dynamics stop at max(f_min, the acceptance level):
        they stall near the round-off floor, above the default f_min.
    newton_start : float
        Newton is tried once the residual is below newton_start * F_y, > 0.
        Default 1e-3.
    newton_iter : int
        Maximum Newton iterations per attempt, >= 1. Default 30.
    slide : float
        Error (no equilibrium) once the mean x displacement of ``top`` from
        the start exceeds this length, > 0. Default 2.
    """

    F_x: float = 0.0
    f_min: float = 1e-15
    f_accept: float | None = None
    gamma: float = 2.0
    gamma_rot: float = 0.1
    protocol: str = "frictionless-then-friction"
    relax_dynamics: str = "auto"
    settle_steps: int = 30000
    mu_settle: float = 0.0
    g_settle: float = 0.5
    top_gap: float = 0.05
    top_attempts: int = 4
    clearance: str = "auto"
    top_layer: str = "free"
    check_every: int = 1000
    max_steps: int = 5_000_000
    newton: bool = True
    newton_start: float = 1e-3
    newton_iter: int = 30
    slide: float = 2.0

    def validate(self):
        """The relaxation's checks (:class:`ConfigError` naming the field)."""
        check_number("F_x", self.F_x)
        check_positive("f_min", self.f_min)
        if self.f_accept is not None:
            check_positive("f_accept", self.f_accept)
        if self.f_accept is not None and self.f_accept < self.f_min:
            raise ConfigError(f"f_accept must be >= f_min = {self.f_min!r}, got "
                              f"f_accept = {self.f_accept!r}")
        check_positive("gamma", self.gamma)
        check_positive("gamma_rot", self.gamma_rot)
        if self.protocol not in PROTOCOLS:
            raise ConfigError(f"protocol must be one of {', '.join(PROTOCOLS)}, got "
                              f"protocol = {self.protocol!r}")
        if self.relax_dynamics not in RELAX_DYNAMICS:
            raise ConfigError(f"relax_dynamics must be one of {', '.join(RELAX_DYNAMICS)}, "
                              f"got relax_dynamics = {self.relax_dynamics!r}")
        check_int("settle_steps", self.settle_steps, 0)
        check_positive("top_gap", self.top_gap)
        check_int("top_attempts", self.top_attempts, 1)
        if self.clearance not in CLEARANCE_RULES:
            raise ConfigError(f"clearance must be one of {', '.join(CLEARANCE_RULES)}, "
                              f"got clearance = {self.clearance!r}")
        if self.top_layer not in TOP_LAYERS:
            raise ConfigError(f"top_layer must be one of {', '.join(TOP_LAYERS)}, got "
                              f"top_layer = {self.top_layer!r}")
        check_nonnegative("mu_settle", self.mu_settle)
        check_nonnegative("g_settle", self.g_settle)
        check_int("check_every", self.check_every, 1)
        check_int("max_steps", self.max_steps, 1)
        if not isinstance(self.newton, bool):
            raise ConfigError(f"newton must be True or False, got newton = {self.newton!r}")
        check_positive("newton_start", self.newton_start)
        check_int("newton_iter", self.newton_iter, 1)
        check_positive("slide", self.slide)


@dataclass(frozen=True)
class RampConfig(RelaxConfig):
    """F_x ramp with eigenvalue analysis and bisection (docs/model.md section 6, step 2).

    Attributes
    ----------
    F_x : float
        Start value of the ramp (the data file is re-equilibrated there first).
    dF_x : float
        Ramp step, > 0. Default 1e-4 (paper).
    F_x_max : float
        Stop (no complex pair found) beyond this value, > F_x. Default 1.
    tol : float
        Bisection tolerance on F_x^c, > 0. Default 1e-7.
    dF_x_max : float or None
        None (default): every step is dF_x. A number > dF_x: adaptive ramp,
        steps between dF_x and dF_x_max chosen from the predicted distance to
        the nearest coalescence (``pywrap.stages.ramp.next_step``, docs/driver.md).
    keep_equilibria : bool
        True (default): every point's equilibrium files stay in ``ramp/``.
        False: at each checkpoint the ramp removes the files of the points
        that no later point starts from and that are not an end of the
        certified bracket (it keeps the last step, the bracket's lower end
        and its upper end); ``ramp.h5`` keeps every decision and eigenvalue
        either way. For large N (docs/driver.md, "Disk use"). A storage
        choice, not part of the result: a ramp may be resumed with the
        other value.
    saddle_escape : bool
        True (default): a point whose Newton equilibrium screens as a saddle
        (a negative eigenvalue, ``analysis.stability.analyze.negative_modes``)
        is equilibrated again by damped dynamics from the same start
        (:func:`remote_trigger.pywrap.stages.point.ramp_point`, docs/driver.md
        "Saddles"). False: Newton's equilibrium is kept, saddle or not (the
        behaviour of ramps written before this option; an older ramp.h5 is
        resumed only with False).
    pairs : str
        Which complex pairs end the ramp and are bracketed. ``'all'``
        (default): the first certified complex pair. ``'collective'``: the
        first that is not *soft* (soft: every eigenvalue of the pair below
        ``SOFT_MODE_REL`` = 1e-4 lambda_max in |Re lambda|, two near-floppy
        modes of one or two weakly held disks,
        ``analysis.stability.verdict.collective_decision``); a point whose
        only certified complex pairs are soft counts as real, and the column
        ``soft_pairs`` of ramp.h5 counts them (docs/driver.md "Soft pairs").
    part_size : int or None
        None (default): a sliced verdict (above 3000 dofs) is one scan, run
        on rank 0 while the other ranks wait. An integer >= 60 (the slice
        size, ``analysis.stability.sliced.scan.SLICE_SIZE``): the scan in parts of about this many eigenvalues
        (``VerdictOptions.part_size``), run on every MPI rank of the ramp
        (``pywrap.runtime.rankmap``); the answer depends on it, never on
        the number of ranks (docs/analysis.md "One large point on many
        cores").
    between : int
        1 (default): the first certified complex step and the bisection
        below it. m >= 2: before the bisection, m - 1 loads evenly spaced
        between every two consecutive steps below the first complex step
        (the lower certified real) are decided too, each from the lower
        step's equilibrium, lowest first (``stages.ramp.between_loads``);
        the first complex one ends the check and the bisection moves there.
        A complex window narrower than a step is then looked for at the
        resolution dF_x / m, for about (m - 1) x (the steps) more points
        (docs/driver.md "What the bracket certifies").
    """

    #: fields added after ramp files were written: the value an older file has
    #: (``clearance``, a relax field, plays no part in a ramp)
    LATER_FIELDS = {"saddle_escape": False, "clearance": "auto", "pairs": "all", "between": 1,
                    "top_layer": "free"}
    #: the values of ``pairs``
    PAIRS = ("all", "collective")

    dF_x: float = 1e-4
    F_x_max: float = 1.0
    tol: float = 1e-7
    dF_x_max: float = None
    keep_equilibria: bool = True
    saddle_escape: bool = True
    pairs: str = "all"
    part_size: int = None
    between: int = 1

    def validate(self):
        """The relaxation's checks and the ramp's (:class:`ConfigError`)."""
        super().validate()
        check_positive("dF_x", self.dF_x)
        if self.dF_x_max is not None:
            check_number("dF_x_max", self.dF_x_max)
            if not self.dF_x_max > self.dF_x:
                raise ConfigError(f"dF_x_max must be > dF_x = {self.dF_x!r} (or None: "
                                  f"fixed steps), got dF_x_max = {self.dF_x_max!r}")
        check_number("F_x_max", self.F_x_max)
        if self.F_x_max <= self.F_x:
            raise ConfigError(f"F_x_max must be > F_x = {self.F_x!r}, got "
                              f"F_x_max = {self.F_x_max!r}")
        check_positive("tol", self.tol)
        for name in ("keep_equilibria", "saddle_escape"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name} must be True or False, got "
                                  f"{name} = {getattr(self, name)!r}")
        if self.pairs not in self.PAIRS:
            raise ConfigError(f"pairs must be one of {', '.join(map(repr, self.PAIRS))}, "
                              f"got pairs = {self.pairs!r}")
        check_int("between", self.between, 1)
        if self.part_size is not None:
            from remote_trigger.analysis.stability.sliced.scan import SLICE_SIZE

            check_int("part_size", self.part_size, 2)
            if self.part_size < SLICE_SIZE:      # refused here, not at the first sliced point
                raise ConfigError(f"part_size must be >= the slice size ({SLICE_SIZE}), got "
                                  f"part_size = {self.part_size!r}")


@dataclass(frozen=True)
class DynamicsConfig(StageConfig):
    """Undamped runs from an equilibrium (perturbation and instability).

    Attributes
    ----------
    F_x : float
        Horizontal load of the run (should match the equilibrium's).
    t_max : float
        Simulated time, > 0: the run takes whole records of
        ``record_every`` steps, floor(t_max / (record_every dt)) of them
        (at least one), so it may end up to one record before t_max.
        Default 1000.
    record_every : int
        Steps between records of D(t), v and mu, >= 1. Default 100.
    a : float
        Amplitude of f(t) = a cos(omega_p t) added to F_x on ``top``, >= 0.
        Default 1e-12 (paper).
    omega_p : float
        Angular frequency of f(t), >= 0. Default 0.01.
    B, w, mu_ss : float
        mu(v) law (Eq. 4): mu = mu0 (B exp(-w (v~ - v~0)) + mu_ss) above v~0;
        defaults 0.2, 0.4, 0.8 (mu0 is ``mu``).
    v0 : float or None
        Threshold velocity; None means measured by run (a): ``v0_margin``
        times its largest |v_top| over every step.
    v0_margin : float
        Factor of that measured v0, >= 1. Default 10, the default of the
        paper job's ``fig5_v0_margin`` (which multiplies the largest |v_top|
        of the first half of its run (a)). With 1, run (c) (f(t) of the
        default a = 1e-12, a forced velocity ~3e-6 of the noise) crossed v0
        by its noise alone in 4 of 8 runs, which then looked triggered
        (docs/results/driver.md, "Perturb v0 margin").
    v_ss : float or None
        Velocity scale of v~ = v / v_ss; None means v_ss = v0.
    d_sat : float
        Instability: stop once D(t) exceeds this, > 0. Default 1e-2.
    t_on : float
        Onset of f(t), >= 0: 0 (default) switches f(t) on as a step at t = 0;
        t_on > 0 multiplies it by the raised cosine (1 - cos(pi t / t_on)) / 2
        for t < t_on (smooth onset, no ringing of the fast modes).
    tau : float or None
        Viscous damping time, > 0: ``fix viscous`` with gamma = m / tau on
        the translational velocities (Section IV's -(1/tau) dx/dt for the
        positions; rotations undamped). None (default): no damping.
    """

    F_x: float = 0.0
    t_max: float = 1000.0
    record_every: int = 100
    a: float = 1e-12
    omega_p: float = 0.01
    B: float = 0.2
    w: float = 0.4
    mu_ss: float = 0.8
    v0: float = None
    v0_margin: float = 10.0
    v_ss: float = None
    d_sat: float = 1e-2
    t_on: float = 0.0
    tau: float = None

    #: files written before the field: v0 was run (a)'s largest |v_top| itself
    LATER_FIELDS = {"v0_margin": 1.0}

    def validate(self):
        """The run's checks (:class:`ConfigError` naming the field)."""
        check_number("F_x", self.F_x)
        check_positive("t_max", self.t_max)
        check_int("record_every", self.record_every, 1)
        check_nonnegative("a", self.a)
        check_nonnegative("omega_p", self.omega_p)
        check_nonnegative("B", self.B)
        check_nonnegative("w", self.w)
        check_nonnegative("mu_ss", self.mu_ss)
        for name in ("v0", "v_ss"):
            val = getattr(self, name)
            if val is not None:
                check_positive(name, val)
        check_number("v0_margin", self.v0_margin, 1)
        check_positive("d_sat", self.d_sat)
        check_nonnegative("t_on", self.t_on)
        if self.tau is not None:
            check_positive("tau", self.tau)


def check_packing_args(n, seed, phi=0.82, dim=2):
    """Validate the arguments of the packing generator.

    Raises
    ------
    ConfigError
        If n is not an even integer >= 6, seed is not a non-negative integer,
        or phi is outside (0.1, 0.91) (spheres, ``dim`` = 3: (0.1, 0.74)).
    """
    top = 0.91 if dim == 2 else 0.74
    if not 0.1 < check_number("phi", phi) < top:
        raise ConfigError(f"phi must be in (0.1, {top}){' for spheres' if dim == 3 else ''}, "
                          f"got phi = {phi!r}")
    if not isinstance(n, bool) and isinstance(n, int) and n < 6:
        from remote_trigger.pywrap.stages.packing import RADII, smallest_n

        raise ConfigError(f"n must be >= 6, got n = {n} "
                          f"({smallest_n(phi, RADII, dim)})")
    check_int("n", n, 6)
    if n % 2:
        raise ConfigError(f"n must be even (equal numbers of both radii), got n = {n}")
    check_int("seed", seed, 0)
