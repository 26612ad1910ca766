"""analysis.output: the one atomic writer; a failed write leaves the old file and no litter."""
import json
import os

import h5py
import numpy as np
import pytest

from remote_trigger.analysis import output


def _listing(folder):
    return sorted(os.listdir(folder))


def test_success_replaces_and_leaves_no_temporary(tmp_path):
    p = tmp_path / "r.json"
    p.write_text("old")
    output.write_json_atomic(p, {"a": 1})
    assert json.loads(p.read_text()) == {"a": 1}
    assert _listing(tmp_path) == ["r.json"]


@pytest.mark.parametrize("writer", ["text", "json", "h5", "npz", "path"])
def test_failure_keeps_the_old_file(tmp_path, writer):
    p = tmp_path / "r.out"
    p.write_text("old")

    class Boom(Exception):
        pass

    def bad():
        raise Boom

    with pytest.raises((Boom, TypeError)):
        if writer == "text":
            output.write_text_atomic(p, 3)                  # not a str: TypeError
        elif writer == "json":
            output.write_json_atomic(p, {"x": object()})     # not serialisable
        elif writer == "h5":
            output.write_h5_atomic(p, {"x": [1.0, 2.0]}, attrs={"bad": object()})
        elif writer == "npz":
            output.write_npz_atomic(p, {"x": np.arange(3), "y": _Unpicklable()})
        else:
            with output.atomic_path(p) as tmp:
                with open(tmp, "w") as fh:
                    fh.write("half")
                bad()
    assert p.read_text() == "old"
    assert _listing(tmp_path) == ["r.out"]


class _Unpicklable:
    def __reduce__(self):
        raise TypeError("no pickling")


def test_h5_is_float64_and_complete(tmp_path):
    p = tmp_path / "x.h5"
    output.write_h5_atomic(p, {"g/x": np.arange(3, dtype=np.float32)}, attrs={"k": 2})
    with h5py.File(p) as fh:
        assert fh["g/x"].dtype == np.float64 and fh.attrs["k"] == 2
    assert _listing(tmp_path) == ["x.h5"]


def test_savefig_takes_the_format_from_the_name(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1])
    output.savefig_atomic(fig, tmp_path / "f.png")
    output.savefig_atomic(fig, tmp_path / "f.pdf")
    plt.close(fig)
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "f.pdf").read_bytes()[:4] == b"%PDF"
    assert _listing(tmp_path) == ["f.pdf", "f.png"]


def test_sidecar_writer_is_the_readers_format(tmp_path):
    """analysis.state.write_sidecar writes exactly what load_sidecar reads; bad input refused."""
    from remote_trigger.analysis.state.dumpfile import PARAM_KEYS, load_sidecar, write_sidecar

    vals = {"k_n": 2e5, "k_t": 2e5 * 2 / 7, "mu": 0.8, "wall_y": 0.0,
            "F_x": 0.061690159999999994, "F_y": 3, "dt": np.float64(1e-3)}
    dump = str(tmp_path / "eq.dump")
    write_sidecar(dump, vals)
    back = load_sidecar(dump)
    assert back == {k: float(vals[k]) for k in PARAM_KEYS}     # exact round trip
    assert _listing(tmp_path) == ["eq.dump.json"]
    with pytest.raises(ValueError, match="missing \\['dt'\\]"):
        write_sidecar(dump, {k: v for k, v in vals.items() if k != "dt"})
    with pytest.raises(ValueError, match="F_x must be a finite number"):
        write_sidecar(dump, dict(vals, F_x=float("nan")))
    assert load_sidecar(dump) == back                           # nothing overwritten
