"""Sliced verdicts saved by a ramp (``stages.ramp``'s ``verdict_dir``): a ramp
killed inside a point's scan resumes it, to the same ramp.h5 bit for bit, and
a second ramp from the same packing at another friction takes its F_x = 0
verdict from the first's (the same K to the last bit in this packing; not in
every one), changing nothing.

The verdict is sliced by lowering the dense-path switch below the packing's
size (as in test_ramp.py), in slices of 12 eigenvalues (a few per scan); a kill is an exception raised from inside the
slicing, which leaves the files a SIGKILL at that moment would (every file is
written atomically)."""
import os
import pickle

import numpy as np
import pytest

from remote_trigger.analysis.stability import eigen
from remote_trigger.analysis.stability.sliced import scan
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.runtime.results import read_all
from remote_trigger.pywrap.stages.config import RampConfig

from .test_kill import compare_ramp

DF, TOL = 0.01, 1e-5
_SLICES = scan.ritz_slices      # the real one (the counters below wrap it)


class _Killed(Exception):
    """Stands for a kill inside a scan."""


class _CountScans:
    """Wraps ``sliced.scan.ritz_slices``: counts scans and slices; raises _Killed at slice
    ``kill_at`` (counted over the whole run). ``firsts``: the numbers of the
    slices that began a scan."""

    def __init__(self, kill_at=None):
        self.scans, self.slices, self.kill_at = 0, 0, kill_at
        self.firsts = set()

    def __call__(self, *args, **kwargs):
        self.scans += 1
        self.firsts.add(self.slices + 1)
        for sl in _SLICES(*args, **kwargs):
            self.slices += 1
            if self.slices == self.kill_at:
                raise _Killed
            yield sl


def _sliced_small(mp):
    mp.setattr(eigen, "DENSE_MAX", 10)
    mp.setattr(scan, "SLICE_SIZE", 12)


@pytest.fixture(scope="module")
def sliced_refs(relaxed, tmp_path_factory):
    """Uninterrupted sliced ramps at mu0 and 0.8 mu0, each on its own."""
    out = {}
    with pytest.MonkeyPatch.context() as mp:
        _sliced_small(mp)
        for name, f in (("mu0", 1.0), ("mu_ss", 0.8)):
            cfg = RampConfig(datafile=relaxed.datafile, dF_x=DF, tol=TOL)
            cfg = cfg.replace(mu=cfg.mu * f)
            folder = tmp_path_factory.mktemp(f"sliced_{name}")
            count = _CountScans()
            mp.setattr(scan, "ritz_slices", count)
            res = stages.ramp(cfg, str(folder), quiet=True)
            assert res.status == "complete", res.message
            assert not os.path.exists(folder / "ramp" / "verdicts")   # removed at the end
            out[name] = (cfg, read_all(res.h5), count)
    return out


def test_a_ramp_killed_inside_a_scan_resumes_it_bitwise(sliced_refs, tmp_path, monkeypatch):
    cfg, ref, ref_count = sliced_refs["mu0"]
    npts = sum(ref[1][f"{k}/F_x"].size for k in ("steps", "bisection"))
    assert ref_count.scans == npts and ref_count.slices > 2 * npts
    _sliced_small(monkeypatch)
    monkeypatch.setattr(scan, "CHECKPOINT_SECONDS", 0.0)
    # killed halfway through the ramp's slices, inside a scan: at a slice
    # that is not a scan's first, so that the scan has saved its state (how
    # many slices each scan takes depends on the BLAS's rounding, so the
    # slice is chosen from the reference run's count)
    kill_at = next(k for k in range(ref_count.slices // 2, ref_count.slices + 1)
                   if k not in ref_count.firsts)
    killer = _CountScans(kill_at=kill_at)
    monkeypatch.setattr(scan, "ritz_slices", killer)
    with pytest.raises(_Killed):
        stages.ramp(cfg, str(tmp_path), quiet=True)
    saved = os.listdir(tmp_path / "ramp" / "verdicts")
    assert sum(f.endswith(".scan.pkl") for f in saved) == 1, saved
    # the slices of the saved buffer, computed again on resume (no vectors saved)
    state, = [f for f in saved if f.endswith(".scan.pkl")]
    with open(tmp_path / "ramp" / "verdicts" / state, "rb") as fh:
        again = len(pickle.load(fh)[1].buf.edges)
    assert again >= 1
    resumed = _CountScans()
    monkeypatch.setattr(scan, "ritz_slices", resumed)
    res = stages.ramp(cfg, str(tmp_path), quiet=True, resume=True)
    assert res.status == "complete"
    assert compare_ramp(ref, res.h5) == []
    # the killed scan went on from its last saved slice, not from the start
    # (the buffer's slices computed again besides)
    assert killer.slices - 1 + resumed.slices == ref_count.slices + again
    assert not os.path.exists(tmp_path / "ramp" / "verdicts")


def test_the_second_ramp_of_a_packing_takes_its_F_x_0_verdict_from_the_first(
        sliced_refs, tmp_path, monkeypatch):
    """Two ramps sharing a verdict folder, as an ensemble packing's: the 0.8 mu0
    ramp scans one point fewer than on its own (in this packing its F_x = 0
    K is the mu0 ramp's to the last bit: asserted below from the ramps on
    their own), and both ramp.h5 are bitwise those of the ramps on their own."""
    _sliced_small(monkeypatch)
    shared = tmp_path / "verdicts"
    for name in ("mu0", "mu_ss"):
        cfg, ref, ref_count = sliced_refs[name]
        count = _CountScans()
        monkeypatch.setattr(scan, "ritz_slices", count)
        res = stages.ramp(cfg, str(tmp_path / name), quiet=True, verdict_dir=str(shared))
        assert compare_ramp(ref, res.h5) == []
        assert count.scans == ref_count.scans - (name == "mu_ss")
    done = [f for f in os.listdir(shared) if f.endswith(".done.pkl")]
    assert len(done) == sliced_refs["mu0"][2].scans + sliced_refs["mu_ss"][2].scans - 1
    # the premise, from the ramps on their own: the same F_x = 0 verdict
    first = [sorted(k for k in sliced_refs[m][1][1] if k.startswith("eigenvalues/steps/"))[0]
             for m in ("mu0", "mu_ss")]
    assert first[0] == first[1]
    np.testing.assert_array_equal(sliced_refs["mu0"][1][1][first[0]],
                                  sliced_refs["mu_ss"][1][1][first[0]])
    for m in ("mu0", "mu_ss"):
        assert sliced_refs[m][1][1]["steps/F_x"][0] == 0.0
