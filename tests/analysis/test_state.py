"""Reading equilibrium dumps: round trip, parameters, and clear errors on bad input."""
import json

import numpy as np
import pytest

from remote_trigger.analysis.state.dumpfile import read_dump
from remote_trigger.analysis.state.state import ContactParams, build_state

from .builders import random_packing, write_dump


@pytest.fixture(scope="module")
def packing():
    return random_packing(seed=11)


def test_round_trip_is_exact(tmp_path, packing):
    path = write_dump(tmp_path / "eq.dump", packing)
    st = read_dump(path)
    assert st.n == packing.n and st.n_contacts == packing.n_contacts
    # ids ascending; write_dump wrote the (shuffled) ids in the packing's order
    assert np.all(np.diff(st.ids) > 0)
    np.testing.assert_array_equal(st.ids, packing.ids)
    np.testing.assert_array_equal(st.positions, packing.positions)     # %.17g is exact
    np.testing.assert_array_equal(st.radii, packing.radii)
    np.testing.assert_array_equal(st.contact_i, packing.contact_i)
    np.testing.assert_array_equal(st.contact_j, packing.contact_j)
    np.testing.assert_array_equal(st.contact_xi, packing.contact_xi)
    np.testing.assert_array_equal(st.wall_index, packing.wall_index)
    np.testing.assert_array_equal(st.wall_xi, packing.wall_xi)
    assert st.params == packing.params and st.wall_y == 0.0
    np.testing.assert_allclose(st.inertia, 0.5 * st.masses * st.radii**2, rtol=0, atol=0)
    np.testing.assert_array_equal(st.mass_diagonal()[2::3], 0.5 * st.masses)
    assert st.periodic == (True, False)
    assert st.notes == {"unrecorded_contacts": 0, "stale_history": 0, "stale_wall_history": 0,
                        "touching_pairs": 0}
    # the contacts' ids satisfy ids[i] < ids[j]
    assert np.all(st.ids[st.contact_i] < st.ids[st.contact_j])


def test_dump_rows_in_any_order_and_last_frame(tmp_path, packing):
    def shuffle(header, rows):
        rng = np.random.default_rng(0)
        return header, [rows[k] for k in rng.permutation(len(rows))]

    path = tmp_path / "shuffled.dump"
    write_dump(path, packing, transform=shuffle)
    text = open(path).read()
    moved = packing.with_xi(packing.contact_xi * 0.5)
    p2 = tmp_path / "second.dump"
    write_dump(p2, moved, sidecar=False)
    with open(path, "a") as fh:                     # two snapshots in one file
        fh.write(open(p2).read())
    st_last = read_dump(path)
    st_first = read_dump(path, frame=0)
    np.testing.assert_array_equal(st_last.contact_xi, moved.contact_xi)
    np.testing.assert_array_equal(st_first.contact_xi, packing.contact_xi)
    assert text.count("ITEM: TIMESTEP") == 1


def test_explicit_parameters_override_sidecar(tmp_path, packing):
    path = write_dump(tmp_path / "eq.dump", packing)
    st = read_dump(path, mu=0.5, k_t=1000.0)
    assert st.params == ContactParams(packing.params.k_n, 1000.0, 0.5)
    nos = write_dump(tmp_path / "nos.dump", packing, sidecar=False)
    with pytest.raises(ValueError, match=r"\['k_n', 'k_t', 'mu', 'wall_y'\]"):
        read_dump(nos)
    st2 = read_dump(nos, k_n=2e5, k_t=1e4, mu=1.0, wall_y=0.0)
    assert st2.params.k_t == 1e4


@pytest.mark.parametrize("col", ["radius", "d2_mindlin_t[3]", "v_fext_y", "x",
                                 "d_mindlin_wall_t"])
def test_missing_column_is_named(tmp_path, packing, col):
    path = write_dump(tmp_path / "eq.dump", packing, drop=(col,))
    with pytest.raises(ValueError, match="missing"):
        read_dump(path)


def test_nan_is_reported_with_its_column(tmp_path, packing):
    def poison(header, rows):
        parts = rows[4].split()
        parts[4] = "nan"                            # column x
        rows[4] = " ".join(parts)
        return header, rows

    path = write_dump(tmp_path / "nan.dump", packing, transform=poison)
    with pytest.raises(ValueError, match=r"non-finite value nan in column 'x'"):
        read_dump(path)


def test_truncated_file(tmp_path, packing):
    path = write_dump(tmp_path / "eq.dump", packing)
    lines = open(path).read().splitlines()
    with open(path, "w") as fh:
        fh.write("\n".join(lines[:-3]) + "\n")
    with pytest.raises(ValueError, match="truncated file"):
        read_dump(path)
    with open(path, "w") as fh:                     # cut inside a line
        fh.write("\n".join(lines[:-1]) + "\n" + lines[-1][:20] + "\n")
    with pytest.raises(ValueError, match="expected .* values"):
        read_dump(path)
    with open(path, "w") as fh:
        fh.write("\n".join(lines[:3]) + "\n")
    with pytest.raises(ValueError, match="truncated file"):
        read_dump(path)
    open(path, "w").close()
    with pytest.raises(ValueError, match="no snapshot"):
        read_dump(path)


def test_missing_file():
    with pytest.raises(FileNotFoundError, match="nowhere.dump"):
        read_dump("/nonexistent/nowhere.dump")


def test_overlapping_centres(tmp_path, packing):
    pos = packing.positions.copy()
    pos[3] = pos[7] + [1e-3, 0.0]

    def move(header, rows):
        parts = rows[3].split()
        parts[4], parts[5] = "%.17g" % pos[3, 0], "%.17g" % pos[3, 1]
        rows[3] = " ".join(parts)
        return header, rows

    path = write_dump(tmp_path / "eq.dump", packing, transform=move)
    with pytest.raises(ValueError, match=r"overlapping centres: atom ids \d+ and \d+ are"):
        read_dump(path)


def test_no_contacts(tmp_path):
    pos = np.array([[1.0, 2.0], [4.0, 2.0], [7.0, 5.0]])
    st = build_state(ids=[1, 2, 3], positions=pos, radii=[0.5, 0.7, 0.5], masses=[1, 1, 1],
                     box_lo=[0, -1], box_hi=[10, 10], params=ContactParams(2e5, 5e4, 1.0),
                     wall_y=0.0, require_contacts=False)
    path = write_dump(tmp_path / "free.dump", st)
    with pytest.raises(ValueError, match="no contacts"):
        read_dump(path)


def test_mirror_mismatch_and_one_sided_contact(tmp_path, packing):
    path = write_dump(tmp_path / "eq.dump", packing)
    lines = open(path).read().splitlines()
    cols = lines[8].split()[2:]
    c_xi = cols.index("d2_mindlin_t[1]")
    c_p = cols.index("i2_mindlin_partner[1]")
    row = next(k for k in range(9, len(lines)) if int(lines[k].split()[c_p]) > 0)
    parts = lines[row].split()
    parts[c_xi] = "%.17g" % (float(parts[c_xi]) + 1e-6)
    bad = lines.copy()
    bad[row] = " ".join(parts)
    with open(path, "w") as fh:
        fh.write("\n".join(bad) + "\n")
    with pytest.raises(ValueError, match="two sides of the history disagree"):
        read_dump(path)
    parts = lines[row].split()
    parts[c_p] = "0"                               # the partner entry of one side gone
    for k in range(1, 8):                          # keep slots packed
        parts[c_p + k - 1] = lines[row].split()[c_p + k]
    parts[c_p + 7] = "0"
    bad = lines.copy()
    bad[row] = " ".join(parts)
    with open(path, "w") as fh:
        fh.write("\n".join(bad) + "\n")
    with pytest.raises(ValueError, match="not in that of atom id"):
        read_dump(path)


def test_unknown_partner_and_bad_sidecar(tmp_path, packing):
    path = write_dump(tmp_path / "eq.dump", packing)
    lines = open(path).read().splitlines()
    cols = lines[8].split()[2:]
    c_p = cols.index("i2_mindlin_partner[8]")
    parts = lines[9].split()
    parts[c_p] = "99999"
    lines[9] = " ".join(parts)
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match="partner id 99999"):
        read_dump(path)
    path2 = write_dump(tmp_path / "ok.dump", packing)
    json.dump({"k_n": "big", "k_t": 1.0, "mu": 1.0, "wall_y": 0.0}, open(str(path2) + ".json",
                                                                          "w"))
    with pytest.raises(ValueError, match="k_n must be a number"):
        read_dump(path2)
    with pytest.raises(ValueError, match="mu must be >= 0"):
        read_dump(path, mu=-1.0)


def test_history_geometry_disagreement_is_repaired_with_warning(tmp_path, packing):
    """An overlapping pair with no history gets xi = 0; a stale entry is dropped."""
    with pytest.warns(UserWarning, match="overlapping pairs without history"):
        st = build_state(ids=packing.ids, positions=packing.positions, radii=packing.radii,
                         masses=packing.masses, box_lo=packing.box_lo, box_hi=packing.box_hi,
                         params=packing.params, wall_y=0.0,
                         partners=np.zeros((packing.n, 8), np.int64),
                         partner_xi=np.zeros((packing.n, 8)))
    assert st.notes["unrecorded_contacts"] == packing.n_contacts
    np.testing.assert_array_equal(st.contact_xi, 0.0)
    path = write_dump(tmp_path / "eq.dump", packing)
    moved = packing.positions.copy()
    k = packing.contact_i[0]
    moved[k, 1] = moved[:, 1].max() + 3.0          # lift one disk out of its contacts
    lines = open(path).read().splitlines()
    row = 9 + int(np.nonzero(np.array([int(l.split()[0]) for l in lines[9:]])
                             == packing.ids[k])[0][0])
    parts = lines[row].split()
    parts[5] = "%.17g" % moved[k, 1]
    lines[row] = " ".join(parts)
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    with pytest.warns(UserWarning, match="history and geometry disagree"):
        st2 = read_dump(path)
    assert st2.notes["stale_history"] >= 1


@pytest.mark.parametrize("delta, history, contact, touching, warned", [
    (-1e-15, True, False, 1, False), (1e-15, True, True, 0, False),
    (1e-15, False, True, 1, False), (-1e-9, True, False, 0, True),
    (1e-9, False, True, 0, True), (1e-9, True, True, 0, False)])
def test_touching_band_across_the_periodic_boundary(delta, history, contact, touching,
                                                     warned):
    """Two disks overlapping by delta across the periodic boundary. Inside the
    touching band (a few ulps of the coordinates) the pair style lists the
    pair as its history says, with xi = 0: history without overlap, or
    overlap without history, is then neither stale nor unrecorded (no
    warning); outside the band they are (a gap of 1e-9 with history, an
    overlap of 1e-9 without). A contact is an overlap, delta > 0, as always."""
    import warnings

    from remote_trigger.analysis.state.contacts import touch_band

    W = 47.62432831515532
    pos = np.array([[W - 0.3, 5.0], [0.7 - delta, 5.0]])
    assert touch_band([0, -1], [W, 10], 1.0) == pytest.approx(64 * 2.22e-16 * (2 * W + 1),
                                                              rel=1e-3)
    part = [[2, 0], [1, 0]] if history else [[0, 0], [0, 0]]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        st = build_state(ids=[1, 2], positions=pos, radii=[0.5, 0.5], masses=[1, 1],
                         box_lo=[0, -1], box_hi=[W, 10], params=ContactParams(2e5, 5e4, 1.0),
                         wall_y=0.0, partners=part, partner_xi=[[0, 0], [0, 0]],
                         wall_t=[0, 0], require_contacts=False)
    assert (st.contact_i.size == 1) == contact
    assert st.notes["touching_pairs"] == touching
    assert (len(w) > 0) == warned, [str(x.message) for x in w]


def test_mirror_check_scale_is_the_snapshots_largest_t_star():
    """Spheres: each side advances its own t, so the two sides of a barely
    touching contact (t* ~ 1e-6) may differ by round-off of the history's
    scale (1.5e-15, as measured in an ensemble run) -- accepted; a mismatch
    of 1e-10 (above 1e-9 x the largest t* ~ 3.5e-3) is still refused."""
    from remote_trigger.analysis.state.state3d import state3d_from_history

    params = ContactParams(2e5, 2e5 * 2 / 7, 1.0)
    d_small, d_big = 1.7e-7, 1e-3               # overlaps of the two contacts
    pos = np.array([[5.0, 5.0, 5.0], [5.0, 6.0 - d_small, 5.0], [6.0 - d_big, 5.0, 5.0]])
    t_small = np.array([5.696931578993402e-07, 0.0, 3.78e-08])
    t_big = np.array([0.0, 1e-4, 2e-4])

    def state(mismatch):
        partners = np.array([[2, 3], [1, 0], [1, 0]])
        t = np.zeros((3, 2, 3))
        t[0, 0], t[1, 0] = t_small, -(t_small + mismatch)
        t[0, 1], t[2, 0] = t_big, -t_big
        return state3d_from_history(ids=[1, 2, 3], positions=pos, radii=[0.5] * 3,
                                    masses=[1.0] * 3, box_lo=[0.0] * 3, box_hi=[10.0] * 3,
                                    params=params, periodic=(False,) * 3, partners=partners,
                                    partner_t=t, wall_y=None)

    assert params.mu * params.k_n * d_small / params.k_t < 1e-6 < np.linalg.norm(t_small) * 2
    st = state(np.array([1.5e-15, 1e-16, 2e-16]))
    assert st.n_contacts == 2
    with pytest.raises(ValueError, match="two sides of the history disagree"):
        state(np.array([1e-10, 0.0, 0.0]))
