"""The winding count of eigenvalues in a box (analysis.stability.sliced.winding) on
matrix functions whose zeros are known: T(z) = V diag(lambda_i - z) V^-1 and a
non-normal one, with and without an error bound."""
import numpy as np
import pytest

from remote_trigger.analysis.stability.enclosure import sigma_min_lower
from remote_trigger.analysis.stability.sliced.winding import box_zero_count


def _diag_schur(lam, V=None, err=0.0):
    lam = np.asarray(lam, complex)
    m = lam.size
    V = np.eye(m) if V is None else V
    Vi = np.linalg.inv(V)

    def schur(z, deriv=True):
        T = V @ np.diag(lam - z) @ Vi
        return T, err, -np.eye(m), 0.0
    return schur


LAM = [1.0, 2.0, 3.0 + 0.5j, 3.0 - 0.5j, 3.1, 5.0 + 0.02j, 5.0 - 0.02j]


@pytest.mark.parametrize("box, want", [
    ((2.5, 3.5, 0.25, 0.75), 1),          # the pair's upper member
    ((2.5, 3.5, -0.75, 0.75), 3),         # both members and the real 3.1
    ((0.5, 2.5, 0.1, 1.0), 0),            # above two real eigenvalues: none
    ((4.99, 5.01, 0.01, 0.03), 1),        # a pair close to the axis
    ((0.0, 6.0, -1.0, 1.0), 7),
])
def test_count_of_known_zeros(box, want):
    rng = np.random.default_rng(0)
    V = np.eye(7) + 0.3 * rng.standard_normal((7, 7))      # non-normal
    cnt, why, margin = box_zero_count(_diag_schur(LAM, V), *box, curv=0.0)
    assert cnt == want, why
    assert margin > 1


def test_an_error_bound_larger_than_the_distance_to_a_zero_is_no_answer():
    """err(z) bounds ||T_F - T_c||: a zero within err of the box's edge may lie
    on either side, so no count is given (never a wrong one)."""
    cnt, why, _ = box_zero_count(_diag_schur(LAM, err=0.3), 2.5, 3.5, 0.25, 0.75, curv=0.0)
    assert cnt is None and why.startswith("winding count:")
    cnt, _, _ = box_zero_count(_diag_schur(LAM, err=1e-3), 2.5, 3.5, 0.25, 0.75, curv=0.0)
    assert cnt == 1


def test_sigma_min_lower_of_a_complex_matrix():
    """Both bounds of ||T^-1||_2 (the winding uses the spectral one) are below
    sigma_min and not far below it, for complex and real matrices (neither
    is always the tighter); another norm is refused."""
    rng = np.random.default_rng(1)
    for T in (rng.standard_normal((5, 5)) + 1j * rng.standard_normal((5, 5)),
              rng.standard_normal((7, 7))):
        s = np.linalg.svd(T, compute_uv=False)[-1]
        for norm in ("spectral", "frobenius"):
            lo = sigma_min_lower(T, norm=norm)
            assert 0.5 * s <= lo <= s                  # rigorous, and not far below
    with pytest.raises(ValueError, match="norm must be 'frobenius' or 'spectral', got norm = 'max'"):
        sigma_min_lower(T, norm="max")
