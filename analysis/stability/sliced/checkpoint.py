"""The checkpoint of a sliced scan: its files, key and format, save and restore.

``classify_sliced(..., checkpoint_dir=D)`` (docs/analysis.md, "Checkpoint of
a scan") saves its scan (a :class:`~.scan.SlicedScan`) as
``D/sliced-<key>.scan.pkl`` and its finished verdict as
``D/sliced-<key>.done.pkl`` (:class:`ScanFiles`), each a pickle of ``(key,
object)`` written atomically; ``key`` (:func:`scan_key`) is a sha256 of the
scaled matrix to the last bit, of the options and of
:data:`CHECKPOINT_FORMAT`, so a call only ever finds its own state. A saved
scan holds no Ritz vector: the buffer (:class:`~.buffer.RitzBuffer`) pickles
their shape and :func:`sha` instead, and a resume computes its slices again
(:func:`restore_ritz`). :func:`saved_scans` lists a folder's saved scans for
progress reports. A scan in parts (:mod:`.parts`) saves each finished task
instead, ``D/sliced-<key>.task-cut-NNNNN.pkl`` and ``.task-part-NNNNN.pkl``
(:meth:`ScanFiles.save_task`), its key including the part size.
"""
import copy
import hashlib
import os
import pickle

import numpy as np

from remote_trigger.analysis.stability.sliced.numerics import SliceFailure

__all__ = ["CHECKPOINT_FORMAT", "ScanFiles", "scan_key", "saved_scans", "sha", "restore_ritz"]

#: checkpoint format; a file of another format (or code) is not resumed (4: the
#: buffer's class and pickled state, and slices whose bits differ from those of 3;
#: 5: ARPACK's shorter Lanczos basis, slices whose bits differ from those of 4;
#: 6: the scan's classes in the package ``sliced``, where pickle finds them by
#: module path: a file of 5 names classes that no longer exist there; 7: counts
#: made again in double-word arithmetic, shifts moved away from a tiny pivot
#: before ARPACK runs and slices computed again only above ARPACK's own residual
#: bound, so slice edges and shifts whose bits differ from those of 6; 8: the
#: first slice's shift just below the lowest eigenvalue, not at the Gershgorin
#: bound, so slice edges whose last bits differ from those of 7; 9: where the
#: factor is dense (large sphere packings) the shift-invert solves by SuperLU
#: and the counts by the multifrontal LDL^T, both in SuperLU's order, so slice
#: edges and eigenvalues whose bits differ from those of 8 there; disks' scans
#: are bitwise those of 8; 10: a slice's pairs by the Lanczos without restarts
#: of :mod:`.lanczos` (ARPACK only where it has not converged), so slice edges
#: and eigenvalues whose bits differ from those of 9; 11: the counts at the
#: runs' shifts prove the slices between them (:func:`~.slices.ritz_slices`), a
#: saved position may hold a pending run, and slice edges differ from those of 10;
#: 12: where a run's count is not at hand (its float64 count too fuzzy to use,
#: or SuperLU's solves), chains of runs between two counted ones (a saved
#: position says how many counts it left out), so slice edges there may
#: differ from those of 11 (a shift too near one of its run's Ritz values, a
#: chain made again); where QDLDL's float64 counts serve (disks up to
#: N = 10^4, spheres up to N ~ 1000), scans are bitwise those of 11)
CHECKPOINT_FORMAT = 12


def scan_key(A, rel_error, window, slice_size, stop_at_complex, max_strip, soft_rel=None,
             part_size=None):
    """sha256 of everything a scan depends on: A = M^-1/2 K M^-1/2 (canonical CSR,
    bitwise), the options, the largest strip decided on the real axis
    (``scan._MAX_STRIP``: a scan or verdict saved under another limit is
    not taken, so its strips are not decided by two rules) and the
    checkpoint format. ``soft_rel`` (the stop rule's soft-pair threshold)
    and ``part_size`` (a scan in parts) enter only when given, so the keys of
    scans without them are those of earlier versions."""
    h = hashlib.sha256()
    opts = (CHECKPOINT_FORMAT, A.shape, float(rel_error), float(window),
            int(slice_size), bool(stop_at_complex), int(max_strip))
    if soft_rel is not None:
        opts += (float(soft_rel),)
    if part_size is not None:
        opts += ("parts", int(part_size))
    h.update(repr(opts).encode())
    for arr in (A.indptr, A.indices, A.data):
        h.update(np.ascontiguousarray(arr).view(np.uint8))
    return h.hexdigest()[:32]


def _load(path, key):
    """The object saved at ``path`` for ``key``; None if there is none, or it is
    unreadable (truncated, or of other code: a class pickle no longer finds)
    or of another key (a scan from the start then replaces it)."""
    try:
        with open(path, "rb") as fh:
            saved = pickle.load(fh)
    except Exception:           # missing, truncated or from other code
        return None
    if not (isinstance(saved, tuple) and len(saved) == 2 and saved[0] == key):
        return None
    return saved[1]


def _save(path, key, obj):
    """Save (key, obj) to ``path`` atomically (pickle), creating its folder."""
    from remote_trigger.analysis.output import atomic_path

    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            pickle.dump((key, obj), fh, protocol=pickle.HIGHEST_PROTOCOL)


class ScanFiles:
    """The files of one scan in a checkpoint folder.

    Parameters
    ----------
    folder : str or path-like
        ``classify_sliced``'s ``checkpoint_dir`` (created at the first save).
    key : str
        The scan's :func:`scan_key`.

    Attributes
    ----------
    scan_path : str
        ``<folder>/sliced-<key>.scan.pkl``: the scan's state (a
        :class:`~.scan.SlicedScan`, without its Ritz vectors).
    verdict_path : str
        ``<folder>/sliced-<key>.done.pkl``: the finished verdict and its
        statistics.
    """

    def __init__(self, folder, key):
        self.key = key
        stem = os.path.join(os.fspath(folder), f"sliced-{key}")
        self.folder = os.path.dirname(stem)
        self.scan_path = stem + ".scan.pkl"
        self.verdict_path = stem + ".done.pkl"

    def load_verdict(self):
        """The saved (SpectrumDecision, SlicedStats) of this key, or None."""
        return _load(self.verdict_path, self.key)

    def load_scan(self):
        """The saved scan of this key, or None (its Ritz vectors not restored:
        :func:`restore_ritz`)."""
        return _load(self.scan_path, self.key)

    def save_scan(self, scan):
        """Save the scan's state, atomically (its buffer without vectors)."""
        _save(self.scan_path, self.key, scan)

    def task_path(self, kind, j):
        """``<folder>/sliced-<key>.task-<kind>-<j>.pkl``: a finished task of a scan
        in parts (``kind`` 'cut' or 'part', ``j`` its number)."""
        return os.path.join(self.folder, f"sliced-{self.key}.task-{kind}-{int(j):05d}.pkl")

    def load_task(self, kind, j):
        """The saved result of task ``kind`` ``j`` of this key, or None."""
        return _load(self.task_path(kind, j), self.key)

    def save_task(self, kind, j, result):
        """Save the result of a finished task of a scan in parts, atomically."""
        _save(self.task_path(kind, j), self.key, result)

    def save_verdict(self, decision, stats):
        """Save the finished verdict and its statistics, atomically, and remove
        every ``sliced-*.scan.pkl`` and saved task of the folder (a folder
        serves one scan at a time: another scan's state is stale)."""
        _save(self.verdict_path, self.key, (decision, stats))
        for name in os.listdir(self.folder):
            if name.startswith("sliced-") and (name.endswith(".scan.pkl")
                                               or ".task-" in name):
                try:
                    os.unlink(os.path.join(self.folder, name))
                except FileNotFoundError:
                    pass


def saved_scans(folder):
    """The scans saved in ``folder`` (``classify_sliced``'s ``checkpoint_dir``)
    and how far each had come at its last save, for progress reports.

    Parameters
    ----------
    folder : str
        A checkpoint folder; missing is the same as empty.

    Returns
    -------
    list of (str, int, int, float)
        Per ``sliced-*.scan.pkl``, and per scan in parts (its
        ``sliced-<key>.task-part-*.pkl``, one entry for them all), sorted by
        name: its path (for a scan in parts the pattern
        ``<folder>/sliced-<key>.task-part-*.pkl``); the eigenvalues of the
        symmetric part listed by then (the count ``progress`` reports; for a
        scan in parts those of its finished parts); the order n; the save's
        time (the file's mtime, seconds since the epoch; the latest part's). A
        file that cannot be read (being replaced, or of other code) is left
        out. It is only read: safe beside the running scan.
    """
    try:
        names = sorted(os.listdir(folder))
    except FileNotFoundError:
        return []
    out, parts = [], {}
    for name in names:
        path = os.path.join(folder, name)
        if not name.startswith("sliced-"):
            continue
        stem, _, rest = name.partition(".")
        part = rest.startswith("task-part-") and rest.endswith(".pkl")
        if not (part or rest == "scan.pkl"):
            continue
        try:
            mtime = os.path.getmtime(path)
            with open(path, "rb") as fh:
                _, obj = pickle.load(fh)
            if part:
                listed, n, last = parts.get(stem, (0, 0, 0.0))
                parts[stem] = (listed + len(obj.lam), int(obj.stats.n), max(last, mtime))
            else:
                out.append((path, int(obj.counted), int(obj.stats.n), mtime))
        except Exception:       # noqa: BLE001 - replaced meanwhile, truncated or other code
            continue
    out += [(os.path.join(folder, stem + ".task-part-*.pkl"), listed, n, mtime)
            for stem, (listed, n, mtime) in parts.items()]
    return sorted(out)


def sha(a):
    """sha256 of an array's bytes (C order), hex: what a saved scan keeps of its
    Ritz vectors."""
    return hashlib.sha256(np.ascontiguousarray(a).view(np.uint8)).hexdigest()


def restore_ritz(sc, slices):
    """Put the Ritz vectors back into a scan loaded from its checkpoint.

    The saved buffer (:class:`~.buffer.RitzBuffer`) has no vectors, only their
    shape and :func:`sha`. Its slices are computed again from the position
    saved before the first of them (``sc.starts``) by ``slices(position)``,
    the slicing's generator with statistics of its own (the scan's are those
    of the uninterrupted scan already). The slicing is deterministic, so they are
    the slices the scan had: checked by their edges, their Ritz values and
    the sha256 of the vectors.

    Returns
    -------
    bool
        False where they are not the saved ones (another BLAS thread count,
        a damaged state): the scan then starts from the beginning.
    """
    buf = sc.buf
    shape, digest = buf.__dict__.pop("q_shape", None), buf.__dict__.pop("q_sha", None)
    if shape is None or (buf.edges and buf.edges[0][0] not in sc.starts):
        return False
    Qs, th = [np.zeros((shape[0], 0))], [np.zeros(0)]
    if buf.edges:
        gen = slices(copy.deepcopy(sc.starts[buf.edges[0][0]]))
        try:
            for _, lo, hi in buf.edges:
                sl = next(gen)
                if (sl.lo, sl.hi) != (lo, hi):
                    return False
                Qs.append(sl.Q)
                th.append(sl.theta)
        except (StopIteration, SliceFailure):
            return False
    Q = np.hstack(Qs)
    if Q.shape != tuple(shape) or sha(Q) != digest or \
            np.concatenate(th).tobytes() != buf.th.tobytes():
        return False
    buf.Q = Q
    return True
