"""``remote-trigger paper``: the paper end to end, with figures and a report.

One command reproduces Charan, Pomyalov & Procaccia, *Generic Mechanism for
Remote Triggering of Earthquakes*, on the default scene (N = 100, the
paper's parameters; docs/model.md) and writes everything under one folder
(``--out``, default ``demo-out``); docs/paper.md describes it in full.

Steps (each a stage of :mod:`remote_trigger.pywrap.stages`):

1. ``generate`` a seeded packing and ``relax`` it (default protocol of the
   driver); packing fraction and residual go to the report.
2. ``ramp`` F_x for mu and mu_low from the same relaxed packing, with the
   eigenvalues of M^-1 K at every equilibrium and F_x^c by bisection; then a
   short *continuation* above F_x^c (:func:`continue_ramp`) so that Fig. 3
   shows the pair after its birth and Fig. 4 starts from an equilibrium.
3. Fig. 4: ``instability`` at F_x = fig4_ratio * F_x^c(mu).
4. Fig. 5 (:mod:`.fig5`): a load inside the window F_x^c(mu_ss mu) < F_x <
   F_x^c(mu), its friction-drop analysis (mu*), the runs (a)-(c) of the
   paper, the controls (d), (e) and the paper's amplitude (p).
5. The normal form (``remote_trigger.analysis.dynamics.normal_form``).
6. Figures (:mod:`.figures`) and ``report.md`` (:mod:`.report`), both made
   from the files alone.

With two or more MPI ranks the independent stages run side by side (task
parallelism: ranks split into two groups; the two ramps, then the
instability run + normal form against the perturbation runs); within a
group LAMMPS decomposes the domain as usual.

Checkpoints: the manifest ``paper.json`` is rewritten (atomically, by rank
0) after every phase with that phase's summary; ``--resume``
(:func:`run_paper`, ``resume=True``) reloads the finished phases, continues
the ramps from their ``ramp.h5`` and reruns any other unfinished phase from
its start, so that the report equals that of an uninterrupted run.
"""
# The package: config (PaperConfig, the paper's reference values), manifest
# (output folder, paper.json, resume), stage_configs (the stage configurations),
# phases (the runs of each phase), fig5 (the Fig. 5 phase), job (phase order,
# rank groups, checkpoints), report + report_checks + report_metrics +
# report_fig5 (report.md), figures (the PNGs) and cli (the subcommand). The
# names below are the job's public API, used by the jobs that start from a
# paper folder (trigger map, ensemble).
from remote_trigger.pywrap.jobs.paper.config import PaperConfig, PAPER, build_config  # noqa: F401
from remote_trigger.pywrap.jobs.paper.manifest import (  # noqa: F401
    OUTPUTS, OUTPUT_GLOBS, MANIFEST, ramp_dir, prepare_out, config_difference,
    load_manifest, finished_phases)
from remote_trigger.pywrap.jobs.paper.stage_configs import (  # noqa: F401
    model_fields, relax_config, ramp_config, dynamics_config)
from remote_trigger.pywrap.jobs.paper.phases import (  # noqa: F401
    analyze_on_root, continue_ramp, extension_loads, run_ramp, run_instability, run_perturb,
    run_normal_form, Clock)
from remote_trigger.pywrap.jobs.paper.job import run_paper  # noqa: F401
from remote_trigger.pywrap.jobs.paper.cli import register, config_from_args, main  # noqa: F401

__all__ = ["OUTPUTS", "OUTPUT_GLOBS", "MANIFEST", "ramp_dir", "prepare_out",
           "config_difference", "load_manifest", "finished_phases", "run_paper",
           "relax_config", "ramp_config", "dynamics_config", "model_fields", "register",
           "config_from_args", "main"]
