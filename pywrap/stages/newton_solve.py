"""Newton's linear algebra: the stiffness K of a gathered state and solves of K dq = G.

Part of :mod:`remote_trigger.pywrap.stages`, used by the Newton polishing of
:mod:`remote_trigger.pywrap.stages.equilibrium`. K = -dG/dq is the analytic
Jacobian of ``remote_trigger.analysis.stability.jacobian`` (paper Appendix C;
spheres: ``jacobian3d``, 6 dofs per sphere),
dense up to :data:`DENSE_NEWTON_MAX` degrees of freedom and sparse above;
:func:`newton_solver` factorises it once (dense LU or SuperLU) and falls back
to least squares when K is singular (``lstsq``, or preconditioned LSMR for a
sparse K).
"""
import numpy as np

def analysis_state(state, k_n, k_t, mu, F_x, F_y, wall_y=0.0, top_layer="free"):
    """Convert an :class:`AtomState` into ``remote_trigger.analysis`` State (State3D
    for spheres, :func:`analysis_state3d`; ``top_layer`` 'rigid': its
    ``rigid_layer`` is the ``top`` layer)."""
    from remote_trigger.analysis.state.state import ContactParams, build_state

    if state.dim == 3:
        return analysis_state3d(state, k_n, k_t, mu, F_x, F_y, wall_y,
                                rigid_layer=state.top if top_layer == "rigid" else None)
    ext = np.zeros((state.n, 2))
    ext[state.top, 0] = F_x
    ext[state.top, 1] = -F_y
    return build_state(
        ids=state.ids, positions=state.positions, radii=state.radii, masses=state.masses,
        box_lo=state.box_lo, box_hi=state.box_hi,
        params=ContactParams(float(k_n), float(k_t), float(mu)), wall_y=wall_y,
        partners=state.partner, partner_xi=state.xi, wall_t=state.wall_xi, external=ext,
        velocities=state.velocities, omega=state.omega, types=state.types, F_x=F_x, F_y=F_y,
        require_contacts=False)


def analysis_state3d(state, k_n, k_t, mu, F_x, F_y, wall_y=0.0, rigid_layer=None):
    """The :class:`~remote_trigger.analysis.state.state3d.State3D` of a gathered state
    of spheres: contacts = overlapping pairs with the pair's t, the wall y =
    ``wall_y`` with the wall fix's t, loads (F_x, -F_y, 0) on ``top``; float64;
    ``rigid_layer`` (a mask, optional): the rigid top layer."""
    from remote_trigger.analysis.state.state import ContactParams
    from remote_trigger.analysis.state.state3d import state3d_from_history

    ext = np.zeros((state.n, 3))
    ext[state.top, 0] = F_x
    ext[state.top, 1] = -F_y
    return state3d_from_history(
        ids=state.ids, positions=state.positions, radii=state.radii, masses=state.masses,
        box_lo=state.box_lo, box_hi=state.box_hi,
        params=ContactParams(float(k_n), float(k_t), float(mu)), periodic=(True, False, True),
        partners=state.partner, partner_t=state.xi, wall_y=wall_y, wall_t=state.wall_xi,
        external=ext, F_x=F_x, F_y=F_y, rigid_layer=rigid_layer)


#: largest number of degrees of freedom (3N) that Newton solves with a dense
#: LU (N = 400 disks); above it K stays sparse and is factorised by SuperLU
#: (a dense K at N = 1e4 would need 7.2 GB)
DENSE_NEWTON_MAX = 1200


def stiffness_dense(state, k_n, k_t, mu, F_x, F_y):
    """Dense K = -dG/dq (3N x 3N; spheres 6N x 6N) of a gathered state (analysis Jacobian)."""
    K = stiffness(state, k_n, k_t, mu, F_x, F_y, sparse=True)
    return K.toarray() if hasattr(K, "toarray") else np.asarray(K)


def stiffness(state, k_n, k_t, mu, F_x, F_y, sparse=None):
    """K = -dG/dq (3N x 3N; spheres 6N x 6N) of a gathered state (analysis Jacobian).

    Parameters
    ----------
    state : AtomState
    k_n, k_t, mu, F_x, F_y : float
    sparse : bool, optional
        Return a ``scipy.sparse`` matrix; default: sparse above
        :data:`DENSE_NEWTON_MAX` degrees of freedom, dense ndarray below.

    Returns
    -------
    ndarray or scipy.sparse matrix, shape (3N, 3N) or (6N, 6N)
    """
    from remote_trigger.analysis.stability import jacobian, jacobian3d

    ndof = (6 if state.dim == 3 else 3) * state.n
    if sparse is None:
        sparse = ndof > DENSE_NEWTON_MAX
    ast = analysis_state(state, k_n, k_t, mu, F_x, F_y)
    K = (jacobian3d.stiffness_matrix3d if state.dim == 3 else jacobian.stiffness_matrix)(ast)
    if sparse:
        return K
    return K.toarray() if hasattr(K, "toarray") else np.asarray(K)


def newton_step(K, G):
    """Solve K dq = G for dq (shape (N, 3)), ignoring disks without contacts.

    ``newton_solver(K)(G)``: see :func:`newton_solver`.
    """
    return newton_solver(K)(G)


def newton_solver(K, tie=None):
    """Factorise K once for Newton steps K dq = G.

    Rows and columns that are entirely zero (contactless disks) are dropped;
    the rest is factorised by LU (dense, or SuperLU for a sparse K), or, if K
    is singular (a disk held by one contact has a zero rolling mode), solved
    by least squares (``lstsq``; sparse: :func:`_singular_sparse_solver`).

    Parameters
    ----------
    K : ndarray or scipy.sparse matrix, shape (3N, 3N)
    tie : sequence of array_like of int, optional
        Groups of ascending dofs that each move as one (the x, y and z of a
        rigid top layer, ``top_layer = 'rigid'``): K is solved as P^T K P
        (``analysis.stability.system.tie_dofs``), G enters as P^T G (a
        group's summed force; under ``fix aveforce`` each dof carries the
        mean) and dq = P dq' (one step for a group).

    Returns
    -------
    callable
        ``solve(G)``: G of shape (N, 3) (or 3N) -> dq of shape (N, 3); dq = 0
        on the dropped rows. The factorisation is reused by every call (the
        chord steps of :func:`polish`). Spheres: G of shape (N, 6) or 6N -> dq
        of shape (N, 6) (the block size follows G's).
    """
    if tie:
        return _tied_solver(K, [np.asarray(g, np.int64) for g in tie])
    if hasattr(K, "tocsc"):
        return _sparse_newton_solver(K)
    import scipy.linalg as sla

    live = np.any(K != 0.0, axis=1) | np.any(K != 0.0, axis=0)
    idx = np.nonzero(live)[0]
    Kr = K[np.ix_(idx, idx)]
    lu = None
    import warnings
    if idx.size:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sla.LinAlgWarning)
                lu = sla.lu_factor(Kr, check_finite=True)
            d = np.abs(np.diag(lu[0]))
            if not (np.all(np.isfinite(lu[0])) and np.min(d) > 1e-13 * np.max(d)):
                lu = None
        except (sla.LinAlgError, ValueError):
            lu = None

    def reduced(gr):
        sol = sla.lu_solve(lu, gr) if lu is not None else None
        if sol is None or not np.all(np.isfinite(sol)):
            sol = sla.lstsq(Kr, gr, cond=1e-14)[0]
        return sol

    return _on_live_dofs(idx, reduced)


def _tied_solver(K, groups):
    """:func:`newton_solver` on P^T K P for groups of dofs that each move as one."""
    from remote_trigger.analysis.stability.system import tie_dofs, tie_index

    n = K.shape[0]
    Kt, _ = tie_dofs(K, np.ones(n), groups)
    inner = newton_solver(Kt if hasattr(K, "tocsc") else Kt.toarray())
    col, _ = tie_index(n, groups)       # q = P q': the index in q' of every dof

    def solve(G):
        G = np.asarray(G, np.float64)
        g = G.reshape(-1)
        gt = np.zeros(Kt.shape[0])
        np.add.at(gt, col, g)           # P^T G
        dq = inner(gt[:, None]).reshape(-1)[col]
        return dq.reshape(-1, G.shape[1] if G.ndim == 2 else 3)

    return solve


def _on_live_dofs(idx, reduced):
    """``solve(G)``: dq = 0 but on the live dofs ``idx``, where ``reduced(G[idx])``;
    dq has G's shape ((N, 3) or (N, 6); a flat G gives (N, 3))."""
    def solve(G):
        G = np.asarray(G, np.float64)
        g = G.reshape(-1)
        dq = np.zeros_like(g)
        if idx.size:
            dq[idx] = reduced(g[idx])
        return dq.reshape(-1, G.shape[1] if G.ndim == 2 else 3)

    return solve


def _sparse_newton_solver(K):
    """:func:`newton_solver` for a sparse K: SuperLU, or preconditioned LSMR if K is
    singular (:func:`_singular_sparse_solver`)."""
    import warnings

    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    K = sp.csr_matrix(K)
    K.eliminate_zeros()
    live = (np.diff(K.indptr) > 0) | (np.bincount(K.indices, minlength=K.shape[1]) > 0)
    idx = np.nonzero(live)[0]
    Kr = K[idx][:, idx].tocsc()
    lu = None
    if idx.size:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                lu = spla.splu(Kr)
            d = np.abs(lu.U.diagonal())
            if not (np.all(np.isfinite(d)) and d.min() > 1e-13 * d.max()):
                lu = None
        except RuntimeError:            # exactly singular
            lu = None
    singular = []                       # its solver, built at the first need

    def reduced(gr):
        sol = lu.solve(gr) if lu is not None else None
        if sol is None or not np.all(np.isfinite(sol)):
            if not singular:
                singular.append(_singular_sparse_solver(Kr))
            sol = singular[0](gr)
        return sol

    return _on_live_dofs(idx, reduced)


#: relative residual at which the least-squares Newton step of a singular
#: sparse K stops (:func:`_singular_sparse_solver`)
LSMR_TOL = 1e-10


def _singular_sparse_solver(Kr):
    """Least-squares steps for a singular sparse K (zero modes of weakly held disks).

    LSMR on K M y = g, x = M y, with M = (K + delta I)^-1 (SuperLU, delta =
    1e-8 max |K_ii|) as right preconditioner: K M is the identity but for the
    near-null directions, which least squares leaves out (as the dense path's
    ``lstsq`` does), so a few tens of iterations suffice where unpreconditioned
    LSMR needed thousands (measured: 31 s at 4800 dof). The preconditioner is
    factorised once; returns ``solve(gr)``. LSMR stops at a relative
    residual of :data:`LSMR_TOL` (an inexact Newton step: far below the
    contraction of any Newton step, >= 1e-3; at 1e-15 it ran to its 200
    iterations, ~5 s per step at N = 9600, without a better step).
    """
    import warnings

    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = Kr.shape[0]
    delta = 1e-8 * float(np.max(np.abs(Kr.diagonal())))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lu = spla.splu((Kr + delta * sp.identity(n, format="csc")).tocsc())
    KrT = Kr.T.tocsr()
    op = spla.LinearOperator((n, n), matvec=lambda y: Kr @ lu.solve(y),
                             rmatvec=lambda z: lu.solve(KrT @ z, trans="T"), dtype=float)

    def solve(gr):
        y = spla.lsmr(op, gr, atol=LSMR_TOL, btol=LSMR_TOL, conlim=1e14, maxiter=200)[0]
        return lu.solve(y)

    return solve
