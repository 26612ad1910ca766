"""Bad input to the analysis library's public functions: a clear ValueError naming
the argument, before any result (found by using the Python API as a new user)."""
import numpy as np
import pytest

from remote_trigger.analysis.state.state import build_state
from remote_trigger.analysis.stability.eigen import sparse_eigen
from remote_trigger.analysis.stability.jacobian import (
    find_rattlers, remove_dofs, stiffness_matrix)

from .builders import random_packing


@pytest.fixture(scope="module")
def packing():
    return random_packing(seed=11)


def _rebuilt(st, **kw):
    return build_state(ids=st.ids, positions=st.positions, radii=st.radii, masses=st.masses,
                       box_lo=st.box_lo, box_hi=st.box_hi, params=st.params, wall_y=st.wall_y,
                       **kw)


def test_non_finite_loads_and_history_are_refused(packing):
    """A NaN load gave a NaN residual and a "certified real" verdict on it."""
    n = packing.n
    with pytest.raises(ValueError, match=r"external must be finite, got 4 non-finite"):
        _rebuilt(packing, external=np.where(np.arange(2 * n).reshape(n, 2) < 4, np.nan, 0.0))
    with pytest.raises(ValueError, match="wall_t must be finite"):
        _rebuilt(packing, wall_t=np.full(n, np.inf))
    with pytest.raises(ValueError, match="partners needs partner_xi"):
        _rebuilt(packing, partners=np.zeros((n, 2)))


def test_spheres_non_finite_history_is_refused():
    from remote_trigger.analysis.state.state import ContactParams
    from remote_trigger.analysis.state.state3d import build_state3d

    kw = dict(ids=[1, 2], positions=[[0, 0.5, 0], [0.99, 0.5, 0]], radii=[0.5, 0.5],
              masses=[1.0, 1.0], box_lo=[-5, 0, -5], box_hi=[5, 10, 5],
              params=ContactParams(2e5, 2e5 / 3.5, 1.0), periodic=(True, False, True),
              pairs=[[1, 2]])
    build_state3d(**kw, pair_t=[[0.0, 1e-4, 0.0]])
    with pytest.raises(ValueError, match="pair_t must be finite"):
        build_state3d(**kw, pair_t=[[np.nan, 0.0, 0.0]])


def test_sparse_eigen_arguments(packing):
    """A v0 of another length crashed the interpreter (ARPACK reads n entries);
    k = 2.5 was an internal ARPACK error; sigma = nan was called an eigenvalue."""
    rat = find_rattlers(packing)
    Kr, mr = remove_dofs(stiffness_matrix(packing), packing.mass_diagonal(), rat.keep_dofs)
    n = Kr.shape[0]
    with pytest.raises(ValueError, match=rf"v0 must be a finite array of shape \({n},\), "
                                         r"got shape \(3,\)"):
        sparse_eigen(Kr, mr, sigma=1.0, v0=np.ones(3))
    with pytest.raises(ValueError, match="k must be an integer"):
        sparse_eigen(Kr, mr, k=2.5, sigma=1.0)
    for bad in (np.nan, 1.0 + 2.0j):
        with pytest.raises(ValueError, match="sigma must be a finite real number"):
            sparse_eigen(Kr, mr, sigma=bad)
    assert sparse_eigen(Kr, mr, k=4, sigma=1.0, v0=np.ones(n)).eigenvalues.size == 4


def test_remove_dofs_checks_its_indices(packing):
    """Negative indices wrapped silently, repeats and floats were taken."""
    K, m = stiffness_matrix(packing), packing.mass_diagonal()
    n = K.shape[0]
    for bad, msg in (([-1, 0], r"distinct indices in \[0, "), ([0, 0], "1 repeated"),
                     ([0, n], r"values in \[0, "), ([0.0, 1.0], "integers")):
        with pytest.raises(ValueError, match=msg):
            remove_dofs(K, m, np.asarray(bad))
    with pytest.raises(ValueError, match="mass must have shape"):
        remove_dofs(K, m[:-1], [0, 1])
    with pytest.raises(ValueError, match="K must be square"):
        remove_dofs(K.toarray()[:, :-1], m, [0, 1])
    Kr, mr = remove_dofs(K, m, [2, 0])
    assert Kr.shape == (2, 2) and mr.tolist() == [m[2], m[0]]


@pytest.mark.parametrize("kw, msg", [
    (dict(rel_error=-1.0), r"rel_error must be in \[0, 0.01\)"),
    (dict(window=0.0), "window must be a finite number > 0"),
    (dict(slice_size=0), "slice_size must be an integer >= 2"),
    (dict(checkpoint_seconds=-1.0), "checkpoint_seconds must be a number >= 0"),
    (dict(checkpoint_seconds="a"), "checkpoint_seconds must be a number >= 0"),
])
def test_sliced_verdict_options(packing, kw, msg):
    """rel_error = -1 gave a verdict with a negative backward error, window = 0
    and a checkpoint interval without a folder were taken, slice_size = 0 was
    an ARPACK error."""
    from remote_trigger.analysis.stability.sliced import classify_sliced

    rat = find_rattlers(packing)
    Kr, mr = remove_dofs(stiffness_matrix(packing), packing.mass_diagonal(), rat.keep_dofs)
    with pytest.raises(ValueError, match=msg):
        classify_sliced(Kr, mr, **kw)


def test_analyze_dump_passes_the_readers_keywords(packing, tmp_path):
    """mirror_rtol and inertia_factor went to analyze (TypeError)."""
    from remote_trigger.analysis.stability.analyze import analyze_dump

    from .builders import write_dump

    path = write_dump(tmp_path / "eq.dump", packing)
    a = analyze_dump(str(path), mirror_rtol=1e-6, inertia_factor=0.5, decide=False)
    assert a.state.n == packing.n and a.eigen is not None


def test_disk_functions_name_spheres_and_bad_arguments(packing):
    """generalized_forces of spheres was an AttributeError; negative_modes with a
    negative threshold counted every eigenvalue; normal_form took d = 2."""
    from remote_trigger.analysis.stability.analyze import negative_modes
    from remote_trigger.analysis.stability.exceptional import normal_form
    from remote_trigger.analysis.stability.jacobian import displaced_state, generalized_forces

    for f in (generalized_forces, lambda s: displaced_state(s, np.zeros(3))):
        with pytest.raises(ValueError, match="expected a State of disks, got str"):
            f("not a state")
    dq = np.full(packing.ndof, np.nan)
    with pytest.raises(ValueError, match=rf"with {packing.ndof} non-finite value"):
        displaced_state(packing, dq)
    with pytest.raises(ValueError, match="rel_threshold must be a finite number >= 0"):
        negative_modes(packing, rel_threshold=-1.0)
    for d, eps in ((0.0, 0.1), (2.0, 0.1), (0.5, np.nan)):
        with pytest.raises(ValueError, match="normal_form needs 0 < d < 1"):
            normal_form(d, eps)
