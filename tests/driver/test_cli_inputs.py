"""The command line and its files, as a new user meets them: what a run would
destroy or silently take is refused, naming the value (--log over a data
file, --set beside the option of one key, a demo over its earlier result),
inputs are named for what they are, and ``ramp --resume`` finds its start."""
import os
import shutil

import pytest

from .test_cli_errors import assert_one_line_error, run_cli


def test_log_never_overwrites_anything_but_a_lammps_log(capsys, relaxed, tmp_path):
    """--log naming the start file (or any file that is not a LAMMPS log) is
    refused before LAMMPS truncates it; a log in a folder still to be made
    (inside --out) is written there, and a LAMMPS log may be written again."""
    start = tmp_path / "start.data"
    shutil.copyfile(relaxed.datafile, start)
    for ext in (".dump", ".dump.json"):
        shutil.copyfile(relaxed.datafile[:-len(".data")] + ext, str(start)[:-5] + ext)
    before = start.read_bytes()
    argv = ["perturb", "--datafile", start, "--quiet", "--runs", "a", "--t-max", "0.1"]
    status, _, err = run_cli(capsys, *argv, "--out", tmp_path / "o1", "--log", start)
    assert status == 2
    assert_one_line_error(err, "--log", "start.data", "is not a LAMMPS log",
                          "nothing was overwritten")
    assert start.read_bytes() == before and not (tmp_path / "o1").exists()
    log = tmp_path / "o2" / "logs" / "perturb.log"
    assert run_cli(capsys, *argv, "--out", tmp_path / "o2", "--log", log)[0] == 0
    assert log.read_bytes().startswith(b"LAMMPS (")
    assert run_cli(capsys, *argv, "--out", tmp_path / "o3", "--log", log)[0] == 0
    status, _, err = run_cli(capsys, *argv, "--out", tmp_path / "o4", "--log", tmp_path)
    assert status == 2
    assert_one_line_error(err, "is a folder")


@pytest.mark.parametrize("extra, needles", [
    (["--set", "mu=0.5", "--mu", "0.7"], ["--set mu=0.5 and --mu both set mu"]),
    (["--set", "dF_x=1e-3", "--dF-x", "2e-3"], ["--set dF_x=1e-3 and --dF-x both set dF_x"]),
    (["--set", "F_x=nan"], ["F_x must be a finite number, got F_x = 'nan' (--set F_x=)"]),
    (["--F-x", "inf"], ["F_x must be a finite number, got F_x = inf (--F-x)"]),
    (["--set", "mu=0.5"], ["--set mu=0.5 contradicts mu = 1.0", "leave --set mu= out"]),
])
def test_set_and_options_name_what_was_given(capsys, relaxed, tmp_path, extra, needles):
    """--set KEY= beside the option of KEY was taken silently (--set won), and
    the messages named the option for a --set value (``--mu 0.5`` contradicts)."""
    status, _, err = run_cli(capsys, "ramp", "--datafile", relaxed.datafile, "--out",
                             tmp_path / "o", "--quiet", *extra)
    assert status == 2
    assert_one_line_error(err, *needles)
    assert not (tmp_path / "o").exists()


def test_demo_keeps_an_earlier_result(capsys, tmp_path):
    """demo into a folder holding its settled.data: refused (it was replaced),
    --overwrite replaces it; a run too short for any contact says so (it
    printed a median of nan)."""
    out = tmp_path / "d"
    status, text, _ = run_cli(capsys, "demo", "--n", 20, "--steps", 0, "--out", out)
    assert status == 0 and "no disk-disk contact yet" in text and "median" not in text
    before = (out / "settled.data").read_bytes()
    status, _, err = run_cli(capsys, "demo", "--n", 20, "--steps", 10, "--out", out)
    assert status == 2
    assert_one_line_error(err, "already holds demo results", "nothing was overwritten")
    assert (out / "settled.data").read_bytes() == before
    status, text, _ = run_cli(capsys, "demo", "--n", 20, "--steps", 10, "--out", out,
                              "--overwrite")
    assert status == 0 and (out / "settled.data").read_bytes() != before


def test_inputs_named_for_what_they_are(capsys, packing_file, tmp_path):
    """A folder given as --datafile is called a folder (it "did not exist"); a
    data file given to jacobian is refused as no dump even where the .npz it
    would write exists (that was the error named); an empty --output is
    called empty (it was "a folder: ''")."""
    status, _, err = run_cli(capsys, "relax", "--datafile", tmp_path, "--out", tmp_path / "o")
    assert status == 2
    assert_one_line_error(err, "datafile is a folder, not a data file")
    data = tmp_path / "p.data"
    shutil.copyfile(packing_file, data)
    (tmp_path / "p.npz").write_bytes(b"keep")
    status, _, err = run_cli(capsys, "jacobian", data)
    assert status == 2
    assert_one_line_error(err, "expected 'ITEM: TIMESTEP'",
                          "this is a LAMMPS data file: give the dump written beside it")
    assert (tmp_path / "p.npz").read_bytes() == b"keep"
    # a file that is neither gets no such hint
    other = tmp_path / "notes.dump"
    other.write_text("some text\n")
    status, _, err = run_cli(capsys, "jacobian", other)
    assert status == 2 and "data file" not in err
    assert_one_line_error(err, "expected 'ITEM: TIMESTEP'")
    status, _, err = run_cli(capsys, "generate", "--output", "")
    assert status == 2
    assert_one_line_error(err, "--output must name a file, got an empty name")


def test_ramp_resume_without_datafile_takes_the_recorded_start(capsys, relaxed, tmp_path):
    """``ramp --out O --resume`` continues the ramp O/ramp.h5 began, from the
    start file it names (it took O/relax/equilibrium.data, absent here)."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    out = tmp_path / "o"
    cfg = RampConfig(datafile=relaxed.datafile, dF_x=0.02, tol=1e-3)
    assert stages.ramp(cfg, str(out), quiet=True, stop_after=1).status == "interrupted"
    assert not (out / "relax").exists()
    status, text, err = run_cli(capsys, "ramp", "--out", out, "--dF-x", 0.02, "--tol", 1e-3,
                                "--resume", "--quiet")
    assert status == 0, err
    assert "F_x^c in [" in text


def test_ramp_resume_without_datafile_from_another_folder(capsys, relaxed, tmp_path,
                                                        monkeypatch):
    """A ramp begun with a relative --datafile, resumed without it from
    another working folder, said "datafile does not exist: OUT/relax/
    equilibrium.data"; so did a truncated ramp.h5. The start file's absolute
    path is recorded; an unreadable ramp.h5 and a start file gone are named."""
    import h5py

    from remote_trigger.pywrap.stages.ramp_file import DATAFILE_ABSPATH

    shutil.copy(relaxed.datafile, tmp_path / "start.data")
    shutil.copy(relaxed.datafile[:-len(".data")] + ".dump", tmp_path / "start.dump")
    shutil.copy(relaxed.datafile[:-len(".data")] + ".dump.json", tmp_path / "start.dump.json")
    (tmp_path / "elsewhere").mkdir()
    args = ("--dF-x", 0.02, "--tol", 1e-3, "--quiet")
    monkeypatch.chdir(tmp_path)
    assert run_cli(capsys, "ramp", "--datafile", "start.data", "--out", "o", *args)[0] == 0
    with h5py.File(tmp_path / "o" / "ramp.h5", "r") as fh:
        assert fh.attrs["datafile"] == "start.data"
        assert fh.attrs[DATAFILE_ABSPATH] == str(tmp_path / "start.data")
    monkeypatch.chdir(tmp_path / "elsewhere")
    status, text, err = run_cli(capsys, "ramp", "--out", tmp_path / "o", "--resume", *args)
    assert status == 0 and err == "", err
    (tmp_path / "start.data").rename(tmp_path / "gone.data")
    status, _, err = run_cli(capsys, "ramp", "--out", tmp_path / "o", "--resume", *args)
    assert status == 2
    relaxed_start = tmp_path / "o" / "relax" / "equilibrium.data"
    assert_one_line_error(err, f"cannot resume {tmp_path / 'o' / 'ramp.h5'} without --datafile: "
                               f"its start file ('{tmp_path / 'start.data'}' or 'start.data' or "
                               f"'{relaxed_start}') is not found from "
                               f"'{tmp_path / 'elsewhere'}'; give --datafile")
    # relax's equilibrium in the folder (a relax + ramp folder moved): the same
    # start (its SHA-256), found there
    relaxed_start.parent.mkdir()
    for ext in ("data", "dump", "dump.json"):
        shutil.copy(tmp_path / f"start.{ext}" if ext != "data" else tmp_path / "gone.data",
                    relaxed_start.parent / f"equilibrium.{ext}")
    status, _, err = run_cli(capsys, "ramp", "--out", tmp_path / "o", "--resume", *args)
    assert status == 0, err
    (tmp_path / "o" / "ramp.h5").write_bytes(b"truncated")
    status, _, err = run_cli(capsys, "ramp", "--out", tmp_path / "o", "--resume", *args)
    assert status == 2
    assert_one_line_error(err, f"cannot resume: {tmp_path / 'o' / 'ramp.h5'} is not a readable "
                               f"HDF5 file")


def test_a_refusal_leaves_no_empty_out_folder(capsys, relaxed, tmp_path):
    """A command refused after it made --out removes the folders it made
    (empty), and keeps an --out that existed before, and any file."""
    args = ("ramp", "--datafile", relaxed.datafile, "--dt", 0.5, "--quiet")
    status, _, err = run_cli(capsys, *args, "--out", tmp_path / "new" / "deeper")
    assert status == 2 and "stability limit" in err
    assert os.listdir(tmp_path) == []
    (tmp_path / "old").mkdir()
    (tmp_path / "kept").mkdir()
    (tmp_path / "kept" / "note.txt").write_text("mine")
    for out in ("old", "kept"):
        status, _, err = run_cli(capsys, *args, "--out", tmp_path / out)
        assert status == 2 and "stability limit" in err
    assert sorted(os.listdir(tmp_path)) == ["kept", "old"]
    assert os.listdir(tmp_path / "old") == [] and os.listdir(tmp_path / "kept") == ["note.txt"]


def test_a_ramps_log_holds_no_warning_of_its_force_evaluations(capsys, relaxed, tmp_path):
    """The driver's force evaluations run with no integrator on purpose; they
    leave no "No fixes with time integration" warning in the LAMMPS log
    (there were hundreds a ramp, and LAMMPS prints no warning after 100), and
    a ramp's log holds no warning at all."""
    log = tmp_path / "ramp.log"
    status, _, _ = run_cli(capsys, "ramp", "--datafile", relaxed.datafile, "--out",
                           tmp_path / "r", "--dF-x", "0.01", "--set", "F_x_max=0.03",
                           "--log", log)
    assert status in (0, 1)     # 1: no complex pair up to F_x_max (no result)
    text = log.read_text()
    assert text.count("\nrun ") > 20
    assert "WARNING" not in text
