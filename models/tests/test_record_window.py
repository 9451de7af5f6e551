"""The window kernel's plan (models/kernel/record_window.py): lag, passes per fetch, the kernel's argument check, and
the trace order."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models.kernel.body_banks import over_ports
from models.setup.constraints import ConstraintSet
from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS, SolverParams, pass_sequence
from models.kernel.record_window import fits, lane_slots, plan_window, sequential_order
from models.order.manifold_schedule import band_width


def _chain(m: int) -> tuple[ConstraintSet, np.ndarray]:
    """Manifold k joins bodies k and k+1 (body 0 static): in order, every body's manifolds are adjacent (D = 2)."""
    z = np.zeros
    cons = ConstraintSet(body_a=np.arange(m), body_b=np.arange(1, m + 1), num_points=np.ones(m, int),
                         normal=z((m, 3)), points=z((m, 4, 3)), jac_inv=z((m, 4)), bias=z((m, 4)), center=z((m, 3)),
                         tangent=z((m, 2, 3)), f_jac_inv=z((m, 2)), spin_damp=z(m, bool))
    dyn = np.ones(m + 1, bool)
    dyn[0] = False
    return cons, dyn


def test_plan_lag_is_the_band_of_the_slots() -> None:
    cons, dyn = _chain(50)
    order = np.arange(50)
    plan = plan_window(cons, dyn, order, SolverParams(4), depth=64)
    assert plan.band == plan.lag == band_width(order, cons, dyn) == 2
    assert plan.fetch_passes == 8 and plan.fetches(SolverParams(4)) == 1
    # bubbles are not slots of the kernel: the same manifolds with bubbles between them have the same lag
    with_bubbles = np.array([0, -1, 1, -1, -1, *range(2, 50)])
    assert plan_window(cons, dyn, with_bubbles, SolverParams(4), depth=64).lag == 2
    # a shuffled order widens the band; a small ring then serves fewer passes per fetch, evenly split
    shuffled = np.random.default_rng(1).permutation(50)
    wide = plan_window(cons, dyn, shuffled, SolverParams(4), depth=64)
    assert wide.lag == band_width(shuffled, cons, dyn) > 2
    most = max(f for f in range(1, 9) if fits(64, 8, wide.lag, f))
    assert fits(64, 8, wide.lag, wide.fetch_passes) and wide.fetches(SolverParams(4)) == -(-8 // most)
    with pytest.raises(ValueError):
        plan_window(cons, dyn, order, SolverParams(4), depth=48)  # not a power of two
    with pytest.raises(ValueError):
        plan_window(cons, dyn, shuffled, SolverParams(4), depth=64, fetch_passes=8)


def test_plan_of_one_kind_fetches() -> None:
    """With the impulses in the records every fetch serves passes of one kind: the most passes per fetch that
    divides the iterations and fits the ring (not the evenly split most of the plan above); a given fetch_passes
    that mixes the kinds is refused."""
    cons, dyn = _chain(50)
    order = np.arange(50)
    assert plan_window(cons, dyn, order, SolverParams(4), depth=64, one_kind=True).fetch_passes == 4
    assert plan_window(cons, dyn, order, SolverParams(3), depth=64, one_kind=True).fetch_passes == 3
    assert plan_window(cons, dyn, order, SolverParams(2, interleaved=True), depth=64, one_kind=True).fetch_passes == 1
    shuffled = np.random.default_rng(1).permutation(50)
    wide = plan_window(cons, dyn, shuffled, SolverParams(4), depth=64, one_kind=True)
    assert 4 % wide.fetch_passes == 0 and fits(64, 8, wide.lag, wide.fetch_passes)
    assert not any(fits(64, 8, wide.lag, f) for f in range(wide.fetch_passes + 1, 5) if 4 % f == 0)
    with pytest.raises(ValueError, match="one kind"):
        plan_window(cons, dyn, order, SolverParams(4), depth=64, fetch_passes=3, one_kind=True)


@pytest.mark.parametrize("lanes", [2, 4])
def test_lane_slots(lanes: int) -> None:
    """Records of ``lanes`` slots: the sequential order kept, no dynamic body twice in a record, and a record padded
    with empty lanes (-1) only where the next manifold shares a dynamic body with it (or at the end)."""
    rng = np.random.default_rng(lanes)
    m, nb = 400, 120
    cons, _ = _chain(m)
    cons.body_a[:] = rng.integers(0, nb, m)
    cons.body_b[:] = (cons.body_a + rng.integers(1, nb, m)) % nb
    dyn = rng.random(nb) > 0.1
    order = rng.permutation(m)
    slots = lane_slots(order, cons, dyn, lanes)
    assert len(slots) % lanes == 0 and np.array_equal(slots[slots >= 0], order)
    records = slots.reshape(-1, lanes)
    for r, rec in enumerate(records):
        real = rec[rec >= 0]
        bodies = np.concatenate([cons.body_a[real], cons.body_b[real]])
        bodies = bodies[dyn[bodies]]
        assert len(np.unique(bodies)) == len(bodies), f"record {r} names a dynamic body twice"
        assert np.all(rec[:len(real)] >= 0), "empty lanes only close a record"
        if len(real) < lanes and r + 1 < len(records):  # padded: the next record's first manifold collides
            nxt = records[r + 1][0]
            assert set(bodies) & {x for x in (cons.body_a[nxt], cons.body_b[nxt]) if dyn[x]}
    assert np.array_equal(lane_slots(order, cons, dyn, 1), order)
    # the plan: lag = D of the records, on the lane slots
    plan = plan_window(cons, dyn, order, SolverParams(4), depth=1024, lanes=lanes)
    assert np.array_equal(plan.slots, slots) and plan.lanes == lanes
    assert plan.lag == plan.band == band_width(slots, cons, dyn, lanes) <= -(-band_width(slots, cons, dyn) // lanes) + 1
    assert plan.empty_lanes == int(np.count_nonzero(slots < 0))
    with pytest.raises(ValueError):
        plan_window(cons, dyn, order, SolverParams(4), depth=1024, lanes=3)


def test_fits_is_the_kernels_check() -> None:
    assert fits(1024, 8, 146, 8) and not fits(1024, 8, 147, 8)  # 7 * 146 + 2 = 1024
    assert not fits(1024, 8, 10, 0) and not fits(1024, 8, 10, 9) and not fits(1024, 8, 0, 2)
    assert fits(4, 8, 1_000_000, 1)


@pytest.mark.parametrize("interleaved", [False, True])
def test_sequential_order(interleaved: bool) -> None:
    params = SolverParams(3, interleaved=interleaved)
    seq = pass_sequence(params)
    rng = np.random.default_rng(4)
    kind = np.array([k for k, _ in seq for _ in range(5)])
    it = np.array([i for _, i in seq for _ in range(5)])
    slot = np.tile(np.arange(5), len(seq))
    perm = rng.permutation(len(kind))
    order = sequential_order(params, kind[perm], it[perm], slot[perm])
    assert np.array_equal(kind[perm][order], kind) and np.array_equal(it[perm][order], it)
    assert np.array_equal(slot[perm][order], slot)
    assert {CONTACT_PASS, FRICTION_PASS} == set(kind.tolist())


def test_lane_slots_keep_a_records_reads_within_the_banks_ports() -> None:
    """With banked body velocities a record of lanes reads at most two bodies of a bank (A and B of its lanes): the
    plan closes a record before a manifold would make a third. Manifold k joins bodies 4k + 1 and 4k + 3 (no body
    shared): with 2 banks each reads bank 1 twice, so every record holds one; with 4 banks bodies 1 and 3 of two
    manifolds still fill banks 1 and 3 twice each (two per record); without banks every record is full."""
    m = 16
    cons, _ = _chain(m)
    cons = dataclasses.replace(cons, body_a=4 * np.arange(m) + 1, body_b=4 * np.arange(m) + 3)
    dyn = np.ones(4 * m + 4, bool)
    order = np.arange(m)
    assert np.all(lane_slots(order, cons, dyn, 2) >= 0)
    two_banks = lane_slots(order, cons, dyn, 2, banks=2)
    assert np.all(two_banks[1::2] == -1) and np.all(two_banks[0::2] == order)
    four = lane_slots(order, cons, dyn, 4, banks=4)
    for r in range(0, len(four), 4):
        reads = tuple(x for s in four[r:r + 4] if s >= 0 for x in (cons.body_a[s], cons.body_b[s]))
        assert not over_ports(4, reads) and np.count_nonzero(four[r:r + 4] >= 0) == 2
