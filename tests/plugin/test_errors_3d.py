"""Bad input in 3D (and 3D-only input in 2D): one-line LAMMPS errors that
name the problem and the value."""
import pytest

from .lmputil import KN, KT, add_sphere, box_commands, box_commands_3d, new_lammps

STYLES = ["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 1.0"]


def expect(setup, cmds, match):
    lmp = new_lammps()
    try:
        lmp.commands_list(setup)
        with pytest.raises(Exception, match=match) as err:
            lmp.commands_list(cmds)
        assert str(err.value).startswith("ERROR")
    finally:
        lmp.close()


@pytest.mark.parametrize("args, match", [
    ("zplane 0.0", r"zplane needs lo and hi \(NULL for an open side\), got 1 values"),
    ("zplane NULL NULL", r"zplane lo and hi are both NULL: no wall"),
    ("zplane 3.0 1.0", r"zplane lo must be below hi, got 3\.0 and 1\.0"),
    ("zplane 0 abc", r"Expected floating point parameter instead of 'abc'"),
    ("zcylinder -2", r"zcylinder R must be > 0, got -2"),
])
def test_bad_wall_arguments_3d(args, match):
    expect(box_commands_3d(), [f"fix w all wall/mindlin/smooth {KN} {KT} 1.0 {args}"], match)


def test_zplane_in_2d_names_the_dimension():
    expect(box_commands(), [f"fix w all wall/mindlin/smooth {KN} {KT} 1.0 zplane 0 1"],
           r"zplane needs dimension 3, this simulation has dimension 2")


@pytest.mark.parametrize("cmd, word", [
    (f"pair_coeff * * {KN} {KT} 1.0 rolling sds 1 1 1", "rolling"),
    (f"pair_coeff * * {KN} {KT} 1.0 twisting marshall", "twisting"),
    (f"fix w all wall/mindlin/smooth {KN} {KT} 1.0 zplane 0 NULL rolling sds 1 1 1",
     "rolling"),
])
def test_rolling_and_twisting_resistance_refused(cmd, word):
    expect(box_commands_3d(), ["pair_style mindlin/smooth", cmd],
           rf"no {word} resistance \(got '{word}'\); pair granular offers")


@pytest.mark.parametrize("hist, match", [
    (["fix h all property/atom i2_mindlin_partner 8 d2_mindlin_tx 8 ghost no"],
     r"needs per-atom arrays d2_mindlin_tx, d2_mindlin_ty, d2_mindlin_tz with as many "
     r"columns as i2_mindlin_partner \(8\); d2_mindlin_ty is missing"),
    (["fix h all property/atom i2_mindlin_partner 8 d2_mindlin_tx 8 d2_mindlin_ty 4 "
      "d2_mindlin_tz 8 ghost no"], r"d2_mindlin_ty is of 4 columns"),
    (["fix h all property/atom d2_mindlin_tx 8 ghost no"],
     r"defines d2_mindlin_tx but not i2_mindlin_partner; define i2_mindlin_partner with "
     r"d2_mindlin_tx, d2_mindlin_ty, d2_mindlin_tz, or none of them"),
])
def test_incomplete_3d_history_arrays(hist, match):
    setup = box_commands_3d(hist=None) + hist
    lmp = new_lammps()
    lmp.commands_list(setup)
    add_sphere(lmp, 1, 0.5, (5, 5, 5))
    lmp.commands_list(STYLES)
    with pytest.raises(Exception, match=match):
        lmp.command("run 0")
    lmp.close()


def test_2d_wall_history_vector_refused_in_3d():
    setup = box_commands_3d(boundary="p f p") + [
        "fix h all property/atom d_mindlin_wall_t ghost no"]
    lmp = new_lammps()
    lmp.commands_list(setup)
    add_sphere(lmp, 1, 0.5, (5, 5, 0.4))
    lmp.commands_list(STYLES + [f"fix w all wall/mindlin/smooth {KN} {KT} 1.0 yplane 0.0"])
    with pytest.raises(Exception, match=r"Fix wall/mindlin/smooth w: d_mindlin_wall_t holds one "
                                        r"value per atom, the 2d history"):
        lmp.command("run 0")
    lmp.close()


def test_sphere_on_the_axis_of_zcylinder():
    lmp = new_lammps()
    lmp.commands_list(box_commands_3d(size=10.0, lo=-5.0, boundary="f f f"))
    add_sphere(lmp, 1, 0.5, (0.0, 0.0, 1.0))
    lmp.commands_list(STYLES + [f"fix w all wall/mindlin/smooth {KN} {KT} 1.0 zcylinder 0.3"])
    with pytest.raises(Exception, match=r"atom 1 \(radius 0\.5\) on the axis of zcylinder "
                                        r"R = 0\.3 has no contact normal"):
        lmp.command("run 0")
    lmp.close()


def test_too_many_contacts_per_sphere_names_the_3d_arrays():
    """In 3D the arrays of t to widen are d2_mindlin_tx/ty/tz, not d2_mindlin_t."""
    setup = box_commands_3d(hist=None) + [
        "fix h all property/atom i2_mindlin_partner 2 d2_mindlin_tx 2 d2_mindlin_ty 2 "
        "d2_mindlin_tz 2 ghost no"]
    lmp = new_lammps()
    lmp.commands_list(setup)
    for xyz in [(5.0, 5.0, 5.0), (5.99, 5.0, 5.0), (4.01, 5.0, 5.0), (5.0, 5.99, 5.0)]:
        add_sphere(lmp, 1, 0.5, xyz)
    lmp.commands_list(STYLES)
    with pytest.raises(Exception, match=r"atom 1 has more than 2 contacts; give "
                                        r"i2_mindlin_partner and d2_mindlin_tx, d2_mindlin_ty "
                                        r"and d2_mindlin_tz more columns, or drop the fix"):
        lmp.command("run 0")
    lmp.close()
