"""A ``map_tasks(fn, tasks)`` whose tasks run on every rank of an MPI communicator.

The sliced verdict in parts
(:mod:`remote_trigger.analysis.stability.sliced.parts`) hands its two rounds
of independent tasks (cuts, then parts) to a ``map_tasks(fn, tasks)``; the
analysis library knows nothing of MPI. :func:`on_rank0_with_ranks` runs a
computation on rank 0 with a :class:`RankMap` for it, while the other ranks
of the communicator run the tasks it hands out (:func:`serve`):

* **Every rank computes.** Rank 0 runs tasks too: a dispatcher thread on
  rank 0 makes all its MPI calls (sending tasks, receiving results) while
  its main thread runs the computation and, whenever it waits for a result,
  the next task not yet handed out. Tasks are handed out dynamically, in
  their order, to the first free rank (the main thread of rank 0 included):
  the lowest parts first, so a merge that stops at its first complex part
  waits for as little as possible.
* **Shared data sent once.** An object of one of ``shared_types`` reached
  while a task is pickled (the
  :class:`~remote_trigger.analysis.stability.sliced.parts.PartsProblem`:
  the matrices S, A, W and the options, the same object in every task of a
  scan) is replaced by a key (:mod:`pickle`'s persistent ids) and sent to
  every other rank once, by ``bcast`` (a tree: log2 k steps on k ranks); a
  task's message is then its few numbers.
* **Results in task order.** The map returns an iterator of ``fn(task)``
  in the order of ``tasks``; a task's exception (on any rank; a result
  that cannot be pickled becomes one) is raised there, at its place in
  the order, as the builtin :func:`map` would: a merge that stops before
  it never sees it.
* **Early stop.** Closing the iterator (the merge stops at its first complex
  part, ``stop_at_complex``) cancels the tasks not handed out yet; a rank
  busy with a task of the cancelled round finishes it (a task cannot be
  interrupted) and its result is dropped. So no rank waits for a message
  that will not come; rank 0 then waits, at the next collective call, at
  most the longest task that was running.
* **Waiting costs no core.** Every wait (a free worker, rank 0's dispatcher)
  polls with ``Iprobe`` and sleeps between polls (0.1-5 ms), instead of a
  blocking receive that keeps a core busy under MPICH and Open MPI.

The result of a task does not depend on the rank that ran it (each task is
deterministic: :mod:`~remote_trigger.analysis.stability.sliced.parts`),
so the merged answer is the same, bit for bit, on any number of ranks
(tests/driver/test_rankmap_mpi.py). Needs an MPI thread level of at least
``MPI_THREAD_SERIALIZED`` (mpi4py asks for ``MPI_THREAD_MULTIPLE``, MPICH
and Open MPI grant it); below it :func:`on_rank0_with_ranks` runs every task
on rank 0 (the same answer, the other ranks waiting). A :class:`RankMap`
serves one computation: the shared objects stay referenced until it closes.
"""
from __future__ import annotations

import io
import pickle
import threading
import time
from typing import NamedTuple

__all__ = ["RankMap", "serve", "on_rank0_with_ranks", "TaskRecord", "wait_message"]

# message tags
_TAG_CTRL, _TAG_RESULT = 7301, 7302
# polling: first and longest sleep between two probes (s)
_POLL_MIN, _POLL_MAX = 1e-4, 5e-3


class TaskRecord(NamedTuple):
    """One task that ran (:attr:`RankMap.log`): its round (1, 2, ... per call of
    the map), its index in the round, the rank that ran it, its wall seconds
    and the CPU seconds of the thread that ran it."""

    round: int
    index: int
    rank: int
    seconds: float
    cpu: float


def wait_message(comm, source, tag):
    """Poll for a message (sleeping between probes, 0.1-5 ms) until one is
    there: a wait that costs no core, where a blocking receive keeps one busy
    under MPICH and Open MPI."""
    pause = _POLL_MIN
    while not comm.Iprobe(source=source, tag=tag):
        time.sleep(pause)
        pause = min(2 * pause, _POLL_MAX)


class _Pickler(pickle.Pickler):
    """Pickles a task with the objects of ``shared_types`` as persistent ids
    (their keys collected in ``keys``)."""

    def __init__(self, fh, rankmap, keys):
        super().__init__(fh, protocol=pickle.HIGHEST_PROTOCOL)
        self.rankmap, self.keys = rankmap, keys

    def persistent_id(self, obj):
        if self.rankmap.shared_types and isinstance(obj, self.rankmap.shared_types):
            key = self.rankmap.key_of(obj)
            self.keys.add(key)
            return key
        return None


class _Unpickler(pickle.Unpickler):
    """Unpickles a task, its persistent ids from the objects received by ``bcast``."""

    def __init__(self, fh, shared):
        super().__init__(fh)
        self.shared = shared

    def persistent_load(self, pid):
        return self.shared[pid]


class _Round:
    """The tasks of one call of the map (rank 0's bookkeeping)."""

    def __init__(self, rid, fn, tasks, payloads, keys):
        self.rid, self.fn, self.tasks, self.payloads = rid, fn, tasks, payloads
        self.keys = keys                # the shared objects its tasks need
        self.next = 0                   # the first task not handed out
        self.results = {}               # index -> (ok, value)
        self.cancelled = False


class RankMap:
    """``map_tasks(fn, tasks)`` over the ranks of ``comm`` (rank 0's side).

    Made on rank 0 while every other rank of ``comm`` runs :func:`serve`;
    :meth:`close` ends both. Use :func:`on_rank0_with_ranks`, which does that.

    Parameters
    ----------
    comm : mpi4py communicator
        Size >= 2; this process is its rank 0.
    shared_types : tuple of type, optional
        Objects of these types inside a task are sent to every rank once
        (``bcast``) and not with each task.

    Attributes
    ----------
    log : list of TaskRecord
        Every task run: its round, index, the rank that ran it and its
        seconds (wall, on that rank).
    bcast_seconds : float
        Wall time rank 0's dispatcher spent sending shared objects.
    """

    def __init__(self, comm, shared_types=()):
        from mpi4py import MPI

        if comm.Get_rank() != 0:
            raise ValueError(f"a RankMap is made on rank 0, not on rank {comm.Get_rank()}")
        self.comm, self.shared_types = comm, tuple(shared_types)
        if MPI.Query_thread() < MPI.THREAD_SERIALIZED:
            raise ValueError(f"a RankMap needs an MPI thread level of at least "
                             f"THREAD_SERIALIZED, got {MPI.Query_thread()}")
        self.log, self.bcast_seconds = [], 0.0
        self._cv = threading.Condition()
        self._round = None
        self._rid = 0
        self._keys = {}                 # id(obj) -> key, for the shared objects
        self._objects = {}              # key -> obj (kept alive: ids stay unique)
        self._sent = set()              # keys the workers hold
        self._error = None              # an exception of the dispatcher thread
        self._stop = False
        self._busy = {}                 # worker rank -> (rid, index, start time)
        self._thread = threading.Thread(target=self._dispatch, name="rankmap", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ rank 0's main thread
    def key_of(self, obj):
        """The persistent key of a shared object (registered on first sight)."""
        key = self._keys.get(id(obj))
        if key is None:
            key = f"shared-{len(self._objects)}"
            self._keys[id(obj)] = key
            self._objects[key] = obj
        return key

    def __call__(self, fn, tasks):
        """``fn(task)`` for every task, run on the ranks; an iterator of the
        results in the order of ``tasks`` (closing it cancels the rest)."""
        tasks = list(tasks)
        payloads, keys = [], set()
        for task in tasks:
            fh = io.BytesIO()
            _Pickler(fh, self, keys).dump((fn, task))
            payloads.append(fh.getvalue())
        with self._cv:
            self._rid += 1
            self._round = _Round(self._rid, fn, tasks, payloads, keys)
            self._cv.notify_all()
            rd = self._round
        return self._results(rd)

    def _results(self, rd):
        """The results of round ``rd`` in order, rank 0 running tasks while it waits."""
        try:
            for i in range(len(rd.tasks)):
                while True:
                    with self._cv:
                        if self._error is not None:
                            raise self._error
                        if i in rd.results:
                            ok, value = rd.results.pop(i)
                            break
                        j = None
                        if rd.next < len(rd.tasks):
                            j, rd.next = rd.next, rd.next + 1
                        else:
                            self._cv.wait(0.05)
                            continue
                    t0, c0 = time.perf_counter(), time.thread_time()
                    try:
                        done = (True, rd.fn(rd.tasks[j]))
                    except Exception as exc:  # noqa: BLE001 - raised at its place below
                        done = (False, exc)
                    with self._cv:
                        rd.results[j] = done
                        self.log.append(TaskRecord(rd.rid, j, 0, time.perf_counter() - t0,
                                                   time.thread_time() - c0))
                if not ok:
                    raise value
                yield value
        finally:
            with self._cv:
                rd.cancelled = True
                rd.next = len(rd.tasks)
                rd.results.clear()

    def close(self):
        """End the round, tell every other rank to leave :func:`serve` and stop
        the dispatcher (after the tasks still running have ended)."""
        with self._cv:
            if self._round is not None:
                self._round.cancelled = True
                self._round.next = len(self._round.tasks)
            self._stop = True
            self._cv.notify_all()
        self._thread.join()
        if self._error is not None:
            raise self._error

    # ------------------------------------------------------------------ rank 0's dispatcher
    def _dispatch(self):
        """The dispatcher thread: every MPI call of rank 0 while the map lives."""
        from mpi4py import MPI

        comm = self.comm
        workers = list(range(1, comm.Get_size()))
        status = MPI.Status()
        pause = _POLL_MIN
        try:
            while True:
                acted = False
                # results (or the end of a cancelled task)
                while comm.Iprobe(source=MPI.ANY_SOURCE, tag=_TAG_RESULT, status=status):
                    src = status.Get_source()
                    rid, i, ok, value, seconds, cpu = pickle.loads(
                        comm.recv(source=src, tag=_TAG_RESULT))
                    with self._cv:
                        self._busy.pop(src, None)
                        self.log.append(TaskRecord(rid, i, src, seconds, cpu))
                        rd = self._round
                        if rd is not None and rd.rid == rid and not rd.cancelled:
                            rd.results[i] = (ok, value)
                        self._cv.notify_all()
                    acted = True
                with self._cv:
                    rd, stop = self._round, self._stop
                    idle = [w for w in workers if w not in self._busy]
                if stop:
                    if len(idle) == len(workers):
                        for w in workers:
                            comm.send(("stop",), dest=w, tag=_TAG_CTRL)
                        return
                elif rd is not None and not rd.cancelled and rd.next < len(rd.tasks):
                    missing = rd.keys - self._sent
                    if missing:
                        # the shared objects go out once every worker is free (bcast)
                        if len(idle) == len(workers):
                            self._share(sorted(missing), workers)
                            acted = True
                    else:
                        for w in idle:
                            with self._cv:
                                if rd.cancelled or rd.next >= len(rd.tasks):
                                    break
                                i, rd.next = rd.next, rd.next + 1
                                self._busy[w] = (rd.rid, i, time.perf_counter())
                            comm.send(("task", rd.rid, i, rd.payloads[i]), dest=w,
                                      tag=_TAG_CTRL)
                            acted = True
                if acted:
                    pause = _POLL_MIN
                else:
                    time.sleep(pause)
                    pause = min(2 * pause, _POLL_MAX)
        except BaseException as exc:  # noqa: BLE001 - handed to the main thread
            with self._cv:
                self._error = exc
                self._cv.notify_all()

    def _share(self, keys, workers):
        """Send the shared objects ``keys`` to every worker (one bcast each)."""
        t0 = time.perf_counter()
        for w in workers:
            self.comm.send(("share", keys), dest=w, tag=_TAG_CTRL)
        for key in keys:
            self.comm.bcast(self._objects[key], root=0)
            self._sent.add(key)
        self.bcast_seconds += time.perf_counter() - t0


def serve(comm):
    """Run the tasks rank 0's :class:`RankMap` hands out, until it closes.

    Called on every rank of ``comm`` but 0. A task's exception is sent back
    to rank 0 (raised there in the order of the tasks), never raised here.
    """
    from remote_trigger.pywrap.runtime.parallel import portable_exception

    shared = {}
    while True:
        wait_message(comm, 0, _TAG_CTRL)
        msg = comm.recv(source=0, tag=_TAG_CTRL)
        if msg[0] == "stop":
            return
        if msg[0] == "share":
            for key in msg[1]:
                shared[key] = comm.bcast(None, root=0)
            continue
        _, rid, i, payload = msg
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            fn, task = _Unpickler(io.BytesIO(payload), shared).load()
            ok, value = True, fn(task)
        except Exception as exc:  # noqa: BLE001 - raised on rank 0
            ok, value = False, portable_exception(exc)
        seconds, cpu = time.perf_counter() - t0, time.thread_time() - c0
        try:
            blob = pickle.dumps((rid, i, ok, value, seconds, cpu),
                                protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # noqa: BLE001 - a result that cannot be sent
            blob = pickle.dumps((rid, i, False, portable_exception(exc), seconds, cpu))
        comm.send(blob, dest=0, tag=_TAG_RESULT)


def on_rank0_with_ranks(comm, fn, shared_types=()):
    """``fn(map_tasks)`` on rank 0, its tasks run on every rank; every rank
    gets its result, as :func:`~remote_trigger.pywrap.runtime.parallel.on_rank0`.

    Every rank of ``comm`` calls this function.

    Parameters
    ----------
    comm : mpi4py communicator or None
        ``None`` or size 1: ``fn(None)`` here (``None``: the caller's
        default map, the builtin :func:`map`); so too on rank 0 alone under
        an MPI thread level below ``THREAD_SERIALIZED``.
    fn : callable
        ``fn(map_tasks)``, called on rank 0; ``map_tasks`` is a
        :class:`RankMap` of ``comm``. Its return value must be picklable.
    shared_types : tuple of type, optional
        As :class:`RankMap`.

    Returns
    -------
    object
        What ``fn`` returned on rank 0, on every rank.

    Raises
    ------
    Exception
        What ``fn`` (or a task) raised, on every rank (as ``on_rank0``).
    """
    from mpi4py import MPI

    from remote_trigger.pywrap.runtime.parallel import on_rank0

    if comm is None or comm.Get_size() == 1:
        return fn(None)
    if MPI.Query_thread() < MPI.THREAD_SERIALIZED:      # (the same on every rank)
        return on_rank0(comm, fn, None)
    if comm.Get_rank() != 0:
        serve(comm)
        return on_rank0(comm, fn)       # (fn is not called here: rank 0's result)

    def run():
        pmap = RankMap(comm, shared_types)
        try:
            return fn(pmap)
        finally:
            pmap.close()

    return on_rank0(comm, run)
