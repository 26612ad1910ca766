"""The stage configurations of ``remote-trigger paper``: RelaxConfig, RampConfig and
DynamicsConfig built from a job configuration (its model, friction and time step).

Used by the phases (:mod:`.phases`, :mod:`.fig5`) and by the other jobs that
start from the paper's stages (``ensemble``, ``trigger-map``).
"""


def model_fields(cfg):
    """The model parameters every stage configuration shares but mu (each stage
    sets its own friction), and the time step."""
    from remote_trigger.pywrap.config import ContactModel

    d = ContactModel.of(cfg).as_dict()
    del d["mu"]
    return dict(d, dt=float(cfg.dt))


def relax_config(cfg, datafile):
    """RelaxConfig of the relaxation: the model, mu, F_x = 0 and ``cfg.relax``."""
    from remote_trigger.pywrap.stages.config import RelaxConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(cfg.mu), F_x=0.0)
    d.update(cfg.relax)
    return RelaxConfig.from_dict(d)


def ramp_config(cfg, datafile, mu):
    """RampConfig of the ramp at friction ``mu`` (from F_x = 0)."""
    from remote_trigger.pywrap.stages.config import RampConfig, RelaxConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(mu), F_x=0.0,
             dF_x=float(cfg.dF_x), tol=float(cfg.tol), F_x_max=float(cfg.F_x_max),
             dF_x_max=getattr(cfg, "dF_x_max", None),
             saddle_escape=getattr(cfg, "saddle_escape", True),
             pairs=getattr(cfg, "pairs", "all"), between=getattr(cfg, "between", 1),
             part_size=getattr(cfg, "part_size", None))
    ramp_fields = set(RampConfig.__dataclass_fields__) - {"settle_steps", "g_settle",
                                                           "mu_settle", "top_gap"}
    d.update({k: v for k, v in cfg.relax.items() if k in ramp_fields
              and k in RelaxConfig.__dataclass_fields__})
    return RampConfig.from_dict(d)


def dynamics_config(cfg, datafile, F_x, t_max, **extra):
    """DynamicsConfig of an undamped run at F_x with friction ``cfg.mu``."""
    from remote_trigger.pywrap.stages.config import DynamicsConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(cfg.mu), F_x=float(F_x),
             t_max=float(t_max), record_every=int(cfg.record_every), a=float(cfg.a_paper),
             omega_p=float(cfg.omega_p), B=float(cfg.B), w=float(cfg.w),
             mu_ss=float(cfg.mu_ss), d_sat=float(cfg.d_sat))
    d.update(extra)
    return DynamicsConfig.from_dict(d)
