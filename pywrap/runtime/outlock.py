"""One run at a time in an output folder: an advisory lock on the folder.

Two commands writing the same ``--out`` at once (a job and its own
``--resume`` started by mistake, two shells) rewrote each other's files with
nothing said. The command line takes an exclusive ``flock`` on the output
folder itself (on rank 0, for the whole command) and refuses a second run
while the first holds it. The lock lives with the open file descriptor: a
run that ends in any way, ``kill -9`` included, releases it, and nothing is
left in the folder. A job re-launched under ``mpirun`` (``--np N``) is
covered by the lock of the process that re-launched it, whose descriptor
mpirun and the ranks inherit: the lock goes with the last process of the job.
"""
import fcntl
import os

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.runtime.relaunch import RELAUNCHED


def lock_output_folder(out):
    """Create ``out`` if needed and hold an exclusive lock on it.

    Parameters
    ----------
    out : str
        The output folder.

    Returns
    -------
    int or None
        The open descriptor that holds the lock (close it to release), or
        None where no lock is taken: ``out`` is not a folder name (a file:
        the command refuses it itself), or this process is a re-launched
        job's rank (its parent holds the lock).

    Raises
    ------
    ConfigError
        If another run holds the lock (the message names the folder).
    """
    if os.environ.get(RELAUNCHED):
        return None
    if not isinstance(out, str) or not out or os.path.exists(out) and not os.path.isdir(out):
        return None
    try:
        os.makedirs(out, exist_ok=True)
        fd = os.open(out, os.O_RDONLY)
    except OSError:
        return None                 # the command's own check names what is wrong
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise ConfigError(f"--out {out!r} is in use by another run (it holds the folder's "
                          f"lock); wait for it to end or choose another folder") from None
    except OSError:
        return fd                   # a file system without flock: no lock, the run goes on
    return fd
