"""Banded schedules: band width D on hand-made cases, reverse Cuthill-McKee on a chain and a ring,
every banded order a permutation, hazard-free after the hazard reordering; the on-chip budget arithmetic."""

from __future__ import annotations

import numpy as np
import pytest

from models.sizing import onchip_budget as ob
from models import scenes
from models.setup.constraints import ConstraintSet, body_table, setup_constraints
from models.formats.number_format import FP16, FP32
from models.order.manifold_schedule import (BANDED_ORDERS, SCHEDULE_KINDS, band_width, banded_order, body_spans,
                                            hazard_distances, hazard_order, make_schedule, pybullet_order, rcm_order,
                                            stats)
from models.timing import platforms


def toy(pairs: list[tuple[int, int]], centers: np.ndarray | None = None) -> ConstraintSet:
    """Manifolds joining the given body pairs; only bodies and centres are set (what the schedulers read)."""
    m = len(pairs)
    z = np.zeros
    c = z((m, 3)) if centers is None else np.asarray(centers, dtype=float)
    return ConstraintSet(
        body_a=np.array([p[0] for p in pairs], dtype=np.int64), body_b=np.array([p[1] for p in pairs], dtype=np.int64),
        num_points=np.ones(m, np.int64), normal=z((m, 3)), points=z((m, 4, 3)), jac_inv=z((m, 4)), bias=z((m, 4)),
        center=c, tangent=z((m, 2, 3)), f_jac_inv=z((m, 2)), spin_damp=z(m, bool))


def dynamic_mask(num_bodies: int, static: tuple[int, ...] = (0,)) -> np.ndarray:
    dyn = np.ones(num_bodies, dtype=bool)
    dyn[list(static)] = False
    return dyn


# body 0 static; manifolds m0 = (0, 1), m1 = (1, 2), m2 = (2, 3), m3 = (0, 3)
SQUARE = toy([(0, 1), (1, 2), (2, 3), (0, 3)])


def test_band_width_by_hand() -> None:
    dyn = dynamic_mask(4)
    assert band_width(np.array([0, 1, 2, 3]), SQUARE, dyn) == 2
    # m0@0 m2@1 bubble@2 m1@3 m3@4: body 1 in slots {0, 3}, body 2 {1, 3}, body 3 {1, 4}; the static body 0
    # (slots 0 and 4, span 5) does not count
    schedule = np.array([0, 2, -1, 1, 3])
    assert body_spans(schedule, SQUARE, dyn).tolist() == [0, 4, 3, 4]
    assert band_width(schedule, SQUARE, dyn) == 4
    assert band_width(schedule, SQUARE, dynamic_mask(4, static=())) == 5
    assert band_width(np.zeros(0, np.int64), toy([]), dyn) == 0


def shuffled(pairs: list[tuple[int, int]], seed: int) -> list[tuple[int, int]]:
    order = np.random.default_rng(seed).permutation(len(pairs))
    return [pairs[k] for k in order]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rcm_on_a_chain_and_a_ring(seed: int) -> None:
    n = 40
    # a chain of dynamic bodies 1..n (each inner body in two manifolds): optimum D = 2, the chain's order
    chain = toy(shuffled([(k, k + 1) for k in range(1, n)], seed))
    dyn = dynamic_mask(n + 1)
    assert band_width(pybullet_order(chain), chain, dyn) > 2
    assert band_width(rcm_order(chain, dyn), chain, dyn) == 2
    # a ring of n bodies: any order puts the two manifolds of some body 2 slots apart at best (D = 3, the
    # zigzag order from one manifold outwards); frame order of the unshuffled ring gives n
    ring_pairs = [(k, (k + 1) % n) for k in range(n)]
    ring = toy(shuffled(ring_pairs, seed))
    dyn = dynamic_mask(n, static=())
    assert band_width(pybullet_order(toy(ring_pairs)), toy(ring_pairs), dyn) == n
    assert band_width(rcm_order(ring, dyn), ring, dyn) == 3


def test_orders_cover_components_and_static_only_manifolds() -> None:
    """Two separate chains, a manifold between two static bodies, an isolated pair: every order is a
    permutation, and the components are not interleaved (D stays that of one chain)."""
    pairs = [(1, 2), (2, 3), (3, 4), (5, 6), (6, 7), (7, 8), (0, 9), (10, 11)]
    centers = np.array([[k, 0.0, 0.0] for k in (0, 1, 2)] + [[k + 0.5, 0.0, 1.0] for k in (0, 1, 2)]
                       + [[9.0, 0.0, 0.0], [-3.0, 0.0, 0.0]])
    cons = toy(shuffled(pairs, 3), centers[np.random.default_rng(3).permutation(len(pairs))])
    dyn = dynamic_mask(12, static=(0, 9))
    for name, order in BANDED_ORDERS.items():
        o = order(cons, dyn)
        assert np.array_equal(np.sort(o), np.arange(len(pairs))), name
    assert band_width(rcm_order(cons, dyn), cons, dyn) == 2
    assert band_width(BANDED_ORDERS["sweep"](cons, dyn), cons, dyn) == 2


@pytest.fixture(scope="module")
def pile():
    frame = scenes.capture_frame("pile", nx=6, ny=6, nz=6, seed=1)
    bodies = body_table(frame)
    return bodies, setup_constraints(frame, bodies)


def test_banded_orders_are_permutations_and_narrower(pile) -> None:
    bodies, cons = pile
    dyn = bodies.dynamic
    bands = {}
    for name, order in BANDED_ORDERS.items():
        o = order(cons, dyn)
        assert np.array_equal(np.sort(o), np.arange(cons.num_manifolds)), name
        bands[name] = band_width(o, cons, dyn)
    best, o = banded_order(cons, dyn)
    assert band_width(o, cons, dyn) == bands[best] == min(bands.values())
    assert bands[best] < band_width(pybullet_order(cons), cons, dyn)


@pytest.mark.parametrize("window", [1, 8, 64])
@pytest.mark.parametrize("kind", [k for k in SCHEDULE_KINDS if k not in ("pybullet", "hazard")])
def test_hazard_reordering_of_banded_orders(pile, kind: str, window: int) -> None:
    bodies, cons = pile
    schedule = make_schedule(kind, cons, bodies.dynamic, window)
    issued = schedule[schedule >= 0]
    assert np.array_equal(np.sort(issued), np.arange(cons.num_manifolds))
    within, _ = hazard_distances(schedule, cons, bodies.dynamic)
    assert np.all(within >= window)
    st = stats(kind, schedule, cons, bodies.dynamic, window)
    assert st.window_violations == 0 and st.band == band_width(schedule, cons, bodies.dynamic)
    assert f"band D={st.band}" in st.describe()


def test_hazard_priority(pile) -> None:
    bodies, cons = pile
    dyn = bodies.dynamic
    identity = np.arange(cons.num_manifolds)
    assert np.array_equal(hazard_order(cons, dyn, 16, identity), hazard_order(cons, dyn, 16))
    rcm = rcm_order(cons, dyn)
    with_priority = hazard_order(cons, dyn, 1, rcm)  # W = 1: nothing to wait for, the priority order itself
    assert np.array_equal(with_priority, rcm)
    with pytest.raises(ValueError, match="permutation"):
        hazard_order(cons, dyn, 16, identity[:-1])
    with pytest.raises(ValueError, match="permutation"):
        hazard_order(cons, dyn, 16, np.zeros_like(identity))
    with pytest.raises(ValueError, match="window"):
        make_schedule("banded", cons, dyn, 0)


def test_budget_by_hand() -> None:
    # fp32 records: contact 64 + 23 x 32 = 800 bits, friction 64 + 14 x 32 = 512 bits -> 164 B; fp16 90 B
    assert ob.record_bytes(FP32) == 164 and ob.record_bytes(FP16) == 90
    zcu = platforms.get_platform("zcu102")
    assert zcu.data_bytes == 912 * 4096 and zcu.raw_bytes == 912 * 4608 == 4104 * 1024
    assert platforms.get_platform("u280").data_bytes == 2016 * 4096 + 960 * 32768
    assert [zcu.capacity(k) for k in platforms.USABLE_SHARE] == [274_080, 548_160, 2_520, 912, 0]
    assert [platforms.get_platform("u280").capacity(k) for k in platforms.USABLE_SHARE] == [1_303_680, 2_607_360, 9_024, 2016, 960]
    b = ob.budget(zcu, FP32, num_bodies=10, num_manifolds=100, band=7, trailing=3)
    assert (b.body_bytes, b.impulse_bytes, b.window_bytes) == (10 * 17 * 4, 100 * 6 * 4, 21 * 164)
    assert b.total_bytes == 6524 and b.fits
    b = ob.budget(zcu, FP16, num_bodies=3, num_manifolds=100, band=7, trailing=1, impulses_resident=False)
    assert (b.body_bytes, b.impulse_bytes, b.window_bytes) == (102, 7 * 6 * 2, 7 * 90)
    one_block = platforms.Platform("one", "zcu102", bram36=1, uram=0)
    assert ob.budget(one_block, FP32, 60, 0, 0).fits  # 4,080 B of 4,096
    assert not ob.budget(one_block, FP32, 61, 0, 0).fits  # 4,148 B
    with pytest.raises(ValueError, match="unknown platform"):
        platforms.get_platform("zcu999")
    with pytest.raises(ValueError, match="trailing"):
        ob.budget(zcu, FP32, 1, 1, 1, trailing=0)


def test_floors_by_hand() -> None:
    """zcu102 (16 GB/s DDR at 275 MHz: 58.18 B/cycle), fp32, 1,000 manifolds, 10 bodies, 4 iterations."""
    from models.kernel.stream_format import StreamLayout

    p = platforms.get_platform("zcu102")
    lay = StreamLayout(FP32)
    per_cycle = 16e9 / 275e6
    bodies = 10 * (lay.body_in_bytes + lay.body_out_bytes)
    today = ob.floors(p, FP32, 10, 1000, 4, fetch_every=0)
    assert today.bytes_per_step == 1000 * 4 * (lay.contact_bytes + lay.friction_bytes) + bodies
    assert today.ddr_cycles == pytest.approx(today.bytes_per_step / per_cycle)
    assert today.compute_cycles == 8000 + 20 and today.manifold_passes == 8000 and today.bound == "DDR"
    # once per 2 iterations, impulses (6 words = 24 B) read and written with each of the 2 fetches
    two = ob.floors(p, FP32, 10, 1000, 4, fetch_every=2, lanes=2, impulses_resident=False)
    assert two.bytes_per_step == 1000 * 2 * (ob.record_bytes(FP32) + 2 * 24) + bodies
    assert two.compute_cycles == 4000 + 20
    assert two.cycles_per_manifold_pass == pytest.approx(max(two.ddr_cycles, 4020) / 8000)
    assert ob.floors(p, FP32, 10, 1000, 4, fetch_every=4).bytes_per_step == 1000 * ob.record_bytes(FP32) + bodies
    # streaming with the impulses travelling (the thesis's way): in the records (fp32: the friction record two
    # beats instead of one, +64 B a pass), written back (16 B a contact pass, 8 B a friction pass)
    travelling = ob.floors(p, FP32, 10, 1000, 4, fetch_every=0, impulses_resident=False)
    assert travelling.bytes_per_step == today.bytes_per_step + 1000 * 4 * (64 + 16 + 8)
    with pytest.raises(ValueError):
        ob.floors(p, FP32, 10, 1000, 4, fetch_every=1, lanes=0)
