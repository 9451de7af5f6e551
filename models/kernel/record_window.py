"""The window kernel's host-side plan: how far each pass trails the one before it, and how many passes
one fetch of the records serves.

The window kernel (``rtl/pgs_window.sv``, a ``pgs_kernel`` built with ``WINDOW`` > 0) reads each manifold's window
record (``models/kernel/stream_format.py``: contact and friction words together) once per fetch and runs the fetch's
passes over an on-chip ring of ``depth`` records, pass j trailing pass j-1 by at least ``lag`` slots. With
``lag`` >= the band width D of the kernel's slot order (``models.order.manifold_schedule.band_width``: every dynamic
body's manifolds within D consecutive slots), every body sees its updates in the order of the sequential solve, so the
kernel's result is the golden model's bit for bit while the passes overlap. The kernel checks at ap_start that the plan
can always progress: ``1 <= fetch_passes <= ctx``, ``lag >= 1`` and ``(fetch_passes - 1) * lag + 2 <= depth``.

With ``lanes`` > 1 (a kernel built with ``LANES``) each ring record holds the combined records of ``lanes``
consecutive slots, issued together into ``lanes`` copies of the pipes. The lanes of a record must not share a
dynamic body: :func:`lane_slots` keeps the sequential order and pads a record with empty lanes (-1) where the
next manifold would share one; ``lag`` and ``depth`` then count records of ``lanes`` slots.

Records of several passes interleave at retire: :func:`sequential_order` puts a trace back into the golden
model's order (pass by pass, slots in order) for the comparison.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models.setup.constraints import ConstraintSet
from models.golden.contact_solver import SolverParams, pass_sequence
from models.kernel.body_banks import over_ports
from models.order.manifold_schedule import band_width, schedule_manifolds

DEFAULT_DEPTH = 16384  # records in the ring of the window builds make sim uses
DEFAULT_CTX = 8  # passes active at a time (pgs_window CTX)



def window_fetches(params: SolverParams, fetch_passes: int) -> int:
    """How many times the window kernel reads the records in one step (each fetch serves ``fetch_passes``)."""
    if fetch_passes < 1:
        raise ValueError(f"fetch_passes must be >= 1, got {fetch_passes}")
    return -(-len(pass_sequence(params)) // fetch_passes)


def window_fetch_kinds(params: SolverParams, fetch_passes: int, one_kind: bool = False) -> list[int | None]:
    """The pass kind of each fetch of the window kernel (None: a fetch serving both kinds). ``one_kind``: every
    fetch must serve passes of one kind (the window kernel with the impulses in the records: fetch_passes divides
    the iterations, or 1 with the kinds interleaved; the kernel refuses other arguments, error code 3)."""
    seq = pass_sequence(params)
    kinds: list[int | None] = []
    for f in range(window_fetches(params, fetch_passes)):
        served = {kind for kind, _ in seq[f * fetch_passes:(f + 1) * fetch_passes]}
        kinds.append(served.pop() if len(served) == 1 else None)
    if one_kind and None in kinds:
        raise ValueError(f"{fetch_passes} passes per fetch mix contact and friction passes of {params.iterations} "
                         f"iteration(s){' (interleaved)' if params.interleaved else ''}: with the impulses in the "
                         "records each fetch serves passes of one kind (fetch_passes must divide the iterations, or "
                         "be 1 with the kinds interleaved)")
    return kinds


@dataclass(frozen=True, eq=False)
class WindowPlan:
    """A window kernel build (``depth``, ``ctx``, ``lanes``) and the arguments of one step (``lag``,
    ``fetch_passes``); ``slots``: the kernel's slots (manifold indices, -1 an empty lane)."""

    depth: int
    ctx: int
    lag: int
    fetch_passes: int
    band: int  # D of the record order (lag >= band makes the run bit-exact)
    lanes: int = 1
    slots: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64), repr=False)

    @property
    def empty_lanes(self) -> int:
        return int(np.count_nonzero(self.slots < 0))

    def fetches(self, params: SolverParams) -> int:
        return window_fetches(params, self.fetch_passes)

    @property
    def ring_records(self) -> int:
        """Records the ring holds at most while the fetch's passes trail each other by ``lag``."""
        return min(self.depth, (self.fetch_passes - 1) * self.lag + 2)


def fits(depth: int, ctx: int, lag: int, fetch_passes: int) -> bool:
    """The kernel's argument check (rtl/pgs_sequencer.sv, error code 3 otherwise)."""
    return 1 <= fetch_passes <= ctx and lag >= 1 and (fetch_passes - 1) * lag + 2 <= depth


def lane_slots(slots: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray, lanes: int,
               banks: int = 0) -> np.ndarray:
    """``slots`` (manifold indices in the sequential order) grouped into records of ``lanes`` slots whose
    manifolds share no dynamic body: the order is kept, and a record is closed with empty lanes (-1) where the
    next manifold shares a dynamic body with one already in it, or (``banks`` > 0: the body velocities in banks,
    ``models.kernel.body_banks``) where its bodies A and B would have the record read some bank more than twice. The
    result has a multiple of ``lanes`` entries."""
    if lanes == 1:
        return np.asarray(slots, dtype=np.int64)
    slots = np.asarray(slots, dtype=np.int64)
    a = np.where(dynamic[cons.body_a[slots]], cons.body_a[slots], -1).tolist()
    b = np.where(dynamic[cons.body_b[slots]], cons.body_b[slots], -1).tolist()
    reads = list(zip(cons.body_a[slots].tolist(), cons.body_b[slots].tolist()))
    out: list[int] = []
    used: set[int] = set()  # dynamic bodies of the record being filled
    read: tuple[int, ...] = ()  # and the bodies its lanes read
    for m, ma, mb, ab in zip(slots.tolist(), a, b, reads):
        mine = {x for x in (ma, mb) if x >= 0}
        if len(out) % lanes and (mine & used or (banks and over_ports(banks, read + ab))):
            out.extend([-1] * (lanes - len(out) % lanes))
        if len(out) % lanes == 0:
            used, read = set(), ()
        out.append(m)
        used |= mine
        read += ab
    out.extend([-1] * (-len(out) % lanes))
    return np.asarray(out, dtype=np.int64)


def plan_window(cons: ConstraintSet, dynamic: np.ndarray, schedule: np.ndarray, params: SolverParams,
                depth: int = DEFAULT_DEPTH, ctx: int = DEFAULT_CTX, fetch_passes: int | None = None,
                lanes: int = 1, one_kind: bool = False, banks: int = 0) -> WindowPlan:
    """The plan of one step: the kernel's slots (bubbles dropped, :func:`lane_slots`), lag = D of its records,
    and ``fetch_passes`` as given or the most passes (every pass of the step at best) whose trailing fits the
    ring. ``one_kind`` (the kernel whose impulses travel with the records): every fetch serves passes of one kind
    (``models.kernel.record_window.window_fetch_kinds``), the most passes per fetch that allows."""
    if depth < 2 or depth & (depth - 1) or ctx < 2 or ctx & (ctx - 1):
        raise ValueError(f"window depth and contexts must be powers of two >= 2, got {depth}, {ctx}")
    if lanes < 1 or lanes & (lanes - 1):
        raise ValueError(f"lanes must be a power of two, got {lanes}")
    slots = lane_slots(schedule_manifolds(schedule), cons, dynamic, lanes, banks)
    band = band_width(slots, cons, dynamic, lanes)
    lag = max(1, band)
    passes = len(pass_sequence(params))
    if fetch_passes is None and one_kind:  # the most passes of one kind per fetch
        fetch_passes = max((f for f in range(1, min(ctx, max(passes, 1)) + 1) if fits(depth, ctx, lag, f)
                            and None not in window_fetch_kinds(params, f)), default=0)
    elif fetch_passes is None:  # the fewest fetches, each serving as few passes as that allows
        most = max((f for f in range(1, min(ctx, max(passes, 1)) + 1) if fits(depth, ctx, lag, f)), default=0)
        fetch_passes = -(-passes // -(-passes // most)) if most and passes else most
    if one_kind and fetch_passes:
        window_fetch_kinds(params, fetch_passes, one_kind=True)  # a ValueError where a fetch mixes the kinds
    if not fits(depth, ctx, lag, fetch_passes):
        raise ValueError(f"a window of {depth} records cannot hold {fetch_passes} passes trailing by {lag} slots "
                         f"(needs (fetch_passes - 1) * lag + 2 <= depth and 1 <= fetch_passes <= {ctx})")
    return WindowPlan(depth, ctx, lag, fetch_passes, band, lanes, slots)


def sequential_order(params: SolverParams, kind: np.ndarray, iteration: np.ndarray, slot: np.ndarray) -> np.ndarray:
    """The permutation that puts trace records (retired in any order) into the sequential solve's order: by pass
    of ``pass_sequence(params)``, then by slot."""
    seq = pass_sequence(params)
    pass_of = np.full((2, max(params.iterations, 1)), len(seq), dtype=np.int64)
    for p, (k, it) in enumerate(seq):
        pass_of[k, it] = p
    ok = (kind >= 0) & (kind < 2) & (iteration >= 0) & (iteration < pass_of.shape[1])
    p = np.where(ok, pass_of[np.clip(kind, 0, 1), np.clip(iteration, 0, pass_of.shape[1] - 1)], len(seq))
    return np.lexsort((slot, p))
