"""What a job records it was computed with (``runtime.environment``).

What must hold (each can fail): the versions are those of the installed
distributions, the BLAS entry is the kernel set OpenBLAS chose in the
process -- forcing another one with ``OPENBLAS_CORETYPE`` shows in the
record -- and, for a package built from this git checkout, the source
commit is one of its commits.
"""
import json
import os
import platform
import re
import subprocess
import sys

import pytest

from remote_trigger.pywrap.runtime.environment import PACKAGES, environment, source

PROJECT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


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


def test_source_is_a_commit_of_this_checkout():
    """``make install`` from a git checkout records its commit (CMake, at the
    build); a record of another tree or a missing one fails here."""
    src = environment()["source"]
    assert src == source() and set(src) == {"commit", "modified"}
    json.dumps(src)
    if not os.path.isdir(os.path.join(PROJECT, ".git")):
        pytest.skip("the tests do not run in a git checkout")
    assert src["commit"] is not None, "the package was built without its commit"
    assert re.fullmatch(r"[0-9a-f]{40}", src["commit"]), src
    assert src["modified"] in (True, False)
    known = subprocess.run(["git", "cat-file", "-e", src["commit"] + "^{commit}"],
                           cwd=PROJECT, capture_output=True)
    assert known.returncode == 0, f"{src['commit']} is not a commit of {PROJECT}"
