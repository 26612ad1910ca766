"""Numerics shared by the steps of the sliced verdict.

The rounding of float64 computations is bounded a priori with Higham's
gamma_k and the unit roundoff u
(:func:`~remote_trigger.analysis.stability.enclosure.gamma`,
:data:`~remote_trigger.analysis.stability.enclosure.U`); the sums and norms of
computed nonnegative quantities are inflated by :data:`INFLATE` instead
(module docstring of :mod:`remote_trigger.analysis.stability.sliced`). A step
that cannot be certified raises :class:`SliceFailure`.
"""

__all__ = ["INFLATE", "SliceFailure"]

#: inflation of computed sums (and norms) of nonnegative terms
INFLATE = 1.0 + 1e-10


class SliceFailure(Exception):
    """A step of the sliced verdict could not be certified; the message is the reason.

    Inside the scan, a boundary or strip that fails is undecided (its reason
    kept); a failure of the slicing itself ends the scan, whose verdict is
    then undecided with this reason (or complex, if a strip below was
    certified complex).
    """
