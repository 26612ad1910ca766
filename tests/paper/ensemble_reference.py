"""The reference ``ensemble --quick`` run kept in tests/data/ensemble_quick2d
(made with the code before ``dim`` existed, commit a163038): its folder and
a check of a table against it."""
import json
import os

import numpy as np

from remote_trigger.pywrap.jobs.ensemble import report as er

REF = os.path.join(os.path.dirname(__file__), "..", "data", "ensemble_quick2d")


def reference_table():
    """The reference run's ``table.json`` (columns, attributes, session)."""
    with open(os.path.join(REF, "table.json")) as fh:
        return json.load(fh)


#: columns added to the table after the reference run: the pair's mode shape
#: (participation, long-wave fraction), the saddle counts, the first soft pair
#: of a ramp with pairs = 'collective' (NaN in a run with 'all', as this one)
ADDED_COLUMNS = {"pair_pr", "pair_particles", "n_saddle", "n_escaped", "pair_longwave",
                 "F_x_soft", "F_x_soft_ss"}
#: text columns added since, with their value for the reference run's packings:
#: what each was computed with (relaxed by the clearance test 'all', the only
#: one then; no environment recorded)
ADDED_TEXT_COLUMNS = {"clearance": "all", "cpu": "", "blas": "", "commit": ""}
#: sections of ensemble.md added since (the size dependence's data set, fits,
#: tests and the window's fate): the rest of the file is the reference's
ADDED_SECTIONS = ("## Data set", "## Size dependence:", "## Is it a weakest link?",
                  "## Does the window survive as N grows?")


def without_added_sections(text):
    """``ensemble.md`` without the sections of :data:`ADDED_SECTIONS` (each from
    its heading to the next one, and the blank line before it)."""
    blocks, cur = [], []
    for line in text.split("\n"):
        if line.startswith("## "):
            blocks.append(cur)
            cur = []
        cur.append(line)
    blocks.append(cur)
    kept = [b for b in blocks if not (b and b[0].startswith(ADDED_SECTIONS))]
    return "\n".join("\n".join(b) for b in kept)


def assert_reference_columns(h5path):
    """The table at ``h5path`` has the reference run's columns, value for value
    (NaN equal to NaN), and the columns added since (a pair's mode shape
    NaN for the reference run's packings, which did not measure it; the
    provenance columns as those packings' results imply)."""
    ref = reference_table()
    got = er.read_table(str(h5path))
    added = ADDED_COLUMNS | set(ADDED_TEXT_COLUMNS)
    assert sorted(set(got) - added) == sorted(ref["columns"])
    assert set(got) >= added
    for c in ADDED_COLUMNS:
        assert np.all(np.isnan(np.asarray(got[c], float))), c
    for c, want in ADDED_TEXT_COLUMNS.items():
        assert list(got[c]) == [want] * len(got[c]), c
    for c, want in ref["columns"].items():
        if c in er.STR_COLS:
            assert list(got[c]) == want, c
        else:
            assert np.array_equal(got[c], np.array(want, float), equal_nan=True), c
