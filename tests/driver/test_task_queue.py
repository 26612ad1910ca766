"""The task queue of the ensemble and trigger-map jobs (jobfolder.claim_task):
every task is taken by exactly one rank, whoever is free first."""
import multiprocessing as mp
import os

from remote_trigger.pywrap.runtime.jobfolder import claim_task, clear_claims

KEYS = [f"N100_s{k}" for k in range(60)]


def _worker(folder, queue):
    queue.put([k for k in KEYS if claim_task(folder, k)])


def test_a_task_is_claimed_once(tmp_path):
    folder = str(tmp_path)
    assert claim_task(folder, "a") is True
    assert claim_task(folder, "a") is False
    assert claim_task(folder, "b") is True


def test_concurrent_ranks_split_the_tasks_without_overlap(tmp_path):
    folder = str(tmp_path)
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    procs = [ctx.Process(target=_worker, args=(folder, q)) for _ in range(4)]
    for p in procs:
        p.start()
    taken = [q.get(timeout=60) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    flat = [k for part in taken for k in part]
    assert sorted(flat) == sorted(KEYS)          # each task once, none lost


def test_clear_claims_leaves_the_results(tmp_path):
    folder = str(tmp_path)
    claim_task(folder, "x")
    (tmp_path / "x.json").write_text("{}")
    clear_claims(folder)
    assert os.listdir(folder) == ["x.json"]
    assert claim_task(folder, "x") is True       # free again (a resumed job)
