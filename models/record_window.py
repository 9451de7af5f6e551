"""The window kernel's host-side plan (issue 10): how far each pass trails the one before it, and how many passes
one fetch of the records serves.

The window kernel (``rtl/pgs_window.sv``, a ``pgs_kernel`` built with ``WINDOW`` > 0) reads each manifold's window
record (``models/stream_format.py``: contact and friction words together) once per fetch and runs the fetch's
passes over an on-chip ring of ``depth`` records, pass j trailing pass j-1 by at least ``lag`` slots. With
``lag`` >= the band width D of the kernel's slot order (``models.schedule.band_width``: every dynamic body's
manifolds within D consecutive slots), every body sees its updates in the order of the sequential solve, so the
kernel's result is the golden model's bit for bit while the passes overlap. The kernel checks at ap_start that the
plan can always progress: ``1 <= fetch_passes <= ctx``, ``lag >= 1`` and ``(fetch_passes - 1) * lag + 2 <= depth``.

Records of several passes interleave at retire: :func:`sequential_order` puts a trace back into the golden
model's order (pass by pass, slots in order) for the comparison.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constraints import ConstraintSet
from .contact_solver import SolverParams, pass_sequence
from .schedule import band_width
from .stream_format import schedule_manifolds

DEFAULT_DEPTH = 16384  # records in the ring of the window builds make sim uses
DEFAULT_CTX = 8  # passes active at a time (pgs_window CTX)


@dataclass(frozen=True)
class WindowPlan:
    """A window kernel build (``depth``, ``ctx``) and the arguments of one step (``lag``, ``fetch_passes``)."""

    depth: int
    ctx: int
    lag: int
    fetch_passes: int
    band: int  # D of the slot order (lag >= band makes the run bit-exact)

    def fetches(self, params: SolverParams) -> int:
        return -(-len(pass_sequence(params)) // self.fetch_passes)

    @property
    def ring_records(self) -> int:
        """Records the ring holds at most while the fetch's passes trail each other by ``lag``."""
        return min(self.depth, (self.fetch_passes - 1) * self.lag + 2)


def fits(depth: int, ctx: int, lag: int, fetch_passes: int) -> bool:
    """The kernel's argument check (rtl/pgs_sequencer.sv, error code 3 otherwise)."""
    return 1 <= fetch_passes <= ctx and lag >= 1 and (fetch_passes - 1) * lag + 2 <= depth


def plan_window(cons: ConstraintSet, dynamic: np.ndarray, schedule: np.ndarray, params: SolverParams,
                depth: int = DEFAULT_DEPTH, ctx: int = DEFAULT_CTX, fetch_passes: int | None = None) -> WindowPlan:
    """The plan of one step: lag = D of the kernel's slots (bubbles dropped), and ``fetch_passes`` as given or
    the most passes (every pass of the step at best) whose trailing fits the ring."""
    if depth < 2 or depth & (depth - 1) or ctx < 2 or ctx & (ctx - 1):
        raise ValueError(f"window depth and contexts must be powers of two >= 2, got {depth}, {ctx}")
    slots = schedule_manifolds(schedule)
    band = band_width(slots, cons, dynamic)
    lag = max(1, band)
    passes = len(pass_sequence(params))
    if fetch_passes is None:  # the fewest fetches, each serving as few passes as that allows
        most = max((f for f in range(1, min(ctx, max(passes, 1)) + 1) if fits(depth, ctx, lag, f)), default=0)
        fetch_passes = -(-passes // -(-passes // most)) if most and passes else most
    if not fits(depth, ctx, lag, fetch_passes):
        raise ValueError(f"a window of {depth} records cannot hold {fetch_passes} passes trailing by {lag} slots "
                         f"(needs (fetch_passes - 1) * lag + 2 <= depth and 1 <= fetch_passes <= {ctx})")
    return WindowPlan(depth, ctx, lag, fetch_passes, band)


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
