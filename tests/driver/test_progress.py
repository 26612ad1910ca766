"""The stages' progress bar off a terminal: plain lines, not carriage returns."""
from remote_trigger.pywrap.stages.common import PROGRESS_LINE_INTERVAL, progress_bar


def test_bar_off_a_terminal_writes_lines(capsys):
    """Under pytest's capture stderr is not a terminal, as in a batch job's log:
    100 updates give one line (the interval is a minute), and no carriage return."""
    assert PROGRESS_LINE_INTERVAL >= 10
    bar = progress_bar(None, "relax", False, 0, unit="chk")
    for k in range(100):
        bar.update(1)
        bar.set_postfix_str(f"residual {10.0 ** -k:.2e}", refresh=True)
    bar.close()
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("relax:"), err


def test_log_lines_every_update_without_interval(capsys, monkeypatch):
    from remote_trigger.pywrap.stages import common

    monkeypatch.setattr(common, "PROGRESS_LINE_INTERVAL", 0.0)   # every update a line
    bar = progress_bar(3, "ramp", False, 0)
    for _ in range(3):
        bar.update(1)
        bar.refresh()
    bar.close()
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) >= 3 and all(ln.startswith("ramp:") for ln in lines), lines
    assert lines[-1].startswith("ramp: 100%"), lines


def test_quiet_and_other_ranks_write_nothing(capsys):
    for quiet, rank in ((True, 0), (False, 1)):
        bar = progress_bar(None, "relax", quiet, rank)
        bar.update(5)
        bar.close()
    assert capsys.readouterr().err == ""
