"""Configuration of ``remote-trigger paper``: defaults, TOML, flags, errors."""
import json
import math
import os
import re

import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.paper.config import (
    PaperConfig, QUICK, PAPER, PAPER_F_X_C_MID, build_config)
from remote_trigger.pywrap.config import read_config_file
from remote_trigger.pywrap.jobs import paper
from remote_trigger.pywrap.cli import main as cli_main


def test_defaults_are_the_papers_parameters():
    cfg = PaperConfig()
    assert (cfg.n, cfg.k_n, cfg.F_y, cfg.mu, cfg.mu_low) == (100, 2e5, 3.0, 1.0, 0.8)
    assert cfg.k_t == pytest.approx(2 * 2e5 / 7)
    assert (cfg.a_paper, cfg.omega_p, cfg.B, cfg.w, cfg.mu_ss) == (1e-12, 0.01, 0.2, 0.4, 0.8)
    assert cfg.a is None                      # Fig. 5's amplitude is measured (fig5.py)
    assert 0 < cfg.fig5_window < 1 and cfg.mu_low == cfg.mu_ss * cfg.mu
    # "the same relative distance": paper's loads over the midpoint of its bracket
    assert cfg.fig4_ratio == pytest.approx(0.012 / 0.01055)
    assert PAPER_F_X_C_MID == pytest.approx(0.5 * (PAPER["F_x_c_mu1_low"]
                                                   + PAPER["F_x_c_mu1_high"]))


def test_precedence_defaults_quick_toml_flags(tmp_path):
    toml = tmp_path / "c.toml"
    toml.write_text('seed = 7\nt_perturb = 123.0\nnf_tau = ["inf", 30.0]\n'
                    '[relax]\ng_settle = 0.4\n')
    cfg = build_config(str(toml), {"t_perturb": 50.0}, quick=True)
    assert cfg.quick and cfg.n == QUICK["n"] and cfg.dF_x == QUICK["dF_x"]   # quick preset
    assert cfg.seed == 7                                                      # file
    assert cfg.t_perturb == 50.0                                              # flag wins
    assert cfg.nf_tau == (math.inf, 30.0)
    # [relax] tables merge: the quick preset's settle_steps and the file's g_settle
    assert cfg.relax == dict(QUICK["relax"], g_settle=0.4)


def test_quick_from_the_file(tmp_path):
    toml = tmp_path / "q.toml"
    toml.write_text("quick = true\n")
    assert build_config(str(toml)).n == QUICK["n"]


@pytest.mark.parametrize("text, key", [
    ("sead = 3\n", "sead"),                       # misspelt key
    ("[relax]\nmu = 0.5\n", "relax.mu"),           # set by the job itself
    ("[ramp]\ntol = 1e-6\n", "ramp"),              # no such table
])
def test_toml_unknown_keys_are_named(tmp_path, text, key):
    toml = tmp_path / "bad.toml"
    toml.write_text(text)
    with pytest.raises(ConfigError) as exc:
        build_config(str(toml))
    assert key in str(exc.value)


def test_reserved_relax_keys_point_to_what_sets_them():
    """A key of [relax] that the job sets itself is refused with advice that
    can be followed: the top-level key of that name where there is one (and
    then it exists), else what sets it (no top-level key is named that the
    configuration would refuse as unknown)."""
    from remote_trigger.pywrap.jobs.ensemble.config import (
        EnsembleConfig, RELAX_SET_BY_JOB as ENSEMBLE_SET)
    from remote_trigger.pywrap.jobs.paper.config import RELAX_SET_BY_JOB as PAPER_SET

    for cls, reserved in ((PaperConfig, PAPER_SET), (EnsembleConfig, ENSEMBLE_SET)):
        for key, why in reserved.items():
            with pytest.raises(ConfigError) as exc:
                cls(relax={key: 1.0})
            msg = str(exc.value)
            assert f"relax.{key} is set by" in msg, msg
            if why is None:
                assert key in cls.names(), (cls.__name__, key)
                assert f"use the top-level key {key!r} instead" in msg, msg
            else:
                assert key not in cls.names(), (cls.__name__, key)
                assert why in msg and "use the top-level key" not in msg, msg


def test_unknown_relax_key_is_named_by_relaxconfig(tmp_path, capsys):
    """Named by RelaxConfig when the job's configuration is built: before a
    re-run into the folder of a finished job removes its outputs (the key was
    found only at the relaxation, after they were gone)."""
    with pytest.raises(ConfigError, match="settel_steps"):
        PaperConfig(relax={"settel_steps": 10})
    with pytest.raises(ConfigError, match="settle_steps must be >= 0"):
        PaperConfig(relax={"settle_steps": -1})
    old = tmp_path / "old"
    old.mkdir()
    for name in ("paper.json", "report.md", "relax.h5"):
        (old / name).write_text("x")
    toml = tmp_path / "typo.toml"
    toml.write_text("[relax]\nsettel_steps = 100\n")
    assert cli_main(["paper", "--out", str(old), "--quick", "--config", str(toml)]) == 2
    assert "settel_steps" in capsys.readouterr().err
    assert sorted(os.listdir(old)) == ["paper.json", "relax.h5", "report.md"]


def test_toml_syntax_error_and_missing_file(tmp_path):
    toml = tmp_path / "broken.toml"
    toml.write_text("n = = 3\n")
    with pytest.raises(ConfigError, match="broken.toml"):
        read_config_file(str(toml))
    with pytest.raises(ConfigError, match="nothere.toml"):
        read_config_file(str(tmp_path / "nothere.toml"))


def test_a_json_config_file_is_read_as_json(tmp_path):
    """A job's config.json (whose nulls TOML cannot write) is a config file too;
    broken JSON and a JSON list are refused naming the file."""
    good = tmp_path / "config.json"
    good.write_text('{"inertia_I0": null, "n": [16], "relax": {"clearance": "all"}}')
    assert read_config_file(str(good)) == {"inertia_I0": None, "n": [16],
                                           "relax": {"clearance": "all"}}
    bad = tmp_path / "bad.json"
    bad.write_text('{"n": [16],}')
    with pytest.raises(ConfigError, match="bad.json' is not valid JSON"):
        read_config_file(str(bad))
    bad.write_text('[1, 2]')
    with pytest.raises(ConfigError, match="bad.json' holds a JSON list, not an object"):
        read_config_file(str(bad))
    # TOML syntax in a .json file is JSON that fails, not TOML that passes
    bad.write_text('n = [16]\n')
    with pytest.raises(ConfigError, match="not valid JSON"):
        read_config_file(str(bad))


@pytest.mark.parametrize("key, val", [
    ("n", 7), ("n", 2), ("seed", -1), ("mu", 0.0), ("mu_low", 1.0), ("dF_x", -1e-4),
    ("tol", 0.0), ("fig4_ratio", 0.9), ("fig5_window", 1.2), ("fig5_window", 0.0),
    ("fig5_window", 1.0), ("fig5_F_x", -0.01), ("omega_p", 0.0), ("omega_p", -0.01),
    ("t_on", -1.0), ("fig5_dt_fraction", 1.0), ("fig5_v0_margin", 0.5), ("t_perturb", 0.0),
    ("mu_low", 0.7),
    ("record_every", 0), ("a", -1e-12), ("a_paper", -1e-12), ("nf_delta", 1.5),
    ("nf_eps", [0.1, 2.0]),
    ("nf_tau", [-1.0]), ("np", 0), ("n", "100"), ("quick", "yes"),
    ("k_n", math.inf), ("t_perturb", math.inf), ("mu", math.nan)])
def test_bad_values_name_the_key(key, val):
    with pytest.raises(ConfigError) as exc:
        PaperConfig.from_dict({key: val})
    assert key in str(exc.value)


@pytest.mark.parametrize("argv, words", [
    (["--n", "7"], ["n = 7"]),
    (["--set", "bogus=1"], ["bogus"]),
    (["--set", "novalue"], ["KEY=VALUE"]),
    (["--fig5-window", "1.5"], ["fig5_window = 1.5"]),
    (["--omega-p", "0"], ["omega_p = 0"]),
    (["--a=-1e-6"], ["a = -1e-06"]),
    (["--config", "/nonexistent/c.toml"], ["c.toml"]),
])
def test_cli_bad_options_exit_2(argv, words, tmp_path, capsys):
    status = cli_main(["paper", "--out", str(tmp_path / "o")] + argv)
    err = capsys.readouterr().err
    assert status == 2
    for w in words:
        assert w in err
    assert not (tmp_path / "o").exists()          # nothing was started


def test_cli_rejects_non_numbers(tmp_path):
    with pytest.raises(SystemExit) as exc:
        cli_main(["paper", "--out", str(tmp_path), "--seed", "one"])
    assert exc.value.code == 2


def test_flags_and_set_reach_the_config(tmp_path):
    parser = __import__("remote_trigger.pywrap.cli", fromlist=["x"]).build_parser()
    args = parser.parse_args(["paper", "--quick", "--seed", "5", "--dF-x", "0.003",
                              "--set", "nf_eps=[0.1,0.01]", "--set", "relax={\"g_settle\": 0.3}"])
    cfg = paper.config_from_args(args)
    assert cfg.quick and cfg.seed == 5 and cfg.dF_x == 0.003
    assert cfg.nf_eps == (0.1, 0.01) and cfg.relax["g_settle"] == 0.3


def test_relaunch_command_and_resolved_config(tmp_path, monkeypatch):
    """--np 2 re-launches `mpirun -np 2 python -m ...cli paper` with the same config."""
    import subprocess

    seen = {}

    def fake_call(cmd, env=None, pass_fds=()):
        seen["cmd"] = cmd
        seen["pass_fds"] = pass_fds
        i = cmd.index("--resolved-config")
        with open(cmd[i + 1]) as fh:
            seen["cfg"] = json.load(fh)
        seen["env"] = env
        return 0

    monkeypatch.setattr(subprocess, "call", fake_call)
    monkeypatch.delenv("REMOTE_TRIGGER_PAPER_CHILD", raising=False)
    out = str(tmp_path / "o")
    assert cli_main(["paper", "--quick", "--np", "2", "--seed", "4", "--out", out]) == 0
    cmd = seen["cmd"]
    assert os.path.basename(cmd[0]) == "mpirun" and cmd[1:3] == ["-np", "2"]
    assert cmd[cmd.index("--out") + 1] == out and "paper" in cmd
    assert seen["env"]["REMOTE_TRIGGER_PAPER_CHILD"] == "1"
    assert len(seen["pass_fds"]) == 1           # the output folder's lock, inherited
    parser = __import__("remote_trigger.pywrap.cli", fromlist=["x"]).build_parser()
    path = tmp_path / "resolved.json"
    path.write_text(json.dumps(seen["cfg"]))
    again = paper.config_from_args(parser.parse_args(
        ["paper", "--resolved-config", str(path)]))
    assert again == build_config(None, {"np": 2, "seed": 4}, quick=True)


def test_output_folder_rules(tmp_path):
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="not written by"):
        paper.prepare_out(str(foreign))
    afile = tmp_path / "afile"
    afile.write_text("")
    with pytest.raises(ConfigError, match="afile"):
        paper.prepare_out(str(afile))
    old = tmp_path / "old"
    (old / "ramp_mu1" / "ramp").mkdir(parents=True)
    for name in ("paper.json", "report.md", "relax.h5", "fig3_eigenvalues.png", "keep.txt",
                 "figures-notes.md"):
        (old / name).write_text("x")
    before = sorted(os.listdir(old))
    # an earlier job's folder: refused without overwrite, nothing deleted
    with pytest.raises(ConfigError, match="holds an earlier .* --overwrite"):
        paper.prepare_out(str(old))
    assert sorted(os.listdir(old)) == before
    paper.prepare_out(str(old), overwrite=True)
    assert sorted(os.listdir(old)) == ["figures-notes.md", "keep.txt"]


def test_a_new_job_in_an_earlier_jobs_folder_needs_overwrite(tmp_path, capsys):
    """``paper --out D`` where D holds an earlier job: exit 2, one line naming D
    and the two ways on, nothing deleted; with ``--resume --overwrite`` too
    (they contradict each other)."""
    old = tmp_path / "old"
    old.mkdir()
    for name in ("paper.json", "report.md", "relax.h5"):
        (old / name).write_text("x")
    assert cli_main(["paper", "--out", str(old), "--quick"]) == 2
    err = capsys.readouterr().err
    assert str(old) in err and "--resume" in err and "--overwrite" in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert cli_main(["paper", "--out", str(old), "--quick", "--np", "2"]) == 2
    assert "holds an earlier" in capsys.readouterr().err
    assert cli_main(["paper", "--out", str(old), "--quick", "--resume", "--overwrite"]) == 2
    assert "give one of them" in capsys.readouterr().err
    assert sorted(os.listdir(old)) == ["paper.json", "relax.h5", "report.md"]


def test_fig5_load_above_the_threshold_is_refused():
    """fig5_F_x at or above F_x^c(mu0) (known only after the ramps) is refused by name."""
    from remote_trigger.pywrap.jobs.paper.fig5 import fig5_load

    ramps = [{"F_x_c_low": 0.0646, "F_x_c_high": 0.06465, "status": "complete"},
             {"F_x_c_low": 0.0587, "F_x_c_high": 0.05875, "status": "complete"}]
    F, lo, hi = fig5_load(PaperConfig(), ramps)
    assert lo == 0.05875 and hi == 0.0646 and lo < F < hi
    assert fig5_load(PaperConfig(fig5_F_x=0.05), ramps)[0] == 0.05
    for bad in (0.0646, 0.07):
        with pytest.raises(ConfigError, match=f"fig5_F_x = {bad!r}"):
            fig5_load(PaperConfig(fig5_F_x=bad), ramps)
    empty = [ramps[0], {"F_x_c_low": 0.07, "F_x_c_high": 0.0701, "status": "complete"}]
    with pytest.raises(ConfigError, match="no window for Fig. 5"):
        fig5_load(PaperConfig(), empty)


def test_one_numeric_validator():
    """Stage, paper, ensemble and trigger-map configurations share check_number."""
    from remote_trigger.pywrap import config
    from remote_trigger.pywrap.jobs.ensemble import config as ensemble_config
    from remote_trigger.pywrap.jobs.paper import config as paper_config
    from remote_trigger.pywrap.jobs.trigger_map import config as trigger_map_config

    assert paper_config.check_number is config.check_number is trigger_map_config.check_number \
        is ensemble_config.check_number
    assert config.check_number("x", 3) == 3.0
    assert config.check_number("tau", math.inf, 0, lo_open=True, allow_inf=True) == math.inf
    for val, words in ((True, "must be a number"), ("1", "must be a number"),
                       (math.nan, "must be a number"), (math.inf, "must be finite"),
                       (0.0, "must be > 0")):
        with pytest.raises(ConfigError, match=words):
            config.check_number("x", val, 0, lo_open=True)
    with pytest.raises(ConfigError, match="x must be <= 1, got x = 2"):
        config.check_number("x", 2, hi=1)


def test_a_key_given_by_flag_and_set_is_refused(capsys):
    """``--set n=60 --n 44``: the flag won silently and the --set value was
    never checked (``--n 40 --set n=-5`` ran a whole job); the same in the
    task-farm jobs (``--np`` and ``--set np=``)."""
    for argv in (["paper", "--out", "unused", "--quick", "--set", "n=60", "--n", "44"],
                 ["ensemble", "--out", "unused", "--quick", "--set", "np=2", "--np", "1"]):
        assert cli_main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "both set" in err[0] and "give one of them" in err[0], err
    assert not os.path.exists("unused")


def test_time_step_refusal_names_what_the_job_takes(tmp_path, capsys):
    """The stages suggest dt = 'auto', which the paper job's dt refuses: its
    message gives the safe value and asks for a number."""
    assert cli_main(["paper", "--quick", "--out", str(tmp_path / "kn"), "--k-n", "2e7",
                     "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "use dt <= 6.98" in err and "--dt VALUE" in err and "'auto'" not in err, err


def test_a_job_without_f_x_c_has_exit_status_1(tmp_path, capsys):
    """--F-x-max below F_x^c: the ramps end without a bracket, Figs. 4-5 are
    skipped; the report is written, and the exit status says there is no
    result (it said 0, "complete")."""
    out = tmp_path / "fmax"
    assert cli_main(["paper", "--quick", "--out", str(out), "--F-x-max", "0.05",
                     "--quiet"]) == 1
    text = capsys.readouterr().out
    assert "report: " in text and "ended without F_x^c" in text
    assert (out / "report.md").is_file()


def test_every_flag_is_helped_from_the_docstring(capsys):
    """Each field of PaperConfig is documented in its Attributes section, and
    `paper --help` gives each flag that description's first sentence and its
    default (it said only "see docs/paper.md" for most)."""
    helps = PaperConfig.field_help()
    assert set(PaperConfig.names()) <= set(helps), set(PaperConfig.names()) - set(helps)
    assert helps["dF_x"].startswith("Ramp step, > 0. Default 2.5e-4")
    assert helps["B"].endswith("(B, w, mu_ss)") and "Default" in helps["B"]
    assert "``" not in " ".join(helps.values()) and ":data:" not in " ".join(helps.values())
    with pytest.raises(SystemExit):
        cli_main(["paper", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert not re.search(r"(FLOAT|INT) see docs/paper\.md", out), out  # a help of its own
    assert "--seed INT Seed of the packing generator, >= 0. Default 1." in out


@pytest.mark.parametrize("command", ["ensemble", "trigger-map"])
def test_the_help_of_a_job_lists_its_configuration_keys(capsys, command):
    """ensemble and trigger-map take their keys by --set and --config only: their
    --help lists every key with its help from the configuration's docstring."""
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig
    from remote_trigger.pywrap.jobs.trigger_map.config import MapConfig

    cls = {"ensemble": EnsembleConfig, "trigger-map": MapConfig}[command]
    with pytest.raises(SystemExit):
        cli_main([command, "--help"])
    out = capsys.readouterr().out
    keys = out.split("configuration keys (--set KEY=VALUE, or a --config file):\n")[1]
    listed = [ln.split(":")[0].strip() for ln in keys.splitlines() if ln.startswith("  ")
              and not ln.startswith("      ")]
    assert listed == cls.names(), listed
    helps = cls.field_help()
    first = next(ln for ln in keys.splitlines() if ln.startswith(f"  {cls.names()[0]}: "))
    assert helps[cls.names()[0]].startswith(first.split(": ", 1)[1].rstrip()), first
