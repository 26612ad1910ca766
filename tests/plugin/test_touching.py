"""Two disks touching across the periodic boundary, at an overlap within a few
ulps of zero: each side decides the contact from its own copy of the geometry
(the other's image x +- L, rounded), so without the touching band the two
histories disagreed at 31 of 81 positions one ulp apart (box 47.6 wide) --
the analyzer's mirror check then refuses the state. Found when a disk held by
one contact (force-free at delta = 0) was driven there by Newton at N = 1600."""
import numpy as np
import pytest

from .lmputil import add_disk, box_commands, history, new_lammps, style_commands

W = 47.62432831515532           # the stored N = 1600 packing's box
X1 = W - 0.3


def pair(x2, steps=1, v=0.0, preset=None, move=False):
    """Disks 1 (x = W - 0.3) and 2 (x = x2) of radius 0.5 at y = 5; their centres
    are 1 apart across the boundary at x2 = 0.7. Returns (history partners)."""
    lmp = new_lammps()
    lmp.commands_list(box_commands(width=W, ylo=-2, yhi=10))
    add_disk(lmp, 1, 0.5, X1, 5.0)
    add_disk(lmp, 1, 0.5, x2, 5.0)
    lmp.commands_list(style_commands(wall=False) + ["timestep 1e-3"])
    if move:
        lmp.commands_list(["fix nve all nve/sphere disc", "fix 2d all enforce2d"])
    if preset is not None:                      # start as a recorded contact
        lmp.command("run 0")
        arr = lmp.numpy.extract_atom("i2_mindlin_partner")
        tag = np.asarray(lmp.numpy.extract_atom("id")[:2])
        for k in range(2):
            arr[k, 0] = 3 - int(tag[k])
    if v:
        lmp.command(f"set atom 2 vx {v!r}")
    lmp.command(f"run {steps}")
    p, _, _ = history(lmp)
    lmp.close()
    return p[0, 0], p[1, 0]


def ulps(x, k):
    for _ in range(abs(k)):
        x = np.nextafter(x, np.inf if k > 0 else -np.inf)
    return float(x)


@pytest.mark.parametrize("preset", [None, True])
def test_histories_mirror_at_round_off_overlaps(preset):
    one_sided = []
    for k in range(-40, 41):
        a, b = pair(ulps(0.7, k), preset=preset)
        if (a == 2) != (b == 1):
            one_sided.append(k)
    assert one_sided == [], one_sided
    # inside the band the recorded state is kept: absent without history,
    # present with it
    a, b = pair(ulps(0.7, -3), preset=preset)
    assert (a == 2) == (preset is not None)


def test_outside_the_band_geometry_decides():
    # overlap 1e-9: a contact, history or not; a gap of 1e-9: none, history or not
    assert pair(0.7 - 1e-9) == (2, 1)
    assert pair(0.7 - 1e-9, preset=True) == (2, 1)
    assert pair(0.7 + 1e-9) == (0, 0)
    assert pair(0.7 + 1e-9, preset=True) == (0, 0)


def test_approach_and_separation_through_the_band():
    # disk 2 moves by 1e-3 per step through the touching distance: the
    # contact appears and disappears on both sides at the same step
    for v in (-1.0, 1.0):
        for steps in range(1, 4):
            a, b = pair(0.7 - v * 1.5e-3, steps=steps, v=v, move=True)
            assert (a == 2) == (b == 1), (v, steps)
