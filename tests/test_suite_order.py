"""The files the suite hands out first (tests/conftest.py) exist."""
import os

from tests.conftest import LONGEST_FIRST


def test_every_file_listed_longest_first_exists():
    here = os.path.dirname(os.path.abspath(__file__))
    missing = [f for f in LONGEST_FIRST if not os.path.isfile(os.path.join(here, *f.split("/")))]
    assert not missing, f"tests/conftest.py LONGEST_FIRST names files that do not exist: {missing}"
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)
