"""The suite's collection order: its longest test files first.

``make test`` runs the suite on pytest-xdist workers with ``--dist loadfile
--no-loadscope-reorder``: each file is one unit of work, handed to the next
free worker in collection order. Handing out the longest files first
(longest-processing-time-first) keeps every worker busy until near the end;
xdist's own reordering (by number of tests per file) put the one-test docs
build, ~1 min, last, on one worker while the other waited. Files not listed
keep their collection order, after these; the order of the tests inside a
file is unchanged. The list only affects how the work is shared, never what
is run; a stale entry costs wall time, nothing else.
"""
import os

#: test files by their seconds in a suite run (2026-11-28, 6088901: the 20
#: longest, ~70 % of the suite's worker time), longest first
LONGEST_FIRST = (
    "paper/test_ensemble_quick.py",
    "paper/test_paper_resume.py",
    "docs/test_docs_build.py",
    "paper/test_ensemble3d_quick.py",
    "driver/test_verdict_checkpoint.py",
    "paper/test_paper3d_quick.py",
    "paper/test_ensemble_combine.py",
    "analysis/test_sliced.py",
    "driver/test_kill.py",
    "driver/test_ramp3d.py",
    "driver/test_deck_placements.py",
    "driver/test_saddle.py",
    "driver/test_timestep.py",
    "driver/test_default_job_bisection.py",
    "driver/test_ramp.py",
    "driver/test_joining_mpi.py",
    "paper/test_ensemble_config.py",
    "driver/test_partial_decision.py",
    "paper/test_paper_quick.py",
    "plugin/test_readme_snippet.py",
)

_HERE = os.path.dirname(os.path.abspath(__file__))


def pytest_collection_modifyitems(session, config, items):
    """Move the items of :data:`LONGEST_FIRST`'s files to the front, in its order
    (a stable sort: every other item keeps its place relative to the others)."""
    rank = {os.path.join(_HERE, *f.split("/")): i for i, f in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(os.path.abspath(str(item.path)), len(rank)))
