"""Bullet3's constraint batching: the manifolds of a frame put into batches in which no dynamic body repeats.

Bullet's GPU solver (``b3GpuPgsContactSolver``) solves a batch's constraints in parallel: since no dynamic body
appears twice in a batch, each work item reads and writes its own two bodies, race-free. The batches run one after
the other, so the whole pass is a sequential Gauss-Seidel pass in one particular order: the batches concatenated
(a manifold of batch k+1 sees every velocity batch k wrote; manifolds of one batch touch disjoint dynamic bodies,
so their order inside the batch changes nothing). The golden model run in that order (``Batches.order`` as its
schedule) is therefore the same computation.

Which batching, and why: **Bullet3's greedy batching of its "large batches" path** (``sortConstraintByBatch3`` in
``b3GpuPgsContactSolver.cpp``, used with ``gUseLargeBatches``: one batching of the whole frame, one kernel launch per
batch), not a graph colouring of our own, because the peer is meant to be Bullet's scheme as Bullet ships it:

1. the contacts are first put in Bullet's determinism order (:func:`determinism_order`: a stable sort by the bodies'
   signed indices, static bodies negated, compared as unsigned 32-bit words);
2. batch after batch, one scan over the constraints not yet batched, in their current positions: a constraint joins
   the batch when neither of its dynamic bodies is flagged (static bodies are never flagged, so any number of ground
   contacts share a batch); its bodies are then flagged and it is swapped with the first unbatched position (the
   swap permutes the constraints still waiting, exactly as Bullet's in-place ``b3Swap`` does);
3. at most ``B3_MAX_NUM_BATCHES`` = 128 batches: Bullet reports ``batchIdx>=B3_MAX_NUM_BATCHES`` and leaves the rest
   unsolved; here a frame that needs more raises :class:`BatchingError` instead of dropping constraints.

The ``simdWidth`` of that path is the constraint count plus one, so the flags are never reset inside a batch (the
spatial-cell path's 64-wide reset and 2,048-bit hash do not apply). A greedy colouring needs at most 2d - 1 batches
for bodies of at most d manifolds; a graph colouring (e.g. DSatur) would need fewer batches, i.e. fewer launches,
but would solve the manifolds in another order than Bullet's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

B3_MAX_NUM_BATCHES = 128  # Bullet3's b3Solver.h


class BatchingError(ValueError):
    """A frame whose manifolds need more batches than the cap (Bullet would leave the rest unsolved)."""


@dataclass(frozen=True)
class Batches:
    """Manifolds in solve order, batch after batch, and the size of each batch."""

    order: np.ndarray  # (M,) manifold indices: batch 0's, then batch 1's, ...
    sizes: np.ndarray  # (B,) manifolds per batch

    @property
    def num_batches(self) -> int:
        return int(self.sizes.shape[0])

    @property
    def offsets(self) -> np.ndarray:
        """(B + 1,) where each batch starts in ``order`` (and the end)."""
        return np.concatenate([[0], np.cumsum(self.sizes)]).astype(np.int64)

    def batch(self, k: int) -> np.ndarray:
        """The manifolds of batch ``k``."""
        off = self.offsets
        return self.order[off[k]:off[k + 1]]


def determinism_order(body_a: np.ndarray, body_b: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """Bullet3's determinism sort of the contacts: stable by (A, B) with each body's signed index (``-idx`` for a
    static body, as ``m_bodyAPtrAndSignBit``; index 0 cannot be negated) compared as an unsigned 32-bit word, so
    contacts with static bodies other than body 0 sort last."""
    def key(body: np.ndarray) -> np.ndarray:
        signed = np.where(dynamic[body], body, -body).astype(np.int64)
        return signed & 0xFFFFFFFF

    return np.lexsort((key(np.asarray(body_b)), key(np.asarray(body_a)))).astype(np.int64)


def greedy_batches(body_a: np.ndarray, body_b: np.ndarray, dynamic: np.ndarray,
                   max_batches: int = B3_MAX_NUM_BATCHES, order: np.ndarray | None = None) -> Batches:
    """Bullet3's ``sortConstraintByBatch3`` over the manifolds in ``order`` (default: :func:`determinism_order`);
    raises :class:`BatchingError` when more than ``max_batches`` batches are needed."""
    body_a = np.asarray(body_a, dtype=np.int64)
    body_b = np.asarray(body_b, dtype=np.int64)
    if body_a.shape != body_b.shape or body_a.ndim != 1:
        raise ValueError(f"body_a and body_b must be equal 1-D arrays, got {body_a.shape} and {body_b.shape}")
    if max_batches < 1:
        raise ValueError(f"max_batches must be >= 1, got {max_batches}")
    m = body_a.shape[0]
    cs = (determinism_order(body_a, body_b, dynamic) if order is None else np.asarray(order, dtype=np.int64)).tolist()
    if sorted(cs) != list(range(m)):
        raise ValueError(f"order must be a permutation of the {m} manifolds")
    dyn = np.asarray(dynamic, dtype=bool)
    a_of = np.where(dyn[body_a], body_a, -1).tolist()
    b_of = np.where(dyn[body_b], body_b, -1).tolist()
    used = bytearray(dyn.shape[0])
    sizes: list[int] = []
    valid = 0
    while valid < m:
        if len(sizes) == max_batches:
            raise BatchingError(f"the frame's {m} manifolds need more than B3_MAX_NUM_BATCHES = {max_batches} "
                                f"batches ({m - valid} left after {max_batches}); Bullet3 would leave them unsolved")
        start, flagged = valid, []
        for i in range(valid, m):
            k = cs[i]
            a, b = a_of[k], b_of[k]
            if (a < 0 or not used[a]) and (b < 0 or not used[b]):
                if a >= 0:
                    used[a] = 1
                    flagged.append(a)
                if b >= 0:
                    used[b] = 1
                    flagged.append(b)
                cs[i], cs[valid] = cs[valid], cs[i]
                valid += 1
        for body in flagged:
            used[body] = 0
        sizes.append(valid - start)
    return Batches(np.asarray(cs, dtype=np.int64), np.asarray(sizes, dtype=np.int64))


def check_batches(batches: Batches, body_a: np.ndarray, body_b: np.ndarray, dynamic: np.ndarray) -> None:
    """Raise ValueError unless every manifold is in exactly one batch and no dynamic body repeats in a batch."""
    m = np.asarray(body_a).shape[0]
    if batches.order.shape != (m,) or not np.array_equal(np.sort(batches.order), np.arange(m)):
        raise ValueError("the batches do not hold every manifold exactly once")
    if int(batches.sizes.sum()) != m or np.any(batches.sizes <= 0):
        raise ValueError(f"batch sizes {batches.sizes.tolist()} do not partition the {m} manifolds")
    for k in range(batches.num_batches):
        idx = batches.batch(k)
        bodies = np.concatenate([np.asarray(body_a)[idx], np.asarray(body_b)[idx]])
        bodies = bodies[np.asarray(dynamic)[bodies]]
        if np.unique(bodies).shape[0] != bodies.shape[0]:
            raise ValueError(f"batch {k} holds a dynamic body twice")
