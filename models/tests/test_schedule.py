"""Schedules: the hazard-aware order keeps every window of W slots free of shared dynamic bodies."""

from __future__ import annotations

import numpy as np
import pytest

from models import scenes
from models.constraints import body_table, setup_constraints
from models.schedule import hazard_distances, make_schedule, stats


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
