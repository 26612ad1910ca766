"""The sliced scan in parts (classify_sliced(..., part_size, map_tasks);
analysis.stability.sliced.parts): the verdict of the whole scan, the same bits
whatever runs the tasks, strips decided across the split points."""
import concurrent.futures
import dataclasses
import hashlib
import pickle

import numpy as np
import pytest

from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.analysis.stability.sliced import (SlicedStats, classify_sliced, saved_scans,
                                                     scaled_parts)

from .test_sliced import planted


def fingerprint(res, st):
    """sha256 of a verdict to the last bit: decision, margins, reasons, eigenvalues,
    strips and statistics."""
    h = hashlib.sha256()
    h.update(repr((res.decision, res.confidence, res.reason, res.scanned_below,
                   res.lambda_max)).encode())
    h.update(np.asarray(res.eigenvalues).tobytes())
    for p in res.pairs:
        h.update(repr((p.is_complex, p.certified, p.margin, p.reason)).encode())
        h.update(np.asarray(p.eigenvalues).tobytes())
    h.update(repr(sorted(dataclasses.asdict(st).items())).encode())
    return h.hexdigest()


def run(K, mass, **kw):
    st = SlicedStats()
    return classify_sliced(K, mass, stats=st, slice_size=20, **kw), st


def test_one_part_is_the_whole_scan():
    """part_size None and part_size >= n (one part) are the whole scan, bit for bit."""
    K, mass = planted(n=150, pairs=[(40, 1.5)])
    ref = run(K, mass)
    assert ref[1].parts == 1 and ref[1].cuts == ()
    assert fingerprint(*run(K, mass, part_size=150)) == fingerprint(*ref)
    assert fingerprint(*run(K, mass, part_size=400, map_tasks=map)) == fingerprint(*ref)


@pytest.mark.parametrize("pairs", [[(100, 1.5)], [(100, 0.97)], [(60, 1.02), (230, 0.7)], []])
def test_parts_give_the_whole_verdict(pairs):
    """Three parts of 100 (n = 300): the verdict of the whole scan, the same
    eigenvalues to within the Ritz radii (one list, sorted the same way), every
    eigenvalue in one strip (the strip sizes add up to n)."""
    K, mass = planted(n=300, pairs=pairs, seed=1)
    whole, wst = run(K, mass)
    res, st = run(K, mass, part_size=100)
    assert st.parts == 3 and len(st.cuts) == 2
    assert all(x < c for x, c in st.cuts)
    assert res.decision is whole.decision, (res.reason, whole.reason)
    assert res.decision is Decision.certified(any(r > 1 for _, r in pairs))
    assert sum(m * c for m, c in st.strips.items()) == 300
    assert res.eigenvalues.size == whole.eigenvalues.size == 300
    tol = 2 * max(st.ritz_radius, wst.ritz_radius)
    assert np.max(np.abs(res.eigenvalues - whole.eigenvalues)) <= tol
    assert st.slices > wst.slices         # the cuts' regions are computed again


def test_the_same_bits_with_a_process_pool():
    """The tasks run one after the other (builtin map) or on two processes: the
    same verdict, eigenvalues, strips and statistics, bit for bit."""
    K, mass = planted(n=300, pairs=[(100, 1.5), (220, 0.9)], seed=1)
    seq = fingerprint(*run(K, mass, part_size=100))
    with concurrent.futures.ProcessPoolExecutor(2) as ex:
        par = fingerprint(*run(K, mass, part_size=100, map_tasks=ex.map))
    assert par == seq


@pytest.mark.parametrize("ratio", [1.5, 0.97])
def test_a_pair_across_a_split_point(ratio):
    """A pair planted with the first split point x_1 between its two eigenvalues
    of S: the part below decides its strip (across x_1), as the whole scan does."""
    n = 300
    i = 100
    for _ in range(4):
        K, mass = planted(n=n, pairs=[(i, ratio)], seed=1)
        res, st = run(K, mass, part_size=100)
        x1 = st.cuts[0][0]
        lam = np.linalg.eigvalsh(scaled_parts(K, mass)[1].toarray())
        below = int(np.count_nonzero(lam < x1))
        S = scaled_parts(K, mass)[1]
        if S[i, i] < x1 < S[i + 1, i + 1]:
            break
        i = below - 1                   # the pair's lower member just below x_1
    else:
        pytest.fail("no pair across the split point")
    whole, _ = run(K, mass)
    assert res.decision is whole.decision is Decision.certified(ratio > 1), res.reason
    if ratio > 1:
        strip = [p for p in res.pairs if p.is_complex]
        assert len(strip) == 1 and strip[0].certified
        assert S[i, i] < strip[0].eigenvalues.real.min() <= strip[0].eigenvalues.real.max() \
            < S[i + 1, i + 1] < st.cuts[0][1]     # across x_1, below the first cut
    assert np.max(np.abs(res.eigenvalues - whole.eigenvalues)) < 1e-6


def test_stop_at_complex_reads_the_parts_in_order():
    """stop_at_complex: the first complex strip ends the merge; with a lazy map the
    parts above it are not run. The answer is that of the stopped whole scan."""
    K, mass = planted(n=300, pairs=[(40, 1.5), (230, 1.3)], seed=1)
    whole, _ = run(K, mass, stop_at_complex=True)
    ran = []

    def lazy_map(fn, tasks):
        for t in tasks:
            ran.append((fn.__name__, t.j))
            yield fn(t)

    res, st = run(K, mass, part_size=100, stop_at_complex=True, map_tasks=lazy_map)
    assert res.decision is Decision.COMPLEX
    assert [r for r in ran if r[0] == "scan_part"] == [("scan_part", 0)]
    assert res.scanned_below == whole.scanned_below < st.cuts[0][1]
    assert np.array_equal(res.eigenvalues, whole.eigenvalues)


@pytest.mark.parametrize("bad", [0, 19, 2.5, "100", True])
def test_a_bad_part_size_is_refused(bad):
    K, mass = planted(n=40)
    with pytest.raises(ValueError, match=r"part_size must be an integer >= slice_size \(20\), "
                                         rf"got part_size = {bad!r}".replace("'", ".")):
        run(K, mass, part_size=bad)


def test_parts_are_checkpointed(tmp_path):
    """With a checkpoint_dir each finished task is saved: a scan stopped by an
    exception inside its second part (as a kill would leave the folder) and
    called again runs only the tasks not saved, and its answer is the
    uninterrupted one, bit for bit; the finished verdict is then saved and
    the task files removed. A map_tasks that is not callable is refused."""
    import os

    K, mass = planted(n=300, pairs=[(100, 1.5), (220, 0.9)], seed=1)
    ref = fingerprint(*run(K, mass, part_size=100))

    class Killed(Exception):
        pass

    ran = []

    def killing_map(fn, tasks):
        for t in tasks:
            if fn.__name__ == "scan_part" and t.j > 0 and kill[0]:
                raise Killed
            ran.append((fn.__name__, t.j))
            yield fn(t)

    kill = [True]
    with pytest.raises(Killed):
        run(K, mass, part_size=100, checkpoint_dir=str(tmp_path), map_tasks=killing_map)
    names = sorted(os.listdir(tmp_path))
    assert [n.split(".", 1)[1] for n in names] == [
        "task-cut-00001.pkl", "task-cut-00002.pkl", "task-part-00000.pkl"], names
    # the progress report counts the eigenvalues of the finished part
    (pattern, listed, n_saved, _), = saved_scans(str(tmp_path))
    with open(tmp_path / names[2], "rb") as fh:
        part0 = pickle.load(fh)[1]
    assert pattern == str(tmp_path / names[2].replace("00000", "*"))
    assert (listed, n_saved) == (len(part0.lam), 300) and 0 < listed < 300
    kill[0], ran[:] = False, []
    assert fingerprint(*run(K, mass, part_size=100, checkpoint_dir=str(tmp_path),
                            map_tasks=killing_map)) == ref
    assert [r[0] for r in ran] == ["scan_part", "scan_part"]      # parts 1 and 2 only
    assert [n.split(".", 1)[1] for n in os.listdir(tmp_path)] == ["done.pkl"]
    ran[:] = []                 # the saved verdict: nothing run
    assert fingerprint(*run(K, mass, part_size=100, checkpoint_dir=str(tmp_path),
                            map_tasks=killing_map)) == ref and ran == []
    with pytest.raises(ValueError, match="map_tasks must be callable, got map_tasks = 4"):
        run(K, mass, part_size=30, map_tasks=4)


def test_parts_with_chains_of_runs_give_the_whole_verdict(monkeypatch):
    """Every float64 count too fuzzy (``DW_FUZZ_FRACTION`` 0): the runs form
    chains between double-word counts, in the whole scan and in three parts
    (each part's chains end at its ceiling); the verdict of the scan with one
    count a run, the same eigenvalues to within the Ritz radii."""
    from remote_trigger.analysis.stability.sliced import inertia

    K, mass = planted(n=300, pairs=[(100, 1.5), (220, 0.9)], seed=1)
    ref, rst = run(K, mass)
    monkeypatch.setattr(inertia, "DW_FUZZ_FRACTION", 0.0)
    whole, wst = run(K, mass)
    res, st = run(K, mass, part_size=100)
    assert wst.deferred_counts > 0 and st.deferred_counts > 0
    assert wst.dw_counts < wst.lanczos_runs
    for got, gst in ((whole, wst), (res, st)):
        assert got.decision is ref.decision is Decision.certified(True)
        assert got.eigenvalues.size == 300
        tol = 2 * max(gst.ritz_radius, rst.ritz_radius)
        assert np.max(np.abs(got.eigenvalues - ref.eigenvalues)) <= tol
