"""Work done once, on MPI rank 0, with its result or its exception on every rank.

Reading and writing files, checking an output folder and the dense
eigen-analysis are done on rank 0 only (under MPI only rank 0 prints and
writes); every rank must then continue with the same result, or stop with
the same exception. :func:`on_rank0` is the one implementation of that
pattern.
"""
import pickle

from remote_trigger.analysis.errors import RemoteTriggerError


def portable_exception(exc):
    """``exc`` if it survives pickling (for ``bcast``), else a stand-in with its text."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:  # noqa: BLE001 - any pickling failure
        return RemoteTriggerError(f"{type(exc).__name__}: {exc}")


def on_rank0(comm, fn, *args, **kwargs):
    """Call ``fn(*args, **kwargs)`` on rank 0 of ``comm``; every rank returns its result.

    Parameters
    ----------
    comm : mpi4py communicator or None
        ``None`` (or a communicator of size 1): just call ``fn``.
    fn : callable
        Called on rank 0 only. Its return value must be picklable.

    Returns
    -------
    object
        What ``fn`` returned on rank 0, on every rank.

    Raises
    ------
    Exception
        Whatever ``fn`` raised on rank 0, re-raised on every rank with its
        type and message (an exception that cannot be pickled becomes a
        :class:`~remote_trigger.analysis.errors.RemoteTriggerError` naming
        its type). ``KeyboardInterrupt`` and ``SystemExit`` on rank 0 are
        re-raised there and reach the other ranks as ``RemoteTriggerError``.
    """
    if comm is None or comm.Get_size() == 1:
        return fn(*args, **kwargs)
    res, err, fatal = None, None, None
    if comm.Get_rank() == 0:
        try:
            res = fn(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank
            err = portable_exception(exc)
        except BaseException as exc:  # Ctrl-C, exit: the others must not wait
            err, fatal = RemoteTriggerError(f"rank 0 stopped: {type(exc).__name__}"), exc
    res, err = comm.bcast((res, err), root=0)
    if fatal is not None:
        raise fatal
    if err is not None:
        raise err
    return res
