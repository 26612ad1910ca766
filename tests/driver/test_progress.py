"""The stages' progress bar off a terminal: a line per update, not carriage returns."""
from remote_trigger.pywrap.stages.common import progress_bar


def test_bar_off_a_terminal_writes_lines(capsys):
    """Under pytest's capture stderr is not a terminal, as in a batch job's log:
    each forced update is a line of its own (the last one too), no carriage
    return, and closing the bar writes no blank line."""
    bar = progress_bar(None, "relax", False, 0, unit="chk")
    for k in range(5):
        bar.update(1)
        bar.set_postfix_str(f"residual {10.0 ** -k:.2e}", refresh=True)
    bar.close()
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = err.splitlines()
    assert all(ln.startswith("relax: ") for ln in lines), lines
    assert lines[-1].startswith("relax: 5chk") and lines[-1].endswith("residual 1.00e-04]")
    assert sum("residual" in ln for ln in lines) >= 5, lines


def test_quiet_and_other_ranks_write_nothing(capsys):
    for quiet, rank in ((True, 0), (False, 1)):
        bar = progress_bar(None, "relax", quiet, rank)
        bar.update(5)
        bar.close()
    assert capsys.readouterr().err == ""
