"""Schedules: the hazard-aware order keeps every window of W slots free of shared dynamic bodies."""

from __future__ import annotations

import numpy as np
import pytest

from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.order.manifold_schedule import BUBBLE, hazard_distances, hazard_order, make_schedule, stats


@pytest.fixture(scope="module", params=[(6, 6, 6), (8, 4, 8)], ids=lambda p: "pile%dx%dx%d" % p)
def pile(request):
    nx, ny, nz = request.param
    frame = scenes.capture_frame("pile", nx=nx, ny=ny, nz=nz, seed=1)
    bodies = body_table(frame)
    return frame, bodies, setup_constraints(frame, bodies)


@pytest.mark.parametrize("window", [1, 8, 32, 64])
def test_hazard_order_is_a_hazard_free_permutation(pile, window) -> None:
    frame, bodies, cons = pile
    order = make_schedule("hazard", cons, bodies.dynamic, window)
    issued = order[order >= 0]
    assert np.array_equal(np.sort(issued), np.arange(cons.num_manifolds))
    within, _ = hazard_distances(order, cons, bodies.dynamic)
    assert np.all(within >= window)
    st = stats("hazard", order, cons, bodies.dynamic, window)
    print(f"{frame.meta['params']}: {st.describe()}")
    assert st.window_violations == 0 and st.slots == cons.num_manifolds + st.bubbles


def _hazard_order_slot_by_slot(a: list[int], b: list[int], dynamic: list[bool], window: int,
                               priority: list[int]) -> list[int]:
    """The rule of ``hazard_order`` written out: each slot takes the first manifold in ``priority`` whose dynamic
    bodies were last issued at least ``window`` slots ago, else it is a bubble."""
    remaining, last, out = list(priority), {}, []
    while remaining:
        slot = len(out)
        for i, k in enumerate(remaining):
            own = [x for x in (a[k], b[k]) if dynamic[x]]
            if all(slot - last[x] >= window for x in own if x in last):
                out.append(remaining.pop(i))
                last.update({x: slot for x in own})
                break
        else:
            out.append(BUBBLE)
    return out


@pytest.mark.parametrize("window", [1, 5, 40])
def test_hazard_order_is_the_slot_by_slot_rule(pile, window) -> None:
    """The heap-based list scheduling gives exactly the rule's schedule, in frame order and in a shuffled
    priority order (seed 3)."""
    _, bodies, cons = pile
    a, b, dyn = cons.body_a.tolist(), cons.body_b.tolist(), bodies.dynamic.tolist()
    shuffled = np.random.default_rng(3).permutation(cons.num_manifolds)
    for priority in (None, shuffled):
        got = hazard_order(cons, bodies.dynamic, window, priority)
        order = list(range(cons.num_manifolds)) if priority is None else priority.tolist()
        assert got.tolist() == _hazard_order_slot_by_slot(a, b, dyn, window, order)


def test_pybullet_order_has_hazards(pile) -> None:
    frame, bodies, cons = pile
    order = make_schedule("pybullet", cons, bodies.dynamic)
    st = stats("pybullet", order, cons, bodies.dynamic, 32)
    assert st.bubbles == 0 and st.window_violations > 0


def test_bad_schedule_arguments(pile) -> None:
    frame, bodies, cons = pile
    with pytest.raises(ValueError, match="window"):
        make_schedule("hazard", cons, bodies.dynamic, 0)
    with pytest.raises(ValueError, match="unknown schedule"):
        make_schedule("random", cons, bodies.dynamic)
