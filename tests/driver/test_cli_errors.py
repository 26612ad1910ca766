"""The command line refuses instead of guessing (issue 13, item 3).

Every trial is a command, its exit status (docs/driver.md, "Exit status":
0 ok, 1 no result, 2 bad input, 3 no equilibrium, 130 interrupted) and the
one line it prints. Commands that need no subprocess run in-process
(``cli.main``); Ctrl-C and ``mpirun`` run the installed ``remote-trigger``.
"""
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from remote_trigger.pywrap import cli

from .conftest import CLI, MPIRUN, cli_env


def run_cli(capsys, *argv):
    """``cli.main`` in-process; returns (status, stdout, stderr)."""
    status = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def assert_one_line_error(err, *needles, status=None):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err and "error" in lines[0], err
    for n in needles:
        assert n in lines[0], (n, lines[0])


@pytest.fixture(scope="module")
def ramp_run(relaxed, tmp_path_factory):
    """A coarse ramp of the small packing: a stable and an unstable start state."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    out = tmp_path_factory.mktemp("ramp")
    res = stages.ramp(RampConfig(datafile=relaxed.datafile, dF_x=0.02, tol=1e-3), str(out),
                      quiet=True)
    assert res.status == "complete" and res.complex_pair[-1] and not res.complex_pair[0]
    k = res.F_x.size - 1
    step = lambda i: os.path.join(str(out), "ramp", f"step_{i:05d}")  # noqa: E731
    return {"out": str(out), "stable": step(1), "unstable": step(k),
            "F_unstable": float(res.F_x[k]), "F_stable": float(res.F_x[1]), "h5": res.h5}


@pytest.fixture()
def bad_files(packing_file, tmp_path):
    """Empty, truncated, NaN and coincident-disk variants of the small packing."""
    text = open(packing_file).read()
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("Atoms"))
    files = {}
    files["empty"] = tmp_path / "empty.data"
    files["empty"].write_text("")
    files["truncated"] = tmp_path / "truncated.data"
    files["truncated"].write_text(text[:len(text) // 2])
    nan = list(lines)
    w = nan[k + 4].split()
    w[5] = "nan"
    nan[k + 4] = " ".join(w)
    files["nan"] = tmp_path / "nan.data"
    files["nan"].write_text("\n".join(nan) + "\n")
    co = list(lines)
    a, b = co[k + 2].split(), co[k + 3].split()
    b[4:6] = a[4:6]
    co[k + 3] = " ".join(b)
    files["coincident"] = tmp_path / "coincident.data"
    files["coincident"].write_text("\n".join(co) + "\n")
    # no top line (the topflag section cut off), and a file with pair coefficients
    files["no_top"] = tmp_path / "no_top.data"
    files["no_top"].write_text(text[:text.index("\ntopflag")] + "\n")
    coeffs = list(lines)
    coeffs[k:k] = ["PairIJ Coeffs # mindlin/smooth", "", "1 1 200000 57142.9 1", ""]
    files["pair_coeffs"] = tmp_path / "pair_coeffs.data"
    files["pair_coeffs"].write_text("\n".join(coeffs) + "\n")
    return files


# --------------------------------------------------------------------------- the error layer
def test_one_exception_base_keeps_builtin_bases():
    from remote_trigger.analysis.errors import RemoteTriggerError
    from remote_trigger.analysis.stability.timestep import TimestepError
    from remote_trigger.pywrap import errors
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.bindings.engine import EngineError
    from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError

    assert errors.RemoteTriggerError is RemoteTriggerError
    for cls, base, status in ((ConfigError, ValueError, 2), (TimestepError, ValueError, 2),
                              (NoEquilibriumError, RuntimeError, 3),
                              (EngineError, RuntimeError, 1)):
        assert issubclass(cls, RemoteTriggerError) and issubclass(cls, base)
        assert cls.exit_status == status


def test_classify_statuses():
    from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError

    assert cli.classify(NoEquilibriumError("no equilibrium at F_x = 1"))[:2] == (
        3, "no equilibrium at F_x = 1")
    assert cli.classify(ValueError("bad\nvalue"))[:2] == (2, "bad value")
    assert cli.classify(FileNotFoundError(2, "No such file or directory", "x.data"))[0] == 2
    assert cli.classify(OSError(28, "No space left on device", "o.h5"))[0] == 1
    status, msg, internal = cli.classify(TypeError("boom"))
    assert status == 1 and internal and "--debug" in msg and "TypeError: boom" in msg


def test_a_reader_that_stops_early_is_no_error():
    """stdout piped into ``head``: the command's write fails with EPIPE; that is
    no error message, and the status is 141 (SIGPIPE's, as a shell gives)."""
    import shlex

    code = ("import argparse, sys; from remote_trigger.pywrap import cli; "
            "args = argparse.Namespace(command='x', func=lambda a: "
            "[print('y' * 99) for _ in range(100000)]); sys.exit(cli._guarded(args, False))")
    proc = subprocess.run(f"{shlex.quote(sys.executable)} -c {shlex.quote(code)} | head -c 3; "
                          "exit ${PIPESTATUS[0]}", shell=True, executable="/bin/bash",
                          capture_output=True, text=True, timeout=120)
    assert proc.stdout == "yyy" and proc.stderr == "" and proc.returncode == 141, proc.stderr


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    from importlib.metadata import version

    assert capsys.readouterr().out.strip() == f"remote-trigger {version('remote-trigger')}"


def test_usage_error_is_one_line(capsys):
    # perturb has no default start (relax and ramp have: test_stages_chain_by_their_defaults)
    with pytest.raises(SystemExit) as exc:
        cli.main(["perturb", "--out", "x"])
    assert exc.value.code == 2
    assert_one_line_error(capsys.readouterr().err, "--datafile", "--help")


def test_options_are_taken_by_their_whole_name_only(capsys, tmp_path):
    """``generate --out DIR`` (the folder option of the other commands) is
    refused, not taken for an abbreviation of ``--output FILE``, and nothing is
    written."""
    with pytest.raises(SystemExit) as exc:
        cli.main(["generate", "--n", "20", "--out", str(tmp_path / "p")])
    assert exc.value.code == 2
    assert_one_line_error(capsys.readouterr().err, "unrecognized arguments: --out",
                          "remote-trigger generate: error", "did you mean --output?",
                          "see remote-trigger generate --help")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv,needles", [
    (["ramp", "--datafile", "x", "--dFx", "1"], ["remote-trigger ramp: error",
                                                 "--dFx 1 (did you mean --dF-x?)"]),
    (["generate", "--n", "20", "more"], ["remote-trigger generate: error",
                                         "unrecognized arguments: more (see"]),
    # one dash where two are meant
    (["generate", "-n", "20"], ["remote-trigger generate: error",
                                "unrecognized arguments: -n 20 (did you mean --n?)"]),
    # a job's configuration key that has no flag: --set names it
    (["paper", "--nf_eps", "0.1"], ["remote-trigger paper: error",
                                    "--nf_eps 0.1 (did you mean --set nf_eps=VALUE?)"]),
    (["paper", "--nf-tau=3"], ["(did you mean --set nf_tau=VALUE?)"]),
    (["ensemble", "--n", "100"], ["remote-trigger ensemble: error",
                                  "--n 100 (did you mean --set n=VALUE?)"]),
    (["trigger-map", "--omega_p", "0.1"], ["(did you mean --set omega_p=VALUE?)"]),
    # the beginning of one option (difflib alone named --set)
    (["relax", "--settle", "100"], ["--settle 100 (did you mean --settle-steps?)"]),
    # another case of an option (difflib named --w), and --np of a stage (--help)
    (["paper", "--N", "40"], ["--N 40 (did you mean --n?)"]),
    (["relax", "--np", "2"], ["--np 2 (did you mean mpirun -np N remote-trigger relax ...?)"]),
    # an option of remote-trigger itself after a subcommand (it named --override)
    (["relax", "--version"], ["--version (did you mean remote-trigger --version?)"]),
    # a subcommand's options before it ("--quiet (did you mean --quiet?)",
    # "--set quick=VALUE", "invalid choice: '2'")
    (["--quiet", "relax", "--out", "q"], ["remote-trigger relax: error: --quiet: options of "
                                          "relax go after it (remote-trigger relax --quiet ...)"]),
    (["--quick", "paper"], ["paper: error: --quick: options of paper go after it"]),
    (["--np", "2", "paper"], ["paper: error: --np 2: options of paper go after it "
                              "(remote-trigger paper --np 2 ...)"])])
def test_unknown_words_name_the_subcommand(capsys, argv, needles):
    """A word the subcommand does not take is refused by that subcommand,
    with the closest of its options where one is close (none for a stray
    positional word)."""
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    assert_one_line_error(capsys.readouterr().err, *needles)


def test_a_start_file_given_without_its_option(capsys, tmp_path):
    """``relax packing.data`` (a file where --datafile is meant) names
    --datafile with the file; a stray word that is no file gets no hint."""
    data = tmp_path / "p.data"
    data.write_text("")
    for argv, needle in ((["relax", str(data)], f"(did you mean --datafile {data}?)"),
                         (["relax", str(tmp_path / "none.data")], "none.data (see"),
                         # where --datafile is required (the missing option is named)
                         (["perturb", str(data)], f"(did you mean --datafile {data}?)"),
                         (["instability", "--out", str(tmp_path / "o"), str(data)],
                          f"(did you mean --datafile {data}?)"),
                         (["perturb", "--out", str(data)], "--datafile (see")):
        with pytest.raises(SystemExit) as exc:
            cli.main(argv)
        assert exc.value.code == 2
        assert_one_line_error(capsys.readouterr().err, f"remote-trigger {argv[0]}: error",
                              needle)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.data"]


@pytest.mark.parametrize("runs,bad", [("C", "'C'"), ("xyz", "'x', 'y', 'z'"), ("abd", "'d'")])
def test_unknown_run_letters(capsys, relaxed, runs, bad):
    with pytest.raises(SystemExit) as exc:
        cli.main(["perturb", "--datafile", relaxed.datafile, "--runs", runs])
    assert exc.value.code == 2
    assert_one_line_error(capsys.readouterr().err, f"unknown run letter(s) {bad}")
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.config import ConfigError

    with pytest.raises(ConfigError, match="unknown run letter"):
        stages.check_runs(runs)


def test_negative_option_values(capsys, relaxed, tmp_path):
    assert cli.preprocess(["ramp", "--dF-x", "-2e-3", "--F-x", "-.5", "--tol", "1e-7"])[0] == [
        "ramp", "--dF-x=-2e-3", "--F-x=-.5", "--tol", "1e-7"]
    assert cli.preprocess(["relax", "--debug", "--F-x", "1"]) == (["relax", "--F-x", "1"], True)
    # the value reaches the configuration, which names it
    status, _, err = run_cli(capsys, "ramp", "--datafile", relaxed.datafile, "--out",
                             tmp_path, "--dF-x", "-2e-3")
    assert status == 2
    assert_one_line_error(err, "dF_x must be > 0, got dF_x = -0.002")


def test_debug_shows_traceback(capsys, bad_files, tmp_path):
    status, _, err = run_cli(capsys, "relax", "--datafile", bad_files["empty"], "--out",
                             tmp_path / "o", "--debug")
    assert status == 2 and "Traceback" in err and "is empty" in err.splitlines()[-1]


# --------------------------------------------------------------------------- input files
@pytest.mark.parametrize("kind,needle", [
    ("empty", "is empty"), ("truncated", "is truncated"),
    ("nan", "non-finite value 'nan' in the Atoms line of atom"),
    ("coincident", "atoms 1 and 2 are at the same place"),
    # (relax said "place_top needs top and bulk disks, got 0 top disks of 100";
    # LAMMPS "Must define pair_style before PairIJ Coeffs", status 1)
    ("no_top", "with a top line and a bulk; this one has no topflag section"),
    ("pair_coeffs", "this one holds 'PairIJ Coeffs' (write_data without nocoeff)")])
def test_bad_data_file(capsys, bad_files, tmp_path, kind, needle):
    status, _, err = run_cli(capsys, "relax", "--datafile", bad_files[kind], "--out",
                             tmp_path / "o", "--quiet")
    assert status == 2
    assert_one_line_error(err, needle, str(bad_files[kind]))
    assert not (tmp_path / "o" / "relax.h5").exists()


# --------------------------------------------------------------------------- output folders
@pytest.mark.parametrize("cmd", ["relax", "demo", "generate"])
def test_out_naming_a_file(capsys, packing_file, tmp_path, cmd):
    afile = tmp_path / "a_file"
    afile.write_text("keep")
    argv = {"relax": ["relax", "--datafile", packing_file, "--out", afile],
            "demo": ["demo", "--n", 6, "--steps", 10, "--out", afile],
            "generate": ["generate", "--n", 20, "--output", afile / "p.data"]}[cmd]
    status, _, err = run_cli(capsys, *argv)
    assert status == 2
    assert_one_line_error(err, str(afile))
    assert afile.read_text() == "keep" and os.listdir(tmp_path) == ["a_file"]


@pytest.mark.parametrize("cmd", ["relax", "paper"])
def test_unwritable_out(capsys, packing_file, cmd):
    argv = (["relax", "--datafile", packing_file] if cmd == "relax" else ["paper", "--quick"])
    status, _, err = run_cli(capsys, *argv, "--out", "/proc/remote-trigger/out", "--quiet")
    assert status == 2
    assert_one_line_error(err, "'/proc/remote-trigger/out': cannot create the folder")


def test_generate_onto_a_folder_leaves_nothing(capsys, tmp_path):
    (tmp_path / "d").mkdir()
    status, _, err = run_cli(capsys, "generate", "--n", 20, "--output", tmp_path / "d")
    assert status == 2
    assert_one_line_error(err, "--output must name a file, got a folder")
    # the writer itself removes its temporary file when the rename fails
    from remote_trigger.pywrap.stages.packing import generate, write_data

    with pytest.raises(IsADirectoryError):
        write_data(generate(20, seed=1), tmp_path / "d")
    assert os.listdir(tmp_path / "d") == [] and sorted(os.listdir(tmp_path)) == ["d"]


def test_full_disk_is_one_line_status_1(capsys, tmp_path, monkeypatch):
    import errno

    from remote_trigger.pywrap.stages import packing

    def full(p, path):
        raise OSError(errno.ENOSPC, "No space left on device", str(path) + ".tmp1")

    monkeypatch.setattr(packing, "write_data", full)
    status, _, err = run_cli(capsys, "generate", "--n", 20, "--output", tmp_path / "p.data")
    assert status == 1
    assert_one_line_error(err, "no space left on the device writing", "p.data.tmp1")


def test_relax_and_perturb_refuse_a_folder_with_their_results(capsys, relaxed, tmp_path):
    out = tmp_path / "o"
    status, stdout, _ = run_cli(capsys, "relax", "--datafile", relaxed.datafile, "--out", out,
                                "--quiet", "--set", "settle_steps=0")
    assert status == 0
    # the line names the file the next stage starts from (``ramp --datafile``)
    start = str(out / "relax" / "equilibrium.data")
    assert stdout.rstrip().endswith(f"a ramp starts from {start}") and os.path.isfile(start)
    before = (out / "relax.h5").read_bytes()
    status, _, err = run_cli(capsys, "relax", "--datafile", relaxed.datafile, "--out", out,
                             "--quiet", "--set", "settle_steps=0")
    assert status == 2
    assert_one_line_error(err, "already holds relax results", "relax.h5",
                          "nothing was overwritten")
    assert (out / "relax.h5").read_bytes() == before
    argv = ["perturb", "--datafile", relaxed.datafile, "--out", out, "--quiet", "--runs", "a",
            "--t-max", "0.1"]
    assert run_cli(capsys, *argv)[0] == 0          # another stage: the same folder is fine
    status, _, err = run_cli(capsys, *argv)
    assert status == 2
    assert_one_line_error(err, "already holds perturb results", "perturb_a.h5")


def test_the_model_line_says_where_the_values_come_from(capsys, relaxed, tmp_path):
    """Every stage prints the model it runs with: from the start file's sidecar,
    or, for a data file without one (``generate``'s), the defaults."""
    bare = tmp_path / "bare.data"
    shutil.copyfile(relaxed.datafile, bare)          # no bare.dump.json beside it
    status, stdout, _ = run_cli(capsys, "relax", "--datafile", bare, "--out", tmp_path / "a",
                                "--set", "settle_steps=0")
    assert status == 0
    line = next(ln for ln in stdout.splitlines() if ln.startswith("relax: model: "))
    assert line.endswith("(no sidecar beside the start file: the defaults)"), line
    status, stdout, _ = run_cli(capsys, "relax", "--datafile", relaxed.datafile, "--out",
                                tmp_path / "b", "--set", "settle_steps=0", "--mu", "1.0")
    assert status == 0
    line = next(ln for ln in stdout.splitlines() if ln.startswith("relax: model: "))
    assert "the start state's sidecar" in line and "--mu as given" in line, line


def test_ramp_resume_refuses_another_datafile(capsys, ramp_run, tmp_path):
    out = tmp_path / "r"
    shutil.copytree(ramp_run["out"], out)
    before = (out / "ramp.h5").read_bytes()
    status, _, err = run_cli(capsys, "ramp", "--datafile", ramp_run["stable"] + ".data",
                             "--out", out, "--dF-x", 0.02, "--tol", 1e-3, "--resume",
                             "--quiet", "--override")
    assert status == 2
    assert_one_line_error(err, "cannot resume", "this run gives datafile =",
                          "step_00001.data", "nothing was changed")
    assert (out / "ramp.h5").read_bytes() == before


def test_perturb_resume_keeps_finished_runs_and_is_bitwise(capsys, relaxed, tmp_path):
    """An interrupted perturb (run (b) cut short, (c) not started) resumed == uninterrupted."""
    from remote_trigger.pywrap.runtime.results import read_all

    argv = ["perturb", "--datafile", relaxed.datafile, "--t-max", 2, "--quiet"]
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    assert run_cli(capsys, *argv, "--out", ref)[0] == 0
    shutil.copytree(ref, cut)
    with h5py.File(cut / "perturb_b.h5", "a") as fh:        # as Ctrl-C leaves it
        fh.attrs["status"] = "failed"
    os.remove(cut / "perturb_c.h5")
    a_before = (cut / "perturb_a.h5").stat().st_mtime_ns
    status, _, err = run_cli(capsys, *argv, "--out", cut, "--a", 2e-12, "--resume")
    assert status == 2
    assert_one_line_error(err, "cannot resume", "a = 1e-12, this run has a = 2e-12")
    status, text, err = run_cli(capsys, *argv, "--out", cut, "--resume")
    assert status == 0, err
    assert re.search(r"perturb \(c\): .* \(v0 \d\.\d{3}e-\d+\) -> ", text), text
    assert (cut / "perturb_a.h5").stat().st_mtime_ns == a_before      # kept, not redone
    for run in "abc":
        ra, rd = read_all(str(ref / f"perturb_{run}.h5"))
        ca, cd = read_all(str(cut / f"perturb_{run}.h5"))
        assert ca["status"] == "complete" and sorted(rd) == sorted(cd)
        for k in rd:
            np.testing.assert_array_equal(cd[k], rd[k], err_msg=f"{run}: {k}")
        # attribute a: the amplitude the run applied (run (a) stored the
        # configuration's 1e-12; the paper job's files store what was applied)
        assert ca["a"] == (0.0 if run == "a" else 1e-12), run
    # run (c)'s v0: v0_margin (default 10) x run (a)'s largest |v_top|
    attrs_a, attrs_c = read_all(str(cut / "perturb_a.h5"))[0], read_all(str(cut / "perturb_c.h5"))[0]
    assert attrs_c["v0_margin"] == 10.0 and "v0_margin" not in attrs_a   # where it made v0
    assert attrs_c["v0"] == 10.0 * attrs_a["v_top_max"] and attrs_c["v_ss"] == attrs_c["v0"]
    parser = cli.build_parser()
    hint = parser.parse_args(["perturb", "--datafile", "x"]).resume_hint
    assert "--resume continues" in hint


# --------------------------------------------------------------------------- the model
def test_stage_takes_the_model_from_the_sidecar(capsys, ramp_run, tmp_path):
    """``instability`` without --F-x runs at the start state's F_x (was: F_x = 0)."""
    status, out, err = run_cli(capsys, "instability", "--datafile",
                               ramp_run["unstable"] + ".data", "--out", tmp_path / "i",
                               "--t-max", 0.5)
    assert status == 0, err
    F = json.load(open(ramp_run["unstable"] + ".dump.json"))["F_x"]
    assert f"F_x = {F!r}" in out and "nan" not in out
    assert float(re.search(r"predicted ([0-9.e+-]+) ->", out).group(1)) > 0, out
    with h5py.File(tmp_path / "i" / "instability.h5") as fh:
        assert fh.attrs["F_x"] == F and fh.attrs["complex_pair"]
        assert fh.attrs["predicted_growth_rate"] > 0


def test_conflicting_value_needs_override(capsys, ramp_run, tmp_path):
    status, _, err = run_cli(capsys, "perturb", "--datafile", ramp_run["stable"] + ".data",
                             "--F-x", "0.1", "--out", tmp_path / "p", "--t-max", 0.1)
    F = json.load(open(ramp_run["stable"] + ".dump.json"))["F_x"]
    assert status == 2
    assert_one_line_error(err, f"--F-x 0.1 contradicts F_x = {F!r}", "--override")
    assert not (tmp_path / "p").exists()
    status, _, err = run_cli(capsys, "perturb", "--datafile", ramp_run["stable"] + ".data",
                             "--set", "k_n=3e5", "--out", tmp_path / "p", "--t-max", 0.1)
    assert status == 2
    assert_one_line_error(err, "--set k_n=300000.0 contradicts k_n = 200000.0")


def test_instability_from_a_stable_state_refuses(capsys, ramp_run, tmp_path):
    status, out, err = run_cli(capsys, "instability", "--datafile",
                               ramp_run["stable"] + ".data", "--out", tmp_path / "i",
                               "--t-max", 1, "--quiet")
    assert status == 2
    assert_one_line_error(err, f"F_x = {ramp_run['F_stable']!r} is linearly stable",
                          "every eigenvalue certified real", "--allow-stable")
    # nothing written, and the folder this run made for --out is gone again
    assert not os.path.exists(tmp_path / "i")
    status, out, err = run_cli(capsys, "instability", "--datafile",
                               ramp_run["stable"] + ".data", "--out", tmp_path / "i",
                               "--t-max", 0.2, "--quiet", "--allow-stable")
    assert status == 0
    assert "predicted none (the start is linearly stable: real)" in out and "nan" not in out


# --------------------------------------------------------------------------- jacobian
@pytest.fixture()
def wrong_k_n(ramp_run, tmp_path):
    """The stable equilibrium dump with a sidecar whose k_n, k_t are 100x too large."""
    dump = tmp_path / "wrong.dump"
    shutil.copyfile(ramp_run["stable"] + ".dump", dump)
    side = json.load(open(ramp_run["stable"] + ".dump.json"))
    side.update(k_n=100 * side["k_n"], k_t=100 * side["k_t"])
    (tmp_path / "wrong.dump.json").write_text(json.dumps(side))
    return dump


def test_jacobian_refuses_a_non_equilibrium(capsys, wrong_k_n, tmp_path):
    out = tmp_path / "K.npz"
    status, stdout, err = run_cli(capsys, "jacobian", wrong_k_n, "-o", out)
    assert status == 2 and not out.exists() and "complex pair" not in stdout
    assert_one_line_error(err, "is not an equilibrium of its parameters", "round-off floor",
                          "--allow-residual")
    status, stdout, err = run_cli(capsys, "jacobian", wrong_k_n, "-o", out, "--allow-residual")
    assert status == 0 and "WARNING" in err and "WARNING" in stdout
    assert int(np.load(out)["equilibrium"]) == 0


def test_jacobian_equilibrium_and_conflicts(capsys, ramp_run, tmp_path):
    dump = ramp_run["stable"] + ".dump"
    status, stdout, _ = run_cli(capsys, "jacobian", dump, "-o", tmp_path / "K.npz")
    assert status == 0 and "complex pair: no" in stdout
    assert int(np.load(tmp_path / "K.npz")["equilibrium"]) == 1
    status, _, err = run_cli(capsys, "jacobian", dump, "-o", tmp_path / "L.npz", "--k-n", 3e5)
    assert status == 2
    assert_one_line_error(err, "--k-n 300000.0 contradicts k_n = 200000.0", "--override")


@pytest.mark.parametrize("target", ["dir/", "dir", "missing/K.npz", "K.txt"])
def test_jacobian_output_must_be_an_npz_file(capsys, ramp_run, tmp_path, target):
    (tmp_path / "dir").mkdir()
    status, _, err = run_cli(capsys, "jacobian", ramp_run["stable"] + ".dump", "-o",
                             str(tmp_path / target) + ("/" if target.endswith("/") else ""))
    assert status == 2
    assert_one_line_error(err, "-o/--output")
    assert os.listdir(tmp_path / "dir") == []


# --------------------------------------------------------------------------- Ctrl-C, MPI
def test_ctrl_c_in_a_ramp(relaxed, tmp_path):
    out = tmp_path / "r"
    cmd = [CLI, "ramp", "--datafile", relaxed.datafile, "--out", str(out), "--dF-x", "0.01",
           "--tol", "1e-3", "--quiet"]
    proc = subprocess.Popen(cmd, env=cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    t0 = time.monotonic()
    while not (out / "ramp.h5").exists() and proc.poll() is None and time.monotonic() - t0 < 60:
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    stdout, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (stdout, err)
    assert err.strip().splitlines() == [
        "remote-trigger ramp: interrupted; ramp.h5 holds the equilibria up to its last "
        "checkpoint (at most 5 s old): the same command with --resume continues from there "
        "(bitwise the same result)"], err
    resumed = subprocess.run(cmd + ["--resume"], env=cli_env(), capture_output=True, text=True,
                             timeout=120)
    assert resumed.returncode == 0, resumed.stderr


@pytest.mark.mpi
def test_mpi_only_rank_0_prints_global_numbers(ramp_run, tmp_path):
    def run(*argv, np_=1):
        pre = [MPIRUN, "-np", str(np_)] if np_ > 1 else []
        return subprocess.run(pre + [CLI, *map(str, argv)], env=cli_env(), capture_output=True,
                              text=True, timeout=120)

    demo = {n: run("demo", "--n", 40, "--steps", 4000, "--out", tmp_path / f"d{n}", np_=n)
            for n in (1, 2)}
    for n, p in demo.items():
        assert p.returncode == 0, p.stderr
        assert p.stdout.count("demo: settled") == 1, p.stdout
    contacts = {n: [ln for ln in p.stdout.splitlines() if "contacts" in ln]
                for n, p in demo.items()}
    assert contacts[1] == contacts[2]
    jac = run("jacobian", ramp_run["stable"] + ".dump", "-o", tmp_path / "K.npz", np_=2)
    assert jac.returncode == 0 and jac.stdout.count("jacobian:") == 1, jac.stdout
    bad = run("ramp", "--datafile", tmp_path / "missing.data", np_=2)
    assert bad.returncode == 2 and bad.stderr.count("error") == 1, bad.stderr
    nf = run("normal-form", "-o", tmp_path / "nf", "--eps", 0.1, "--tau", "inf", np_=2)
    assert nf.returncode == 0 and nf.stdout.count("normal form, delta") == 1, nf.stdout
    acc = run("accuracy", "--quick", "-o", tmp_path / "acc", np_=2)
    assert acc.returncode == 2 and acc.stderr.count("run it without mpirun") == 1, acc.stderr


def test_generate_refuses_to_overwrite(capsys, tmp_path):
    out = tmp_path / "p.data"
    assert run_cli(capsys, "generate", "--n", 20, "--seed", 1, "--output", out)[0] == 0
    before = out.read_bytes()
    status, _, err = run_cli(capsys, "generate", "--n", 20, "--seed", 2, "--output", out)
    assert status == 2 and out.read_bytes() == before
    assert_one_line_error(err, "exists", "--overwrite", "nothing was written")
    assert run_cli(capsys, "generate", "--n", 20, "--seed", 2, "--output", out,
                   "--overwrite")[0] == 0
    assert out.read_bytes() != before
    # -o is --output, as for jacobian and normal-form
    status, _, err = run_cli(capsys, "generate", "--n", 20, "--seed", 3, "-o", out)
    assert status == 2 and out.read_bytes() != before
    assert run_cli(capsys, "generate", "--n", 20, "--seed", 3, "-o", tmp_path / "q.data")[0] == 0
    assert (tmp_path / "q.data").exists()


def test_stages_chain_by_their_defaults(capsys, tmp_path, monkeypatch):
    """generate -> relax -> ramp -> jacobian with no file named: relax starts
    from generate's packing.data, ramp from OUT/relax/equilibrium.data, and
    jacobian writes DUMP's name with .npz beside it (a second run refuses to
    overwrite it). Without the file, the one-line error names the default."""
    monkeypatch.chdir(tmp_path)
    status, _, err = run_cli(capsys, "relax", "--quiet")
    assert status == 2
    assert_one_line_error(err, "'packing.data'")
    status, _, err = run_cli(capsys, "ramp", "--quiet", "--out", "o2")
    assert status == 2
    assert_one_line_error(err, repr(os.path.join("o2", "relax", "equilibrium.data")))
    assert list(tmp_path.iterdir()) == []
    assert run_cli(capsys, "generate", "--n", 20, "--seed", 1)[0] == 0
    status, out, _ = run_cli(capsys, "relax", "--quiet")
    assert status == 0 and "a ramp starts from out/relax/equilibrium.data" in out
    status, out, _ = run_cli(capsys, "ramp", "--quiet", "--dF-x", 0.05, "--tol", 0.01,
                             "--set", "F_x_max=0.1")
    with h5py.File(tmp_path / "out" / "ramp.h5", "r") as f:
        start = f.attrs["datafile"]
    assert os.path.samefile(start, tmp_path / "out" / "relax" / "equilibrium.data"), start
    dump = os.path.join("out", "relax", "equilibrium.dump")
    status, out, _ = run_cli(capsys, "jacobian", dump)
    assert status == 0 and "written: out/relax/equilibrium.npz" in out
    assert (tmp_path / "out" / "relax" / "equilibrium.npz").is_file()
    status, _, err = run_cli(capsys, "jacobian", dump)
    assert status == 2
    assert_one_line_error(err, "'out/relax/equilibrium.npz' exists", "--overwrite")


def test_jacobian_default_output_name():
    from remote_trigger.pywrap.cli.jacobian import default_output

    assert default_output("a/equilibrium.dump") == "a/equilibrium.npz"
    assert default_output("a/step_00001.dump") == "a/step_00001.npz"
    assert default_output("state") == "state.npz"
    assert default_output("K.npz") == "K.npz.npz"      # never the input itself


def test_jacobian_refuses_to_overwrite(capsys, ramp_run, tmp_path):
    dump = ramp_run["stable"] + ".dump"
    out = tmp_path / "K.npz"
    assert run_cli(capsys, "jacobian", dump, "-o", out)[0] == 0
    before = out.read_bytes()
    status, _, err = run_cli(capsys, "jacobian", dump, "-o", out)
    assert status == 2 and out.read_bytes() == before
    assert_one_line_error(err, "exists", "--overwrite", "nothing was written")
    assert run_cli(capsys, "jacobian", dump, "-o", out, "--overwrite")[0] == 0


# --------------------------------------------------------------------------- too large
def test_ramp_without_memory_for_the_verdict_stops_with_the_reason(capsys, relaxed, tmp_path,
                                                                   monkeypatch):
    """A point whose dense verdict does not fit in memory ends the ramp with
    exit status 1 and one line naming n and both amounts (no verdict guessed)."""
    monkeypatch.setenv("REMOTE_TRIGGER_MEMORY_GB", "1e-6")
    status, _, err = run_cli(capsys, "ramp", "--datafile", relaxed.datafile, "--out",
                             tmp_path / "o", "--dF-x", "0.02", "--quiet")
    assert status == 1
    assert_one_line_error(err, "no stability verdict: the dense verdict for n = ",
                          "KiB available (REMOTE_TRIGGER_MEMORY_GB")
    monkeypatch.setenv("REMOTE_TRIGGER_MEMORY_GB", "lots")
    status, _, err = run_cli(capsys, "ramp", "--datafile", relaxed.datafile, "--out",
                             tmp_path / "p", "--dF-x", "0.02", "--quiet")
    assert status == 2
    assert_one_line_error(err, "REMOTE_TRIGGER_MEMORY_GB = 'lots': not a positive number")


def test_ramp_from_an_unrelaxed_packing_says_so(capsys, tmp_path, packing_file, relaxed):
    """A ramp started from ``generate``'s loose packing (not an equilibrium) ends
    with a note that its first point was settled by damped dynamics with friction,
    not by the relax protocol; from relax's equilibrium there is no such note."""
    args = ("--quiet", "--dF-x", "0.05", "--set", "F_x_max=0.05")
    status, out, _ = run_cli(capsys, "ramp", "--datafile", packing_file,
                             "--out", tmp_path / "loose", *args)
    assert status in (0, 1)
    note = [ln for ln in out.splitlines() if "note:" in ln]
    assert len(note) == 1 and f"{packing_file} was not an equilibrium" in note[0], out
    assert "relax/equilibrium.data" in note[0], note
    status, out, _ = run_cli(capsys, "ramp", "--datafile", relaxed.datafile,
                             "--out", tmp_path / "relaxed", *args)
    assert "note:" not in out, out


def test_every_command_says_what_it_does_and_writes():
    """``remote-trigger COMMAND --help`` starts with what the command does (a
    description, not only its options), and every stage names its output."""
    import argparse

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        assert p.description and len(p.description) > 60, name
    for name in ("relax", "ramp", "perturb", "instability"):
        assert "OUT/" in sub.choices[name].description, name


def test_a_path_with_a_space_is_refused_before_lammps(capsys, relaxed, tmp_path):
    """LAMMPS splits its commands at whitespace: such a --datafile was a LAMMPS
    "Cannot open file" crash (exit 1), such an --out failed only after the
    whole relaxation. Now exit 2 at once, nothing created; in a folder whose
    own name has a space, relative paths without one still work."""
    spaced = tmp_path / "sp ace"
    spaced.mkdir()
    data = spaced / "my packing.data"
    shutil.copy(relaxed.datafile, data)
    status, _, err = run_cli(capsys, "relax", "--datafile", data, "--out", tmp_path / "o")
    assert status == 2
    assert_one_line_error(err, f"--datafile '{data}'", "LAMMPS splits its commands at "
                          "whitespace")
    out = tmp_path / "out dir"
    status, _, err = run_cli(capsys, "relax", "--datafile", relaxed.datafile, "--out", out)
    assert status == 2
    assert_one_line_error(err, f"--out '{out}'")
    assert not out.exists() and not (tmp_path / "o").exists()
    # generate's data file, which every stage then refused
    status, _, err = run_cli(capsys, "generate", "--n", 20, "-o", spaced / "new packing.data")
    assert status == 2
    assert_one_line_error(err, f"--output '{spaced / 'new packing.data'}'", "LAMMPS splits")
    assert not (spaced / "new packing.data").exists()
    shutil.copy(relaxed.datafile, spaced / "p.data")
    here = os.getcwd()
    try:
        os.chdir(spaced)
        status, _, err = run_cli(capsys, "perturb", "--datafile", "p.data", "--out", "o",
                                 "--quiet", "--runs", "a", "--t-max", "0.1")
    finally:
        os.chdir(here)
    assert status == 0, err
    assert (spaced / "o" / "perturb_a.h5").is_file()
    # the Python stages too (the relaxation ran whole, then write_dump failed)
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.stages.config import RampConfig, RelaxConfig

    with pytest.raises(ConfigError, match=r"^datafile '.*my packing.data': LAMMPS splits"):
        RelaxConfig(datafile=data)
    for stage, cfg in ((stages.relax, RelaxConfig(datafile=relaxed.datafile)),
                       (stages.ramp, RampConfig(datafile=relaxed.datafile))):
        with pytest.raises(ConfigError, match=r"^out '.*out dir': LAMMPS splits"):
            stage(cfg, str(out), quiet=True)
        assert not out.exists()


def test_more_ranks_than_cores_is_warned(monkeypatch, capsys):
    """--np 4 on 2 cores ran several times slower than --np 2, with no word."""
    from remote_trigger.pywrap.runtime import relaunch

    monkeypatch.setattr(relaunch.os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    child = [sys.executable, "-c", "raise SystemExit(3)"]
    assert relaunch.call_under_mpirun(child, dict(os.environ), "paper", 3) == 3
    assert capsys.readouterr().err.strip() == (
        "remote-trigger paper: warning: 3 MPI ranks compute on 2 cores: they share cores and "
        "wait by polling, which makes the job several times slower; give --np 2 or fewer")
    assert relaunch.call_under_mpirun(child, dict(os.environ), "paper", 2) == 3
    assert capsys.readouterr().err == ""


@pytest.fixture
def default_sigint():
    """Python's own SIGINT handler for the test (the one a process starts with
    is inherited: SIG_IGN in a job put in the background by a shell without
    job control), the inherited one restored after it."""
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, inherited)


def test_the_relauncher_prints_the_interrupt_line(capsys, default_sigint):
    """The interrupt line of a re-launched job was printed by its rank 0,
    which mpirun could kill before the Python handler ran (inside a LAMMPS
    call): in one CI run an interrupted `paper --np 2` printed nothing. The
    re-launching process now prints it once its child has ended: after a
    Ctrl-C it received, or a child's status 130; its ranks print nothing."""
    from remote_trigger.pywrap.runtime import relaunch

    line = "remote-trigger paper: interrupted; the same command with --resume continues"
    # a Ctrl-C this process receives while the child runs (the child ends 0)
    child = [sys.executable, "-c", "import os, signal, time; "
             "os.kill(os.getppid(), signal.SIGINT); time.sleep(0.2)"]
    assert relaunch.call_under_mpirun(child, dict(os.environ), "paper", 1,
                                      "the same command with --resume continues") == 130
    assert capsys.readouterr().err.splitlines() == [line]
    # a child that ends 130 (its ranks got the Ctrl-C alone)
    child = [sys.executable, "-c", "raise SystemExit(130)"]
    assert relaunch.call_under_mpirun(child, dict(os.environ), "ramp", 1) == 130
    assert capsys.readouterr().err.splitlines() == ["remote-trigger ramp: interrupted"]
    # any other end: no line, the child's status
    child = [sys.executable, "-c", "raise SystemExit(2)"]
    assert relaunch.call_under_mpirun(child, dict(os.environ), "paper", 1) == 2
    assert capsys.readouterr().err == ""
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    # a rank of a re-launched job ends at Ctrl-C without a word
    code = ("import os, signal, sys, types\n"
            "from remote_trigger.pywrap.cli import exit_on_interrupt\n"
            "exit_on_interrupt(types.SimpleNamespace(command='paper', resume_hint='h'))\n"
            "os.kill(os.getpid(), signal.SIGINT)\n")
    for flag, err in (("1", ""), ("", "remote-trigger paper: interrupted; h\n")):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=dict(os.environ, **{relaunch.RELAUNCHED: flag}))
        assert (done.returncode, done.stderr) == (130, err)


@pytest.mark.mpi
def test_ctrl_c_of_a_relaunched_job_prints_one_line(tmp_path):
    """Ctrl-C (SIGINT to the terminal's process group) of `paper --np 2`: the
    re-launching process and rank 0 both printed the interrupt line (and,
    once, neither did: test_the_relauncher_prints_the_interrupt_line)."""
    out = tmp_path / "p"
    proc = subprocess.Popen([CLI, "paper", "--quick", "--np", "2", "--out", str(out)],
                            env=cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    t0 = time.monotonic()
    while not (out / "paper.json").exists() and proc.poll() is None \
            and time.monotonic() - t0 < 60:
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert [ln for ln in err.splitlines() if ln.strip()] == [
        "remote-trigger paper: interrupted; paper.json records every finished phase: the same "
        "command with --resume continues the job"], err


def test_one_run_at_a_time_in_an_output_folder(capsys, relaxed, tmp_path, monkeypatch):
    """A ramp and its own --resume started by mistake (or two paper jobs in one
    --out) both ran to the end, rewriting the same files. The command line
    now holds a lock on --out: a second run is refused while the first runs;
    the lock goes with the first run (any end, kill -9 too) and is not taken
    by the ranks of a re-launched job."""
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.runtime.outlock import lock_output_folder
    from remote_trigger.pywrap.runtime.relaunch import RELAUNCHED, call_under_mpirun

    out = tmp_path / "o"
    held = lock_output_folder(str(out))                 # "the first run"
    assert out.is_dir() and os.listdir(out) == []
    with pytest.raises(ConfigError, match="is in use by another run"):
        lock_output_folder(str(out))
    status, _, err = run_cli(capsys, "relax", "--datafile", relaxed.datafile, "--out", out,
                             "--quiet")
    assert status == 2
    assert_one_line_error(err, f"--out '{out}' is in use by another run")
    assert os.listdir(out) == []
    monkeypatch.setenv(RELAUNCHED, "1")
    assert lock_output_folder(str(out)) is None        # a re-launched job's rank
    monkeypatch.delenv(RELAUNCHED)
    # a job re-launched under mpirun inherits the lock: its processes hold it
    # after the re-launching one is gone (here a grandchild outlives both)
    gone = tmp_path / "gone"
    job = [sys.executable, "-c", "import subprocess, sys; subprocess.Popen([sys.executable, "
           "'-c', 'import os, sys, time\\nwhile not os.path.exists(sys.argv[1]): "
           f"time.sleep(0.01)', {str(gone)!r}], close_fds=False)"]
    try:
        assert call_under_mpirun(job, dict(os.environ), "relax", 1, lock=held) == 0
        os.close(held)                                 # the first run ends ...
        with pytest.raises(ConfigError, match="is in use by another run"):
            lock_output_folder(str(out))               # ... its job's processes not yet
    finally:
        gone.write_text("")
    t0 = time.monotonic()
    while True:                                        # the grandchild ends (not our child)
        try:
            os.close(lock_output_folder(str(out)))
            break
        except ConfigError:
            assert time.monotonic() - t0 < 60, "the job's lock outlived its processes"
            time.sleep(0.01)
    status, _, err = run_cli(capsys, "perturb", "--datafile", relaxed.datafile, "--out", out,
                             "--quiet", "--runs", "a", "--t-max", "0.1")
    assert status == 0, err
    os.close(lock_output_folder(str(out)))             # and released it


def test_a_config_folder_is_named_as_one(capsys, tmp_path):
    """``--config .`` (a folder) said "config file does not exist"."""
    status, _, err = run_cli(capsys, "ensemble", "--config", tmp_path, "--out", tmp_path / "e")
    assert status == 2
    assert_one_line_error(err, f"config file is a folder, not a TOML or JSON file: "
                               f"'{tmp_path}'")
