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


def _noisy_schur(lam, V, err, seed):
    """T_c(z) = T(z) + E(z), ||E(z)||_2 <= 0.9 err, E a fresh random matrix at
    every z (not analytic, not even continuous): what the proof allows of a
    computed complement. T itself is one member of the set."""
    lam = np.asarray(lam, complex)
    m = lam.size
    Vi = np.linalg.inv(V)

    def schur(z, deriv=True):
        r = np.random.default_rng([seed, abs(hash(z)) % 2**32])
        E = r.standard_normal((m, m)) + 1j * r.standard_normal((m, m))
        E *= 0.9 * err / np.linalg.norm(E, 2)
        return V @ np.diag(lam - z) @ Vi + E, err, -np.eye(m), 0.0
    return schur


def test_errors_do_not_accumulate_over_the_segments():
    """Two pairs 0.015 apart (4 zeros), a box of half-width 0.0075 about the
    upper one: with err up to 1e-3 (0.13 of the distance from the edge to the
    zeros) the count is 1. The nodes' errors cancel around the loop (module
    docstring); summed per segment, as a cruder bound would, they exceed pi
    from err = 3e-4 on."""
    lam = [5 + 0.02j, 5 - 0.02j, 5 + 0.035j, 5 - 0.035j]
    box = (4.9925, 5.0075, 0.0275, 0.0425)
    for err in (1e-4, 3e-4, 1e-3):
        cnt, why, margin = box_zero_count(_diag_schur(lam, err=err), *box, curv=0.0)
        assert cnt == 1 and margin > 1, (err, why)


@pytest.mark.parametrize("seed", range(3))
def test_a_count_is_never_wrong_under_adversarial_errors(seed):
    """Random perturbations of norm up to err at every evaluation (the computed
    T_c may be any matrix within err of the true T): the count is the true
    one or None, over boxes that hold 0, 1 or 2 zeros and boxes whose edge
    passes within a few err of a zero; and with err small beside those
    distances it is given."""
    rng = np.random.default_rng(100 + seed)
    V = np.eye(6) + 0.2 * rng.standard_normal((6, 6))
    lam = np.array([5 + 0.02j, 5 - 0.02j, 5.01 + 0.03j, 5.01 - 0.03j, 4.97, 5.04])
    given = 0
    for _ in range(15):
        x0, y0 = rng.uniform(4.96, 5.03), rng.uniform(0.001, 0.04)
        w, hgt = rng.uniform(0.003, 0.03, size=2)
        box = (x0, x0 + w, y0, y0 + hgt)
        inside = int(np.sum((lam.real > box[0]) & (lam.real < box[1])
                            & (lam.imag > box[2]) & (lam.imag < box[3])))
        for err in (1e-6, 3e-4, 2e-3):
            cnt, why, margin = box_zero_count(_noisy_schur(lam, V, err, seed), *box, curv=0.0)
            assert cnt is None or cnt == inside, (box, err, cnt, inside)
            assert (cnt is None) == (margin == 0.0)
            given += err == 1e-6 and cnt is not None
    assert given >= 12          # the near-exact complement counts (almost) every box


def _near_exceptional(err, seed=0, eps=(0.002 ** 2, 0.0035 ** 2), a=0.496):
    """T(z) = B - z, B two 2 x 2 blocks [[a, 1], [-eps, a]] (pairs a +- i sqrt(eps),
    just past their exceptional points) in a random orthonormal basis: sigma_min(T)
    near a zero is about the product of the distances to the pair's two members,
    far below either."""
    B = np.zeros((4, 4), complex)
    for k, e in enumerate(eps):
        B[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[a, 1.0], [-e, a]]
    Q = np.linalg.qr(np.random.default_rng(seed).standard_normal((4, 4)))[0]
    B = Q @ B @ Q.T
    calls = []

    def schur(z, deriv=True):
        calls.append(z)
        return B - z * np.eye(4), err, -np.eye(4), 0.0
    return schur, calls


@pytest.mark.parametrize("err", [0.0, 1e-8, 1e-7])
def test_a_pair_near_its_exceptional_point_is_counted_on_the_eigenvector_basis(err):
    """The box of half-width 0.00075 about 0.496 + 0.0035i (the other upper
    member 0.0015 below it): on T the segments must be shorter than
    sigma_min(T) ~ 1e-6 and the walk stops at its budget of evaluations; on
    W T V (V the eigenvectors at the box's centre) they need only be short
    beside the distance to the zeros, and the box holds 1."""
    schur, calls = _near_exceptional(err)
    box = (0.496 - 0.00075, 0.496 + 0.00075, 0.0035 - 0.00075, 0.0035 + 0.00075)
    cnt, why, margin = box_zero_count(schur, *box, curv=0.0)
    assert cnt == 1 and margin > 1, why
    assert len(set(calls)) < 700                # the first walk's 601, then a few more


def test_a_cheap_complement_may_take_a_larger_budget_of_evaluations():
    """T(z) = [[a, 1], [-d^2, a]] - z (a pair a +- i d near its exceptional
    point, d = 0.02), the box of half-width d/2 about a + i d, err = 6e-5: on
    T, sigma_min on the lower edge is ~0.75 d^2 = 3e-4 and segments must be
    shorter than ~1e-4, so the walk needs ~800 evaluations; on W T V the
    error bound (times ||W|| ||V|| ~ 1/d) is above 0.26 of the distance, so
    the second walk gives nothing either. With the default budget (600, for
    sparse LUs) no count; with ``max_evals`` 10 000 (a deflated complement's
    polynomial) the count 1."""
    a, d = 0.5, 0.02
    A0 = np.array([[a, 1.0], [-d * d, a]])
    calls = []

    def schur(z, deriv=True):
        calls.append(z)
        return A0 - z * np.eye(2), 6e-5, -np.eye(2), 0.0
    box = (a - d / 2, a + d / 2, d / 2, 1.5 * d)
    cnt, why, _ = box_zero_count(schur, *box, curv=0.0)
    assert cnt is None and "more than 600 evaluations" in why and "eigenvector basis" in why
    calls.clear()
    cnt, why, margin = box_zero_count(schur, *box, curv=0.0, max_evals=10_000)
    assert cnt == 1 and margin > 1, why
    assert 600 < len(set(calls)) < 10_000


def test_the_deflated_budget_falls_with_the_cost_of_an_evaluation():
    """10 000 evaluations of a deflated complement up to p = 16 (seed 2's strip
    had p = 6), then in proportion to p^-3, never below the bordered route's
    600: a walk that fails by its budget costs about the same at every p."""
    from remote_trigger.analysis.stability.sliced.strips import poly_budget
    from remote_trigger.analysis.stability.sliced.winding import MAX_EVALS

    assert poly_budget(6) == poly_budget(16) == 10_000
    assert poly_budget(32) == 1250
    assert poly_budget(64) == poly_budget(400) == MAX_EVALS == 600


@pytest.mark.parametrize("seed", range(2))
def test_near_exceptional_counts_are_never_wrong_under_adversarial_errors(seed):
    """As above with a random error of norm up to err at every evaluation, over
    random boxes near the four zeros: the true count or none."""
    schur0, _ = _near_exceptional(0.0, seed=seed)
    rng = np.random.default_rng(200 + seed)
    lam = np.array([0.496 + 0.002j, 0.496 - 0.002j, 0.496 + 0.0035j, 0.496 - 0.0035j])
    given = 0
    for _ in range(8):
        x0, y0 = 0.496 + rng.uniform(-0.002, 0.0005), rng.uniform(0.0002, 0.003)
        w, hgt = rng.uniform(0.0005, 0.003, size=2)
        box = (x0, x0 + w, y0, y0 + hgt)
        inside = int(np.sum((lam.real > box[0]) & (lam.real < box[1])
                            & (lam.imag > box[2]) & (lam.imag < box[3])))
        for err in (1e-9, 1e-7):
            def schur(z, deriv=True, err=err):
                T, _, D, _ = schur0(z)
                r = np.random.default_rng([seed, abs(hash(z)) % 2**32])
                E = r.standard_normal((4, 4)) + 1j * r.standard_normal((4, 4))
                return T + 0.9 * err * E / np.linalg.norm(E, 2), err, D, 0.0
            cnt, why, _ = box_zero_count(schur, *box, curv=0.0)
            assert cnt is None or cnt == inside, (box, err, cnt, inside)
            given += cnt is not None
    assert given >= 10          # of 16
