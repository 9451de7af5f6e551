"""The contact manifolds of a stepped pybullet world, read with per-body queries, as few and as parallel as they
can be.

Where the time goes: ``getContactPoints(bodyA=b)`` scans *every* manifold of the world on the server side, so one
query costs time proportional to the world's manifold count M (measured: 0.23 ms at M = 3,545, 1.0 ms at
M = 15,485) and a query per body costs N * M: the thesis frame's 495 s. The global query is O(M) once but corrupt
at that size (``shared/research/pybullet_contacts_at_scale.md``), and pybullet has no query by manifold range, so
the scan per query is pybullet's floor. What can be cut is the number of queries and the cores they run on:

* **a vertex cover of the broadphase**: a query of body b reports every manifold of b, so only a set of bodies that
  touches every overlapping pair needs a query (:func:`query_plan`, greedy by degree over
  ``getOverlappingObjects``): the ground and every other layer of a stack, about half the bodies;
* **forked readers** (``workers`` > 1, for a machine with idle cores): after the step the process forks
  ``workers`` times; each copy of the (single-threaded, in-process) DIRECT world answers a share of the queries
  and the rows are merged in query order. On the shared 2-core machine under load (load average 19) two readers
  gained nothing (``docs/results/cosim_speed.md``, contact capture at scale), so the default is one;
* **consuming readers** (worlds whose pairs have one manifold each, as boxes do: the built-in scenes): a forked
  reader removes each body from its copy of the world once queried, so the manifolds already read leave the
  scan and later queries get cheaper (the parent's world is untouched). Where a pair has several manifolds
  (compound shapes) the removals reorder the survivors, so file worlds are read in-process, in place.

A manifold is kept from the side of its smaller frame index when that body is queried (the rows exactly as
before); otherwise from the other side, turned back exactly as pybullet turned it: the points swapped, the normal
negated, distance, forces and friction directions unchanged (bit for bit, checked in the tests). The result is the
same, byte for byte, as a query of every body (``full=True``).

Manifolds are keyed by (body, link, body, link) through the frame body index of each (pybullet body, link). The
points of one pair come in runs (one run per Bullet manifold, e.g. one per child of a compound shape); a run of
more than 4 points is split into consecutive manifolds of at most 4 in the reported order (pybullet reports no
manifold boundaries inside a run; Bullet's own manifolds hold at most 4 points).
"""

from __future__ import annotations

import os
import pickle
import sys
import time
from dataclasses import dataclass

import numpy as np
import pybullet as p

POINT_COLUMNS = 19  # point_on_a(3) point_on_b(3) normal_on_b(3) distance normal_force f1 dir1(3) f2 dir2(3)
MAX_POINTS = 4
PARALLEL_MIN_QUERIES = 4000  # fewer queries than this are read in-process (a fork costs more than it saves)


@dataclass
class Manifolds:
    """Contact manifolds in frame indices (the manifold fields of Frame)."""

    body_a: np.ndarray
    body_b: np.ndarray
    num_points: np.ndarray
    point_on_a: np.ndarray
    point_on_b: np.ndarray
    normal_on_b: np.ndarray
    distance: np.ndarray
    normal_force: np.ndarray
    lateral_friction1: np.ndarray
    lateral_dir1: np.ndarray
    lateral_friction2: np.ndarray
    lateral_dir2: np.ndarray

    def __len__(self) -> int:
        return int(self.body_a.shape[0])

    def as_dict(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class FrameBodies:
    """The frame's bodies in pybullet: frame body i is link ``links[i]`` (-1: the base) of body ``ids[i]``."""

    ids: np.ndarray  # (N,) int64 pybullet unique ids
    links: np.ndarray  # (N,) int64 link indices

    def index_of(self) -> dict[tuple[int, int], int]:
        return {(int(b), int(l)): i for i, (b, l) in enumerate(zip(self.ids.tolist(), self.links.tolist()))}


def query_plan(client: int, bodies: FrameBodies, dynamic: np.ndarray, margin: float) -> np.ndarray:
    """Frame indices whose queries report every manifold: a greedy vertex cover (highest degree first) of the
    broadphase's overlapping pairs, each body's AABB grown by ``margin`` (m: what a body moved in the step)."""
    index_of = bodies.index_of()
    n = bodies.ids.shape[0]
    edges: list[tuple[int, int]] = []
    for i, (b, l) in enumerate(zip(bodies.ids.tolist(), bodies.links.tolist())):
        lo, hi = p.getAABB(b, l, physicsClientId=client)
        found = p.getOverlappingObjects([x - margin for x in lo], [x + margin for x in hi], physicsClientId=client)
        for ob, ol in found or ():
            j = index_of.get((int(ob), int(ol)))
            if j is not None and j > i and (dynamic[i] or dynamic[j]):
                edges.append((i, j))
    return _greedy_cover(n, np.asarray(edges, dtype=np.int64).reshape(-1, 2))


def _greedy_cover(n: int, edges: np.ndarray) -> np.ndarray:
    """A vertex cover of the graph (sorted frame indices): repeatedly the vertex with most uncovered edges."""
    import heapq

    adj: list[list[int]] = [[] for _ in range(n)]
    for i, j in edges.tolist():
        adj[i].append(j)
        adj[j].append(i)
    degree = [len(a) for a in adj]
    heap = [(-d, v) for v, d in enumerate(degree) if d]
    heapq.heapify(heap)
    covered = np.zeros(n, dtype=bool)
    while heap:
        d, v = heapq.heappop(heap)
        if covered[v] or degree[v] == 0:
            continue
        if -d != degree[v]:  # stale entry
            heapq.heappush(heap, (-degree[v], v))
            continue
        covered[v] = True
        for u in adj[v]:
            if not covered[u]:
                degree[u] -= 1
        degree[v] = 0
    return np.flatnonzero(covered)


def _read_rows(client: int, bodies: FrameBodies, in_plan: np.ndarray, share: np.ndarray,
               consume: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The kept points of the queries of the pybullet bodies ``share``, in query order: (groups (G,4): frame index
    a < b, number of points, 1 where read from b's side and turned back; points (P,19)), each group one run of one
    pair. ``in_plan`` marks
    the frame bodies whose pybullet body is queried (all its links)."""
    index_of = bodies.index_of()
    groups: list[list[int]] = []
    kept: list[tuple[float, ...]] = []
    for bid in share.tolist():
        pts = p.getContactPoints(bodyA=bid, physicsClientId=client) or ()
        if consume:  # a forked reader's own copy: its manifolds are read, so later scans skip them
            p.removeBody(bid, physicsClientId=client)
        cur: tuple[int, int] | None = None
        for pt in pts:
            if pt[1] != bid:
                raise RuntimeError(f"getContactPoints(bodyA={bid}) reported body {pt[1]} as A")
            me = index_of.get((bid, int(pt[3])))
            j = index_of.get((int(pt[2]), int(pt[4])))
            if me is None or j is None:
                raise RuntimeError(f"contact with an unknown pybullet body/link: ({pt[1]}, {pt[3]}), ({pt[2]}, {pt[4]})")
            if j < me and in_plan[j]:  # the other body's query keeps this pair
                cur = None
                continue
            if (me, j) != cur:
                cur = (me, j)
                groups.append([min(me, j), max(me, j), 0, int(j < me)])
            groups[-1][2] += 1
            if j > me:
                kept.append((*pt[5], *pt[6], *pt[7], pt[8], pt[9], pt[10], *pt[11], pt[12], *pt[13]))
            else:  # seen from the larger index: turn it back (points swapped, normal negated)
                nx, ny, nz = pt[7]
                kept.append((*pt[6], *pt[5], -nx, -ny, -nz, pt[8], pt[9], pt[10], *pt[11], pt[12], *pt[13]))
    data = np.asarray(kept, dtype=np.float64).reshape(-1, POINT_COLUMNS)
    return np.asarray(groups, dtype=np.int64).reshape(-1, 4), data


def _read_forked(client: int, bodies: FrameBodies, in_plan: np.ndarray, queried: np.ndarray,
                 workers: int, consume: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_read_rows` over the pybullet bodies ``queried`` split into ``workers`` contiguous shares, each read by
    a forked copy of this process (the DIRECT world is in-process memory, copied on write), merged in query order."""
    shares = np.array_split(queried, workers)
    readers: list[tuple[int, int]] = []
    for share in shares:
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the reader: answer its share, send the rows, exit without running any cleanup
            os.close(r)
            code = 0
            try:
                blob = pickle.dumps(_read_rows(client, bodies, in_plan, share, consume), protocol=pickle.HIGHEST_PROTOCOL)
            except BaseException as exc:  # report it to the parent, which raises
                blob, code = pickle.dumps(RuntimeError(f"contact reader failed: {exc}")), 1
            with os.fdopen(w, "wb") as out:
                out.write(blob)
            os._exit(code)
        os.close(w)
        readers.append((pid, r))
    parts: list[tuple[np.ndarray, np.ndarray]] = []
    failure: BaseException | None = None
    for pid, r in readers:
        with os.fdopen(r, "rb") as inp:
            blob = inp.read()
        _, status = os.waitpid(pid, 0)
        got = pickle.loads(blob) if blob else RuntimeError(f"contact reader {pid} died (status {status})")
        if isinstance(got, BaseException) or status != 0:
            failure = failure or (got if isinstance(got, BaseException) else RuntimeError("contact reader failed"))
            continue
        parts.append(got)
    if failure is not None:
        raise failure
    return (np.concatenate([g for g, _ in parts]).reshape(-1, 4),
            np.concatenate([d for _, d in parts]).reshape(-1, POINT_COLUMNS))


def read_manifolds(client: int, bodies: FrameBodies, queried: np.ndarray, workers: int = 1,
                   progress: bool = False, parallel_min: int | None = None, consume: bool = False) -> Manifolds:
    """The manifolds reported to the queries of ``queried`` (frame indices, ascending; every body for the old
    behaviour), read by ``workers`` forked readers, sorted by (body_a, body_b) and, within a pair, in report
    order, runs of more than 4 points split into manifolds of at most 4. Forked readers only from
    ``parallel_min`` queries on (default :data:`PARALLEL_MIN_QUERIES`). With ``consume`` (only for worlds whose
    pairs have one manifold each, as boxes do) the readers, always forked then, remove each body from their copy
    of the world after its query."""
    t0 = time.monotonic()
    first = np.asarray(queried, dtype=np.int64)
    uids = bodies.ids[first]
    uids = uids[np.sort(np.unique(uids, return_index=True)[1])]  # each pybullet body once, in frame order
    in_plan = np.isin(bodies.ids, uids)
    least = PARALLEL_MIN_QUERIES if parallel_min is None else parallel_min
    if (workers > 1 or consume) and uids.shape[0] >= least and hasattr(os, "fork"):
        g, data = _read_forked(client, bodies, in_plan, uids, min(workers, uids.shape[0]), consume)
    else:
        g, data = _read_rows(client, bodies, in_plan, uids)
    if progress:
        print(f"  contact query: {uids.shape[0]} of {len(set(bodies.ids.tolist()))} bodies queried, {g.shape[0]} runs, "
              f"{time.monotonic() - t0:.1f} s ({workers} reader(s))", file=sys.stderr, flush=True)
    return _assemble(g, data)


def _assemble(g: np.ndarray, data: np.ndarray) -> Manifolds:
    """Runs (G,4) of points (P,19) into manifolds of at most 4 points, sorted (stable) by (body_a, body_b)."""
    counts = g[:, 2]
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64) if g.shape[0] else np.zeros(0, np.int64)
    pieces = (counts + MAX_POINTS - 1) // MAX_POINTS  # manifolds per run
    run_of = np.repeat(np.arange(g.shape[0]), pieces)
    piece = np.arange(run_of.shape[0]) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    num = np.minimum(counts[run_of] - piece * MAX_POINTS, MAX_POINTS)
    first = starts[run_of] + piece * MAX_POINTS
    a, b = g[run_of, 0], g[run_of, 1]
    order = np.lexsort((b, a))  # stable: runs keep their report order within a pair
    a, b, num, first = a[order], b[order], num[order], first[order]
    m = a.shape[0]
    row = np.repeat(np.arange(m), num)
    slot = np.arange(row.shape[0]) - np.repeat(np.cumsum(num) - num, num)
    src = np.repeat(first, num) + slot

    def per_point(cols: slice | int) -> np.ndarray:
        width = () if isinstance(cols, int) else (3,)
        arr = np.zeros((m, MAX_POINTS) + width)
        arr[row, slot] = data[src][:, cols]
        return arr

    return Manifolds(
        body_a=a.astype(np.int32), body_b=b.astype(np.int32), num_points=num.astype(np.int32),
        point_on_a=per_point(slice(0, 3)), point_on_b=per_point(slice(3, 6)), normal_on_b=per_point(slice(6, 9)),
        distance=per_point(9), normal_force=per_point(10), lateral_friction1=per_point(11),
        lateral_dir1=per_point(slice(12, 15)), lateral_friction2=per_point(15), lateral_dir2=per_point(slice(16, 19)))
