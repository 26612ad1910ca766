"""Continue a packing from a data file with undamped, sheared dynamics.

Used in-process by the restart tests and as a script under ``mpirun`` by the
MPI test:

    mpirun -np 2 python runner.py START.data OUT.npz NSTEPS [SPLIT MODE]

With SPLIT and MODE (``data`` or ``restart``): run SPLIT steps, write a data
or restart file, then continue in a fresh LAMMPS instance for the remaining
steps. MODE ``split``: the same two ``run`` commands in one instance, no file.
The final state (sorted by atom ID, float64) is saved on rank 0.
"""
import os
import sys

from mpi4py import MPI

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lmputil  # noqa: E402
import numpy as np  # noqa: E402

DT = 5e-4
SETTINGS = ["units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
            "boundary p f p", "comm_modify vel yes"]


def styles_and_dynamics(lmp, upper_y):
    """Wall, integrator and loads: all disks pushed down (as when they were
    settled), the upper ones also sideways, so that contacts slide."""
    kn, kt = lmputil.KN, lmputil.KT
    lmp.commands_list([
        "set group all mass 1.0",
        f"fix wall all wall/mindlin/smooth {kn!r} {kt!r} {lmputil.MU!r} yplane 0.0",
        f"region upper block INF INF {upper_y!r} INF INF INF units box",
        "group upper region upper",
        "fix nve all nve/sphere disc", "fix 2d all enforce2d",
        "fix load all addforce 0.0 -5.0 0.0",
        "fix push upper addforce 2.0 0.0 0.0",
        f"timestep {DT!r}",
    ])


def open_data(datafile, upper_y, comm=None):
    """A LAMMPS instance with the packing of ``datafile``, ready to run."""
    lmp = lmputil.new_lammps(comm=comm)
    lmp.commands_list(SETTINGS + [lmputil.HIST, "pair_style mindlin/smooth",
                                  f"read_data {datafile} fix hist NULL hist"])
    styles_and_dynamics(lmp, upper_y)
    return lmp


def open_restart(restartfile, upper_y, comm=None):
    """Same from a restart file: the history fix is re-issued with its ID."""
    lmp = lmputil.new_lammps(comm=comm)
    lmp.commands_list([f"read_restart {restartfile}", "comm_modify vel yes", lmputil.HIST])
    styles_and_dynamics(lmp, upper_y)
    return lmp


def state(lmp):
    """Everything that defines the continuation, ordered by atom ID.

    Positions are unwrapped (x + image * L): atoms are remapped into the
    periodic box only when neighbor lists are rebuilt, which happens at
    different steps when a run is split.
    """
    out = {}
    for name, t, c in [("x", 1, 3), ("v", 1, 3), ("omega", 1, 3), ("f", 1, 3),
                       ("torque", 1, 3), ("i2_mindlin_partner", 0, 8),
                       ("d2_mindlin_t", 1, 8), ("d_mindlin_wall_t", 1, 1)]:
        arr = np.ctypeslib.as_array(lmp.gather(name, t, c)).copy()
        out[name] = arr.reshape(-1, c) if c > 1 else arr
    image = np.ctypeslib.as_array(lmp.gather("image", 0, 1)).astype(np.int64)
    ix = (image & 1023) - 512           # LAMMPS_SMALLBIG image-flag packing
    boxlo, boxhi = lmp.extract_box()[:2]
    out["x"][:, 0] += ix * (boxhi[0] - boxlo[0])
    return out


def continue_run(datafile, nsteps, upper_y, split=None, mode=None, workdir=".", comm=None):
    """Run ``nsteps`` from ``datafile``, optionally through a file round trip."""
    lmp = open_data(datafile, upper_y, comm=comm)
    if split is None:
        lmp.command(f"run {nsteps}")
    else:
        lmp.command(f"run {split}")
        mid = os.path.join(workdir, f"mid.{mode}")
        if mode == "split":
            pass
        elif mode == "data":
            lmp.command(f"write_data {mid} pair ij")
            lmp.close()
            lmp = open_data(mid, upper_y, comm=comm)
        elif mode == "restart":
            lmp.command(f"write_restart {mid}")
            lmp.close()
            lmp = open_restart(mid, upper_y, comm=comm)
        else:
            raise ValueError(f"mode must be 'split', 'data' or 'restart', got {mode!r}")
        lmp.command(f"run {nsteps - split}")
    out = state(lmp)
    lmp.close()
    return out


def main(argv):
    datafile, outfile, nsteps, upper_y = argv[1], argv[2], int(argv[3]), float(argv[4])
    split = int(argv[5]) if len(argv) > 5 else None
    mode = argv[6] if len(argv) > 6 else None
    out = continue_run(datafile, nsteps, upper_y, split, mode,
                       workdir=os.path.dirname(outfile), comm=MPI.COMM_WORLD)
    if MPI.COMM_WORLD.rank == 0:
        np.savez(outfile, **out)


if __name__ == "__main__":
    main(sys.argv)
