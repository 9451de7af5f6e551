"""Warm starting: points matched across steps as Bullet 2 matches them, bad input dropped or rejected with its reason,
the host's application equal to the velocity change the solver's own passes make, and a resting stack closer to
the exact reference after a warm-started step than after a cold one."""

from __future__ import annotations

import numpy as np
import pytest

from models.closed_loop.loop import COLD, Remedy, run_closed_loop
from models.setup.constraints import BodyTable, ConstraintSet, plane_space
from models.golden.contact_solver import Impulses, SolverParams, solve
from models.exact.reference import exact_reference
from models.formats.number_format import FLOAT64
from models.exact.solution_error import solution_error
from models.golden.warm_start import (MANIFOLD_GONE, NEGATIVE_NORMAL, NONFINITE, POINT_GONE, WARMSTART_FACTOR,
                                      ContactMemory, Contacts, apply_impulses, check_impulses, warm_start)

SEED = 20261202


def _frame(rng: np.random.Generator, m: int = 5, n: int = 4) -> tuple[BodyTable, ConstraintSet]:
    """Random bodies (0 static, full symmetric inverse inertia) and manifolds of 1..4 points between them."""
    inv_mass = np.concatenate([[0.0], rng.uniform(0.2, 2.0, n - 1)])
    a6 = rng.uniform(0.1, 0.3, (n, 3))
    inv_inertia = np.concatenate([a6 + 0.5, rng.uniform(-0.05, 0.05, (n, 3))], axis=1)
    inv_inertia[0] = 0.0
    bodies = BodyTable(position=rng.normal(size=(n, 3)), orientation=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                       linear_velocity=rng.normal(size=(n, 3)), angular_velocity=rng.normal(size=(n, 3)),
                       inv_mass=inv_mass, inv_inertia=inv_inertia)
    pairs = np.array([rng.choice(n, 2, replace=False) for _ in range(m)])
    pairs[pairs[:, 0] == 0] = pairs[pairs[:, 0] == 0][:, ::-1]  # A always dynamic
    num = rng.integers(1, 5, m)
    valid = np.arange(4)[None, :] < num[:, None]
    normal = rng.normal(size=(m, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    points = np.where(valid[..., None], rng.normal(size=(m, 4, 3)), 0.0)
    t0, t1 = plane_space(-normal)
    cons = ConstraintSet(body_a=pairs[:, 0], body_b=pairs[:, 1], num_points=num, normal=normal, points=points,
                         jac_inv=np.where(valid, -rng.uniform(0.2, 1.0, (m, 4)), 0.0),
                         bias=np.where(valid, rng.uniform(-0.3, 0.3, (m, 4)), 0.0),
                         center=points.sum(axis=1) / num[:, None], tangent=np.stack([t0, t1], axis=1),
                         f_jac_inv=-rng.uniform(0.2, 1.0, (m, 2)), spin_damp=np.zeros(m, dtype=bool))
    return bodies, cons


def test_application_equals_the_velocity_change_of_the_solvers_own_passes() -> None:
    """One contact and one friction pass of the golden solver change the velocities by M^-1 J^T lambda of the
    impulses they accumulate: applying those impulses from the start must give the same velocities (float64)."""
    print("seed", SEED)
    rng = np.random.default_rng(SEED)
    for _ in range(5):
        bodies, cons = _frame(rng)
        res = solve(bodies, cons, np.arange(cons.num_manifolds), FLOAT64, SolverParams(iterations=1))
        assert np.any(res.impulses.normal > 0) and np.any(res.impulses.friction != 0)
        applied = apply_impulses(bodies, cons, res.impulses, FLOAT64)
        np.testing.assert_allclose(applied.linear_velocity, res.bodies.linear_velocity, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(applied.angular_velocity, res.bodies.angular_velocity, rtol=1e-9, atol=1e-12)
        assert np.array_equal(applied.linear_velocity[0], bodies.linear_velocity[0])  # the static body untouched


def test_application_of_one_normal_impulse_by_hand() -> None:
    """A unit cube (mass 2, diagonal inverse inertia 3) resting on the static ground, one point under its corner:
    lambda = 1 N s along n = +y gives dv = n / 2 and dw = I^-1 (r x n)."""
    bodies = BodyTable(position=np.array([[0.0, 0.5, 0.0], [0.0, 0.0, 0.0]]),
                       orientation=np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)), linear_velocity=np.zeros((2, 3)),
                       angular_velocity=np.zeros((2, 3)), inv_mass=np.array([0.5, 0.0]),
                       inv_inertia=np.array([[3.0, 3.0, 3.0], [0.0, 0.0, 0.0]]))
    n = np.array([[0.0, 1.0, 0.0]])
    t0, t1 = plane_space(-n)
    pts = np.zeros((1, 4, 3))
    pts[0, 0] = [0.5, 0.0, 0.5]
    cons = ConstraintSet(body_a=np.array([0]), body_b=np.array([1]), num_points=np.array([1]), normal=n, points=pts,
                         jac_inv=np.array([[-1.0, 0, 0, 0]]), bias=np.zeros((1, 4)), center=pts[:, 0],
                         tangent=np.stack([t0, t1], axis=1), f_jac_inv=np.array([[-1.0, -1.0]]),
                         spin_damp=np.zeros(1, bool))
    initial = Impulses(normal=np.array([[1.0, 0, 0, 0]]), friction=np.zeros((1, 2)))
    out = apply_impulses(bodies, cons, initial, FLOAT64)
    r = np.array([0.5, -0.5, 0.5])  # point minus the cube's centre
    assert np.allclose(out.linear_velocity[0], [0.0, 0.5, 0.0])
    assert np.allclose(out.angular_velocity[0], 3.0 * np.cross(r, [0.0, 1.0, 0.0]))
    assert np.array_equal(out.linear_velocity[1], np.zeros(3))


def _contacts(keys: list[tuple[int, int]], local: np.ndarray, num: list[int]) -> Contacts:
    k = np.asarray(keys, dtype=np.int64)
    return Contacts(k[:, 0], k[:, 1], np.asarray(num), np.asarray(local, dtype=np.float64))


def _cons_for(contacts: Contacts) -> ConstraintSet:
    m = contacts.num_manifolds
    n = np.tile([0.0, 1.0, 0.0], (m, 1))
    t0, t1 = plane_space(-n)
    return ConstraintSet(body_a=contacts.body_a, body_b=contacts.body_b, num_points=contacts.num_points, normal=n,
                         points=np.zeros((m, 4, 3)), jac_inv=-np.ones((m, 4)) * contacts.valid(), bias=np.zeros((m, 4)),
                         center=np.zeros((m, 3)), tangent=np.stack([t0, t1], axis=1), f_jac_inv=-np.ones((m, 2)),
                         spin_damp=np.zeros(m, bool))


SQUARE = np.array([[0.5, -0.5, 0.5], [-0.5, -0.5, 0.5], [-0.5, -0.5, -0.5], [0.5, -0.5, -0.5]])


def test_points_match_within_the_breaking_threshold_and_new_ones_start_from_zero() -> None:
    old = _contacts([(1, 0), (2, 1), (3, 0)], np.stack([SQUARE] * 3), [4, 4, 4])
    cons_old = _cons_for(old)
    normal = np.array([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0], [1.0, 1.0, 1.0, 1.0]])
    memory = ContactMemory.of(old, cons_old, Impulses(normal, np.array([[0.5, -0.25], [0.0, 0.0], [1.0, 1.0]])))
    moved = SQUARE.copy()
    moved[0] += [0.001, 0.0, 0.0]  # 1 mm: the same point
    moved[2] += [0.03, 0.0, 0.0]  # 3 cm: past 0.02 m, a new point
    moved[3] = moved[1] + [0.0, 0.0, 0.005]  # next to old point 1 (taken by new point 1): new
    new = _contacts([(1, 0), (4, 0), (2, 1)], np.stack([moved, SQUARE, SQUARE[[3, 2, 1, 0]]]), [4, 4, 2])
    cons = _cons_for(new)
    ws = warm_start(memory, new, cons, friction_coeff=0.7)
    f = WARMSTART_FACTOR
    assert np.allclose(ws.impulses.normal[0], [f * 1.0, f * 2.0, 0.0, 0.0])
    assert np.array_equal(ws.impulses.normal[1], np.zeros(4))  # a new manifold (4, 0)
    assert np.allclose(ws.impulses.normal[2], [f * 8.0, f * 7.0, 0.0, 0.0])  # reordered points, matched by position
    # friction: the remembered vector on the same tangents, times the factor, within mu * sum(normal)
    assert np.allclose(ws.impulses.friction[0], [f * 0.5, -f * 0.25])
    r = ws.report
    assert (r.matched_points, r.new_points) == (4, 6)
    assert r.dropped[POINT_GONE] == 2 + 2 and r.dropped[MANIFOLD_GONE] == 1  # (1,0): 2 points; (2,1): 2; (3,0) gone


def test_friction_is_clamped_to_the_new_friction_limit() -> None:
    c = _contacts([(1, 0)], SQUARE[None], [4])
    memory = ContactMemory.of(c, _cons_for(c), Impulses(np.full((1, 4), 0.1), np.array([[5.0, -5.0]])))
    ws = warm_start(memory, c, _cons_for(c), friction_coeff=0.7)
    limit = 0.7 * WARMSTART_FACTOR * 0.4
    assert np.allclose(ws.impulses.friction, [[limit, -limit]])


@pytest.mark.parametrize("bad,reason", [(np.nan, NONFINITE), (np.inf, NONFINITE), (-1.0, NEGATIVE_NORMAL)])
def test_a_bad_remembered_impulse_is_dropped_and_counted(bad: float, reason: str) -> None:
    c = _contacts([(1, 0)], SQUARE[None], [4])
    normal = np.array([[1.0, bad, 3.0, 4.0]])
    memory = ContactMemory.of(c, _cons_for(c), Impulses(normal, np.zeros((1, 2))))
    ws = warm_start(memory, c, _cons_for(c), friction_coeff=0.7)
    assert ws.impulses.normal[0, 1] == 0.0 and np.all(np.isfinite(ws.impulses.normal))
    assert np.allclose(ws.impulses.normal[0, [0, 2, 3]], WARMSTART_FACTOR * np.array([1.0, 3.0, 4.0]))
    assert ws.report.dropped[reason] == 1 and ws.report.matched_points == 3


def test_a_nonfinite_friction_drops_the_whole_manifold() -> None:
    c = _contacts([(1, 0)], SQUARE[None], [4])
    memory = ContactMemory.of(c, _cons_for(c), Impulses(np.ones((1, 4)), np.array([[np.nan, 0.0]])))
    ws = warm_start(memory, c, _cons_for(c), friction_coeff=0.7)
    assert not np.any(ws.impulses.normal) and not np.any(ws.impulses.friction)
    assert ws.report.dropped[NONFINITE] == 4 and ws.report.new_points == 4


def test_impulses_that_do_not_fit_the_frame_are_rejected() -> None:
    c = _contacts([(1, 0), (2, 0)], np.stack([SQUARE] * 2), [4, 4])
    cons = _cons_for(c)
    with pytest.raises(ValueError, match="does not match itself"):
        ContactMemory(c, np.zeros((3, 4)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="for 2 manifolds"):
        ContactMemory.of(c, cons, Impulses.zeros(3))
    with pytest.raises(ValueError, match="for 2 manifolds"):
        warm_start(None, _contacts([(1, 0)], SQUARE[None], [4]), cons, 0.7)
    with pytest.raises(ValueError, match="expected"):
        check_impulses(Impulses.zeros(1), cons)
    bad = Impulses.zeros(2)
    bad.friction[1, 0] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        check_impulses(bad, cons)
    bad = Impulses.zeros(2)
    bad.normal[0, 0] = -1e-3
    with pytest.raises(ValueError, match="negative normal"):
        check_impulses(bad, cons)


def test_warm_start_brings_a_resting_stack_closer_to_the_exact_reference() -> None:
    """Two consecutive steps of a 4-cube stack at rest (float64 loop): the second step warm-started from the first
    is closer to its exact limit after 1 and 4 iterations than cold-started."""
    r = run_closed_loop("stack", 2, FLOAT64, 4, warmup_steps=20, remedy=Remedy("warm", WARMSTART_FACTOR), n=4)
    last = r.extra["last step"]
    assert last.initial is not None and r.extra["warm start"]["matched points"] > 0
    ref = exact_reference(last.bodies, last.cons, SolverParams())
    dyn = last.bodies.dynamic
    for it in (1, 4):
        params = SolverParams(iterations=it)
        cold = solve(last.bodies, last.cons, last.order, FLOAT64, params).bodies
        warm = solve(apply_impulses(last.bodies, last.cons, last.initial, FLOAT64), last.cons, last.order, FLOAT64,
                     params, initial=last.initial).bodies
        e_cold = solution_error(cold, ref.bodies, dyn).max_dv
        e_warm = solution_error(warm, ref.bodies, dyn).max_dv
        print(f"{it} it: max |dv| cold {e_cold:.3g} m/s, warm {e_warm:.3g} m/s")
        assert e_warm < 0.5 * e_cold


def test_cold_remedy_is_the_gpu_scheme_bit_for_bit() -> None:
    """The default remedy runs exactly the loop of before (no warm start, one call per step)."""
    a = run_closed_loop("incline", 3, FLOAT64, 4)
    b = run_closed_loop("incline", 3, FLOAT64, 4, remedy=COLD)
    assert a.extra["kernel calls"] == 3 and a.extra["last step"].initial is None
    assert np.array_equal(a.final.linear_velocity, b.final.linear_velocity)
