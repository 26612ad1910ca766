"""The dense verdict refuses an order that would not fit in memory
(analysis.stability.verdict.check_dense_fits, available_memory)."""
import pytest

from remote_trigger.analysis.errors import InputError, TooLargeError
from remote_trigger.analysis.stability import verdict


def test_refused_above_the_memory_and_accepted_below():
    need = verdict.DENSE_PEAK_MATRICES * 8 * 1000 ** 2
    verdict.check_dense_fits(1000, available=need)              # exactly fits
    with pytest.raises(TooLargeError) as exc:
        verdict.check_dense_fits(1000, available=need - 1)
    msg = str(exc.value)
    assert "n = 1000 dofs needs about 0.1 GiB" in msg and "0.1 GiB available" in msg
    assert isinstance(exc.value, MemoryError) and exc.value.exit_status == 1


def test_available_memory_from_the_environment(monkeypatch):
    monkeypatch.setenv(verdict.MEMORY_ENV, "2")
    assert verdict.available_memory() == 2 * 2**30
    for bad in ("0", "-1", "two", "nan"):
        monkeypatch.setenv(verdict.MEMORY_ENV, bad)
        with pytest.raises(InputError, match=f"= '{bad}': not a positive number"):
            verdict.available_memory()
    monkeypatch.delenv(verdict.MEMORY_ENV)
    avail = verdict.available_memory()
    assert avail is None or avail > 0
