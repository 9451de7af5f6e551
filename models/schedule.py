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

import numpy as np

from .constraints import ConstraintSet

BUBBLE = -1


@dataclass
class ScheduleStats:
    name: str
    window: int
    slots: int
    manifolds: int
    bubbles: int
    wrap_conflicts: int
    window_violations: int

    def describe(self) -> str:
        share = 100.0 * self.bubbles / self.slots if self.slots else 0.0
        return (f"{self.name} (W={self.window}): {self.manifolds} manifolds in {self.slots} slots, "
                f"{self.bubbles} bubbles ({share:.2f}%), {self.window_violations} hazards within the window, "
                f"{self.wrap_conflicts} across the pass wrap")


def pybullet_order(cons: ConstraintSet) -> np.ndarray:
    return np.arange(cons.num_manifolds, dtype=np.int64)


def _dynamic_pairs(cons: ConstraintSet, dynamic: np.ndarray) -> tuple[list[int], list[int]]:
    """Body indices per manifold with static bodies replaced by -1 (they never conflict)."""
    a = np.where(dynamic[cons.body_a], cons.body_a, -1)
    b = np.where(dynamic[cons.body_b], cons.body_b, -1)
    return a.tolist(), b.tolist()


def hazard_order(cons: ConstraintSet, dynamic: np.ndarray, window: int) -> np.ndarray:
    """Greedy hazard-free order with bubbles (see module docstring). ``window`` >= 1."""
    if window < 1:
        raise ValueError(f"hazard window must be >= 1, got {window}")
    a_list, b_list = _dynamic_pairs(cons, dynamic)
    m = len(a_list)
    last_issue: dict[int, int] = {}
    ready: list[int] = list(range(m))  # heap of manifold indices believed ready
    heapq.heapify(ready)
    waiting: list[tuple[int, int]] = []  # heap of (earliest slot, manifold)
    out: list[int] = []
    slot = 0
    far = -(1 << 40)
    while ready or waiting:
        while waiting and waiting[0][0] <= slot:
            heapq.heappush(ready, heapq.heappop(waiting)[1])
        issued = False
        while ready:
            k = heapq.heappop(ready)
            earliest = max(last_issue.get(a_list[k], far), last_issue.get(b_list[k], far)) + window
            if earliest <= slot:
                out.append(k)
                if a_list[k] >= 0:
                    last_issue[a_list[k]] = slot
                if b_list[k] >= 0:
                    last_issue[b_list[k]] = slot
                issued = True
                break
            heapq.heappush(waiting, (earliest, k))
        if not issued:
            if not waiting:
                break
            gap = waiting[0][0] - slot
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
    a_list, b_list = _dynamic_pairs(cons, dynamic)
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
        window_violations=int(np.sum(within < window)),
    )


def make_schedule(kind: str, cons: ConstraintSet, dynamic: np.ndarray, window: int = 64) -> np.ndarray:
    if kind == "pybullet":
        return pybullet_order(cons)
    if kind == "hazard":
        return hazard_order(cons, dynamic, window)
    raise ValueError(f"unknown schedule {kind!r} (expected 'pybullet' or 'hazard')")
