"""Synthetic packings for the analyzer tests (no LAMMPS needed)."""
import numpy as np

from remote_trigger.analysis.state.state import ContactParams, build_state

KN = 2.0e5
KT = 2.0 * KN / 7.0
MU = 1.0


def random_packing(seed, nx=6, ny=5, mu=MU, kt=KT, kn=KN, cap_fraction=0.3, wall=True,
                   xi_scale=1.0):
    """Disks on a jittered, slightly compressed triangular lattice, periodic in x.

    Radii are 0.5 or 0.7 at random; the bottom row overlaps the wall at y = 0.
    Tangential displacements are random with u = |xi|/t* drawn from a mix of
    cases: 0, uniform in (0, 1), exactly 1 (at the cap), 1 - 1e-9 (just below)
    and 1.3 (trial value beyond the cap). Returns a State.
    """
    rng = np.random.default_rng(seed)
    n = nx * ny
    radii = np.where(rng.random(n) < 0.5, 0.5, 0.7)
    a = 1.15                                        # lattice spacing < typical R_i + R_j
    L = nx * a
    pos = np.empty((n, 2))
    for k in range(n):
        r, c = divmod(k, nx)
        pos[k] = ((c + 0.5 * (r % 2)) * a, 0.45 + r * a * 0.87)
    pos += rng.uniform(-0.04, 0.04, size=pos.shape)
    pos[:, 0] %= L
    ids = rng.permutation(np.arange(1, n + 1) * 3)  # non-contiguous, unsorted ids
    params = ContactParams(kn, kt, mu)
    st = build_state(ids=ids, positions=pos, radii=radii, masses=np.ones(n),
                     box_lo=[0.0, -1.0], box_hi=[L, ny * a + 2.0], params=params,
                     wall_y=0.0 if wall else None, partners=None, require_contacts=True)

    def draw(delta):
        ts = mu * kn * delta / kt if kt > 0 else np.ones_like(delta)
        kind = rng.integers(0, 5, size=delta.size)
        u = np.where(kind == 0, 0.0, rng.uniform(0.05, 0.95, size=delta.size))
        capmix = rng.random(delta.size) < cap_fraction
        u = np.where(capmix & (kind == 2), 1.0, u)
        u = np.where(capmix & (kind == 3), 1.0 - 1e-9, u)
        u = np.where(capmix & (kind == 4), 1.3, u)
        return xi_scale * u * ts * rng.choice([-1.0, 1.0], size=delta.size)

    d = st.separation(st.contact_i, st.contact_j)
    delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.hypot(d[:, 0], d[:, 1])
    return st.with_xi(draw(delta), draw(st.wall_delta))


COLUMNS = ("id type radius mass x y vx vy omegaz fx fy tqz v_fext_x v_fext_y".split())


def history_arrays(state, slots=8):
    """(partner ids, xi) per disk, shape (N, slots), both sides of every contact."""
    n = state.n
    part = np.zeros((n, slots), np.int64)
    xi = np.zeros((n, slots))
    lists = [[] for _ in range(n)]
    for a, b, x in zip(state.contact_i, state.contact_j, state.contact_xi):
        lists[a].append((state.ids[b], x))
        lists[b].append((state.ids[a], x))
    for k, lst in enumerate(lists):
        lst.sort()
        if len(lst) > slots:
            raise ValueError("too many contacts for the slots")
        for s, (pid, x) in enumerate(lst):
            part[k, s] = pid
            xi[k, s] = x
    wall = np.zeros(n)
    wall[state.wall_index] = state.wall_xi
    return part, xi, wall


def write_dump(path, state, slots=8, sidecar=True, drop=(), forces=None, step=100,
               transform=None):
    """Write ``state`` as a text dump in the format of docs/conventions.md section 3.

    ``drop``: column names to leave out; ``transform(header, rows)`` may edit
    the text before writing (for corruption tests). Returns the path.
    """
    import json

    from remote_trigger.analysis.stability.jacobian import generalized_forces

    part, xi, wall = history_arrays(state, slots)
    if forces is None:
        G = generalized_forces(state, external=False).reshape(-1, 3)
        forces = np.column_stack([G[:, 0], G[:, 1], G[:, 2] * state.radii])
    cols = list(COLUMNS) + [f"i2_mindlin_partner[{k + 1}]" for k in range(slots)] + \
        [f"d2_mindlin_t[{k + 1}]" for k in range(slots)] + ["d_mindlin_wall_t"]
    n = state.n
    vals = {
        "id": state.ids, "type": np.where(state.radii < 0.6, 1, 2), "radius": state.radii,
        "mass": state.masses, "x": state.positions[:, 0], "y": state.positions[:, 1],
        "vx": np.zeros(n), "vy": np.zeros(n), "omegaz": np.zeros(n),
        "fx": forces[:, 0], "fy": forces[:, 1], "tqz": forces[:, 2],
        "v_fext_x": state.external[:, 0], "v_fext_y": state.external[:, 1],
    }
    for k in range(slots):
        vals[f"i2_mindlin_partner[{k + 1}]"] = part[:, k]
        vals[f"d2_mindlin_t[{k + 1}]"] = xi[:, k]
    vals["d_mindlin_wall_t"] = wall
    cols = [c for c in cols if c not in drop]

    def fmt(v):
        if isinstance(v, (int, np.integer)):
            return str(int(v))
        return "%.17g" % v

    rows = [" ".join(fmt(vals[c][k]) for c in cols) for k in range(n)]
    header = ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ATOMS", str(n),
              "ITEM: BOX BOUNDS pp ff pp",
              "%.17g %.17g" % (state.box_lo[0], state.box_hi[0]),
              "%.17g %.17g" % (state.box_lo[1], state.box_hi[1]),
              "-0.5 0.5", "ITEM: ATOMS " + " ".join(cols)]
    if transform is not None:
        header, rows = transform(header, rows)
    with open(path, "w") as fh:
        fh.write("\n".join(header + rows) + "\n")
    if sidecar:
        p = state.params
        with open(str(path) + ".json", "w") as fh:
            json.dump({"k_n": p.k_n, "k_t": p.k_t, "mu": p.mu, "wall_y": state.wall_y,
                       "F_x": 0.0, "F_y": 3.0, "dt": 1e-3}, fh)
    return path
