"""What a job records it was computed with (``runtime.environment``).

What must hold (each can fail): the versions are those of the installed
distributions, and the BLAS entry is the kernel set OpenBLAS chose in the
process -- forcing another one with ``OPENBLAS_CORETYPE`` shows in the
record.
"""
import json
import os
import platform
import subprocess
import sys

import pytest

from remote_trigger.pywrap.runtime.environment import PACKAGES, environment


def test_versions_are_the_installed_ones():
    import numpy
    import scipy

    env = environment()
    assert set(env["packages"]) == set(PACKAGES)
    assert env["packages"]["numpy"] == numpy.__version__
    assert env["packages"]["scipy"] == scipy.__version__
    assert env["python"] == platform.python_version()
    json.dumps(env)                     # recorded in JSON files


@pytest.mark.skipif(platform.machine() != "x86_64", reason="OpenBLAS core types of x86_64")
def test_forced_core_type_is_recorded():
    env = environment()
    if not env["blas"] or any(b["library"] != "openblas" for b in env["blas"]):
        pytest.skip("numpy's or scipy's BLAS is not OpenBLAS")
    code = ("import json; from remote_trigger.pywrap.runtime.environment import environment; "
            "print(json.dumps(environment()))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, OPENBLAS_CORETYPE="Haswell"), check=True)
    forced = json.loads(proc.stdout)
    assert len(forced["blas"]) == len(env["blas"]) >= 1
    assert all(b["architecture"] == "Haswell" for b in forced["blas"])
    assert forced["openblas_coretype"] == "Haswell"
