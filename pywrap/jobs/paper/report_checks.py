"""The check rows of ``report.md`` of ``remote-trigger paper``: one measured
quantity against the paper's statement, with its verdict (:data:`VERDICTS`).

Written by :mod:`remote_trigger.pywrap.jobs.paper.report` and
:mod:`remote_trigger.pywrap.jobs.paper.report_fig5`.
"""

VERDICTS = ("pass", "differs")


def add_check(rows, cid, quantity, measured, paper, ok, reason="", note=""):
    """Append a row of the report's table: verdict 'pass' if ``ok`` else
    'differs', with ``note`` (pass) or ``reason`` (differs) as its reason."""
    rows.append({"id": cid, "quantity": quantity, "measured": measured, "paper": paper,
                 "verdict": "pass" if ok else "differs",
                 "reason": note if ok else (reason or "see text")})
