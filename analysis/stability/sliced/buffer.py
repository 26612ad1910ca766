"""The Ritz pairs a sliced scan keeps in memory (its *buffer*).

Part of :mod:`remote_trigger.analysis.stability.sliced`: the scan adds each
slice of Ritz pairs of the symmetric part S (:mod:`.slices`) and forgets the
oldest slices once the certified boundaries have passed them; the strips and
boundaries (:mod:`.strips`) read the values, vectors and couplings kept here.
"""
import math

import numpy as np

from remote_trigger.analysis.stability.sliced.checkpoint import sha
from remote_trigger.analysis.stability.sliced.numerics import INFLATE

__all__ = ["RitzBuffer"]


class RitzBuffer:
    """The Ritz pairs of the slices in memory: values, residuals, vectors, Q^T W Q
    (skew), ||W q_i||, and the norms of the overlaps Q_i^T Q_j of different
    slices. W Q itself is not kept (as many columns of n as Q): a strip's
    W Q_I is computed where it is needed, column for column the same numbers.

    Q (n x m, the slices' vectors side by side in slice order) is a view of
    a column-major store with room to grow: a slice is written into the room
    after Q, the slices dropped (always the oldest) only move the view's
    start, and Q is moved only when the store is full (:meth:`_append`),
    where a concatenation would copy all of Q at every slice.

    Pickled (a scan's checkpoint) without Q, its only array of n rows: the
    sha256 of Q's bytes and its shape are saved instead, and a resumed scan
    computes the buffer's slices again (:func:`.checkpoint.restore_ritz`)."""

    def __init__(self, n):
        self.th = np.zeros(0)
        self.rs = np.zeros(0)
        self.sid = np.zeros(0, int)
        self.Q = np.zeros((n, 0), order="F")
        self.Wn = np.zeros((0, 0))
        self.wqn = np.zeros(0)   # ||W q_i||
        self.phis = {}          # slice id -> phi
        self.radii = {}         # slice id -> Kahan radius
        self.cross = {}         # (i, j), i < j -> ||Q_i^T Q_j||_F
        self.edges = []         # (id, lo, hi)

    @property
    def Q(self):
        """The Ritz vectors side by side, n rows and m columns; None in a loaded
        state whose vectors are not restored."""
        if self._store is None:
            return None
        return self._store[:, self._q0:self._q1]

    @Q.setter
    def Q(self, Q):
        self._store = None if Q is None else np.array(Q, order="F")
        self._q0, self._q1 = 0, (0 if Q is None else Q.shape[1])

    def __getstate__(self):
        state = self.__dict__.copy()
        for key in ("_store", "_q0", "_q1"):
            del state[key]
        Q = self.Q
        state["Q"] = None
        if Q is not None:      # (None: a loaded state, its vectors not restored)
            state.update(q_shape=Q.shape, q_sha=sha(Q))
        return state

    def __setstate__(self, state):
        state = dict(state)
        Q = state.pop("Q", None)
        self.__dict__.update(state)
        self.Q = Q

    def _append(self, V):
        """Q <- [Q, V]. When the store is full, Q moves to its start if the
        dropped columns leave room for V there, in pieces of q0 columns
        (source and destination of a piece do not overlap, so no temporary
        copy), else to a new store with room for max(m/4, 4k) more columns
        (the old and the new store then exist together); a column is copied
        a few times at most."""
        n, k = V.shape
        q0, q1 = self._q0, self._q1
        m = q1 - q0
        if q1 + k > self._store.shape[1]:
            if m + k <= self._store.shape[1]:
                for c in range(0, m, q0):
                    w = min(q0, m - c)
                    self._store[:, c:c + w] = self._store[:, q0 + c:q0 + c + w]
            else:
                store = np.empty((n, m + k + max(m // 4, 4 * k)), order="F")
                store[:, :m] = self._store[:, q0:q1]
                self._store = store
            self._q0, self._q1 = 0, m
        self._store[:, self._q1:self._q1 + k] = V
        self._q1 += k

    def add(self, sl, sid):
        """Append slice ``sl`` (its Ritz values ``theta``, vectors ``Q``, ``WQ``,
        residuals, phi, Kahan radius and edges) under the id ``sid``: the
        projected W grows by its rows and columns, and the overlap of its
        vectors with each slice already held is recorded (``cross``)."""
        k = sl.theta.size
        # Q^T W Q_new and Q^T Q_new in one pass over Q
        G = self.Q.T @ np.hstack([sl.WQ, sl.Q])
        C = G[:, :k]
        D = sl.Q.T @ sl.WQ
        # the buffer's slices are contiguous runs of Q's columns, in slice order
        ids, first = np.unique(self.sid, return_index=True)
        ends = list(first[1:]) + [self.sid.size]
        for j, a, b in zip(ids, first, ends):
            self.cross[(int(j), sid)] = float(np.linalg.norm(G[a:b, k:]))
        self.Wn = np.block([[self.Wn, C], [-C.T, D]])
        self._append(sl.Q)
        self.th = np.concatenate([self.th, sl.theta])
        self.wqn = np.concatenate([self.wqn, np.linalg.norm(sl.WQ, axis=0)])
        self.rs = np.concatenate([self.rs, sl.resid])
        self.sid = np.concatenate([self.sid, np.full(sl.theta.size, sid)])
        self.phis[sid] = sl.phi
        self.radii[sid] = sl.radius
        self.edges.append((sid, sl.lo, sl.hi))

    def drop_below(self, x):
        """Forget the slices whose upper edge is below x (keep at least one)."""
        gone = [e for e in self.edges[:-1] if e[2] < x]
        if not gone:
            return
        # the oldest slices: the first columns of Q
        ngone = int(np.count_nonzero(np.isin(self.sid, [e[0] for e in gone])))
        keep = slice(ngone, None)
        self.th, self.rs, self.sid = self.th[keep], self.rs[keep], self.sid[keep]
        self.wqn = self.wqn[keep]
        self._q0 += ngone
        self.Wn = self.Wn[keep, keep]
        self.edges = self.edges[len(gone):]
        ids = {e[0] for e in self.edges}
        self.phis = {i: v for i, v in self.phis.items() if i in ids}
        self.radii = {i: v for i, v in self.radii.items() if i in ids}
        self.cross = {ij: v for ij, v in self.cross.items() if ij[0] in ids and ij[1] in ids}

    @property
    def radius(self):
        """Largest Kahan radius of the slices in the buffer: each eigenvalue of S
        matched to a Ritz value here lies within it of that value (those of the
        slices dropped lie below ``lo``)."""
        return max(self.radii[e[0]] for e in self.edges) if self.edges else 0.0

    @property
    def lo(self):
        """Lower edge of the oldest slice held."""
        return self.edges[0][1]

    @property
    def hi(self):
        """Upper edge of the newest slice held."""
        return self.edges[-1][2]

    def phi(self, idx):
        """Bound of ||Q_N^T Q_N - I||_2 for the Ritz vectors idx (their slices' overlaps)."""
        used = sorted(set(int(i) for i in self.sid[idx]))
        tot = sum(self.phis[i] ** 2 for i in used)
        tot += 2 * sum(self.cross[(i, j)] ** 2 for i in used for j in used if i < j)
        return math.sqrt(tot) * INFLATE
