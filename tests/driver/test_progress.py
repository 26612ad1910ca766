"""The stages' progress bar off a terminal: lines, not carriage returns, at
most one per LOG_INTERVAL seconds."""
import io

from remote_trigger.pywrap.stages.common import _LogLines, progress_bar


def test_bar_off_a_terminal_writes_lines(capsys):
    """Under pytest's capture stderr is not a terminal, as in a batch job's log:
    each forced update is a line of its own (the last one too), no carriage
    return, and closing the bar writes no blank line (log_interval=0: no rate
    limit; test_lines_are_rate_limited_and_the_last_is_kept)."""
    bar = progress_bar(None, "relax", False, 0, unit="chk", log_interval=0)
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


def test_lines_are_rate_limited_and_the_last_is_kept():
    """With a 10 s interval (a fake clock), updates 3 s apart give a line at
    0, 12, 24 s ... and the state held back at closing is written then."""
    clock = [0.0]
    fp = io.StringIO()
    log = _LogLines(fp, 10.0, clock=lambda: clock[0])
    for k in range(10):                      # updates at 0, 3, ..., 27 s
        clock[0] = 3.0 * k
        log.write(f"\rrelax: {k}chk")
    assert fp.getvalue().splitlines() == ["relax: 0chk", "relax: 4chk", "relax: 8chk"]
    log.write("\r    \r")                   # tqdm's blanking when the bar closes
    assert fp.getvalue().splitlines()[-1] == "relax: 9chk"
    log.write("\r")                          # nothing pending: nothing written
    assert len(fp.getvalue().splitlines()) == 4


def test_the_last_state_is_written_off_a_terminal(capsys):
    """Updates faster than tqdm's own refresh limit (a run's records): the line
    written when the bar closes is its true last state, 1000/1000 (it ended at
    a count tqdm had last shown, e.g. 9987/10000)."""
    bar = progress_bar(1000, "perturb", False, 0, unit=" records")
    for _ in range(1000):
        bar.update(1)
    bar.close()
    lines = capsys.readouterr().err.splitlines()
    assert "1000/1000" in lines[-1], lines
