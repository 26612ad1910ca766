"""The ``remote-trigger`` command line.

Each subcommand lives in its own module, which defines
``register(subparsers)``; the module is named in :data:`SUBCOMMANDS` and
imported only when the command line is built, so ``import lammps`` (which
imports this package through its plugin entry point) stays light.
"""
import argparse
import importlib
import os
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
    "remote_trigger.pywrap.demo",
    "remote_trigger.pywrap.stages_cli",
    "remote_trigger.pywrap.paper",
    "remote_trigger.pywrap.trigger_map",
    "remote_trigger.pywrap.ensemble",
    "remote_trigger.analysis.normal_form",
    "remote_trigger.analysis.cli_jacobian",
    "remote_trigger.analysis.accuracy",
]


def build_parser():
    """Return the argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="remote-trigger",
        description="Frictional disks with smoothed Mindlin contacts in LAMMPS: "
                    "remote triggering of earthquakes (Charan, Pomyalov, Procaccia).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in SUBCOMMANDS:
        importlib.import_module(name).register(sub)
    return parser


def main(argv=None):
    """Run the command line; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args) or 0
    except (ValueError, FileNotFoundError) as exc:
        print(f"remote-trigger {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
