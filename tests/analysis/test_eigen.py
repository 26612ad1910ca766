"""Eigenvalues of M^-1 K: dense vs ARPACK shift-invert, frequencies, pipeline, CLI."""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.analyze import analyze, analyze_dump
from remote_trigger.analysis.stability.eigen import (
    dense_eigen, dynamical_matrix, eigenvalues, frequencies, growth_rate, sparse_eigen)
from remote_trigger.analysis.stability.jacobian import find_rattlers, remove_dofs, stiffness_matrix
from remote_trigger.pywrap.cli import main

from .builders import random_packing, write_dump
from remote_trigger.analysis.stability.decision import Decision


@pytest.fixture(scope="module")
def system():
    st = random_packing(21, nx=10, ny=8, xi_scale=0.3, cap_fraction=0.2)
    K = stiffness_matrix(st)
    rat = find_rattlers(st)
    Kr, mr = remove_dofs(K, st.mass_diagonal(), rat.keep_dofs)
    return st, Kr, mr


def test_dense_eigenpairs_satisfy_definitions(system):
    _, Kr, mr = system
    res = dense_eigen(Kr, mr)
    A = dynamical_matrix(Kr, mr).toarray()
    lam, vr, vl = res.eigenvalues, res.right, res.left
    scale = np.abs(lam).max()
    assert np.abs(A @ vr - vr * lam).max() <= 1e-10 * scale
    assert np.abs(vl.conj().T @ A - lam[:, None] * vl.conj().T).max() <= 1e-10 * scale
    assert np.all(res.kappa >= 1.0 - 1e-12)
    assert np.all(np.diff(lam.real) >= 0)
    # generalized problem K v = lambda M v
    assert np.abs(Kr @ vr - (mr[:, None] * vr) * lam).max() <= 1e-10 * scale


def test_sparse_shift_invert_matches_dense(system):
    _, Kr, mr = system
    dense = dense_eigen(Kr, mr, vectors=False).eigenvalues
    sigma = float(np.median(dense.real))
    sparse = sparse_eigen(Kr, mr, k=10, sigma=sigma, left=True)
    nearest = dense[np.argsort(np.abs(dense - sigma))[:10]]
    for lam in sparse.eigenvalues:
        assert np.min(np.abs(nearest - lam)) <= 1e-9 * np.abs(dense).max()
    assert sparse.method == "arpack-shift-invert" and sparse.sigma == sigma
    d = dense_eigen(Kr, mr)
    for lam, kap in zip(sparse.eigenvalues, sparse.kappa):
        j = np.argmin(np.abs(d.eigenvalues - lam))
        assert kap == pytest.approx(d.kappa[j], rel=1e-5)
    auto = eigenvalues(Kr, mr, method="sparse", k=6, sigma=sigma)
    assert auto.eigenvalues.size == 6


def test_frequencies_and_growth_rate():
    lam = np.array([4.0, -9.0, 3.0 + 4.0j, 3.0 - 4.0j])
    w = frequencies(lam)
    np.testing.assert_allclose(w[:, 0] ** 2, lam)
    np.testing.assert_allclose(w[:, 1], -w[:, 0])
    # sqrt(3 + 4i) = 2 + i: e^{i omega t} with omega = +-(2 + i) grows at rate 1;
    # lambda = -9 is a static instability, rate 3
    assert growth_rate(lam[[0, 2, 3]]) == pytest.approx(1.0)
    assert growth_rate(lam) == pytest.approx(3.0)
    assert growth_rate(np.array([1.0, 2.0])) == 0.0


def test_bad_masses_and_shapes(system):
    _, Kr, mr = system
    with pytest.raises(ValueError, match="mass has"):
        dynamical_matrix(Kr, mr[:-1])
    bad = mr.copy()
    bad[4] = 0.0
    with pytest.raises(ValueError, match="entry 4 is 0.0"):
        dynamical_matrix(Kr, bad)
    with pytest.raises(ValueError, match="square"):
        dynamical_matrix(sp.csr_matrix((3, 4)), np.ones(3))
    with pytest.raises(ValueError, match="k must"):
        sparse_eigen(Kr, mr, k=Kr.shape[0])
    with pytest.raises(ValueError, match="method"):
        eigenvalues(Kr, mr, method="magic")


def test_analyze_pipeline_dense_and_sparse_agree(system):
    st, _, _ = system
    res = analyze(st)
    assert res.eigen.method == "dense" and res.decision is not None
    lam = res.eigenvalues
    sigma = float(np.quantile(lam.real, 0.3))
    res_s = analyze(st, method="sparse", k=8, sigma=sigma)
    for v in res_s.eigenvalues:
        assert np.min(np.abs(lam - v)) <= 1e-9 * np.abs(lam).max()
    assert res_s.decision.eigenvalues.size == 8
    # the dense decision agrees with the pairs LAPACK found in this (non-EP) case
    n_cx = np.sum(lam.imag > 0)
    assert res.decision.decision is Decision.certified(n_cx > 0)


def test_cli_writes_documented_arrays(tmp_path, system, capsys):
    st, _, _ = system
    path = write_dump(tmp_path / "eq.dump", st)
    out = tmp_path / "K.npz"
    # a random packing is not an equilibrium: analysed only with --allow-residual
    assert main(["jacobian", str(path), "-o", str(out), "--allow-residual"]) == 0
    text = capsys.readouterr().out
    assert "rattlers removed" in text and "complex pair" in text
    d = np.load(out)
    K = sp.csr_matrix((d["K_data"], d["K_indices"], d["K_indptr"]), shape=tuple(d["K_shape"]))
    ref = analyze_dump(str(path), allow_residual=True)
    assert (K != ref.K).nnz == 0
    np.testing.assert_array_equal(d["mass"], st.mass_diagonal())
    np.testing.assert_array_equal(d["ids"], np.repeat(st.ids, 3))
    np.testing.assert_array_equal(d["rattlers"], ref.rattlers.ids)
    np.testing.assert_allclose(d["eigenvalues"], ref.eigenvalues, rtol=1e-12,
                               atol=1e-12 * np.abs(ref.eigenvalues).max())
    assert d["eigenvalues"].size == 3 * (st.n - ref.rattlers.ids.size)
    assert int(d["complex_pair"]) in (0, 1)


def test_cli_bad_input_exit_code(tmp_path, capsys):
    assert main(["jacobian", str(tmp_path / "missing.dump"), "-o",
                 str(tmp_path / "x.npz")]) == 2
    assert "dump file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.dump"
    bad.write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\n")
    assert main(["jacobian", str(bad), "-o", str(tmp_path / "x.npz")]) == 2
    assert "truncated" in capsys.readouterr().err


def test_band_scan_finds_dense_eigenvalues(system):
    from remote_trigger.analysis.stability.eigen import band_scan, default_shift

    _, Kr, mr = system
    dense = dense_eigen(Kr, mr, vectors=False).eigenvalues
    scan = band_scan(Kr, mr, windows=3, k=8)
    assert scan.method == "arpack-band-scan" and 12 <= scan.eigenvalues.size <= 24
    for lam in scan.eigenvalues:
        assert np.min(np.abs(dense - lam)) <= 1e-9 * np.abs(dense).max()
    dmax = np.max(Kr.diagonal() / mr)
    assert default_shift(Kr, mr) == pytest.approx(0.25 * dmax)
    with pytest.raises(ValueError, match="lo < hi"):
        band_scan(Kr, mr, lo=5.0, hi=1.0)


def test_cli_sparse_path(tmp_path, system):
    st, _, _ = system
    path = write_dump(tmp_path / "eq.dump", st)
    out = tmp_path / "Ks.npz"
    assert main(["jacobian", str(path), "-o", str(out), "--method", "sparse", "--k", "8",
                 "--allow-residual"]) == 0
    d = np.load(out)
    assert d["eigenvalues"].size == 8 and str(d["method"]) == "arpack-shift-invert"
    dense = analyze_dump(str(path), allow_residual=True).eigenvalues
    for lam in d["eigenvalues"]:
        assert np.min(np.abs(dense - lam)) <= 1e-9 * np.abs(dense).max()


@pytest.mark.parametrize("opts, needle", [
    (["--sigma", "nan"], "sigma must be a finite number, got sigma = nan"),
    (["--sigma", "inf"], "sigma must be a finite number, got sigma = inf"),
    (["--k", "0"], "k must be an integer >= 1, got k = 0"),
    (["--k", "-3"], "k must be an integer >= 1, got k = -3"),
])
def test_cli_sparse_path_bad_options(tmp_path, system, capsys, opts, needle):
    """--sigma nan was blamed on an eigenvalue, inf was an internal ARPACK
    error, and k <= 0 was taken as 2: each is now a one-line error, status 2."""
    st, _, _ = system
    path = write_dump(tmp_path / "eq.dump", st)
    out = tmp_path / "Ks.npz"
    assert main(["jacobian", str(path), "-o", str(out), "--method", "sparse",
                 "--allow-residual", *opts]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln]
    assert len(err) == 1 and needle in err[0], err
    assert not out.exists()
