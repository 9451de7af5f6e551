"""Schedules: the order in which a pass visits the manifolds.

A schedule is an int array of manifold indices in issue order; -1 marks a bubble (an empty issue slot
the hardware spends waiting). It is the only definition of "sequential" that the golden model and
the kernel share: both solve the manifolds of a pass one after the other in this order.

* ``pybullet_order``: the order of the frame (pybullet's manifolds sorted by body pair).
* ``hazard_order``: a reordering in which no two manifolds within any W consecutive slots share a
  dynamic body, so a pipeline with W slots in flight never reads a velocity still being updated.
  Greedy list scheduling: each slot takes the earliest (in frame order) manifold whose dynamic bodies
  were last issued at least W slots ago; when none is ready the slot is a bubble. Passes repeat the
  same schedule back to back, so conflicts across the wrap from the end of one pass to the start of
  the next are counted too (the kernel stalls for those).
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from models.setup.constraints import ConstraintSet

BUBBLE = -1
UP_AXIS = 1  # frames are y-up (models/formats/frame.py)


@dataclass
class ScheduleStats:
    name: str
    window: int
    slots: int
    manifolds: int
    bubbles: int
    wrap_conflicts: int
    window_violations: int
    band: int  # D: the longest run of slots over which one dynamic body's manifolds spread (band_width)

    def describe(self) -> str:
        share = 100.0 * self.bubbles / self.slots if self.slots else 0.0
        return (f"{self.name} (W={self.window}): {self.manifolds} manifolds in {self.slots} slots, "
                f"{self.bubbles} bubbles ({share:.2f}%), {self.window_violations} hazards within the window, "
                f"{self.wrap_conflicts} across the pass wrap, band D={self.band}")


def pybullet_order(cons: ConstraintSet) -> np.ndarray:
    return np.arange(cons.num_manifolds, dtype=np.int64)


def _dynamic_pairs(cons: ConstraintSet, dynamic: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body indices per manifold with static bodies replaced by -1 (they never conflict)."""
    a = np.where(dynamic[cons.body_a], cons.body_a, -1).astype(np.int64)
    b = np.where(dynamic[cons.body_b], cons.body_b, -1).astype(np.int64)
    return a, b


def _check_permutation(order: np.ndarray, m: int) -> np.ndarray:
    """``order`` as an int64 array, or ValueError unless it holds every index 0..m-1 exactly once."""
    order = np.asarray(order, dtype=np.int64)
    if order.shape != (m,) or not np.array_equal(np.sort(order), np.arange(m)):
        raise ValueError(f"priority order must be a permutation of the {m} manifolds")
    return order


def hazard_order(cons: ConstraintSet, dynamic: np.ndarray, window: int,
                 priority: np.ndarray | None = None) -> np.ndarray:
    """Greedy hazard-free order with bubbles (see module docstring). ``window`` >= 1.

    ``priority`` (a permutation of the manifolds) replaces frame order as the order in which ready
    manifolds are preferred; None is frame order."""
    order = np.arange(cons.num_manifolds, dtype=np.int64) if priority is None else \
        _check_permutation(priority, cons.num_manifolds)
    return hazard_order_of(order, cons, dynamic, window)


def hazard_order_of(manifolds: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray, window: int) -> np.ndarray:
    """The greedy hazard-free order (with bubbles) of the given ``manifolds`` alone, preferred in their given order
    (``hazard_order`` of a subset: a group that must stay together, e.g. one layer pair of shock propagation)."""
    if window < 1:
        raise ValueError(f"hazard window must be >= 1, got {window}")
    idx = np.asarray(manifolds, dtype=np.int64)
    a, b = _dynamic_pairs(cons, dynamic)
    ranks = _greedy_hazard_ranks(a[idx].tolist(), b[idx].tolist(), window)
    return np.where(ranks >= 0, idx[np.maximum(ranks, 0)], BUBBLE)


def _greedy_hazard_ranks(a_list: list[int], b_list: list[int], window: int) -> np.ndarray:
    """The list scheduling of ``hazard_order`` over manifolds given by rank (their bodies, -1 = static).

    ``ready`` is a heap of manifolds believed ready (lowest rank first); a popped manifold whose bodies were issued
    less than ``window`` slots ago waits in ``waiting``, a heap of ``earliest slot * m + rank`` (one int: the order
    of (earliest slot, rank) pairs), until that slot. Static bodies share one entry of ``last_issue`` that stays
    far in the past."""
    m = len(a_list)
    far = -(1 << 40)
    static = max(a_list + b_list, default=-1) + 1
    last_issue = [far] * (static + 1)
    a_of = [x if x >= 0 else static for x in a_list]
    b_of = [x if x >= 0 else static for x in b_list]
    ready: list[int] = list(range(m))  # ascending: already a heap
    waiting: list[int] = []
    out: list[int] = []
    push, pop = heapq.heappush, heapq.heappop
    slot = 0
    while ready or waiting:
        next_slot_key = (slot + 1) * m
        while waiting and waiting[0] < next_slot_key:
            push(ready, pop(waiting) % m)
        issued = False
        while ready:
            k = pop(ready)
            a, b = a_of[k], b_of[k]
            la, lb = last_issue[a], last_issue[b]
            earliest = (la if la > lb else lb) + window
            if earliest <= slot:
                out.append(k)
                last_issue[a] = slot
                last_issue[b] = slot
                last_issue[static] = far
                issued = True
                break
            push(waiting, earliest * m + k)
        if not issued:
            if not waiting:
                break
            gap = waiting[0] // m - slot
            out.extend([BUBBLE] * gap)
            slot += gap
            continue
        slot += 1
    return np.asarray(out, dtype=np.int64)


def hazard_distances(schedule: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each slot, the distance (in slots) back to the previous use of each of its dynamic bodies.

    Returns (within, wrap): ``within`` are distances inside one pass (absent: large), ``wrap`` the distances
    when the previous use lies in the previous pass (the schedule repeats back to back).
    """
    s = np.asarray(schedule)
    n = s.shape[0]
    big = np.iinfo(np.int64).max // 4
    a_list, b_list = (x.tolist() for x in _dynamic_pairs(cons, dynamic))
    last: dict[int, int] = {}
    first: dict[int, int] = {}
    within = np.full(n, big, dtype=np.int64)
    for slot, k in enumerate(s.tolist()):
        if k < 0:
            continue
        for body in (a_list[k], b_list[k]):
            if body < 0:
                continue
            if body in last:
                within[slot] = min(within[slot], slot - last[body])
            else:
                first[body] = slot
            last[body] = slot
    wrap = np.full(n, big, dtype=np.int64)
    for body, f in first.items():
        wrap[f] = min(wrap[f], f + n - last[body])
    return within, wrap


def stats(name: str, schedule: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray, window: int) -> ScheduleStats:
    within, wrap = hazard_distances(schedule, cons, dynamic)
    return ScheduleStats(
        name=name, window=window, slots=int(schedule.shape[0]), manifolds=int(np.sum(schedule >= 0)),
        bubbles=int(np.sum(schedule < 0)), wrap_conflicts=int(np.sum(wrap < window)),
        window_violations=int(np.sum(within < window)), band=band_width(schedule, cons, dynamic),
    )


# --- band width -----------------------------------------------------------------------------------------
def body_spans(schedule: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray, per_record: int = 1) -> np.ndarray:
    """Per body, last slot - first slot + 1 over the slots of ``schedule`` holding its manifolds; with
    ``per_record`` > 1, over the records of ``per_record`` consecutive slots (the window kernel's lanes).

    0 for static bodies and for bodies in no manifold. Bubbles (-1) occupy slots like manifolds do."""
    s = np.asarray(schedule, dtype=np.int64)
    slots = np.nonzero(s >= 0)[0]
    body = np.concatenate([cons.body_a[s[slots]], cons.body_b[s[slots]]])
    slot = np.concatenate([slots, slots]) // per_record
    keep = dynamic[body]
    first = np.full(dynamic.shape[0], np.iinfo(np.int64).max, dtype=np.int64)
    last = np.full(dynamic.shape[0], -1, dtype=np.int64)
    np.minimum.at(first, body[keep], slot[keep])
    np.maximum.at(last, body[keep], slot[keep])
    return np.where(last >= 0, last - first + 1, 0)


def band_width(schedule: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray, per_record: int = 1) -> int:
    """D: the largest span of slots (of records of ``per_record`` slots; :func:`body_spans`) over the dynamic
    bodies; 0 when none is in a manifold."""
    return int(body_spans(schedule, cons, dynamic, per_record).max(initial=0))


# --- banded orders --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Incidence:
    """Which manifolds touch which dynamic body: ``manifolds[start[k]:start[k + 1]]`` touch body k.

    ``a``/``b`` are the manifolds' bodies with static ones replaced by -1; ``degree`` is the number of
    manifold-body incidences reachable from a manifold (its graph degree plus one per dynamic body)."""

    start: np.ndarray
    manifolds: np.ndarray
    a: np.ndarray
    b: np.ndarray
    degree: np.ndarray

    @staticmethod
    def of(cons: ConstraintSet, dynamic: np.ndarray) -> "_Incidence":
        a, b = _dynamic_pairs(cons, dynamic)
        m = cons.num_manifolds
        body = np.concatenate([a, b])
        manifold = np.concatenate([np.arange(m), np.arange(m)])
        keep = body >= 0
        by_body = np.argsort(body[keep], kind="stable")
        start = np.searchsorted(body[keep][by_body], np.arange(dynamic.shape[0] + 1))
        count = np.diff(start)
        degree = np.where(a >= 0, count[np.maximum(a, 0)], 0) + np.where(b >= 0, count[np.maximum(b, 0)], 0)
        return _Incidence(start, manifold[keep][by_body], a, b, degree)

    @property
    def num_manifolds(self) -> int:
        return int(self.a.shape[0])

    def manifolds_of(self, bodies: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The manifolds of ``bodies`` one body after the other, and for each the index into ``bodies``."""
        count = self.start[bodies + 1] - self.start[bodies]
        total = int(count.sum())
        within = np.arange(total) - np.repeat(np.cumsum(count) - count, count)
        return self.manifolds[np.repeat(self.start[bodies], count) + within], np.repeat(np.arange(len(bodies)), count)


class _LevelWalk:
    """Cuthill-McKee level structures over one incidence, placing each manifold at most once.

    :meth:`walk` places the roots in the given order, then level after level the unplaced manifolds that
    share a dynamic body with the level before, ordered by the position of the earliest manifold of that
    level they share a body with, then by degree, then by index (Cuthill-McKee, one level at a time)."""

    def __init__(self, inc: _Incidence) -> None:
        self.inc = inc
        self.pos = np.full(inc.num_manifolds, -1, dtype=np.int64)
        self.expanded = np.zeros(inc.start.shape[0] - 1, dtype=bool)
        self.placed = 0

    def walk(self, roots: np.ndarray) -> list[np.ndarray]:
        """The levels (manifold arrays, in placement order) of the component(s) reached from ``roots``."""
        front = np.asarray(roots, dtype=np.int64)
        levels: list[np.ndarray] = []
        while front.size:
            self.pos[front] = self.placed + np.arange(front.size)
            self.placed += front.size
            levels.append(front)
            front = self._next_level(front)
        return levels

    def undo(self, levels: list[np.ndarray]) -> None:
        """Forget a walk (a trial walk of the pseudo-peripheral search)."""
        placed = np.concatenate(levels)
        bodies = np.concatenate([self.inc.a[placed], self.inc.b[placed]])
        self.pos[placed] = -1
        self.expanded[bodies[bodies >= 0]] = False
        self.placed -= placed.size

    def _next_level(self, front: np.ndarray) -> np.ndarray:
        inc = self.inc
        body = np.stack([inc.a[front], inc.b[front]], axis=1).ravel()
        parent = np.repeat(self.pos[front], 2)
        known = body >= 0
        body, first = np.unique(body[known], return_index=True)  # front is in position order:
        parent = parent[known][first]  # the first occurrence is the earliest manifold
        fresh = ~self.expanded[body]
        body, parent = body[fresh], parent[fresh]
        self.expanded[body] = True
        reached, src = inc.manifolds_of(body)
        parent = parent[src]
        new = self.pos[reached] < 0
        reached, parent = reached[new], parent[new]
        by_parent = np.lexsort((reached, inc.degree[reached], parent))
        reached = reached[by_parent]
        _, first = np.unique(reached, return_index=True)
        return reached[np.sort(first)]



def _pseudo_peripheral(walk: _LevelWalk, seed: int) -> int:
    """A manifold of ``seed``'s component far from the rest (George and Liu): restart from the last level's
    lowest-degree manifold while that makes the level structure deeper."""
    root, levels = seed, walk.walk(np.array([seed]))
    walk.undo(levels)
    while True:
        last = levels[-1]
        candidate = int(last[np.argmin(walk.inc.degree[last])])
        trial = walk.walk(np.array([candidate]))
        walk.undo(trial)
        if len(trial) <= len(levels):
            return root
        root, levels = candidate, trial


def _components_in(walk: _LevelWalk, seeds: np.ndarray) -> Iterator[int]:
    """The seeds (in the given order) that are still unplaced when their turn comes: one per component
    when the caller places each yielded seed's whole component before asking for the next."""
    for seed in seeds.tolist():
        if walk.pos[seed] < 0:
            yield seed


def rcm_order(cons: ConstraintSet, dynamic: np.ndarray) -> np.ndarray:
    """Reverse Cuthill-McKee on the manifold graph (edges: a shared dynamic body), component by component
    (in the order of their lowest manifold index), each from a pseudo-peripheral manifold."""
    walk = _LevelWalk(_Incidence.of(cons, dynamic))
    parts = [np.concatenate(walk.walk(np.array([_pseudo_peripheral(walk, seed)])))[::-1]
             for seed in _components_in(walk, np.arange(cons.num_manifolds))]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


def _body_extent(cons: ConstraintSet, dynamic: np.ndarray, axis: int) -> float:
    """The size of a body along ``axis`` as the manifolds see it: the median, over dynamic bodies in two or
    more manifolds, of the extent of their manifold centres along ``axis`` (0 when there is no such body)."""
    coord = cons.center[:, axis]
    body = np.concatenate([cons.body_a, cons.body_b])
    value = np.concatenate([coord, coord])
    keep = dynamic[body]
    lo = np.full(dynamic.shape[0], np.inf)
    hi = np.full(dynamic.shape[0], -np.inf)
    np.minimum.at(lo, body[keep], value[keep])
    np.maximum.at(hi, body[keep], value[keep])
    count = np.bincount(body[keep], minlength=dynamic.shape[0])
    extent = (hi - lo)[count >= 2]
    return float(np.median(extent)) if extent.size else 0.0


def layered_order(cons: ConstraintSet, dynamic: np.ndarray) -> np.ndarray:
    """Manifold centres sorted by layer along the up axis, then x, then z (the other two axes in order).

    A layer is the up coordinate rounded to a multiple of the bodies' height (:func:`_body_extent`)."""
    c = cons.center
    height = _body_extent(cons, dynamic, UP_AXIS)
    layer = np.round(c[:, UP_AXIS] / height) if height > 0 else c[:, UP_AXIS]
    first, second = (ax for ax in range(3) if ax != UP_AXIS)
    return np.lexsort((c[:, second], c[:, first], layer))


def _face_sweep(cons: ConstraintSet, inc: _Incidence, dynamic: np.ndarray, axis: int, across: int) -> np.ndarray:
    """Cuthill-McKee from a face, component by component (in order along ``axis``): the roots are the
    component's manifolds within half a body (:func:`_body_extent`) of its lowest centre along ``axis``,
    ordered by ``across``, then by the remaining axis."""
    c = cons.center
    rest = 3 - axis - across
    half = 0.5 * _body_extent(cons, dynamic, axis)
    walk = _LevelWalk(inc)
    parts = []
    for seed in _components_in(walk, np.argsort(c[:, axis], kind="stable")):
        trial = walk.walk(np.array([seed]))
        walk.undo(trial)
        members = np.concatenate(trial)
        roots = members[c[members, axis] <= c[seed, axis] + half]
        roots = roots[np.lexsort((roots, c[roots, rest], c[roots, across]))]
        parts.append(np.concatenate(walk.walk(roots)))
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


def sweep_order(cons: ConstraintSet, dynamic: np.ndarray) -> np.ndarray:
    """The face sweep (module docstring) over every sweep axis and root order, the one of smallest D."""
    inc = _Incidence.of(cons, dynamic)
    sweeps = (_face_sweep(cons, inc, dynamic, axis, across) for axis in range(3) for across in range(3)
              if across != axis)
    return min(sweeps, key=lambda order: band_width(order, cons, dynamic))


BandedOrder = Callable[[ConstraintSet, np.ndarray], np.ndarray]
BANDED_ORDERS: dict[str, BandedOrder] = {"layered": layered_order, "rcm": rcm_order, "sweep": sweep_order}
SCHEDULE_KINDS = ("pybullet", "hazard", "banded", *BANDED_ORDERS)


def banded_order(cons: ConstraintSet, dynamic: np.ndarray) -> tuple[str, np.ndarray]:
    """The banded order of smallest D (the first such in ``BANDED_ORDERS``) and its name."""
    orders = {name: order(cons, dynamic) for name, order in BANDED_ORDERS.items()}
    name = min(orders, key=lambda n: band_width(orders[n], cons, dynamic))
    return name, orders[name]


def make_schedule(kind: str, cons: ConstraintSet, dynamic: np.ndarray, window: int = 64) -> np.ndarray:
    """The schedule of ``kind`` (``SCHEDULE_KINDS``); every kind but ``pybullet`` is hazard-free within
    ``window`` slots: ``banded`` and the named banded orders go through ``hazard_order`` as its priority."""
    if kind == "pybullet":
        return pybullet_order(cons)
    if kind == "hazard":
        return hazard_order(cons, dynamic, window)
    if kind == "banded" or kind in BANDED_ORDERS:
        if window < 1:
            raise ValueError(f"hazard window must be >= 1, got {window}")
        order = banded_order(cons, dynamic)[1] if kind == "banded" else BANDED_ORDERS[kind](cons, dynamic)
        return hazard_order(cons, dynamic, window, order)
    raise ValueError(f"unknown schedule {kind!r} (expected one of {', '.join(SCHEDULE_KINDS)})")


def schedule_manifolds(schedule: np.ndarray) -> np.ndarray:
    """The schedule without bubbles: slot k of a pass holds manifold ``schedule_manifolds(s)[k]``."""
    s = np.asarray(schedule, dtype=np.int64)
    return s[s >= 0]
