"""The packing generator: reproducible, valid geometry, readable by LAMMPS."""
import re

import numpy as np
import pytest

from remote_trigger.pywrap.stages.packing import generate, write_data, box_width, RADII


def test_same_seed_same_packing_other_seed_differs():
    a, b, c = generate(40, seed=7), generate(40, seed=7), generate(40, seed=8)
    for name in ("positions", "radii", "types", "top"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.positions, c.positions)



def _rsa_all_pairs(radii, width, height, rng, max_tries):
    """Reference: each draw tested against every disk placed before it."""
    xs, ys = [], []
    for r in radii:
        for _ in range(max_tries):
            x = rng.uniform(0.0, width)
            y = rng.uniform(r, r + height)
            if xs:
                dx = x - np.asarray(xs)
                dx -= width * np.round(dx / width)
                dy = y - np.asarray(ys)
                rr = radii[:len(xs)] + r
                if np.any(dx * dx + dy * dy < rr * rr):
                    continue
            xs.append(x)
            ys.append(y)
            break
    return xs, ys


@pytest.mark.parametrize("n, seed, width", [(6, 0, 2.9), (40, 7, 5.0), (400, 1, 20.8),
                                            (1000, 3, 32.0)])
def test_cell_list_placement_equals_the_all_pairs_test(n, seed, width):
    # one column of cells (width < 3 x 1.4) and several; loose phi 0.55 near RSA jamming
    from remote_trigger.pywrap.stages.packing import _random_sequential_addition

    radii = np.array([RADII[1]] * (n // 2) + [RADII[0]] * (n // 2))
    height = float(np.sum(np.pi * radii ** 2)) / (0.55 * width)
    rng_ref, rng = np.random.default_rng(seed), np.random.default_rng(seed)
    ref = _rsa_all_pairs(radii, width, height, rng_ref, 200000)
    got = _random_sequential_addition(radii, width, height, rng, 200000, 0.55)
    assert got[0] == ref[0] and got[1] == ref[1]          # bit for bit
    assert rng.bit_generator.state == rng_ref.bit_generator.state   # the same draws

@pytest.mark.parametrize("n", [20, 100])
def test_geometry(n):
    p = generate(n, seed=3)
    assert p.n == n
    # equal numbers of both radii, types 1 = small, 2 = large
    assert np.count_nonzero(p.radii == RADII[0]) == n // 2
    np.testing.assert_array_equal(p.types, np.where(p.radii == RADII[0], 1, 2))
    # width gives an L x L box at phi = 0.82
    assert p.width == pytest.approx(np.sqrt(np.sum(np.pi * p.radii ** 2) / 0.82))
    # no overlaps (periodic in x), nothing below the wall
    dx = p.positions[:, 0][:, None] - p.positions[:, 0][None, :]
    dx -= p.width * np.round(dx / p.width)
    dy = p.positions[:, 1][:, None] - p.positions[:, 1][None, :]
    gap = np.hypot(dx, dy) - (p.radii[:, None] + p.radii[None, :])
    np.fill_diagonal(gap, 1.0)
    assert gap.min() > 0
    assert np.all(p.positions[:, 1] - p.radii >= 0)
    # the top line is above every bulk disk, even in number, evenly spaced
    assert p.n_top >= 2 and p.n_top % 2 == 0
    assert p.positions[:, 1][p.top].min() > p.positions[:, 1][~p.top].max()
    assert np.allclose(np.diff(np.sort(p.positions[:, 0][p.top])), p.width / p.n_top)


def test_data_file_read_by_lammps(tmp_path):
    from remote_trigger.pywrap.bindings.engine import Engine

    p = generate(30, seed=2)
    path = tmp_path / "p.data"
    write_data(p, path)
    with Engine() as eng:
        eng.load_deck("in.relax", {"datafile": str(path)}, ("scene",))
        eng.command("run 0")
        st = eng.gather_state()
        assert eng.natoms == 30
        np.testing.assert_array_equal(st.top, p.top)
        np.testing.assert_array_equal(st.positions[:, 0], p.positions[:, 0])      # exact round trip
        np.testing.assert_array_equal(st.radii, p.radii)
        np.testing.assert_array_equal(st.masses, np.ones(30))  # set mass 1, not density
        assert int(eng.lmp.extract_global("natoms")) == 30
        # scatter takes N rows only (a flattened (N, 3) array wrote its first
        # 30 numbers into x; a short one was an IndexError)
        x = eng.gather("x")
        for bad in (x.ravel(), x[:-1], x.T, np.zeros((30, 4))):
            with pytest.raises(ValueError, match=r"scatter 'x': values must have shape "
                                                 r"\(30,\) or \(30, k\) with k <= 3, got "
                                                 r"shape " + re.escape(str(bad.shape))):
                eng.scatter("x", bad)
        np.testing.assert_array_equal(eng.gather("x"), x)          # nothing was written
        eng.scatter("x", x[:, :2] + 0.0)
        np.testing.assert_array_equal(eng.gather("x"), x)
        # a variable that does not exist, a fractional step count (run(1.5)
        # ran 1 step; equal() was float()'s TypeError of None)
        from remote_trigger.pywrap.bindings.engine import EngineError

        with pytest.raises(EngineError, match=r"equal\('nope'\): no equal-style variable"):
            eng.equal("nope")
        for bad in (1.5, "3", -1, True):
            with pytest.raises(ValueError, match=rf"nsteps must be an integer >= 0, got "
                                                 rf"nsteps = {re.escape(repr(bad))}"):
                eng.run(bad)
        assert eng.step() == 0
    with Engine() as eng:               # one section named alone (read letter by letter)
        eng.load_deck("in.relax", {"datafile": str(path)}, "scene")
        assert eng.natoms == 30


@pytest.mark.parametrize("kw, msg", [
    (dict(n=-4), "n = -4"), (dict(n=21), "n = 21"),
    (dict(n=20, radii=(-0.5, 0.7)), "radii"), (dict(n=20, radii=(0.7, 0.5)), "radii"),
    (dict(n=20, phi=1.5), "phi = 1.5"),
    # numpy's own errors named no seed
    (dict(n=20, seed=-1), "seed must be an integer >= 0, got seed = -1"),
    (dict(n=20, seed=1.5), "seed must be an integer >= 0, got seed = 1.5"),
    (dict(n=20, seed=None), "seed must be an integer >= 0, got seed = None")])
def test_bad_arguments(kw, msg):
    with pytest.raises(ValueError, match=msg.replace("(", r"\(")):
        generate(**kw)
