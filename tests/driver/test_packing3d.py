"""``generate --dim 3``: the seeded sphere packing, its data file, read by LAMMPS (in.relax3d)."""
import re

import numpy as np
import pytest

from remote_trigger.analysis.state.datafile import read_data
from remote_trigger.pywrap import cli
from remote_trigger.pywrap.stages.packing import (
    N_3D, PHI_3D, RADII, TOP_SPACING_3D, box_width, generate, write_data)


def test_same_seed_same_packing_other_seed_differs():
    a, b, c = (generate(N_3D, seed=s, dim=3) for s in (7, 7, 8))
    for name in ("positions", "radii", "types", "top"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.positions, c.positions)


def test_2d_packing_unchanged_by_the_dimension_argument():
    a, b = generate(100, seed=3), generate(100, seed=3, dim=2)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert a.dim == 2 and a.positions.shape == (100, 2)


@pytest.mark.parametrize("n", [N_3D, 300])
def test_geometry(n):
    p = generate(n, seed=3, dim=3)
    assert p.dim == 3 and p.n == n and p.positions.shape == (n, 3)
    assert np.count_nonzero(p.radii == RADII[0]) == n // 2
    np.testing.assert_array_equal(p.types, np.where(p.radii == RADII[0], 1, 2))
    # L = 1.25 m, m even, the largest up to the cube edge at phi = 0.64
    m = int(round(p.width / TOP_SPACING_3D))
    assert m % 2 == 0 and p.width == TOP_SPACING_3D * m == box_width(n, PHI_3D, dim=3)
    edge = (np.sum(4 / 3 * np.pi * p.radii ** 3) / PHI_3D) ** (1 / 3)
    assert TOP_SPACING_3D * m <= edge < TOP_SPACING_3D * (m + 2)
    # no overlaps (periodic in x and z), nothing below the wall, inside the box
    d = p.positions[:, None, :] - p.positions[None, :, :]
    for a in (0, 2):
        d[..., a] -= p.width * np.round(d[..., a] / p.width)
    gap = np.linalg.norm(d, axis=-1) - (p.radii[:, None] + p.radii[None, :])
    np.fill_diagonal(gap, 1.0)
    assert gap.min() > 0
    assert np.all(p.positions[:, 1] - p.radii >= 0)
    assert np.all((p.positions[:, [0, 2]] >= 0) & (p.positions[:, [0, 2]] < p.width))
    # the top layer: m x m, checkerboard of radii, spacing 1.25, above every bulk sphere
    assert p.n_top == m * m
    t = p.positions[p.top]
    assert t[:, 1].min() - np.max(p.positions[~p.top, 1] + p.radii[~p.top]) >= 0.05 + RADII[1] - 1e-12
    a, b = np.round(t[:, 0] / TOP_SPACING_3D - 0.5), np.round(t[:, 2] / TOP_SPACING_3D - 0.5)
    np.testing.assert_allclose(t[:, 0], (a + 0.5) * TOP_SPACING_3D, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(p.radii[p.top], np.where((a + b) % 2 == 0, RADII[1], RADII[0]))


def test_data_file_round_trip(tmp_path):
    """Written with repr: read back bit for bit, and seen as three-dimensional."""
    p = generate(N_3D, seed=2, dim=3)
    path = tmp_path / "p3.data"
    write_data(p, path)
    d = read_data(path)
    assert d.dimension == 3 and d.n == N_3D
    np.testing.assert_array_equal(np.column_stack([d.positions, d.z]), p.positions)
    np.testing.assert_array_equal(d.radii, p.radii)
    np.testing.assert_array_equal(d.top, p.top)
    np.testing.assert_array_equal(d.box_hi - d.box_lo, [p.width, p.yhi - p.ylo, p.width])
    p2 = tmp_path / "p2.data"
    write_data(generate(20, seed=2), p2)
    assert read_data(p2).dimension == 2


def test_a_disk_file_with_z_is_refused_in_one_line(tmp_path, capsys):
    """z != 0 makes a file three-dimensional, but a file with the disks' history
    section is 2D: the contradiction is refused, naming the atom and its z (it
    was taken as 3D, and LAMMPS stopped at the unknown section, exit status 1)."""
    p2 = tmp_path / "p2.data"
    write_data(generate(20, seed=2), p2)
    lines = p2.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("Atoms")) + 2
    words = lines[k].split()
    words[6] = "0.1"
    lines[k] = " ".join(words)
    bad = tmp_path / "z.data"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=rf"atom {words[0]} has z = 0\.1, but section 'hist' "
                                         r"is the contact history of disks"):
        read_data(bad)
    assert cli.main(["relax", "--datafile", str(bad), "--out", str(tmp_path / "o"),
                     "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "z = 0.1" in err[0], err
    assert not (tmp_path / "o").exists()


def test_data_file_read_by_the_3d_deck(tmp_path):
    from remote_trigger.pywrap.bindings.engine import Engine

    p = generate(N_3D, seed=2, dim=3)
    path = tmp_path / "p3.data"
    write_data(p, path)
    with Engine() as eng:
        eng.load_deck("in.relax3d", {"datafile": str(path)}, ("scene", "damped", "dynamics"))
        eng.command("run 0")
        assert eng.dimension == 3 and eng.natoms == N_3D
        st = eng.gather_state()
        assert st.dim == 3
        np.testing.assert_array_equal(st.positions, p.positions)        # exact round trip
        np.testing.assert_array_equal(st.top, p.top)
        np.testing.assert_array_equal(st.radii, p.radii)
        np.testing.assert_array_equal(st.masses, np.ones(N_3D))
        np.testing.assert_array_equal(st.box_hi - st.box_lo, [p.width, p.yhi - p.ylo, p.width])
        assert not np.any(st.xi) and not np.any(st.wall_xi)             # history starts at 0


def test_generate_command(tmp_path, capsys):
    out = tmp_path / "g.data"
    assert cli.main(["generate", "--dim", "3", "--seed", "4", "--output", str(out)]) == 0
    assert f"{N_3D} spheres (16 in top), L = 5" in capsys.readouterr().out
    assert read_data(out).dimension == 3


@pytest.mark.parametrize("argv, needle", [
    (["--dim", "3", "--phi", "0.8"], "phi = 0.8"),          # above random close packing
    (["--dim", "3", "--n", "7"], "n = 7"),
    (["--dim", "3", "--n", "0"], "got n = 0 (the smallest n that works at phi = 0.64 is 82)"),
    (["--dim", "4"], "invalid choice: 4"),
    # a box of 2 x 2 top spheres (L = 2.5): a sphere could touch two images of another
    (["--dim", "3", "--n", "40"], "n = 40 is too small: the periodic width L = 2.5 is not "
                                  "above 4 R2 = 2.8"),
])
def test_generate_bad_input(tmp_path, capsys, argv, needle):
    try:
        status = cli.main(["generate", *argv, "--output", str(tmp_path / "g.data")])
    except SystemExit as exc:            # argparse's own refusal
        status = exc.code
    assert status == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and needle in err[0], err
    assert not (tmp_path / "g.data").exists()


@pytest.mark.parametrize("kw, msg", [
    (dict(n=20, dim=4), "dim = 4"), (dict(n=20, dim=3, phi=0.75), "phi = 0.75"),
    (dict(n=20, dim=3, phi_loose=0.5), "phi_loose = 0.5"),
    (dict(n=6, dim=3), "top layer of 4 spheres"),
    (dict(n=80, dim=3), "n = 80 is too small: the periodic width L = 2.5"),
    (dict(n=6, dim=2, phi=0.9), "n = 6 is too small: the periodic width L = 2.784")])
def test_bad_arguments(kw, msg):
    with pytest.raises(ValueError, match=msg):
        generate(**kw)


@pytest.mark.parametrize("kw", [dict(n=40, dim=3), dict(n=6, dim=2, phi=0.9),
                                dict(n=6, dim=3), dict(n=0, dim=3)])
def test_too_small_n_names_the_smallest_that_works(kw):
    """The error names the smallest n: it generates, the even n below it does not."""
    with pytest.raises(ValueError) as exc:
        generate(**kw)
    m = re.search(r"the smallest n that works at phi = \S+ is (\d+)\)$", str(exc.value))
    assert m, str(exc.value)
    smallest = int(m.group(1))
    assert generate(**dict(kw, n=smallest)).n == smallest
    with pytest.raises(ValueError, match=f"n = {smallest - 2} is too small"):
        generate(**dict(kw, n=smallest - 2))
