"""Re-launch a command-line job under the environment's ``mpirun`` (``--np N``).

``paper``, ``trigger-map``, ``ensemble``, ``ramp`` and ``jacobian`` take
``--np N``: run from a serial shell, they start ``mpirun -np N python -m
remote_trigger.pywrap.cli COMMAND ...`` with an environment flag that keeps
the child from re-launching itself, and return its exit status. ``ramp``
and ``jacobian`` repeat their own command line (:func:`relaunch_words`).
"""
import os
import shutil
import subprocess
import sys

from remote_trigger.pywrap.config import ConfigError

#: set in the environment of every job re-launched under mpirun (``--np N``):
#: the re-launching process holds the job's output-folder lock
#: (:mod:`~remote_trigger.pywrap.runtime.outlock`)
RELAUNCHED = "REMOTE_TRIGGER_RELAUNCHED"


def find_mpirun(np, command):
    """Path of ``mpirun``: next to the interpreter (the venv's), else on PATH.

    Raises
    ------
    ConfigError
        If there is none (the message names ``np`` and the command to run by hand).
    """
    mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
    if not os.path.exists(mpirun):
        mpirun = shutil.which("mpirun")
    if not mpirun:
        raise ConfigError(f"np = {np} needs mpirun, found none next to {sys.executable} "
                          f"or on PATH; run `mpirun -np {np} remote-trigger {command}` yourself")
    return mpirun


def relaunch(command, args, np, env_flag, extra=()):
    """Run ``remote-trigger COMMAND`` with the options of ``args`` under ``mpirun -np np``.

    Forwards ``--out``, ``--config``, ``--quick``, ``--set``, ``--resume``,
    ``--quiet`` (those ``args`` has) and ``extra``; the child gets ``--np 1``
    and ``env_flag=1`` in its environment.

    Returns
    -------
    int
        The child's exit status.
    """
    cmd = [find_mpirun(np, command), "-np", str(np), sys.executable, "-m",
           "remote_trigger.pywrap.cli", command, "--out", args.out, "--np", "1"]
    if getattr(args, "config", None):
        cmd += ["--config", args.config]
    if getattr(args, "quick", None):
        cmd.append("--quick")
    for s in getattr(args, "set", None) or []:
        cmd += ["--set", s]
    cmd += list(extra)
    if getattr(args, "resume", False):
        cmd.append("--resume")
    if getattr(args, "quiet", False):
        cmd.append("--quiet")
    # ensemble and trigger-map run np - 1 workers beside their coordinator
    return call_under_mpirun(cmd, dict(os.environ, **{env_flag: "1"}), command, np - 1,
                             getattr(args, "resume_hint", None), getattr(args, "out_lock", None))


def relaunch_words(command, words, np, resume_hint=None, lock=None):
    """Run ``remote-trigger WORDS`` (the command line as given, ``command``
    among its words) under ``mpirun -np np``, every rank computing; returns
    the child's exit status.

    ``--np N`` (or ``--np=N``) is removed from ``words``; the child has
    :data:`RELAUNCHED` set, so it does not re-launch itself. ``lock``: as
    :func:`call_under_mpirun`.
    """
    words, skip = list(words), False
    kept = []
    for w in words:
        if skip:
            skip = False
        elif w == "--np":
            skip = True
        elif not w.startswith("--np="):
            kept.append(w)
    cmd = [find_mpirun(np, command), "-np", str(np), sys.executable, "-m",
           "remote_trigger.pywrap.cli"] + kept
    return call_under_mpirun(cmd, dict(os.environ), command, np, resume_hint, lock)


def interrupt_line(command, resume_hint=None):
    """The one line a command prints when Ctrl-C ends it (``resume_hint`` appended)."""
    return f"remote-trigger {command}: interrupted" + (f"; {resume_hint}" if resume_hint else "")


def call_under_mpirun(cmd, env, command, workers, resume_hint=None, lock=None):
    """Run the re-launched job ``cmd`` (``mpirun ...``); returns its exit status.

    Warns on stderr when ``workers`` (the ranks that compute) exceed the
    cores this process may use: the ranks then share cores and wait by
    polling. Ctrl-C reaches the job's ranks from the terminal; they end
    without a word (:data:`RELAUNCHED`) and this process, once they have
    ended, prints the one interrupt line (:func:`interrupt_line`) and
    returns 130. (Rank 0 printed it, unless mpirun killed it first: a
    Python handler runs only between two bytecodes, never inside a long
    LAMMPS call, so the line was missing from some interrupted jobs.)
    A job whose status is 130 without a Ctrl-C here gets the line too.

    ``lock``, the descriptor holding the output folder's lock
    (:mod:`~remote_trigger.pywrap.runtime.outlock`), is inherited by mpirun,
    hydra's proxy and the ranks, so that the lock lasts as long as any
    process of the job: killed alone (``kill -9`` of this process), this
    process left mpirun and the ranks running without it, and after a
    ``kill -9`` of its process group the ranks (in sessions of their own)
    went on writing for some milliseconds, while a second run in the same
    folder was already accepted.
    """
    import signal

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if cores and workers > cores:
        # (np 4 on 2 cores: 93 s against 8 s at np 2 for `paper --quick`, most of it
        # the MPI ranks' busy polling, and no word of it)
        print(f"remote-trigger {command}: warning: {workers} MPI ranks compute on {cores} "
              f"core{'s' if cores > 1 else ''}: they share cores and wait by polling, which "
              f"makes the job several times slower; give --np {cores} or fewer",
              file=sys.stderr, flush=True)
    interrupted = []
    old = signal.signal(signal.SIGINT, lambda signum, frame: interrupted.append(signum))
    try:
        status = subprocess.call(cmd, env=dict(env, **{RELAUNCHED: "1"}),
                                 pass_fds=() if lock is None else (lock,))
    finally:
        signal.signal(signal.SIGINT, old)
    if interrupted or status == 130:
        sys.stdout.flush()
        print(interrupt_line(command, resume_hint), file=sys.stderr, flush=True)
        return 130
    return status
