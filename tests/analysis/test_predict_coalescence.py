"""analysis.eigtrack.predict_coalescence: gap^2 extrapolation to an exceptional point."""
import math

import numpy as np
import pytest

from remote_trigger.analysis.stability.eigtrack import predict_coalescence


def _spectrum(F, F_c, p=0.5, c=3.0, centre=2.0):
    """A real pair whose gap closes like c (F_c - F)^p, and two bystanders."""
    g = c * (F_c - F) ** p
    return np.array([centre - g / 2, centre + g / 2, 0.1, 9.0 + F], complex)


@pytest.mark.parametrize("F0,F1", [(0.0, 0.01), (0.3, 0.35), (0.49, 0.499)])
def test_square_root_law_is_extrapolated_exactly(F0, F1):
    F_c = 0.5
    d, i = predict_coalescence(F0, _spectrum(F0, F_c), F1, _spectrum(F1, F_c))
    assert d == pytest.approx(F_c - F1, rel=1e-10)
    assert i == 1          # sorted: 0.1, lower, upper, 9 + F


@pytest.mark.parametrize("p", [1.0, 2.0])
def test_faster_closing_gap_is_underestimated(p):
    F_c, F0, F1 = 0.5, 0.2, 0.21
    d, _ = predict_coalescence(F0, _spectrum(F0, F_c, p), F1, _spectrum(F1, F_c, p))
    assert 0 < d < F_c - F1
    assert d == pytest.approx((F_c - F1) / (2 * p), rel=0.1)


def test_opening_gaps_predict_nothing():
    lam0 = np.array([1.0, 2.0, 4.0])
    d, i = predict_coalescence(0.0, lam0, 0.1, lam0 * [1.0, 1.1, 1.5])
    assert d == math.inf and i == -1


def test_a_complex_value_means_zero_distance():
    lam0 = np.array([1.0, 1.2, 3.0], complex)
    lam1 = np.array([1.1 + 0.01j, 1.1 - 0.01j, 3.0])
    assert predict_coalescence(0.0, lam0, 0.1, lam1)[0] == 0.0


def test_refuses_what_it_cannot_compare():
    with pytest.raises(ValueError, match="different sizes"):
        predict_coalescence(0.0, [1.0, 2.0], 0.1, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="F > F_prev"):
        predict_coalescence(0.1, [1.0, 2.0], 0.1, [1.0, 2.0])
