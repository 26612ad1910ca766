"""``trigger-map`` configuration: bad input is refused, naming the value, nothing written."""

import numpy as np
import pytest

from remote_trigger.pywrap.jobs.trigger_map import config as tc
from remote_trigger.pywrap.jobs.trigger_map import job as tm
from remote_trigger.pywrap.jobs.trigger_map import report as tr
from remote_trigger.pywrap.jobs.trigger_map import loads
from remote_trigger.pywrap.cli import main
from remote_trigger.pywrap.config import ConfigError


@pytest.mark.parametrize("key,val,words", [
    ("omega_p", [], "omega_p = []"),
    ("omega_p", [0.01, 0.0], "omega_p = [0.01, 0.0]"),
    ("omega_p", [-1.0], "omega_p = [-1.0]"),
    ("tau", [100.0, 0.0], "tau = [100.0, 0.0]"),
    ("tau", [-5.0], "tau = [-5.0]"),
    ("tau_g", [0.0], "tau_g = [0.0]"),
    ("fractions", [0.5, 1.0], "fractions = [0.5, 1.0]"),
    ("fractions", [0.0], "fractions = [0.0]"),
    ("onsets", ["ramp"], "onsets = ['ramp']"),
    ("onsets", [], "onsets = []"),
    ("t_max", 0.0, "t_max = 0.0"),
    ("dt_fraction", 1.0, "dt_fraction = 1.0"),
    ("factor", 1.0, "factor = 1.0"),
    ("d_run_factor", 0.5, "d_run_factor = 0.5"),
    ("a_max_factor", -1.0, "a_max_factor = -1.0"),
    ("omega_p", 0.01, "omega_p = 0.01"),
])
def test_bad_values_name_the_value(key, val, words):
    with pytest.raises(ConfigError) as err:
        tc.MapConfig.from_dict({"paper": "x", key: val})
    assert words in str(err.value)


def test_unknown_key_and_missing_paper():
    with pytest.raises(ConfigError, match="'omega'"):
        tc.MapConfig.from_dict({"paper": "x", "omega": [1.0]})
    with pytest.raises(ConfigError, match="paper"):
        tc.MapConfig.from_dict({})
    # the message names the option a user of the command line gives
    with pytest.raises(ConfigError, match=r"paper \(--paper DIR\) must name"):
        tc.MapConfig.from_dict({"paper": ""})


@pytest.mark.parametrize("argv,words", [
    (["--set", "omega_p=[]"], "omega_p = []"),
    (["--set", "tau=[-1]"], "tau = [-1]"),
    (["--set", "fractions=[1.5]"], "fractions = [1.5]"),
    ([], "not a paper job's output folder"),
])
def test_cli_refuses_and_writes_nothing(argv, words, tmp_path, capsys):
    out = tmp_path / "map"
    status = main(["trigger-map", "--paper", str(tmp_path / "nopaper"), "--out", str(out)]
                  + argv)
    assert status == 2
    assert words in capsys.readouterr().err
    assert not out.exists()


def test_quick_preset_and_precedence(tmp_path):
    toml = tmp_path / "m.toml"
    toml.write_text('paper = "p"\nt_max = 300.0\n')
    cfg = tc.build_config(str(toml), {"factor": 1.2}, quick=True)
    assert cfg.quick and cfg.t_max == 300.0 and cfg.factor == 1.2
    assert list(cfg.omega_p) == tc.QUICK["omega_p"]


def test_tasks_cover_the_grid_and_share_controls():
    cfg = tc.MapConfig(paper="p", dt_check=2)
    setup = {"loads": [{"kind": "window 0.25", "fraction": 0.25},
                       {"kind": "window 0.5", "fraction": 0.5},
                       {"kind": "below", "fraction": -0.5}],
             "taus": [10.0, 100.0], "omegas": [0.01, 0.1, 1.0]}
    tasks = tm.make_tasks(cfg, setup)
    ctrl = [t for t in tasks if t["kind"] == "control"]
    thr = [t for t in tasks if t["kind"] == "threshold" and "check_of" not in t]
    half = [t for t in tasks if "check_of" in t]
    assert len(ctrl) == 3 * 3 and len(thr) == 3 * 3 * 3 * 2 and len(half) == 2
    assert all(t["load"] == 1 and t["tau"] is None for t in half)
    assert all(t["dt_fraction"] == 0.5 * cfg.dt_fraction for t in half)
    assert len({t["key"] for t in tasks}) == len(tasks)


def test_msd_minimum_image():
    class S:
        def __init__(self, x):
            self.positions = np.array(x, float)
            self.box_lo = np.array([0.0, 0.0, -0.5])
            self.box_hi = np.array([10.0, 5.0, 0.5])
    a = S([[9.9999, 1.0, 0.0], [5.0, 2.0, 0.0]])
    b = S([[0.0001, 1.0, 0.0], [5.0, 2.0, 0.0]])
    assert loads._msd(a, b) == pytest.approx(0.5 * 0.0002 ** 2, rel=1e-6)


def test_a_failed_point_is_a_row_with_its_reason(tmp_path):
    """collect(): a task that raised is reported with its error; its neighbours are not."""
    import json

    setup = {"loads": [{"kind": "window 0.5", "fraction": 0.5, "F_x": 0.06}], "taus": [],
             "omegas": [0.01]}
    cfg = tc.MapConfig(paper="p", onsets=["step"], dt_check=0)
    tasks = tm.make_tasks(cfg, setup)
    (tmp_path / "tasks").mkdir()
    logs = {
        "control_L0_T0": {"task": tasks[0], "status": "complete", "runs": [],
                          "noise_triggered": False, "switched": False},
        "L0_T0_W0_step": {"task": tasks[1], "status": "failed", "runs": [],
                          "error": "NoEquilibriumError: residual 3.0"},
    }
    for k, v in logs.items():
        (tmp_path / "tasks" / f"{k}.json").write_text(json.dumps(v))
    setup["loads"][0].update(growth=0.01, growth_tau=[])
    rows = tr.collect(str(tmp_path), tasks, setup)
    assert len(rows) == 1 and rows[0]["status"].startswith("failed: NoEquilibriumError")
    assert np.isnan(rows[0]["a_c"])


def test_resume_refuses_a_paper_job_made_again(tmp_path):
    """A map resumed after its paper job was run again in the same folder (another
    seed, other brackets, another v0) is refused, naming what changed: the loads
    of the first job were kept beside runs and ramp numbers of the second."""
    import json
    import types

    from mpi4py import MPI

    from remote_trigger.pywrap.jobs.paper.config import PaperConfig
    from remote_trigger.pywrap.jobs.trigger_map.loads import paper_fingerprint, prepare_loads

    man = {"ramps": [{"F_x_c_low": 0.1013, "F_x_c_high": 0.1014},
                     {"F_x_c_low": 0.0915, "F_x_c_high": 0.0916}], "perturb": {"v0": 2.35e-11}}
    kept = {"loads": [], "v0": 2.35e-11, "paper_job": paper_fingerprint(PaperConfig(), man)}
    (tmp_path / "loads.json").write_text(json.dumps(kept))
    cfg = types.SimpleNamespace(paper="q")
    # the same job: the kept loads are used
    assert prepare_loads(cfg, PaperConfig(), man, str(tmp_path), MPI.COMM_SELF)["v0"] == 2.35e-11
    again = dict(man, perturb={"v0": 2.78e-11})
    with pytest.raises(ConfigError, match=r"paper job 'q' changed since this map began "
                                          r"\(seed = 1 then, 2 now; v0 = 2\.35e-11 then, "
                                          r"2\.78e-11 now\)"):
        prepare_loads(cfg, PaperConfig(seed=2), again, str(tmp_path), MPI.COMM_SELF)


def test_a_paper_job_whose_second_ramp_is_not_at_mu_ss_is_refused(tmp_path):
    """A paper job run with mu_low != mu_ss mu (and fig5_F_x) has no F_x^c(mu_ss
    mu0): the map took F_x^c(mu_low) for it and placed its loads in the wrong
    window. Refused by name when the paper job is read."""
    import json

    from remote_trigger.pywrap.jobs.paper.config import PaperConfig

    cfg = dict(PaperConfig(mu_low=0.7, fig5_F_x=0.095).to_dict(), nf_tau=[None, 300.0])
    man = {"status": "complete", "perturb": {"v0": 1e-11}, "ramps": [{}, {}], "config": cfg}
    (tmp_path / "paper.json").write_text(json.dumps(man))
    with pytest.raises(ConfigError, match=r"ramped mu_low = 0\.7, not mu_ss mu0 = 0\.8"):
        loads.load_paper_job(str(tmp_path))


def test_resume_takes_the_paper_folder_by_any_name(tmp_path, monkeypatch):
    """--resume from another working folder, where the paper folder's
    relative name is another: not a configuration difference (the job is
    compared by loads.json's paper_job); another key still is."""
    import types

    from remote_trigger.pywrap.jobs.trigger_map.job import _check_out
    from remote_trigger.pywrap.runtime.jobfolder import write_json

    out = tmp_path / "map"
    out.mkdir()
    cfg = types.SimpleNamespace(paper="q", to_dict=lambda: {"paper": "q", "seed": 1})
    write_json(str(out / "config.json"), cfg.to_dict())
    monkeypatch.chdir(out)
    moved = types.SimpleNamespace(paper="../q", to_dict=lambda: {"paper": "../q", "seed": 1})
    _check_out(moved, str(out), resume=True)
    with pytest.raises(ConfigError, match="--resume"):
        _check_out(moved, str(out), resume=False)
    other = types.SimpleNamespace(paper="../q", to_dict=lambda: {"paper": "../q", "seed": 2})
    with pytest.raises(ConfigError, match="seed = 1 .then. vs 2 .now."):
        _check_out(other, str(out), resume=True)


def test_rise_ratio_text_is_not_a_rate_where_g_is_not_positive():
    """The 'rise / g' cell showed the rise rate itself (as if a ratio) where g <= 0."""
    from remote_trigger.pywrap.jobs.trigger_map.report import _rise_ratio

    assert _rise_ratio({"rise_rate": 0.02, "growth_tau": 0.01, "rise_records": 5}) == "2.00"
    assert _rise_ratio({"rise_rate": -0.0138, "growth_tau": -0.002, "rise_records": 5}) == \
        "- (g = -0.002 <= 0; rise rate -0.0138)"
    assert _rise_ratio({"rise_rate": float("nan"), "growth_tau": 0.01, "rise_records": 2}) == \
        "- (2 rec.)"


def test_another_jobs_folder_is_named_as_such(tmp_path):
    """An ensemble's folder given to trigger-map (or the reverse) said "holds a
    trigger map; add --resume", and --resume then listed every key as
    differing. An older config.json of the same job, with a key or two
    fewer, is still compared key by key."""
    import json

    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig
    from remote_trigger.pywrap.runtime.jobfolder import check_job_folder

    ens = EnsembleConfig.from_dict({}).to_dict()
    tmap = tc.MapConfig.from_dict({"paper": "p"}).to_dict()
    for theirs, mine, kind in ((ens, tmap, "a trigger map"), (tmap, ens, "an ensemble")):
        out = tmp_path / kind.replace(" ", "_")
        out.mkdir()
        (out / "config.json").write_text(json.dumps(theirs))
        for resume in (False, True):
            with pytest.raises(ConfigError, match=f"holds the results of another job, not "
                                                  f"{kind}"):
                check_job_folder(str(out), mine, resume, kind)
    old = tmp_path / "old"
    old.mkdir()
    first = sorted(tmap)[0]
    (old / "config.json").write_text(json.dumps({k: v for k, v in tmap.items() if k != first}))
    with pytest.raises(ConfigError, match=f"configuration differs in {first} = None"):
        check_job_folder(str(old), tmap, True, "a trigger map")


def test_a_damaged_record_is_named(tmp_path, capsys):
    """A damaged config.json under ensemble --resume said only "Expecting
    property name enclosed in double quotes: line 1 column 2 (char 1)"."""
    from remote_trigger.pywrap import cli
    from remote_trigger.pywrap.runtime.jobfolder import read_json

    out = tmp_path / "e"
    out.mkdir()
    (out / "config.json").write_text("{not json")
    assert cli.main(["ensemble", "--quick", "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"remote-trigger ensemble: error: {out / 'config.json'} is not "
                          f"readable JSON (Expecting property name"), err
    assert err.endswith("it was damaged: restore it or start the job in another folder"), err
    assert (out / "config.json").read_text() == "{not json"          # left as it was
    (out / "loads.json").write_bytes(b"{\xff}")
    with pytest.raises(ConfigError, match=r"loads.json is not readable JSON \('utf-8' codec"):
        read_json(str(out / "loads.json"))
    (out / "loads.json").write_text("null")
    with pytest.raises(ConfigError, match=r"loads.json is not readable JSON \(null, not an "
                                          r"object\)"):
        read_json(str(out / "loads.json"))
    (out / "loads.json").write_text('{"v0": 1e-9}')
    assert read_json(str(out / "loads.json")) == {"v0": 1e-9}
