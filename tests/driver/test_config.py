"""Configuration validation, HDF5 round trip, and errors that lose nothing."""
import os

import h5py
import numpy as np
import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import (
    RelaxConfig, RampConfig, DynamicsConfig, check_packing_args)


@pytest.mark.parametrize("key, val", [
    ("f_min", 0.0), ("f_min", -1e-15), ("F_y", 0.0), ("F_y", -3.0), ("k_n", -2e5),
    ("mu", -0.1), ("dt", 0.0), ("gamma", -1.0), ("check_every", 0)])
def test_bad_values_name_field_and_value(packing_file, key, val):
    with pytest.raises(ConfigError) as exc:
        RelaxConfig.from_dict({"datafile": packing_file, key: val})
    assert key in str(exc.value) and repr(val) in str(exc.value)


@pytest.mark.parametrize("val, msg", [
    (1, "part_size must be >= 2, got part_size = 1"),
    (100.0, "part_size must be an integer, got part_size = 100.0"),
    (True, "part_size must be an integer, got part_size = True"),
    (59, r"part_size must be >= the slice size \(60\), got part_size = 59")])
def test_bad_part_size(packing_file, val, msg):
    with pytest.raises(ConfigError, match=f"^{msg}$"):
        RampConfig(datafile=packing_file, part_size=val)
    assert RampConfig(datafile=packing_file, part_size=2000).part_size == 2000
    assert RampConfig(datafile=packing_file, part_size=60).part_size == 60


def test_numpy_values_are_taken_as_python_numbers(packing_file):
    """A value from an array (np.int64 from a loop over np.arange, np.float32,
    an array of seeds) is checked and stored as the Python number; a
    non-integer stays refused."""
    import json
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig
    cfg = RelaxConfig(datafile=packing_file, settle_steps=np.int64(10), k_n=np.float32(2e5))
    assert type(cfg.settle_steps) is int and cfg.settle_steps == 10
    assert type(cfg.k_n) is float and cfg.k_n == 2e5
    ens = EnsembleConfig(n=np.array([100, 400]), seeds=np.arange(1, 4))
    assert ens.n == (100, 400) and ens.seeds == ((1, 2, 3), (1, 2, 3))
    assert json.loads(json.dumps(ens.to_dict()))["n"] == [100, 400]
    with pytest.raises(ConfigError, match="settle_steps = 1.5"):
        RelaxConfig(datafile=packing_file, settle_steps=np.float64(1.5))
    with pytest.raises(ConfigError, match="settle_steps = True"):
        RelaxConfig(datafile=packing_file, settle_steps=np.bool_(True))


def test_a_float32_is_refused(packing_file):
    """np.float32(1e-3) became dF_x = 0.0010000000474974513: its rounding in every
    load (float64 end to end for what feeds a Jacobian)."""
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig

    with pytest.raises(ConfigError, match=r"dF_x must be float64 \(or a Python float\), got a "
                                          r"float32 value that float64 holds as another "
                                          r"number: dF_x = np.float32\(0.001\)"):
        RampConfig(datafile=packing_file, dF_x=np.float32(1e-3))
    with pytest.raises(ConfigError, match=r"got a float16 value"):
        EnsembleConfig(dF_x=np.array([1e-3], np.float16))
    assert RampConfig(datafile=packing_file, dF_x=np.float64(1e-3)).dF_x == 1e-3


def test_unknown_key(packing_file):
    with pytest.raises(ConfigError, match="fmin"):
        RampConfig.from_dict({"datafile": packing_file, "fmin": 1e-15})


def test_missing_datafile(tmp_path):
    missing = str(tmp_path / "nope.data")
    with pytest.raises(ConfigError, match="nope.data"):
        RelaxConfig(datafile=missing)


def test_negative_n():
    with pytest.raises(ConfigError, match="n = -100"):
        check_packing_args(-100, 0)


def test_defaults_and_hdf5_round_trip(packing_file, tmp_path):
    cfg = RampConfig(datafile=packing_file, dF_x=2e-4)
    assert cfg.k_t == pytest.approx(2 * cfg.k_n / 7) and cfg.f_min == 1e-15
    with h5py.File(tmp_path / "c.h5", "w") as fh:
        for k, v in cfg.to_attrs().items():
            fh.attrs[k] = v
    with h5py.File(tmp_path / "c.h5", "r") as fh:
        back = RampConfig.from_attrs(dict(fh.attrs))
    assert back == cfg
    d = DynamicsConfig(datafile=packing_file)
    assert DynamicsConfig.from_attrs(d.to_attrs()) == d and d.v0 is None


def test_cli_reports_bad_value(packing_file, capsys):
    from remote_trigger.pywrap.cli import main

    assert main(["relax", "--datafile", packing_file, "--F-y", "-3", "--quiet"]) == 2
    assert "F_y = -3.0" in capsys.readouterr().err
    assert main(["generate", "--n", "-10"]) == 2
    assert "n = -10" in capsys.readouterr().err


def test_corrupt_and_truncated_dump(relaxed, tmp_path):
    from remote_trigger.analysis.stability.verdict import stability_of_dump

    text = open(relaxed.dumpfile).read()
    bad = tmp_path / "trunc.dump"
    bad.write_text(text[: len(text) // 2])
    open(str(bad) + ".json", "w").write(open(relaxed.dumpfile + ".json").read())
    with pytest.raises(ValueError, match="trunc.dump"):
        stability_of_dump(str(bad))
    garbage = tmp_path / "garbage.dump"
    garbage.write_text("ITEM: TIMESTEP\nhello\n")
    with pytest.raises(ValueError, match="garbage.dump"):
        stability_of_dump(str(garbage))


def test_ramp_refuses_to_overwrite_and_bad_resume_file(relaxed, tmp_path):
    from remote_trigger.pywrap import stages

    cfg = RampConfig(datafile=relaxed.datafile, dF_x=0.01)
    out = tmp_path / "r"
    out.mkdir()
    h5 = out / "ramp.h5"
    h5.write_bytes(b"not an hdf5 file")
    before = h5.read_bytes()
    with pytest.raises(ConfigError, match="exists"):
        stages.ramp(cfg, str(out), quiet=True)
    with pytest.raises(ConfigError, match="ramp.h5"):
        stages.ramp(cfg, str(out), quiet=True, resume=True)
    assert h5.read_bytes() == before          # nothing lost
    assert not os.path.exists(out / "ramp" / "step_00000.data")


def test_one_model_type_for_every_configuration(packing_file):
    """k_n, k_t, mu, F_y: one type (ContactModel) gives the defaults and the checks of
    the stage, paper and ensemble configurations alike."""
    from remote_trigger.pywrap.config import ContactModel
    from remote_trigger.pywrap.stages.config import DynamicsConfig
    from remote_trigger.pywrap.jobs.paper.config import PaperConfig
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig

    ref = ContactModel()
    assert ref.k_t == pytest.approx(2 * ref.k_n / 7)
    for cfg in (RelaxConfig(datafile=packing_file), DynamicsConfig(datafile=packing_file),
                PaperConfig(), EnsembleConfig()):
        assert ContactModel.of(cfg) == ref, type(cfg).__name__
    assert RelaxConfig(datafile=packing_file, k_n=1e4).model == ContactModel(k_n=1e4)
    # the same message from every configuration
    for make in (lambda **kw: RelaxConfig(datafile=packing_file, **kw), PaperConfig,
                 EnsembleConfig, ContactModel):
        with pytest.raises(ConfigError, match=r"^k_t must be >= 0, got k_t = -1\.0$"):
            make(k_t=-1.0)
        with pytest.raises(ConfigError, match=r"^F_y must be > 0, got F_y = 0(\.0)?$"):
            make(F_y=0)
