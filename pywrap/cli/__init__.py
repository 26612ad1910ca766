"""The ``remote-trigger`` command line.

Each subcommand lives in its own module, which defines
``register(subparsers)``; the module is named in :data:`SUBCOMMANDS` and
imported only when the command line is built, so ``import lammps`` (which
imports this package through its plugin entry point) stays light. Adding a
subcommand is one line in :data:`SUBCOMMANDS`: error handling, exit
statuses, ``--debug`` and the MPI rules are applied here, to every
subcommand, by :func:`run_command`.

Exit status (docs/driver.md, "Exit status"): 0 success, 1 no result,
2 bad input, 3 no equilibrium, 130 interrupted. An error is printed as one
line, ``remote-trigger COMMAND: error: MESSAGE``, on rank 0 only; the
traceback only with ``--debug``. A command that fails removes the
folders it made for ``--out`` that hold no file. Ctrl-C prints one line with the
subcommand's note and ends the process (:func:`exit_on_interrupt`). A subparser may set, with ``set_defaults``:

``serial=True``
    the command runs on rank 0 only (under ``mpirun`` the other ranks wait
    and exit with rank 0's status);
``resume_hint='...'``
    the note printed after an interruption (how to continue).
"""
import argparse
import errno
import importlib
import os
import re
import sys

# BLAS threads. The driver's linear algebra is small (dense 300 x 300 for
# N = 100) and runs next to LAMMPS (one MPI rank per core); a threaded BLAS on
# a shared 2-core machine is then up to ~80x slower (measured: 2.4 s vs 0.03 s
# for one scipy.linalg.eig of 279 x 279 with another job running). The
# command line therefore uses one BLAS thread unless the user chose otherwise.
# This is set here, before numpy is imported, and not in the package's
# __init__, which `import lammps` imports through the plugin entry point.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

#: modules that each add one or more subcommands
SUBCOMMANDS = [
    "remote_trigger.pywrap.jobs.demo",
    "remote_trigger.pywrap.cli.stages",
    "remote_trigger.pywrap.jobs.paper",
    "remote_trigger.pywrap.jobs.trigger_map.job",
    "remote_trigger.pywrap.jobs.ensemble.job",
    "remote_trigger.analysis.dynamics.normal_form",
    "remote_trigger.pywrap.cli.jacobian",
    "remote_trigger.pywrap.jobs.accuracy.job",
]

#: a negative number written as an option value (``--dF-x -2e-3``)
_NEGATIVE = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-inf(inity)?$", re.IGNORECASE)


def world_rank():
    """Rank of this process in MPI_COMM_WORLD, without initializing MPI.

    Uses mpi4py if it is already imported, else the launcher's environment
    (MPICH/Hydra ``PMI_RANK``, Open MPI ``OMPI_COMM_WORLD_RANK``, PMIx
    ``PMIX_RANK``); 0 outside ``mpirun``.
    """
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        return mpi.COMM_WORLD.Get_rank()
    for var in ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK"):
        if os.environ.get(var, "").isdigit():
            return int(os.environ[var])
    return 0


class Parser(argparse.ArgumentParser):
    """ArgumentParser that prints (help, usage errors, --version) on rank 0 only
    and takes options by their whole name only (no abbreviations: ``generate
    --out DIR`` would otherwise be taken for ``--output FILE``)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def _print_message(self, message, file=None):
        if world_rank() == 0:
            super()._print_message(message, file)

    #: the words being parsed (set by :func:`main`), for the hint below
    words = ()

    def error(self, message):
        """Print one line, ``PROG: error: MESSAGE (see PROG --help)``, and exit 2.

        A missing ``--datafile`` beside a word that is a file (not an
        option's value) gets ``(did you mean --datafile WORD?)``, as
        :func:`unrecognized` gives a stray file where --datafile is optional.
        """
        if "required: --datafile" in message:
            files = [w for k, w in enumerate(Parser.words) if not w.startswith("-")
                     and os.path.isfile(w) and not (k and Parser.words[k - 1].startswith("-")
                                                    and "=" not in Parser.words[k - 1])]
            if files:
                message += f" (did you mean --datafile {files[0]}?)"
        self._print_message(f"{self.prog}: error: {one_line(message)} (see {self.prog} "
                            f"--help)\n", sys.stderr)
        self.exit(2)


def _version():
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("remote-trigger")
    except PackageNotFoundError:        # running from a source tree
        return "unknown"


def build_parser():
    """Return the argument parser with every subcommand registered."""
    parser = Parser(
        prog="remote-trigger",
        description="Frictional disks and spheres with smoothed Mindlin contacts in LAMMPS: "
                    "remote triggering of earthquakes (Charan, Pomyalov, Procaccia).",
        epilog="Exit status: 0 success, 1 no result, 2 bad input, 3 no equilibrium, "
               "130 interrupted (docs/driver.md). Errors are one line; --debug (anywhere "
               "on the line) shows the traceback. A negative option value may be written "
               "--F-x -2e-3 or --F-x=-2e-3.")
    parser.add_argument("--version", action="version", version=f"remote-trigger {_version()}")
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of an error (may follow the command)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in SUBCOMMANDS:
        importlib.import_module(name).register(sub)
    parser.commands = sub.choices        # name -> the subcommand's parser
    return parser


def unrecognized(parser, command, extra):
    """Refuse the words ``extra`` that ``command`` does not take (exit 2).

    The one line names the subcommand (``remote-trigger generate: error:
    unrecognized arguments: --out p (did you mean --output?) (see
    remote-trigger generate --help)``): an option (``--x`` or ``-x``, not a
    negative number) that names a configuration key of a job with no flag of
    its own (the subcommand's default ``config_keys``) is named as
    ``--set KEY=VALUE``; ``--np`` of a subcommand without it as ``mpirun
    -np N``; the option that differs from it in case only, else the one
    option of the subcommand that begins with it, else the one closest to
    it (:func:`difflib.get_close_matches`), as the likely meant one; a stray
    word that is a file, for a subcommand that reads its start file from
    ``--datafile``, as ``--datafile WORD``; an option of ``remote-trigger``
    itself (``--version``) as ``remote-trigger --version``.
    """
    import difflib

    sub = parser.commands.get(command, parser)
    known = [o for a in sub._actions for o in a.option_strings if o.startswith("--")]
    keys = sub.get_default("config_keys") or ()
    top = [o for a in parser._actions for o in a.option_strings]
    hints = []
    for word in extra:
        if word.startswith("-") and not _NEGATIVE.match(word):
            option = word.split("=", 1)[0]
            if option in top and option not in known:
                # (relax --version suggested --override)
                hints.append(f"remote-trigger {option}")
                continue
            key = option.lstrip("-").replace("-", "_")
            if key in keys:
                hints.append(f"--set {key}=VALUE")
                continue
            if option == "--np" and "--np" not in known:
                # (it suggested --help): the stages run under mpirun themselves
                hints.append(f"mpirun -np N remote-trigger {command} ...")
                continue
            # the option spelt in other case (--N for --n), else the one that
            # begins with the word (--settle for --settle-steps), else the
            # closest by difflib
            same = [o for o in known if o.lower() == option.lower()]
            begun = [o for o in known if o.startswith(option)]
            hints += (same or (begun if len(begun) == 1 else
                               difflib.get_close_matches(option, known, n=1)))
        elif "--datafile" in known and os.path.isfile(word):
            hints.append(f"--datafile {word}")
    hint = f" (did you mean {', '.join(dict.fromkeys(hints))}?)" if hints else ""
    sub.error(f"unrecognized arguments: {' '.join(extra)}{hint}")


def options_before_command(parser, argv):
    """Refuse a subcommand's options written before it (exit 2).

    ``remote-trigger --quiet relax`` was told ``--quiet (did you mean
    --quiet?)``, ``--quick paper`` ``--set quick=VALUE`` and ``--np 2 paper``
    ``invalid choice: '2'``. The words before the first subcommand name
    that are not options of ``remote-trigger`` itself are named, with the
    command line that puts them after the subcommand.
    """
    top = {o for a in parser._actions for o in a.option_strings}
    for k, word in enumerate(argv):
        if word == "--":
            return
        if word in parser.commands:
            moved = [w for w in argv[:k] if w.split("=", 1)[0] not in top]
            if any(w.startswith("-") for w in moved):
                parser.commands[word].error(
                    f"{' '.join(moved)}: options of {word} go after it (remote-trigger "
                    f"{word} {' '.join(moved)} ...)")
            return


def preprocess(argv):
    """Command-line words before parsing: ``--debug`` found, negative values joined.

    ``--opt -2e-3`` becomes ``--opt=-2e-3`` (argparse takes ``-2e-3`` for an
    option and reports a missing value); ``--debug`` anywhere (before a
    ``--``) is removed and returned as a flag.

    Returns
    -------
    argv : list of str
    debug : bool
    """
    out, debug, literal = [], False, False
    for word in argv:
        if literal:
            out.append(word)
            continue
        if word == "--":
            literal = True
            out.append(word)
        elif word == "--debug":
            debug = True
        elif (_NEGATIVE.match(word) and out and out[-1].startswith("-")
              and out[-1] != "--" and "=" not in out[-1] and not _NEGATIVE.match(out[-1])):
            out[-1] = f"{out[-1]}={word}"
        else:
            out.append(word)
    return out, debug


def one_line(text):
    """``text`` with every run of whitespace (newlines too) as one space."""
    return " ".join(str(text).split())


def classify(exc):
    """Exit status and one-line message of an exception.

    Returns
    -------
    status : int
        The error's ``exit_status`` (project errors); 2 for any other
        ``ValueError`` and for file errors (not found, permission, a
        directory where a file is expected, ...); 1 for a full disk and for
        anything unexpected.
    message : str
    internal : bool
        True for an unexpected error (a bug: the message suggests ``--debug``).
    """
    from remote_trigger.analysis.errors import RemoteTriggerError

    if isinstance(exc, RemoteTriggerError):
        return exc.exit_status, one_line(exc) or type(exc).__name__, False
    if isinstance(exc, OSError):
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return 1, one_line(f"no space left on the device writing {exc.filename!r} "
                               f"({exc.strerror})"), False
        if exc.strerror and exc.filename is not None:
            msg = f"{exc.strerror}: {os.fspath(exc.filename)!r}"
        else:
            msg = str(exc)
        return 2, one_line(msg), False
    if isinstance(exc, ValueError):
        return 2, one_line(exc) or type(exc).__name__, False
    return 1, one_line(f"internal error: {type(exc).__name__}: {exc} (rerun with --debug "
                       f"for the traceback)"), True


def exit_on_interrupt(args, debug=False):
    """Install the command line's SIGINT handler: one line on rank 0, exit 130 at once.

    A KeyboardInterrupt raised wherever Python happens to be when Ctrl-C
    arrives can land in a finalizer or weakref callback ("Exception
    ignored", the run goes on and exits 0) or unwind through the LAMMPS
    instance being closed (measured: 3 and 1 of 20 interrupted ramps).
    Every result file is written atomically and a run killed at any moment
    resumes bitwise (tests/driver/test_kill.py), so the handler ends the
    process as ``kill`` would, after printing the note of ``resume_hint``.
    The ranks of a job re-launched under mpirun (``--np N``) print nothing:
    the re-launching process prints the line
    (:func:`~remote_trigger.pywrap.runtime.relaunch.call_under_mpirun`).
    With ``debug`` the default KeyboardInterrupt (and its traceback) is kept.

    Returns
    -------
    The previous handler.
    """
    import signal

    if debug:
        return signal.getsignal(signal.SIGINT)
    from remote_trigger.pywrap.runtime.relaunch import RELAUNCHED, interrupt_line

    speak = world_rank() == 0 and not os.environ.get(RELAUNCHED)
    text = (interrupt_line(args.command, getattr(args, "resume_hint", None)) + "\n").encode()

    def handler(signum, frame):
        if speak:
            try:
                sys.stdout.flush()
            except Exception:  # noqa: BLE001 - a print may be in progress
                pass
            os.write(2, text)
        os._exit(130)

    return signal.signal(signal.SIGINT, handler)


def _new_folder(path):
    """The outermost folder of ``path`` that does not exist yet (None if it does)."""
    if not isinstance(path, str) or not path or os.path.exists(path):
        return None
    path = os.path.abspath(path)
    while not os.path.exists(os.path.dirname(path)):
        path = os.path.dirname(path)
    return path


def _remove_empty(root):
    """Remove the folders under ``root`` (made by this run) that hold no file,
    ``root`` too when it ends empty: a refused command leaves no empty
    ``--out`` behind. Files are never touched; a folder another rank is
    filling stays."""
    if root is None or not os.path.isdir(root):
        return
    for folder, _, _ in os.walk(root, topdown=False):
        try:
            os.rmdir(folder)
        except OSError:
            pass


#: the options whose paths reach LAMMPS commands (the decks' ``read_data
#: ${datafile}``, the driver's ``write_dump``/``write_data`` in ``--out``, and
#: generate's ``--output``, the data file every stage then reads) ...
LAMMPS_PATH_OPTIONS = (("datafile", "--datafile"), ("out", "--out"), ("paper", "--paper"),
                       ("output", "--output"))
#: ... in the commands that run LAMMPS or write its start file (jacobian and
#: normal-form do neither)
LAMMPS_COMMANDS = ("demo", "generate", "relax", "ramp", "perturb", "instability", "paper",
                   "trigger-map", "ensemble", "accuracy")


def check_lammps_paths(args):
    """Refuse, before anything runs, a path with whitespace that would reach LAMMPS
    (:func:`~remote_trigger.pywrap.config.check_lammps_path` of each option).

    Raises
    ------
    ConfigError
        Naming the option and the path.
    """
    from remote_trigger.pywrap.config import check_lammps_path

    if getattr(args, "command", None) not in LAMMPS_COMMANDS:
        return
    for dest, flag in LAMMPS_PATH_OPTIONS:
        check_lammps_path(flag, getattr(args, dest, None))


def _guarded(args, debug):
    """Run ``args.func``; errors become one line on stderr and an exit status
    (and the folders this run made for ``--out`` are removed if they hold no
    file)."""
    import traceback

    rank = world_rank()
    prog = f"remote-trigger {args.command}"
    made = _new_folder(getattr(args, "out", None)) if rank == 0 else None
    # (one run at a time in an --out: pywrap.runtime.outlock)
    lock = None
    try:
        check_lammps_paths(args)
        # (``ensemble --status`` only reads the folder, beside the run holding it)
        if rank == 0 and getattr(args, "command", None) in LAMMPS_COMMANDS \
                and not getattr(args, "status", False):
            from remote_trigger.pywrap.runtime.outlock import lock_output_folder

            lock = lock_output_folder(getattr(args, "out", None))
            # a job re-launched under mpirun inherits it (relaunch.call_under_mpirun)
            args.out_lock = lock
        status = int(args.func(args) or 0)
        if status:
            _remove_empty(made)
        return status
    except KeyboardInterrupt:
        from remote_trigger.pywrap.runtime.relaunch import RELAUNCHED, interrupt_line

        if rank == 0:
            if debug:
                traceback.print_exc()
            if not os.environ.get(RELAUNCHED):    # (else the re-launching process prints it)
                print(interrupt_line(args.command, getattr(args, "resume_hint", None)),
                      file=sys.stderr, flush=True)
        return 130
    except BrokenPipeError:
        # the reader of stdout went away (``... | head``): not an error of the
        # command; stdout goes to /dev/null so that the exit flush cannot fail
        # again, and the status is the shell's for SIGPIPE
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception as exc:  # noqa: BLE001 - the command line's last resort
        status, msg, internal = classify(exc)
        if rank == 0 or internal:
            if debug:
                traceback.print_exc()
            who = f" (rank {rank})" if rank else ""
            print(f"{prog}: error{who}: {msg}", file=sys.stderr, flush=True)
        _remove_empty(made)
        return status
    finally:
        if lock is not None:
            os.close(lock)


def run_command(args, debug=False):
    """Run a parsed command with the error rules of the module docstring.

    Parameters
    ----------
    args : argparse.Namespace
        From :func:`build_parser`; ``args.func`` is the subcommand.
    debug : bool
        Print tracebacks.

    Returns
    -------
    int
        Exit status.
    """
    if not getattr(args, "serial", False):
        return _guarded(args, debug)
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    status = _guarded(args, debug) if comm.Get_rank() == 0 else None
    return comm.bcast(status, root=0) if comm.Get_size() > 1 else status


def main(argv=None):
    """Run the command line; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        The words after ``remote-trigger``; default ``sys.argv[1:]``, and
        then (a real command line) Ctrl-C ends the process at once
        (:func:`exit_on_interrupt`); called with ``argv`` (in-process),
        Ctrl-C raises KeyboardInterrupt and returns 130.
    """
    command_line = argv is None
    argv, debug = preprocess(sys.argv[1:] if argv is None else list(argv))
    parser = build_parser()
    Parser.words = tuple(argv)
    options_before_command(parser, argv)
    args, extra = parser.parse_known_args(argv)
    if extra:
        unrecognized(parser, args.command, extra)
    debug = debug or args.debug
    if command_line:
        exit_on_interrupt(args, debug)
    return run_command(args, debug=debug)
