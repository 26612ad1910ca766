"""The exception hierarchy of remote-trigger (importable without LAMMPS or MPI).

Every error the driver and the command line raise on purpose derives from
:class:`RemoteTriggerError` (the analysis library's input checks raise
:class:`InputError` or plain ``ValueError``; both are exit status 2). Each
class keeps the builtin base it had before (``ValueError`` for bad input,
``RuntimeError`` for a calculation that failed), so ``except ValueError`` and ``pytest.raises(ValueError)`` keep
working, and carries the exit status of the ``remote-trigger`` command line
(docs/driver.md, "Exit status"):

======  ==============================================================
status  meaning
======  ==============================================================
0       success
1       no result (a calculation ran and ended without one)
2       bad input: an option, a file, an output folder (nothing written)
3       no mechanical equilibrium at the requested load
130     interrupted (Ctrl-C / SIGINT)
======  ==============================================================

The driver's classes (``ConfigError``, ``NoEquilibriumError``,
``EngineError``) live in :mod:`remote_trigger.pywrap` and derive from the
classes here; :mod:`remote_trigger.pywrap.errors` re-exports this module.
"""

import numbers

__all__ = ["RemoteTriggerError", "InputError", "NotEquilibriumError", "TooLargeError", "EXIT_OK",
           "EXIT_NO_RESULT", "EXIT_BAD_INPUT", "EXIT_NO_EQUILIBRIUM", "EXIT_INTERRUPTED",
           "is_real", "is_integer"]

#: exit statuses of the command line
EXIT_OK = 0
EXIT_NO_RESULT = 1
EXIT_BAD_INPUT = 2
EXIT_NO_EQUILIBRIUM = 3
EXIT_INTERRUPTED = 130


class RemoteTriggerError(Exception):
    """Base of every error raised on purpose by remote-trigger.

    Attributes
    ----------
    exit_status : int
        Status the command line exits with for this error (class attribute).
    """

    exit_status = EXIT_NO_RESULT


class InputError(RemoteTriggerError, ValueError):
    """Bad input: an option, a file or an output folder; the message names the value."""

    exit_status = EXIT_BAD_INPUT


class NotEquilibriumError(InputError):
    """A state given as an equilibrium has a residual far above the round-off floor."""


class TooLargeError(RemoteTriggerError, MemoryError):
    """A calculation that does not fit in this machine's memory; the message
    names the size, the memory it needs and the memory available."""


def is_real(val):
    """True for a real number, Python's or numpy's; a bool is not one (the input checks' test)."""
    return isinstance(val, numbers.Real) and not isinstance(val, bool)


def is_integer(val):
    """True for an integer, Python's or numpy's; a bool is not one."""
    return isinstance(val, numbers.Integral) and not isinstance(val, bool)
