"""The peers: Bullet3's batching, Bullet's batched scheme in Warp (CPU) against the golden model of the same order,
and MuJoCo's PGS on a frame's boxes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.golden.contact_solver import SolverParams
from models.golden.integrator import IntegrationParams
from models.formats.number_format import FP32
from models.peers import mujoco_peer, warp_pgs
from models.peers.batching import (B3_MAX_NUM_BATCHES, BatchingError, Batches, check_batches, determinism_order,
                                   greedy_batches)

ITERS = SolverParams(iterations=4)


def _step(frame):
    bodies = body_table(frame)
    return frame, bodies, setup_constraints(frame, bodies), IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))


@pytest.fixture(scope="module")
def pile():
    return _step(scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2))


@pytest.fixture(scope="module")
def jenga():
    """A user world: Bullet 2 inertia (the full symmetric 3x3) and friction per manifold."""
    return _step(scenes.load_scene("jenga_tower", "", 1)[0])


# --- batching ------------------------------------------------------------------------------------------------------
def test_batches_hold_every_manifold_once_and_no_dynamic_body_twice(pile) -> None:
    frame, bodies, cons, _ = pile
    b = greedy_batches(cons.body_a, cons.body_b, bodies.dynamic)
    check_batches(b, cons.body_a, cons.body_b, bodies.dynamic)
    assert 1 < b.num_batches <= B3_MAX_NUM_BATCHES
    assert b.sizes.sum() == cons.num_manifolds and np.all(b.sizes > 0)
    for k in range(b.num_batches):  # the invariant, checked here on its own
        idx = b.batch(k)
        dyn = np.concatenate([cons.body_a[idx], cons.body_b[idx]])
        dyn = dyn[bodies.dynamic[dyn]]
        assert np.unique(dyn).size == dyn.size
    # ground contacts share batches: the first batch holds more manifolds than there are dynamic bodies / 2
    assert b.sizes[0] > np.count_nonzero(bodies.dynamic) // 2


def test_check_batches_finds_a_broken_batching(pile) -> None:
    frame, bodies, cons, _ = pile
    b = greedy_batches(cons.body_a, cons.body_b, bodies.dynamic)
    first, second = b.batch(0), b.batch(1)
    # a manifold of batch 1 that shares a dynamic body with one of batch 0, moved into batch 0
    shared = next(j for j, m in enumerate(second) if {cons.body_a[m], cons.body_b[m]} & {
        x for x in np.concatenate([cons.body_a[first], cons.body_b[first]]) if bodies.dynamic[x]})
    order = b.order.copy()
    order[[b.sizes[0] - 1, b.sizes[0] + shared]] = order[[b.sizes[0] + shared, b.sizes[0] - 1]]
    bad = Batches(order, b.sizes.copy())
    with pytest.raises(ValueError, match="holds a dynamic body twice"):
        check_batches(bad, cons.body_a, cons.body_b, bodies.dynamic)
    with pytest.raises(ValueError, match="every manifold exactly once"):
        check_batches(Batches(np.concatenate([b.order[:-1], b.order[:1]]), b.sizes), cons.body_a, cons.body_b,
                      bodies.dynamic)


def test_greedy_batching_follows_bullets_in_place_swap() -> None:
    """sortConstraintByBatch3: a taken constraint swaps with the first unbatched one, which permutes the rest."""
    a = np.array([1, 1, 2, 4])
    b = np.array([2, 3, 3, 5])
    dynamic = np.array([False, True, True, True, True, True])
    got = greedy_batches(a, b, dynamic, order=np.arange(4))
    # batch 0 scans 0,1,2,3: takes 0 and 3 (3 swaps into position 1, 1 moves to 3); batch 1 scans [2, 1]: takes 2
    assert got.order.tolist() == [0, 3, 2, 1] and got.sizes.tolist() == [2, 1, 1]


def test_static_bodies_never_conflict_and_the_cap_is_enforced() -> None:
    a = np.zeros(6, dtype=int)  # six contacts of body 0 (static) with six bodies, then a chain
    b = np.arange(1, 7)
    dynamic = np.array([False] + [True] * 6)
    assert greedy_batches(a, b, dynamic).sizes.tolist() == [6]
    chain_a, chain_b = np.array([1, 1, 1]), np.array([2, 3, 4])  # body 1 in three manifolds: three batches
    dyn = np.array([False, True, True, True, True])
    assert greedy_batches(chain_a, chain_b, dyn).num_batches == 3
    with pytest.raises(BatchingError, match="B3_MAX_NUM_BATCHES = 2"):
        greedy_batches(chain_a, chain_b, dyn, max_batches=2)


def test_determinism_order_sorts_by_signed_bodies_as_unsigned_words() -> None:
    a = np.array([3, 2, 0, 5])
    b = np.array([4, 7, 2, 1])
    dynamic = np.array([False, True, True, True, True, False, True, True])
    # keys: body 5 is static -> -5 as u32 (sorts last); body 0 cannot be negated -> 0 (sorts first)
    assert determinism_order(a, b, dynamic).tolist() == [2, 1, 0, 3]


# --- Warp against the golden model ---------------------------------------------------------------------------------


def _warp_and_golden(step, cons32=None):
    frame, bodies, cons, ip = step
    batches = greedy_batches(cons.body_a, cons.body_b, bodies.dynamic)
    b32, c32 = bodies.rounded(FP32), cons.rounded(FP32)
    peer = warp_pgs.WarpPgs(b32, c32 if cons32 is None else cons32, batches, ITERS, ip, "cpu")
    return peer, peer.run(), warp_pgs.golden_same_order(b32, c32, batches, ITERS, ip), batches


@pytest.mark.parametrize("scene", ["pile", "jenga"])
def test_warp_on_the_cpu_equals_the_golden_model_of_the_same_order(scene, request) -> None:
    step = request.getfixturevalue(scene)
    _, ours, golden, _ = _warp_and_golden(step)
    agreement = warp_pgs.compare_with_golden(ours, golden[:2], golden[2])
    print(agreement.describe())
    assert golden[2].underflow == 0  # no subnormal in the step: the arithmetic is the same, so every bit must be
    assert agreement.bit_exact, agreement.describe()
    assert agreement.words == 13 * step[1].num_bodies + 6 * step[2].num_manifolds
    assert np.any(ours[1].normal > 0) and np.any(ours[1].friction != 0)  # the step did solve contacts


def test_the_comparison_catches_one_ulp_and_another_order(pile) -> None:
    """A solver fed one bias one ulp off differs from the golden model; so does the golden model in another
    (equally valid) order: the comparison is word for word, not within a tolerance."""
    frame, bodies, cons, ip = pile
    c32 = cons.rounded(FP32)
    bias = c32.bias.copy()
    bias[0, 0] = float(np.nextafter(np.float32(bias[0, 0]), np.float32(np.inf)))
    _, ours, golden, batches = _warp_and_golden(pile, dataclasses.replace(c32, bias=bias))
    off = warp_pgs.compare_with_golden(ours, golden[:2], golden[2])
    assert not off.bit_exact and off.max_abs_difference > 0
    _, ours, _, _ = _warp_and_golden(pile)
    reversed_batches = Batches(np.concatenate([batches.batch(k) for k in reversed(range(batches.num_batches))]),
                               batches.sizes[::-1].copy())
    other = warp_pgs.golden_same_order(bodies.rounded(FP32), c32, reversed_batches, ITERS, ip)
    assert not warp_pgs.compare_with_golden(ours, other[:2], other[2]).bit_exact


def test_signed_zeros_follow_ieee_minimum_maximum_and_negation() -> None:
    """Warp's unary minus is 0 - x (-(+0) = +0): the kernels negate by * -1 and order zeros as IEEE 754-2019."""
    import warp as wp

    @wp.kernel
    def probe(a: wp.array(dtype=float), b: wp.array(dtype=float), out: wp.array2d(dtype=float)):
        i = wp.tid()
        out[i, 0] = warp_pgs.ieee_max(a[i], b[i])
        out[i, 1] = warp_pgs.ieee_min(a[i], b[i])
        out[i, 2] = warp_pgs.negate(a[i])

    pairs = np.array([(0.0, -0.0), (-0.0, 0.0), (-0.0, -0.0), (0.0, 0.0), (-1.0, 2.0), (np.nan, 1.0)], np.float32)
    out = wp.zeros((len(pairs), 3), dtype=float, device="cpu")
    wp.launch(probe, dim=len(pairs), inputs=[wp.array(pairs[:, 0], device="cpu"), wp.array(pairs[:, 1], device="cpu"),
                                             out], device="cpu")
    got = out.numpy()
    sign = np.signbit(got[:4])
    assert sign[:, 0].tolist() == [False, False, True, False]  # max: +0 unless both are -0
    assert sign[:, 1].tolist() == [True, True, True, False]  # min: -0 unless both are +0
    assert sign[:, 2].tolist() == [True, False, False, True]  # negation flips the sign bit of a zero
    assert got[4].tolist() == [2.0, -1.0, 1.0] and np.isnan(got[5, 0]) and np.isnan(got[5, 1])


def test_cpu_timing_splits_kernels_and_launches(pile) -> None:
    peer, _, _, batches = _warp_and_golden(pile)
    t = peer.time_step(runs=3)
    assert t.launches == 2 * ITERS.iterations * batches.num_batches + 1
    assert t.step_ms > 0 and t.launch_ms > 0 and t.kernel_ms == pytest.approx(t.step_ms - t.launch_ms)
    assert "1 thread" in t.device and t.eager_ms is None


# --- MuJoCo ---------------------------------------------------------------------------------------------------------


def test_mujoco_steps_the_frame_with_its_pgs_solver(pile) -> None:
    frame, bodies, cons, ip = pile
    res = mujoco_peer.step_frame(frame, bodies, cons, mujoco_peer.MujocoSettings(4, 0.0), 0.7, ip, runs=3)
    assert res.bodies == int(bodies.dynamic.sum()) and res.contacts > cons.num_manifolds  # its own collision
    assert res.rows == 4 * res.contacts  # condim 3, pyramidal: 4 rows a contact
    assert 0 < res.constraint_ms < res.step_ms and res.collision_ms > 0
    assert res.friction_mismatches == 0
    dyn = bodies.dynamic
    assert np.all(np.isfinite(res.final.linear_velocity[dyn])) and np.all(np.isfinite(res.final.angular_velocity))
    # it solved contacts: the bodies resting on the ground no longer fall at g dt
    fall = frame.linear_velocity[dyn, 1] + frame.gravity[1] * frame.dt
    assert np.mean(res.final.linear_velocity[dyn, 1] - frame.gravity[1] * frame.dt > fall + 0.05) > 0.5


def test_mujoco_model_carries_the_schemes_inertia_and_friction(jenga) -> None:
    frame, bodies, cons, _ = jenga
    dyn = np.flatnonzero(bodies.dynamic)
    local = mujoco_peer.local_inertia(bodies, dyn)
    rot = mujoco_peer.rotation_matrices(bodies.orientation[dyn])
    full = np.zeros((dyn.size, 3, 3))
    for k, (i, j) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))):
        full[:, i, j] = full[:, j, i] = local[:, k]
    world_inv = np.linalg.inv(np.einsum("nij,njk,nlk->nil", rot, full, rot))
    assert np.allclose(world_inv, mujoco_peer._world_inverse_inertia(bodies.inv_inertia[dyn]), rtol=1e-9)
    per_body, mismatches = mujoco_peer.geom_friction(cons, frame.num_bodies, 0.7)
    assert mismatches == 0  # MuJoCo's max rule gives every manifold the scheme's mu (0.25 block-block, 0.5 ground)
    assert np.allclose(np.maximum(per_body[cons.body_a], per_body[cons.body_b]), cons.friction[:, 0])


@pytest.mark.parametrize("arena, says", [(300 << 10, "too small for this model: mj_stackAlloc"),
                                         (600 << 10, "dropped contacts or constraint rows")])
def test_a_mujoco_step_beyond_its_arena_is_refused(pile, monkeypatch, tmp_path, arena, says) -> None:
    """An arena too small for the step makes MuJoCo stop (stack overflow) or leave rows out (only a warning): the peer
    refuses both instead of timing a step that is not the frame's."""
    frame, bodies, cons, ip = pile
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warnings to MUJOCO_LOG.TXT here
    monkeypatch.setattr(mujoco_peer, "arena_bytes", lambda bodies, geoms: arena)
    with pytest.raises(mujoco_peer.MujocoCapacityError, match=says):
        mujoco_peer.step_frame(frame, bodies, cons, mujoco_peer.MujocoSettings(4, 0.0), 0.7, ip, runs=1)
