"""Independent tasks of a job spread over MPI ranks with ``mpi4py.futures``.

The ``ensemble`` (one task per packing) and ``trigger-map`` (one task per
map point or control) jobs hand their tasks to :func:`run_tasks`. Under MPI
it uses :class:`mpi4py.futures.MPICommExecutor` on the job's communicator:
rank 0 schedules the tasks (in the order given, a task's follow-ups before
the tasks not yet begun) and receives every result, ranks 1..n-1 run them,
a free rank taking the next task (dynamic load balance). On one rank the
tasks run one after the other in this process.
The same launch works on one machine and on k nodes (``mpirun -np P`` /
``srun``; docs/ensemble.md "Running on k nodes"): no shared file is used to
hand out tasks, only MPI messages; the job's output folder must be visible
to every rank, since a task writes its own files there.

With ``join=True`` the workers left without a task join the points of the
running tasks (:mod:`~remote_trigger.pywrap.runtime.joining`).
"""
import collections
import time

__all__ = ["run_tasks", "n_workers", "helped", "FARM_BACKOFF"]

#: the longest sleep (s) of ``mpi4py.futures``' polling loops (its option
#: ``backoff``; its default, 1 ms, kept rank 0's manager thread at ~3-4 % of
#: a core through a farm; 10 ms: ~1 %, and at most ~10 ms more before a free
#: rank gets its next task)
FARM_BACKOFF = 0.01

#: On rank 0 after a joining :func:`run_tasks`: ``points`` (points that had
#: helpers) and ``helpers`` (sorted (points joined, rank) of each helper
#: task); empty when no helper ran.
helped = {}


def n_workers(comm):
    """Ranks that run tasks: ``size - 1`` under MPI (rank 0 schedules), 1 alone.

    Parameters
    ----------
    comm : mpi4py communicator or None

    Returns
    -------
    int
    """
    size = 1 if comm is None else comm.Get_size()
    return max(1, size - 1)


def run_tasks(comm, tasks, fn, args=(), done=None, join=False):
    """Call ``fn(task, *args)`` for every task; rank 0 gets the results.

    Every rank of ``comm`` calls this function; it returns when every task
    has ended.

    Parameters
    ----------
    comm : mpi4py communicator or None
        ``None`` or size 1: the tasks run here, in order. Size > 1: rank 0
        schedules, the other ranks run the tasks
        (:class:`mpi4py.futures.MPICommExecutor`, root 0).
    tasks : sequence
        Picklable task descriptions, in the order they are handed out.
    fn : callable
        A module-level function (it is pickled by reference); it runs on a
        worker rank and its return value is sent to rank 0 (picklable).
        It should record a task's failure in its result rather than raise.
    args : tuple, optional
        Extra picklable arguments, sent with every task.
    done : callable, optional
        ``done(task, result, wall)`` on rank 0 as each task ends (in the
        order they end): where the job writes the task's result file and
        prints its progress line. It may return an iterable of new tasks
        (follow-ups, e.g. the parts of a task that can run side by side),
        run like the others but before every task not yet handed out, in
        the order returned: a task begun is finished before a new one
        starts (an ensemble's relaxed packing has its ramps run before the
        next packing is relaxed, so its result comes first). Under MPI rank
        0 hands out at most one task per worker at a time and keeps the
        rest, so a follow-up goes to the next free rank.
    join : bool, optional
        Under MPI, workers without a task help the points of the running
        tasks that are decided in parts
        (:mod:`~remote_trigger.pywrap.runtime.joining`); a task handed out
        waits at most for the point its worker is helping. No effect on one
        rank.

    Returns
    -------
    list of (task, result) or None
        On rank 0 the tasks and results in the order they ended; ``None``
        on the other ranks.

    Raises
    ------
    Exception
        Under MPI, the first exception raised by ``fn`` or ``done``,
        re-raised on every rank once the other tasks have ended (as
        :func:`~remote_trigger.pywrap.runtime.parallel.on_rank0` does); on one
        rank it propagates at once.
    """
    ended = []
    helped.clear()
    # the tasks not yet handed out; follow-ups go to its front
    queue = collections.deque(tasks)
    if comm is None or comm.Get_size() == 1:
        while queue:
            task = queue.popleft()
            t0 = time.perf_counter()
            res = fn(task, *args)
            ended.append((task, res))
            if done is not None:
                _first(queue, done(task, res, time.perf_counter() - t0))
        return ended
    from concurrent.futures import FIRST_COMPLETED, wait
    from contextlib import nullcontext

    from mpi4py.futures import MPICommExecutor

    from remote_trigger.pywrap.runtime.joining import POLL_BUSY, POLL_IDLE, Broker, joining
    from remote_trigger.pywrap.runtime.parallel import portable_exception

    error = None
    with (joining(comm) if join else nullcontext()) as jc:
        with MPICommExecutor(comm, root=0, backoff=FARM_BACKOFF) as pool:
            if pool is not None:         # rank 0; the workers run tasks meanwhile
                workers = n_workers(comm)
                broker = Broker(jc, workers) if join else None
                futures = {}

                def hand_out():
                    """One task per worker at most, the front of the queue first."""
                    while queue and len(futures) < workers:
                        task = queue.popleft()
                        futures[pool.submit(_timed, fn, task, args)] = task

                hand_out()
                pause = POLL_BUSY
                while futures:
                    if broker is not None:
                        busy = broker.poll(pool, len(futures))
                        pause = POLL_BUSY if busy else min(2 * pause, POLL_IDLE)
                        waiting = futures.keys() | broker.helpers
                    else:
                        waiting = futures
                    finished, _ = wait(waiting, timeout=None if broker is None else pause,
                                       return_when=FIRST_COMPLETED)
                    if finished:
                        pause = POLL_BUSY
                    for fut in finished:
                        if broker is not None and fut in broker.helpers:
                            failed = _portable(broker.ended(fut))
                            error = error or failed
                            continue
                        task = futures.pop(fut)
                        try:
                            res, wall = fut.result()
                            ended.append((task, res))
                            more = done(task, res, wall) if done is not None else None
                            if error is None:     # after a failure no follow-up is started
                                _first(queue, more)
                        except Exception as exc:  # noqa: BLE001 - raised on every rank below
                            error = error or portable_exception(exc)
                        # (the tasks given are all run, after a failure too)
                        hand_out()
                if broker is not None:          # (even after a failure)
                    failed = _portable(broker.close(pool))
                    error = error or failed
                    if broker.joined:
                        helped.update(points=broker.points, helpers=sorted(broker.joined))
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error
    return ended if comm.Get_rank() == 0 else None


def _first(queue, more):
    """Put the follow-ups ``more`` (an iterable or None) at the front of
    ``queue``, in their order."""
    queue.extendleft(reversed(list(more or ())))


def _portable(exc):
    """:func:`~.parallel.portable_exception` of ``exc``, or None."""
    from remote_trigger.pywrap.runtime.parallel import portable_exception

    return None if exc is None else portable_exception(exc)


def _timed(fn, task, args):
    """``(fn(task, *args), wall time in s)`` on the worker."""
    t0 = time.perf_counter()
    res = fn(task, *args)
    return res, time.perf_counter() - t0
