"""Ranks left without a task join the points of the tasks still running.

A task farm (:func:`~remote_trigger.pywrap.runtime.taskfarm.run_tasks`)
runs one task (a packing of an ensemble) on one worker rank. Near a job's
end fewer tasks than workers remain, and the free workers would wait for the
last, longest tasks. With ``run_tasks(..., join=True)`` they join the
points of the running tasks instead:

* **Helpers.** Rank 0, the farm's scheduler, gives every free worker a
  *helper* task (:func:`help_points`): the helper tells rank 0 it is free
  and waits for a point.
* **A point asks for them.** A task whose point is decided in parts
  (``VerdictOptions.part_size``,
  :mod:`remote_trigger.analysis.stability.sliced.parts`) asks rank 0 for
  helpers when the verdict first hands out tasks (:class:`PointMap`; a
  dense verdict hands out none and asks for nothing). Rank 0 gives it every
  free helper (none while a task waits for a worker). The point's tasks then
  run on a communicator of the task's rank and its helpers, made for that
  point by ``MPI_Comm_create_group`` (only its members take part), through a
  :class:`~remote_trigger.pywrap.runtime.rankmap.RankMap`. After the point
  the helpers are free again; the next point asks again.
* **Helpers leave** when rank 0 sends them away: when a task waits for a
  worker (a follow-up task, or a task queued behind them) and when every
  task of the job has ended. A helper is never interrupted inside a point,
  so a waiting task waits at most the rest of that point.

The answer of a point does not depend on how many helpers joined it: the
parts are fixed by ``part_size`` and each is deterministic, so the merged
verdict and eigenvalues are the same bits on any number of ranks, as for
``ramp --np`` (tests/driver/test_joining_mpi.py). Every wait polls
(:func:`~remote_trigger.pywrap.runtime.rankmap.wait_message`), so waiting
costs no core.
"""
from __future__ import annotations

import itertools
from contextlib import contextmanager

from remote_trigger.pywrap.runtime.rankmap import RankMap, serve, wait_message

__all__ = ["Broker", "POLL_BUSY", "POLL_IDLE", "PointMap", "active", "help_points",
           "joining", "point_map"]

# message tags on the joining communicator
_TAG_READY, _TAG_ASSIGN, _TAG_REQUEST, _TAG_GROUP = 7401, 7402, 7403, 7404
#: rank 0's wait between two polls of the broker (s): right after something
#: happened, and at most (it doubles while nothing does); a point waits at
#: most this long for its helpers
POLL_BUSY, POLL_IDLE = 0.005, 0.2

# this rank's joining communicator while a joining farm runs (None otherwise)
_farm = {"comm": None}


@contextmanager
def joining(comm):
    """The joining communicator of a farm, on every rank of ``comm``.

    Called by every rank of ``comm`` around the farm
    (:func:`~remote_trigger.pywrap.runtime.taskfarm.run_tasks`); while it is
    open, :func:`active`, :func:`point_map` and :func:`help_points` on any
    rank use it.

    Parameters
    ----------
    comm : mpi4py communicator
        The farm's communicator (rank 0 schedules).

    Yields
    ------
    mpi4py communicator
        A duplicate of ``comm`` (freed on exit, collectively): its messages
        never mix with the farm's own or with a task's.
    """
    jc = comm.Dup()
    _farm["comm"] = jc
    try:
        yield jc
    finally:
        _farm["comm"] = None
        jc.Free()


def _sub_comm(jc, ranks, tag):
    """The communicator of ``ranks`` of ``jc`` (in that order), made by them alone."""
    world = jc.Get_group()
    group = world.Incl(list(ranks))
    try:
        return jc.Create_group(group, tag)
    finally:
        group.Free()
        world.Free()


def active(comm):
    """Whether a point on ``comm`` can be joined: ``comm`` is one rank, a
    worker of a joining farm (:func:`joining`) under an MPI thread level of
    at least ``THREAD_SERIALIZED`` (that of
    :class:`~remote_trigger.pywrap.runtime.rankmap.RankMap`)."""
    jc = _farm["comm"]
    if jc is None or jc.Get_rank() == 0 or (comm is not None and comm.Get_size() > 1):
        return False
    from mpi4py import MPI

    return MPI.Query_thread() >= MPI.THREAD_SERIALIZED


class PointMap:
    """The ``map_tasks`` of one point of a farm's task, helpers joining it.

    Made by :func:`point_map`. At its first call it asks rank 0 of the farm
    for the free helpers; with some, that call and the point's later ones
    run on a :class:`~remote_trigger.pywrap.runtime.rankmap.RankMap` of a
    communicator of this rank (rank 0 of it) and the helpers, made for this
    point; with none, on the builtin :func:`map`. A point that never calls
    it (a dense verdict) asks for nothing.

    Parameters
    ----------
    shared_types : tuple of type
        As :class:`~remote_trigger.pywrap.runtime.rankmap.RankMap`.

    Attributes
    ----------
    helpers : list of int
        The helpers' ranks in the farm's communicator (empty before the first
        call, or when rank 0 gave none).
    """

    def __init__(self, shared_types=()):
        self.shared_types = tuple(shared_types)
        self.helpers, self._asked = [], False
        self._sub, self._rankmap = None, None

    def __call__(self, fn, tasks):
        if not self._asked:
            self._asked = True
            jc = _farm["comm"]
            jc.send(None, dest=0, tag=_TAG_REQUEST)
            wait_message(jc, 0, _TAG_GROUP)
            helpers, tag = jc.recv(source=0, tag=_TAG_GROUP)
            if helpers:
                self.helpers = list(helpers)
                self._sub = _sub_comm(jc, [jc.Get_rank()] + self.helpers, tag)
                self._rankmap = RankMap(self._sub, self.shared_types)
        if self._rankmap is None:
            return map(fn, tasks)
        return self._rankmap(fn, tasks)

    def close(self):
        """Send the helpers back to rank 0 of the farm (after their running
        tasks end) and free the point's communicator."""
        if self._rankmap is not None:
            try:
                self._rankmap.close()
            finally:
                self._sub.Free()
                self._rankmap = self._sub = None


@contextmanager
def point_map(shared_types=()):
    """A :class:`PointMap` for one point, closed at the end of the block.

    Use only where :func:`active` is true.

    Yields
    ------
    PointMap
    """
    pmap = PointMap(shared_types)
    try:
        yield pmap
    finally:
        pmap.close()


def help_points(_task=None):
    """A helper's task: join points until rank 0 of the farm sends it away.

    Runs on a free worker of a joining farm (:func:`joining`); rank 0 hands
    it out (:class:`Broker`). A point that fails is reported by the task
    that owns it, not here (:func:`~remote_trigger.pywrap.runtime.rankmap.serve`
    sends a task's exception to its owner).

    Returns
    -------
    tuple of int
        (points joined, this rank in the farm's communicator).
    """
    jc = _farm["comm"]
    points = 0
    while True:
        jc.send(None, dest=0, tag=_TAG_READY)
        wait_message(jc, 0, _TAG_ASSIGN)
        msg = jc.recv(source=0, tag=_TAG_ASSIGN)
        if msg is None:
            return points, jc.Get_rank()
        ranks, tag = msg
        sub = _sub_comm(jc, ranks, tag)
        try:
            serve(sub)                          # the owner's tasks, until it closes
        finally:
            sub.Free()
        points += 1


class Broker:
    """Rank 0's side of joining: which workers help, and which point they join.

    Parameters
    ----------
    comm : mpi4py communicator
        The joining communicator (:func:`joining`), on rank 0.
    n_workers : int
        The farm's worker ranks.

    Attributes
    ----------
    free : list of int
        Ranks of helpers waiting for a point.
    helpers : set of Future
        Helper tasks handed out and not ended.
    joined : list of tuple
        (points joined, rank) of every helper task that ended.
    points : int
        Points that had at least one helper.
    """

    def __init__(self, comm, n_workers):
        self.comm, self.n_workers = comm, int(n_workers)
        self.free, self.helpers, self.joined = [], set(), []
        self.points, self._releasing = 0, 0
        self._tags = itertools.count()

    def _sources(self, tag):
        """Ranks with a message of ``tag`` waiting, each message received."""
        from mpi4py import MPI

        st, out = MPI.Status(), []
        while self.comm.Iprobe(source=MPI.ANY_SOURCE, tag=tag, status=st):
            src = st.Get_source()
            self.comm.recv(source=src, tag=tag)
            out.append(src)
        return out

    def poll(self, pool, n_tasks):
        """Answer the helpers and the points, and keep every worker busy.

        Parameters
        ----------
        pool : mpi4py.futures executor
        n_tasks : int
            The farm's tasks handed out and not ended (running or queued).

        Returns
        -------
        bool
            Whether anything happened (a message, a helper handed out or
            sent away): the caller polls again soon if so, else less often.
        """
        ready = self._sources(_TAG_READY)
        self.free.extend(ready)
        excess = n_tasks + len(self.helpers) - self._releasing - self.n_workers
        for _ in range(max(0, -excess)):          # free workers: a helper each
            self.helpers.add(pool.submit(help_points))
        acted = bool(ready) or excess < 0
        while excess > 0 and self.free:            # a task waits: send helpers away
            self.comm.send(None, dest=self.free.pop(), tag=_TAG_ASSIGN)
            self._releasing += 1
            excess -= 1
            acted = True
        for owner in self._sources(_TAG_REQUEST):
            given = [] if excess > 0 else sorted(self.free)
            self.free = [r for r in self.free if r not in given]
            # a tag tells apart concurrent MPI_Comm_create_group calls of a
            # rank; a point's helpers are its alone, so tags may repeat
            # (and stay below the smallest MPI_TAG_UB, 32767)
            tag = 1 + next(self._tags) % 32000
            for r in given:
                self.comm.send(([owner] + given, tag), dest=r, tag=_TAG_ASSIGN)
            self.comm.send((given, tag), dest=owner, tag=_TAG_GROUP)
            self.points += bool(given)
            acted = True
        return acted

    def ended(self, fut):
        """A helper task ended (it was sent away): record what it did.

        Returns
        -------
        Exception or None
            What the helper task raised, if it did.
        """
        self.helpers.discard(fut)
        self._releasing = max(0, self._releasing - 1)   # (0: it ended by raising)
        try:
            self.joined.append(fut.result())
        except Exception as exc:  # noqa: BLE001 - the farm raises it on every rank
            return exc
        return None

    def close(self, pool):
        """Send every helper away and wait for their tasks to end.

        Returns
        -------
        Exception or None
            The first exception a helper task raised.
        """
        from concurrent.futures import FIRST_COMPLETED, wait

        error = None
        while self.helpers:
            self.poll(pool, self.n_workers + len(self.helpers))   # (no new helper)
            done, _ = wait(self.helpers, timeout=POLL_BUSY, return_when=FIRST_COMPLETED)
            for fut in done:
                error = error or self.ended(fut)
        return error
