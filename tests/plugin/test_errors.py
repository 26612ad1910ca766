"""Bad input gives a LAMMPS error that names the problem, never a crash or a silent run."""
import numpy as np
import pytest

from .lmputil import HIST, KN, KT, add_disk, box_commands, new_lammps


def base(lmp, hist=True, atom_style="sphere", dimension=2, vel=True):
    cmds = box_commands()
    if not hist:
        cmds.remove(HIST)
    if atom_style != "sphere":
        cmds = [f"atom_style {atom_style}" if c.startswith("atom_style") else c for c in cmds]
    if dimension != 2:
        cmds = [f"dimension {dimension}" if c.startswith("dimension") else c for c in cmds]
        cmds = [c.replace("-0.5 0.5", "0 20") for c in cmds]
    if not vel:
        cmds.remove("comm_modify vel yes")
    lmp.commands_list(cmds)


def run_expect(cmds, match, **kw):
    lmp = new_lammps()
    try:
        base(lmp, **kw)
        with pytest.raises(Exception, match=match):
            lmp.commands_list(cmds)
    finally:
        lmp.close()


@pytest.mark.parametrize("coeff, match", [
    ("* * -1.0 1.0 1.0", r"k_n must be > 0, got -1\.0"),
    ("* * 0 1.0 1.0", r"k_n must be > 0, got 0"),
    ("* * 2e5 -3 1.0", r"k_t must be >= 0, got -3"),
    ("* * 2e5 1e4 -0.5", r"mu must be >= 0, got -0\.5"),
    ("* * 2e5 1e4 nan", r"Expected floating point parameter instead of 'nan'"),
    ("* * 2e5 1e4", r"needs 5 arguments \(I J k_n k_t mu\), got 4"),
    ("* * 2e5 abc 1.0", r"Expected floating point parameter instead of 'abc'"),
    ("1 3 2e5 1e4 1.0", r"(?i)numeric index 3 is out of bounds|out of range|bound"),
])
def test_bad_pair_coeff(coeff, match):
    run_expect(["pair_style mindlin/smooth", f"pair_coeff {coeff}"], match)


def test_pair_style_takes_no_arguments():
    run_expect(["pair_style mindlin/smooth 2.5"], r"takes no arguments, got '2.5'")


def test_missing_coefficients():
    lmp = new_lammps()
    base(lmp)
    add_disk(lmp, 1, 0.5, 5.0, 5.0)
    lmp.commands_list(["pair_style mindlin/smooth", "pair_coeff 1 1 2e5 1e4 1.0"])
    with pytest.raises(Exception, match=r"coefficients for types 1 2 are not set|"
                                         r"All pair coeffs are not set"):
        lmp.command("run 0")
    lmp.close()


@pytest.mark.parametrize("kw, match", [
    (dict(vel=False), r"requires ghost atoms store velocity: use 'comm_modify vel yes'"),
])
def test_missing_setup_is_reported_at_run(kw, match):
    lmp = new_lammps()
    base(lmp, **kw)
    add_disk(lmp, 1, 0.5, 5.0, 5.0)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=match):
        lmp.command("run 0")
    lmp.close()


def test_half_defined_history_arrays():
    """A fix property/atom with only one of the two pair arrays is named in the error."""
    lmp = new_lammps()
    base(lmp, hist=False)
    lmp.command("fix hist all property/atom d2_mindlin_t 8 ghost no")
    add_disk(lmp, 1, 0.5, 5.0, 5.0)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=r"defines d2_mindlin_t but not i2_mindlin_partner; "
                                        r"define both .*d_mindlin_wall_t ghost no'\) or neither"):
        lmp.command("run 0")
    lmp.close()


def test_no_radius_no_insertion_is_not_a_zero_cutoff():
    lmp = new_lammps()
    base(lmp, hist=False)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=r"no disk has a radius > 0 and no fix pour or fix "
                                        r"deposit will insert any"):
        lmp.command("run 0")
    lmp.close()


def test_non_sphere_atom_style():
    lmp = new_lammps()
    base(lmp, atom_style="atomic")
    lmp.commands_list(["create_atoms 1 single 5 5 0 units box", "mass * 1.0",
                       "pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=r"requires atom style sphere"):
        lmp.command("run 0")
    lmp.close()


def test_three_dimensions_need_three_history_columns_per_contact():
    """3d is supported; a fix property/atom shaped for 2d (one t column per
    contact) is refused with the count it needs."""
    lmp = new_lammps()
    base(lmp, dimension=3)
    lmp.commands_list(["create_atoms 1 single 5 5 5 units box", "set atom 1 mass 1.0",
                       "pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=r"in 3d the history needs per-atom arrays "
                                        r"d2_mindlin_tx, d2_mindlin_ty, d2_mindlin_tz .*"
                                        r"d2_mindlin_tx is missing"):
        lmp.command("run 0")
    lmp.close()


def test_too_many_contacts_per_disk():
    lmp = new_lammps()
    cmds = box_commands()
    cmds[cmds.index(HIST)] = ("fix hist all property/atom i2_mindlin_partner 2 "
                              "d2_mindlin_t 2 d_mindlin_wall_t ghost no")
    lmp.commands_list(cmds)
    for x, y in [(5.0, 5.0), (5.99, 5.0), (4.01, 5.0), (5.0, 5.99)]:
        add_disk(lmp, 1, 0.5, x, y)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=r"atom 1 has more than 2 contacts; give i2_mindlin_partner "
                                        r"and d2_mindlin_t more columns, or drop the fix "
                                        r"property/atom"):
        lmp.command("run 0")
    lmp.close()


@pytest.mark.parametrize("args, match", [
    ("-2e5 1e4 1.0 yplane 0.0", r"k_n must be > 0, got -2e5"),
    ("2e5 -1 1.0 yplane 0.0", r"k_t must be >= 0, got -1"),
    ("2e5 1e4 -1 yplane 0.0", r"mu must be >= 0, got -1"),
    ("2e5 1e4 1.0 xplane 0.0", r"xplane needs lo and hi \(NULL for an open side\), got 1"),
    ("2e5 1e4 1.0 yplane", r"needs: fix ID group wall/mindlin/smooth k_n k_t mu xplane\|yplane"),
    ("2e5 1e4 1.0 yplane NULL NULL", r"yplane lo and hi are both NULL"),
    ("2e5 1e4 1.0 xplane 5 1", r"xplane lo must be below hi, got 5 and 1"),
    ("2e5 1e4 1.0 xplane 0 abc", r"Expected floating point parameter instead of 'abc'"),
    ("2e5 1e4 1.0 zcylinder -3", r"zcylinder R must be > 0, got -3"),
    ("2e5 1e4 1.0 zcylinder 3 4", r"zcylinder needs one value \(R\), got 2"),
    ("2e5 1e4 1.0 zplane 0 1", r"zplane needs dimension 3, this simulation has dimension 2"),
    ("2e5 1e4 1.0 cplane 0 1", r"unknown wall style 'cplane'"),
    # a keyword after the wall is named (it was 'got 3 values')
    ("2e5 1e4 1.0 yplane 0.0 NULL wiggle y 0.1 1.0", r"unknown keyword 'wiggle' after yplane "
                                                     r"0.0 NULL \(the fix takes no keywords"),
    ("2e5 1e4 1.0 zcylinder 3 foo", r"unknown keyword 'foo' after zcylinder 3"),
])
def test_bad_wall_arguments(args, match):
    run_expect([f"fix w all wall/mindlin/smooth {args}"], match)


def test_two_legacy_walls_cannot_share_the_history_vector():
    lmp = new_lammps()
    base(lmp)
    add_disk(lmp, 1, 0.5, 5.0, 0.4)
    lmp.commands_list([f"fix w1 all wall/mindlin/smooth {KN} {KT} 1.0 yplane 0.0",
                       f"fix w2 all wall/mindlin/smooth {KN} {KT} 1.0 yplane -1.0"])
    with pytest.raises(Exception, match=r"fixes w1 and w2 would both keep their history in "
                                        r"d_mindlin_wall_t"):
        lmp.command("run 0")
    lmp.close()


def test_wall_equal_style_variable():
    lmp = new_lammps()
    base(lmp)
    add_disk(lmp, 1, 0.5, 5.0, 0.4)
    lmp.commands_list([f"fix w all wall/mindlin/smooth {KN} {KT} v_nope yplane 0.0"])
    with pytest.raises(Exception, match=r"variable nope for mu does not exist"):
        lmp.command("run 0")
    lmp.command("variable nope atom 1.0")
    with pytest.raises(Exception, match=r"variable nope for mu is not equal-style"):
        lmp.command("run 0")
    lmp.close()


def test_coincident_centres_are_an_error_not_nan():
    lmp = new_lammps()
    base(lmp)
    add_disk(lmp, 1, 0.5, 5.0, 5.0)
    add_disk(lmp, 1, 0.5, 5.0, 5.0)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
    with pytest.raises(Exception, match=r"atoms 1 and 2 have coincident centres"):
        lmp.command("run 0")
    lmp.close()


@pytest.mark.parametrize("wall", [False, True])
def test_minimize_is_refused(wall):
    """History follows the MD steps (v dt); a minimizer would corrupt it."""
    lmp = new_lammps()
    base(lmp)
    add_disk(lmp, 1, 0.5, 5.0, 5.0)
    add_disk(lmp, 1, 0.5, 5.9, 5.0)
    if wall:
        lmp.command(f"fix w all wall/mindlin/smooth {KN} {KT} 1.0 yplane 0.0")
        lmp.commands_list(["pair_style zero 2.0", "pair_coeff * *"])
        what = "Fix wall/mindlin/smooth"
    else:
        lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 1.0"])
        what = "Pair style mindlin/smooth"
    with pytest.raises(Exception, match=what + r" cannot be used with minimize"):
        lmp.command("minimize 0 1e-10 10 100")
    lmp.close()


def test_frictionless_minimize_settles_a_stack():
    """With mu = 0 minimize is allowed: FIRE finds the Hertz overlaps of a stack.

    Two disks (R = 0.5) above the wall at y = 0, a force -F on the upper one:
    in equilibrium the pair carries F and the wall F, so both overlaps are
    (F / k_n)^(2/3) (pair and wall act in the minimizer, history stays 0).
    """
    F = 3.0
    lmp = new_lammps()
    base(lmp)
    add_disk(lmp, 1, 0.5, 5.0, 0.6)
    add_disk(lmp, 1, 0.5, 5.0, 1.7)
    lmp.commands_list([
        "pair_style mindlin/smooth", f"pair_coeff * * {KN} {KT} 0.0",
        f"fix w all wall/mindlin/smooth {KN} {KT} 0.0 yplane 0.0",
        "group up id 2", f"fix load up addforce 0.0 {-F!r} 0.0",
        "fix 2d all enforce2d", "timestep 1e-3",
        "min_style fire", "min_modify norm max tmax 4",
        "minimize 0.0 1e-9 100000 100000"])
    x = np.ctypeslib.as_array(lmp.gather_atoms("x", 1, 3)).reshape(-1, 3)
    delta = (F / KN) ** (2.0 / 3.0)
    assert x[0, 1] == pytest.approx(0.5 - delta, abs=1e-9)
    assert x[1, 1] - x[0, 1] == pytest.approx(1.0 - delta, abs=1e-9)
    assert x[0, 0] == x[1, 0] == 5.0
    lmp.close()


# ------------------------------------ found by trying the plugin as a LAMMPS user

def _two_disks(lmp, wall=True):
    """Two overlapping disks above the floor, the pair style and the wall."""
    add_disk(lmp, 1, 0.5, 5.0, 1.0)
    add_disk(lmp, 1, 0.5, 5.98, 1.0)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 1.0",
                       "fix nve all nve/sphere disc"])
    if wall:
        lmp.command(f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} 1.0 yplane 0.0")


@pytest.mark.parametrize("fix, name", [
    (None, "wall/mindlin/smooth"),
    ("fix f all addforce/oscillating 0.1 0.0 0.0 0.0 0.0", "addforce/oscillating"),
    ("fix muv all mu/velocity 1.0 1e-3 0.2 0.4 0.8 wall no", "mu/velocity")])
def test_respa_is_refused_not_ignored(fix, name):
    """Under run_style respa the wall's post_force was never called: the wall
    vanished without a word (fix addforce/oscillating and fix mu/velocity
    alike)."""
    lmp = new_lammps()
    try:
        base(lmp)
        _two_disks(lmp, wall=fix is None)
        if fix is not None:
            lmp.command(fix)
        lmp.command("run_style respa 2 2")
        with pytest.raises(Exception, match=rf"Fix {name} does not support run_style respa; "
                                            rf"use run_style verlet"):
            lmp.command("run 1")
    finally:
        lmp.close()


@pytest.mark.parametrize("box, wall, match", [
    ("boundary p p p", "yplane 0.0", r"a yplane wall needs a non-periodic y dimension"),
    ("boundary p f p", "xplane 0.0 20.0", r"a xplane wall needs a non-periodic x dimension"),
    ("boundary p f p", "zcylinder 3.0", r"zcylinder needs non-periodic x and y dimensions; "
                                        r"the boundary command makes x periodic")])
def test_a_wall_across_a_periodic_dimension_is_refused(box, wall, match):
    """Atoms wrap around such a wall (fix wall/gran refuses it too); it ran."""
    lmp = new_lammps()
    try:
        lmp.commands_list([box if c.startswith("boundary") else c for c in box_commands()])
        with pytest.raises(Exception, match=match):
            lmp.command(f"fix w all wall/mindlin/smooth {KN!r} {KT!r} 1.0 {wall}")
    finally:
        lmp.close()


def test_atom_ids_and_special_bonds_weights_are_required():
    """atom_modify id no: the history's partner IDs were all 0 (the empty
    slot) and the error spoke of periodic images; a special_bonds weight of
    0.5 was ignored (full force)."""
    lmp = new_lammps()
    try:
        lmp.commands_list(["units lj", "dimension 2", "atom_style sphere", "atom_modify id no",
                           "boundary p f p", "comm_modify vel yes",
                           "region box block 0 20 -2 20 -0.5 0.5", "create_box 2 box",
                           "create_atoms 1 single 5.0 1.0 0.0 units box",
                           "create_atoms 1 single 5.98 1.0 0.0 units box",
                           "set type 1 diameter 1.0", "set type 1 mass 1.0",
                           "pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 1.0",
                           "fix nve all nve/sphere disc"])
        with pytest.raises(Exception, match=r"Pair style mindlin/smooth requires atom IDs"):
            lmp.command("run 0")
    finally:
        lmp.close()
    run_expect(["special_bonds lj 0.0 0.5 1.0", "pair_style mindlin/smooth",
                f"pair_coeff * * {KN!r} {KT!r} 1.0", "run 0"],
               r"does not scale contact forces by special_bonds weights: lj weight 0\.5 of "
               r"1-3 neighbors must be 0 \(no contact\) or 1")


def test_pair_write_is_refused(tmp_path):
    """pair_write evaluates single() of atoms 0 and 1 at any distance: it read
    past the atom arrays with one atom, and used the two atoms' own radii
    with two. (It writes the table's header before the error: into
    ``tmp_path``, not the working directory.)"""
    lmp = new_lammps()
    try:
        base(lmp)
        _two_disks(lmp)
        lmp.command("run 0")
        with pytest.raises(Exception, match=r"single\(\) got rsq = .* pair_write is not "
                                            r"supported"):
            lmp.command(f"pair_write 1 1 5 r 0.5 1.0 {tmp_path / 'table.txt'} MS")
    finally:
        lmp.close()
