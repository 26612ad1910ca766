"""Certified decisions started from a previous decision's basis (classify_spectrum(basis=)).

Along a path of matrices through an exceptional point, each decision starts
from the previous one's verified basis, as a ramp does. It must give the same
certified answer as the decision from dgeev (both are rigorous: they cannot
disagree), take the basis path far from the exceptional point, and fall back
to dgeev where the basis does not fit.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.decision import SpectrumBasis
from remote_trigger.analysis.stability.exceptional import classify_spectrum

from .arb_oracle import full_spectrum
from .test_exceptional import embedded
from remote_trigger.analysis.stability.decision import Decision


def _path(eps_values, n=40, seed=2):
    return [embedded(0.5, eps, n=n, seed=seed) for eps in eps_values]


def test_path_through_an_exceptional_point_same_answers_as_dgeev():
    eps = np.concatenate([np.geomspace(0.3, 1e-7, 25), -np.geomspace(1e-7, 0.3, 10)])
    basis, starts = None, []
    for e, A in zip(eps, _path(eps)):
        warm = classify_spectrum(A, basis=basis)
        cold = classify_spectrum(A)
        assert cold.start == "dgeev" and cold.decision is Decision.certified(e < 0)
        assert warm.decision is cold.decision, (e, warm.reason)
        assert warm.confidence > 1
        starts.append(warm.start)
        if warm.start == "basis":
            assert warm.timing["eigen"] == 0.0
            # eigenvalues: the verified basis's block centres, near dgeev's
            np.testing.assert_allclose(np.sort_complex(warm.eigenvalues),
                                       np.sort_complex(cold.eigenvalues), rtol=0,
                                       atol=1e-10 * np.abs(cold.eigenvalues).max())
        basis = warm.basis
    # the path is taken far from the exceptional point (and is not the only one)
    assert starts[0] == "dgeev" and starts.count("basis") >= len(eps) // 2, starts
    assert "dgeev" in starts[1:], starts


@pytest.mark.parametrize("e", [1e-3, -1e-3])
def test_basis_answer_agrees_with_arb(e):
    """Independent check: Arb's enclosure of the whole spectrum of the same matrix."""
    A0, A = _path([2 * e, e])
    dec = classify_spectrum(A, basis=classify_spectrum(A0).basis)
    assert dec.start == "basis"
    assert full_spectrum(A) == ("complex" if dec.decision is Decision.COMPLEX else "real")


def test_complex_side_decided_from_the_real_sides_basis(monkeypatch):
    """Across the exceptional point: the basis of a real spectrum (the two
    coalescing modes as two real units) decides the complex matrix beyond it
    by merging the two units into a pair (a bisection point above F_x^c
    started from its lower end); Arb checks the answer. Without the merge
    the correction diverges and the decision starts from dgeev."""
    import remote_trigger.analysis.stability.basis as basis_module

    A0, A = _path([1e-2, -1e-3])
    basis = classify_spectrum(A0).basis
    assert not basis.pairs.any()
    dec = classify_spectrum(A, basis=basis)
    assert dec.start == "basis" and dec.decision is Decision.COMPLEX and dec.confidence > 1
    assert dec.basis.pairs.sum() == 1
    assert full_spectrum(A) == "complex"
    monkeypatch.setattr(basis_module, "_BASIS_MERGE", np.inf)
    assert classify_spectrum(A, basis=basis).start == "dgeev"


def test_basis_that_does_not_fit_falls_back_to_dgeev():
    A, B = _path([1e-2, -1e-2])
    other = classify_spectrum(embedded(0.5, 1e-2, n=30, seed=2)).basis     # n = 30, not 40
    assert classify_spectrum(A, basis=other).start == "dgeev"
    # a basis of an unrelated matrix of the same size: the correction diverges
    rng = np.random.default_rng(5)
    unrelated = classify_spectrum(rng.normal(size=(40, 40))).basis
    res = classify_spectrum(B, basis=unrelated)
    assert res.start == "dgeev" and res.decision is Decision.COMPLEX


def test_basis_save_and_load(tmp_path):
    A = _path([1e-2])[0]
    basis = classify_spectrum(A).basis
    path = tmp_path / "b.npz"
    basis.save(str(path))
    back = SpectrumBasis.load(str(path))
    np.testing.assert_array_equal(back.X, basis.X)
    np.testing.assert_array_equal(back.R, basis.R)       # recomputed as the verification did
    assert back.blocks == basis.blocks
    np.testing.assert_array_equal(back.pairs, basis.pairs)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a basis")
    with pytest.raises(ValueError, match="bad.npz"):
        SpectrumBasis.load(str(bad))
