"""The driver stages: relax, ramp, perturb, instability (docs/model.md section 6).

Each stage is one function taking a validated configuration
(:mod:`remote_trigger.pywrap.stages.config`) and an output folder, and returning a
result object. All MPI ranks of the communicator call the function (LAMMPS
runs domain-decomposed); rank 0 writes the files and runs the eigenvalue
analysis, and broadcasts every decision so that all ranks follow the same path.

Files (fixed names under the output folder ``out``; docs/driver.md):

========================  ===================================================
``relax.h5``              relaxation history; ``relax/equilibrium.*``
``ramp.h5``               one row per ramp step and per bisection step;
                          ``ramp/step_NNNNN.*``, ``ramp/bisect_NNN.*``
``perturb_{a,b,c}.h5``    the three undamped runs; ``perturb/equilibrium.*``
``instability.h5``        the undamped run above F_x^c;
                          ``instability/equilibrium.*``
========================  ===================================================

``X.*`` is an equilibrium: ``X.data`` (``write_data``, exact restart),
``X.dump`` and ``X.dump.json`` (docs/conventions.md section 3).

The stages live in modules by concern -- :mod:`.relax`, :mod:`.ramp`,
:mod:`.runs` (perturb, instability) and :mod:`.common` (scenes,
equilibrium files, output checks, time step) -- and are imported here, so
``stages.relax``, ``stages.ramp``, ``stages.perturb`` and
``stages.instability`` stay the driver's entry points. Below them,
:mod:`.equilibrium` brings a scene to equilibrium (over-damped dynamics,
Newton polishing) with the linear algebra of :mod:`.newton_solve` (the
stiffness K of a gathered state, the solves of K dq = G).
"""
from remote_trigger.pywrap.stages.common import (
    RESULT_VERSION, StableStartError, file_sha256, load_relax_scene, packing_fraction, prepare_out,
    save_equilibrium, start_timestep)
from remote_trigger.pywrap.stages.relax import (
    RelaxResult, antisymmetry, compact_bulk, place_top, press_top, relax, set_friction,
    top_clearance)
from remote_trigger.pywrap.stages.ramp import RampResult, next_bisection_point, ramp, ramp_bracket
from remote_trigger.pywrap.stages.runs import (
    PERTURB_RUNS, SeriesResult, check_runs, instability, perturb)

__all__ = ["relax", "ramp", "perturb", "instability", "RelaxResult", "RampResult",
           "SeriesResult", "StableStartError", "check_runs", "PERTURB_RUNS", "RESULT_VERSION",
           "load_relax_scene", "save_equilibrium", "packing_fraction", "prepare_out",
           "start_timestep", "file_sha256", "ramp_bracket", "next_bisection_point",
           "set_friction", "compact_bulk", "place_top", "press_top", "top_clearance",
           "antisymmetry"]
