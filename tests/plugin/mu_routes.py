"""One undamped scene (c) -- load, f(t) and mu(v) -- built three ways.

The default job's equilibrium at F_x = 0.0645 (N = 100), forced hard enough
that mu(v) switches on within a few hundred steps:

``native``
    ``fix mu/velocity`` and ``fix addforce/oscillating`` (what in.perturb uses).
``flat``
    LAMMPS alone: ``fix adapt`` on the pair and a ``v_`` wall mu from one
    equal-style variable, and ``fix addforce`` with an equal-style variable,
    each written as a single expression. The same operations in the same
    order as the plugin fixes: the same bits.
``nested``
    The former in.perturb (before fix mu/velocity): per-atom variables for
    the load, mu(v) through the variables vtop, vt, vt0 (``muv=False``, a = 0:
    its scene (a)). LAMMPS hands a referenced equal-style variable
    to the referencing one as text with 15 significant digits, so this route
    rounds v~, e(t) and f(t) there (and F_x, when it has more digits): it
    agrees with the others to round-off only.

Used in-process by test_mu_velocity.py and as a script under ``mpirun``:

    mpirun -np 2 python mu_routes.py DATAFILE OUT.npz ROUTE NSTEPS
"""
import os
import sys

from mpi4py import MPI

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lmputil  # noqa: E402
import numpy as np  # noqa: E402

KN, KT = lmputil.KN, lmputil.KT
#: the scene's numbers: load, forcing, Eq. 4
P = dict(Fx=0.0645, Fy=3.0, a=1e-3, wp=1.0, ton=0.5, mu=1.0, v0=1e-6, vss=2e-6, B=0.2,
         w=0.4, muss=0.8, dt=1e-3)
EVERY = 50


def scene_commands(datafile, p=P):
    """Atoms, groups, pair and neighbor settings (as in.perturb)."""
    return [
        "units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
        "boundary p f p", "comm_modify vel yes", lmputil.HIST,
        "fix topflag all property/atom i_top ghost no",
        f"read_data {datafile} fix hist NULL hist fix topflag NULL topflag",
        "set group all mass 1.0", "variable istop atom i_top", "group top variable istop",
        "neighbor 0.2 bin", "neigh_modify delay 0 every 1 check yes",
        f"timestep {p['dt']!r}", "reset_timestep 0 time 0.0",
        "pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {p['mu']!r}",
    ]


def route_commands(route, p=P, muv=True, a=None):
    """Wall, mu(v) and load of one route (fix IDs wall, muv, load)."""
    a = p["a"] if a is None else a
    if route == "native":
        cmds = [f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} {p['mu']!r} yplane 0.0"]
        if muv:
            cmds.append(f"fix muv top mu/velocity {p['mu']!r} {p['v0']!r} {p['B']!r} "
                        f"{p['w']!r} {p['muss']!r} vss {p['vss']!r}")
        return cmds + [f"fix load top addforce/oscillating {p['Fx']!r} {-p['Fy']!r} 0.0 "
                       f"{a!r} {p['wp']!r} onset {p['ton']!r}"]
    vt, vt0 = f"abs(vcm(top,x))/{p['vss']!r}", f"{p['v0']!r}/{p['vss']!r}"
    env = (f"ternary(time<{p['ton']!r},0.5*(1.0-cos(PI*time/{p['ton']!r})),1.0)"
           if p["ton"] > 0 else "1.0")
    if route == "flat":
        mu = (f"ternary({vt}<={vt0},{p['mu']!r},{p['mu']!r}*({p['B']!r}*exp(-{p['w']!r}*"
              f"({vt}-{vt0}))+{p['muss']!r}))")
        return [f"variable mu_now equal {mu}",
                f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} v_mu_now yplane 0.0",
                "fix muv all adapt 1 pair mindlin/smooth mu * * v_mu_now",
                f"variable fx equal {p['Fx']!r}+{a!r}*{env}*cos({p['wp']!r}*time)",
                f"fix load top addforce v_fx {-p['Fy']!r} 0.0"]
    assert route == "nested", route
    cmds = ["variable vtop equal vcm(top,x)"]
    if muv:
        cmds += [
            f"variable vt0 equal {vt0}", f"variable vt equal abs(v_vtop)/{p['vss']!r}",
            f"variable mu_now equal ternary(v_vt<=v_vt0,{p['mu']!r},{p['mu']!r}*({p['B']!r}*"
            f"exp(-{p['w']!r}*(v_vt-v_vt0))+{p['muss']!r}))",
            f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} v_mu_now yplane 0.0",
            "fix muv all adapt 1 pair mindlin/smooth mu * * v_mu_now"]
    else:
        cmds += [f"variable mu_now equal {p['mu']!r}",
                 f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} {p['mu']!r} yplane 0.0"]
    cmds += [f"variable load_x equal {p['Fx']!r}", f"variable load_y equal {p['Fy']!r}",
             "variable loadon equal 1", f"variable env equal {env}"]
    if a != 0:
        cmds += [f"variable pert equal {a!r}*v_env*cos({p['wp']!r}*time)",
                 "variable fext_x atom v_istop*(v_load_x+v_pert)"]
    else:
        cmds.append("variable fext_x atom v_istop*v_load_x")
    return cmds + ["variable fext_y atom -v_istop*v_load_y",
                   "variable fload_x atom v_loadon*v_fext_x",
                   "variable fload_y atom v_loadon*v_fext_y",
                   "fix load top addforce v_fload_x v_fload_y 0.0"]


def open_scene(datafile, route, comm=None, **kw):
    """A LAMMPS instance with the scene of ``route``, integrator and D(t)."""
    lmp = lmputil.new_lammps(comm=comm)
    lmp.commands_list(scene_commands(datafile) + route_commands(route, **kw) + [
        "fix integ all nve/sphere disc", "fix 2d all enforce2d", "compute msd all msd"])
    return lmp


def state(lmp):
    """Positions, velocities, spins and histories ordered by atom ID (all ranks)."""
    out = {}
    for name, t, c in [("x", 1, 3), ("v", 1, 3), ("omega", 1, 3),
                       ("i2_mindlin_partner", 0, 8), ("d2_mindlin_t", 1, 8)]:
        arr = np.ctypeslib.as_array(lmp.gather(name, t, c)).copy()
        out[name] = arr.reshape(-1, c)
    return out


def run(lmp, nsteps, native, every=EVERY):
    """Run in chunks of ``every`` steps (as the driver records); D and mu per chunk.

    mu is fix muv's value (``native``) or, for the variable routes, NaN.
    """
    D, mu = [], []
    for k in range(nsteps // every):
        lmp.command(f"run {every} pre {'yes' if k == 0 else 'no'} post no")
        D.append(lmp.extract_compute("msd", 0, 1)[3])
        mu.append(lmp.extract_fix("muv", 0, 1, 0) if native else np.nan)
    return np.asarray(D), np.asarray(mu)


def main(argv):
    datafile, out, route, nsteps = argv[1], argv[2], argv[3], int(argv[4])
    lmp = open_scene(datafile, route, comm=MPI.COMM_WORLD)
    D, mu = run(lmp, nsteps, route == "native")
    st = state(lmp)
    if MPI.COMM_WORLD.Get_rank() == 0:
        np.savez(out, D=D, mu=mu, **st)
    lmp.close()


if __name__ == "__main__":
    main(sys.argv)
