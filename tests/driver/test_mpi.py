"""Serial and mpirun -np 2 give the same equilibrium and the same F_x^c."""
import subprocess

import numpy as np
import pytest

from remote_trigger.pywrap.runtime.results import read_all

from .conftest import CLI, MPIRUN, cli_env

pytestmark = pytest.mark.mpi


def _run(np_, args):
    cmd = ([MPIRUN, "-np", str(np_)] if np_ > 1 else []) + [CLI] + args + ["--quiet"]
    out = subprocess.run(cmd, env=cli_env(), capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout


def test_relax_and_ramp_serial_vs_np2(relaxed, tmp_path):
    res = {}
    for n in (1, 2):
        out = tmp_path / f"np{n}"
        _run(n, ["relax", "--datafile", relaxed.datafile, "--out", str(out)])
        _run(n, ["ramp", "--datafile", str(out / "relax" / "equilibrium.data"),
                 "--out", str(out), "--dF-x", "0.02", "--tol", "1e-4"])
        res[n] = (read_all(str(out / "relax.h5")), read_all(str(out / "ramp.h5")))
    (ra1, _), (ramp1a, ramp1d) = res[1]
    (ra2, _), (ramp2a, ramp2d) = res[2]
    assert ra2["n_ranks"] == 2
    assert ra1["residual"] == ra2["residual"]            # bitwise
    assert ramp1a["F_x_c_low"] == ramp2a["F_x_c_low"]
    assert ramp1a["F_x_c_high"] == ramp2a["F_x_c_high"]
    for k in ramp1d:
        if k.startswith("eigenvalues/"):
            np.testing.assert_array_equal(ramp1d[k], ramp2d[k])
    # the equilibrium dumps agree to the last bit
    d1 = open(tmp_path / "np1" / "relax" / "equilibrium.dump").read()
    d2 = open(tmp_path / "np2" / "relax" / "equilibrium.dump").read()
    assert d1 == d2
