"""Errors of the driver: the project's hierarchy in one place.

Re-exports :mod:`remote_trigger.analysis.errors` (the base class and exit
statuses) and the driver's own classes, defined next to the code that raises
them: :class:`~remote_trigger.pywrap.config.ConfigError` (bad configuration,
exit 2), :class:`~remote_trigger.pywrap.stages.equilibrium.NoEquilibriumError`
(exit 3), :class:`~remote_trigger.pywrap.bindings.engine.EngineError` (LAMMPS
refused a command, exit 1) and
:class:`~remote_trigger.analysis.stability.timestep.TimestepError` (exit 2).
"""
from remote_trigger.analysis.errors import (
    RemoteTriggerError, InputError, NotEquilibriumError, EXIT_OK, EXIT_NO_RESULT, EXIT_BAD_INPUT,
    EXIT_NO_EQUILIBRIUM, EXIT_INTERRUPTED)
from remote_trigger.pywrap.config import ConfigError  # noqa: F401
from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError  # noqa: F401
from remote_trigger.pywrap.bindings.engine import EngineError  # noqa: F401
from remote_trigger.analysis.stability.timestep import TimestepError  # noqa: F401
