"""``remote-trigger jacobian --part-size P`` on one rank and with ``--np 2``: the
same verdict, margin and eigenvalues, bit for bit (the partition is fixed by
P); bad ``--np`` / ``--part-size`` refused in one line naming the value."""
import subprocess

import numpy as np
import pytest

from remote_trigger.pywrap.cli import main

from .conftest import CLI, cli_env

KEYS = ("complex_pair", "confidence", "eigenvalues", "coverage", "method", "part_size")


@pytest.fixture(scope="module")
def dump(tmp_path_factory):
    """The stored N = 400 equilibrium (n = 1176 kept dofs, certified real)."""
    from tests.data import unpack

    d = tmp_path_factory.mktemp("fr")
    unpack("free_rotation_N400_s5_step_00002.dump.json", str(d))
    return unpack("free_rotation_N400_s5_step_00002", str(d))


def _load(path):
    with np.load(path) as z:
        return {k: z[k] for k in KEYS}


@pytest.mark.mpi
def test_one_and_two_ranks_give_the_same_bits(dump, tmp_path):
    one = tmp_path / "one.npz"
    assert main(["jacobian", dump, "-o", str(one), "--method", "sliced",
                 "--part-size", "300"]) == 0
    two = tmp_path / "two.npz"
    res = subprocess.run([CLI, "jacobian", dump, "-o", str(two), "--method", "sliced",
                          "--part-size", "300", "--np", "2"], env=cli_env(),
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.count("written:") == 1            # rank 0 alone prints
    a, b = _load(one), _load(two)
    assert int(a["complex_pair"]) == 0 and str(a["method"]) == "sliced"
    assert int(a["part_size"]) == 300 and a["eigenvalues"].size == 1176
    for k in KEYS:
        assert a[k].tobytes() == b[k].tobytes(), k


@pytest.mark.parametrize("words, msg", [
    (["--np", "0"], "--np must be >= 1, got --np 0"),
    (["--part-size", "1"], r"--part-size must be an integer >= 2 \(and >= the slice size, 60\), "
                           r"got --part-size 1"),
    (["--np", "2"], "--np 2 needs --part-size P"),
    (["--part-size", "20", "--method", "sliced"],
     r"part_size must be None or an integer >= the slice size \(60\), got part_size = 20"),
])
def test_bad_values_are_refused(dump, tmp_path, capsys, words, msg):
    import re

    assert main(["jacobian", dump, "-o", str(tmp_path / "x.npz")] + words) == 2
    err = capsys.readouterr().err
    assert re.search(msg, err) and err.count("\n") == 1, err
    assert not (tmp_path / "x.npz").exists()
