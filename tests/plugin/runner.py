"""Continue a packing from a data file with undamped, sheared dynamics.

Used in-process by the restart tests and as a script under ``mpirun`` by the
MPI test:

    mpirun -np 2 python runner.py START.data OUT.npz NSTEPS UPPER [SPLIT MODE] [3d [own]]

With SPLIT and MODE (``data`` or ``restart``): run SPLIT steps, write a data
or restart file, then continue in a fresh LAMMPS instance for the remaining
steps. MODE ``split``: the same two ``run`` commands in one instance, no file.
The final state (sorted by atom ID, float64) is saved on rank 0. With ``3d``
the packing is one of spheres (``dimension 3``): the floor is a zplane, the
load along -z, and the history has three arrays. With ``3d own`` the pair
and the floor keep their history themselves (no fix property/atom; the data
file must have no history sections) and the floor has friction.
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
SETTINGS_3D = ["units lj", "dimension 3", "atom_style sphere", "atom_modify map array",
               "boundary p p f", "comm_modify vel yes"]


def styles_and_dynamics(lmp, upper_y, dim=2, floor_kt=0.0):
    """Wall, integrator and loads: all disks pushed down (as when they were
    settled), the upper ones also sideways, so that contacts slide. In 3D
    "down" is -z, ``upper_y`` a height in z, and the floor is frictionless:
    a zplane wall keeps its history in restart files, not in data files
    (as xplane/yplane lo hi walls in 2D), unless ``floor_kt`` is given."""
    kn, kt = lmputil.KN, lmputil.KT
    if dim == 3:
        lmp.commands_list([
            "set group all mass 1.0",
            f"fix wall all wall/mindlin/smooth {kn!r} {floor_kt!r} {lmputil.MU!r} "
            "zplane 0.0 NULL",
            f"region upper block INF INF INF INF {upper_y!r} INF units box",
            "group upper region upper",
            "fix nve all nve/sphere",
            "fix load all addforce 0.0 0.0 -5.0",
            "fix push upper addforce 2.0 1.0 0.0",
            f"timestep {DT!r}",
        ])
        return
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


def open_data(datafile, upper_y, comm=None, dim=2, own=False):
    """A LAMMPS instance with the packing of ``datafile``, ready to run."""
    lmp = lmputil.new_lammps(comm=comm)
    if own:
        lmp.commands_list(SETTINGS_3D + ["pair_style mindlin/smooth", f"read_data {datafile}"])
        styles_and_dynamics(lmp, upper_y, dim, floor_kt=lmputil.KT)
        return lmp
    if dim == 3:
        lmp.commands_list(SETTINGS_3D + lmputil.HIST_3D + [
            "pair_style mindlin/smooth", f"read_data {datafile} {lmputil.READ_HIST_3D}"])
    else:
        lmp.commands_list(SETTINGS + [lmputil.HIST, "pair_style mindlin/smooth",
                                      f"read_data {datafile} fix hist NULL hist"])
    styles_and_dynamics(lmp, upper_y, dim)
    return lmp


def open_restart(restartfile, upper_y, comm=None, dim=2):
    """Same from a restart file: the history fix is re-issued with its ID."""
    lmp = lmputil.new_lammps(comm=comm)
    hist = lmputil.HIST_3D if dim == 3 else [lmputil.HIST]
    lmp.commands_list([f"read_restart {restartfile}", "comm_modify vel yes", *hist])
    styles_and_dynamics(lmp, upper_y, dim)
    return lmp


def state(lmp, dim=2):
    """Everything that defines the continuation, ordered by atom ID.

    Positions are unwrapped (x + image * L): atoms are remapped into the
    periodic box only when neighbor lists are rebuilt, which happens at
    different steps when a run is split.
    """
    out = {}
    hist = ([(f"d2_mindlin_t{c}", 1, 8) for c in "xyz"] if dim == 3
            else [("d2_mindlin_t", 1, 8), ("d_mindlin_wall_t", 1, 1)])
    for name, t, c in [("x", 1, 3), ("v", 1, 3), ("omega", 1, 3), ("f", 1, 3),
                       ("torque", 1, 3), ("i2_mindlin_partner", 0, 8)] + hist:
        arr = np.ctypeslib.as_array(lmp.gather(name, t, c)).copy()
        out[name] = arr.reshape(-1, c) if c > 1 else arr
    image = np.ctypeslib.as_array(lmp.gather("image", 0, 1)).astype(np.int64)
    ix = (image & 1023) - 512           # LAMMPS_SMALLBIG image-flag packing
    boxlo, boxhi = lmp.extract_box()[:2]
    out["x"][:, 0] += ix * (boxhi[0] - boxlo[0])
    if dim == 3:                        # periodic in y as well
        iy = ((image >> 10) & 1023) - 512
        out["x"][:, 1] += iy * (boxhi[1] - boxlo[1])
    return out


def continue_run(datafile, nsteps, upper_y, split=None, mode=None, workdir=".", comm=None,
                 dim=2, own=False):
    """Run ``nsteps`` from ``datafile``, optionally through a file round trip
    (not with ``own``)."""
    lmp = open_data(datafile, upper_y, comm=comm, dim=dim, own=own)
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
            lmp = open_data(mid, upper_y, comm=comm, dim=dim)
        elif mode == "restart":
            lmp.command(f"write_restart {mid}")
            lmp.close()
            lmp = open_restart(mid, upper_y, comm=comm, dim=dim)
        else:
            raise ValueError(f"mode must be 'split', 'data' or 'restart', got {mode!r}")
        lmp.command(f"run {nsteps - split}")
    out = state(lmp, dim)
    lmp.close()
    return out


def main(argv):
    own = argv[-1] == "own"
    argv = argv[:-1] if own else argv
    dim = 3 if argv[-1] == "3d" else 2
    argv = argv[:-1] if dim == 3 else argv
    datafile, outfile, nsteps, upper_y = argv[1], argv[2], int(argv[3]), float(argv[4])
    split = int(argv[5]) if len(argv) > 5 else None
    mode = argv[6] if len(argv) > 6 else None
    out = continue_run(datafile, nsteps, upper_y, split, mode,
                       workdir=os.path.dirname(outfile), comm=MPI.COMM_WORLD, dim=dim,
                       own=own)
    if MPI.COMM_WORLD.rank == 0:
        np.savez(outfile, **out)


if __name__ == "__main__":
    main(sys.argv)
