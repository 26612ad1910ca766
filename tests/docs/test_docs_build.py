"""The documentation site builds without a warning (what `make docs` runs).

sphinx-build with -W (warnings are errors) over docs/: the user pages, the
results pages, the plugin's LAMMPS pages and the API reference generated
from the installed package's docstrings (imported, no LAMMPS run). Skipped
where the docs extra is not installed (`pip install .[docs]`; `make test`
installs it).
"""
import importlib.util
import os
import subprocess
import sys

import pytest

DOCS = os.path.join(os.path.dirname(__file__), "..", "..", "docs")
NEEDED = ("sphinx", "myst_parser", "furo")
missing = [m for m in NEEDED if importlib.util.find_spec(m) is None]

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(bool(missing), reason=f"docs extra not installed (no {', '.join(missing)}): "
                                             "pip install '.[docs]' or make test"),
]


def test_site_builds_without_warnings(tmp_path):
    out = tmp_path / "html"
    cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q",
           "-j", "2", "-d", str(tmp_path / "doctrees"), DOCS, str(out)]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-6000:]
    for page in ("index.html", "ensemble.html", "results/ensemble.html",
                 "plugin/pair_mindlin_smooth.html",
                 "api/generated/remote_trigger.pywrap.stages.ramp.html",
                 "api/generated/remote_trigger.analysis.stability.exceptional.html"):
        assert (out / page).is_file(), page
    # the API page documents the module's function, with its parameters
    ramp = (out / "api/generated/remote_trigger.pywrap.stages.ramp.html").read_text()
    assert 'id="remote_trigger.pywrap.stages.ramp.ramp"' in ramp
