"""The public decision enum and the integer codes stored in the HDF5 files."""
import numpy as np
import pytest

from remote_trigger.analysis.stability.decision import DECISION_CODES, Decision


def test_codes_are_the_stored_integers():
    assert (int(Decision.COMPLEX), int(Decision.REAL), int(Decision.UNDECIDED)) == (1, 0, -1)
    assert DECISION_CODES == {"complex": 1, "real": 0, "undecided": -1}
    stored = np.array([0.0, 1.0, -1.0, 0.0])             # a ramp.h5 decision column
    assert list(stored == Decision.COMPLEX) == [False, True, False, False]
    assert [Decision.of(c) for c in stored] == [Decision.REAL, Decision.COMPLEX,
                                                 Decision.UNDECIDED, Decision.REAL]


def test_labels_round_trip():
    for d in Decision:
        assert Decision.of(d.label) is d and Decision.of(int(d)) is d


@pytest.mark.parametrize("bad", [2, 0.5, float("nan"), "unstable", None])
def test_not_a_decision_is_named(bad):
    with pytest.raises(ValueError, match="not a decision"):
        Decision.of(bad)
