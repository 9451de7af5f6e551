"""Shock propagation (models/golden/shock_propagation.py): layers and frozen sides on a small stack, the ground-up
order, the shock rows' coefficients, a frozen body's velocity untouched by a shock row (contact and friction), the
impulse modes, level vectorization still bit-identical to the sequential loop, and the option off = today's solve,
bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from models import scenes
from models.closed_loop.loop import COLD, Remedy
from models.setup.constraints import BodyTable, ConstraintSet, body_table, plane_space, setup_constraints
from models.golden.contact_solver import Impulses, SolverParams, solve, solve_sequential
from models.setup.inertia import quadratic_form
from models.formats.number_format import FLOAT64, FP16, FP32
from models.order.manifold_schedule import make_schedule
from models.golden.shock_propagation import (FREEZE_A, FREEZE_B, FREEZE_NONE, UNREACHED, ShockConstraintSet,
                                             body_layers, frozen_side, layer_order, shock_constraints)

SEED = 20261203


def test_layers_and_frozen_sides_on_a_small_stack() -> None:
    """Ground 0, a tower 1-2-3 (manifolds in both A/B orientations), 4 beside 1 on the ground, 5-6 touching only
    each other: layers 0,1,2,3,1 and unreached; the lower dynamic body of each manifold between layers is frozen."""
    dynamic = np.array([False, True, True, True, True, True, True])
    a = np.array([1, 1, 3, 4, 1, 5])
    b = np.array([0, 2, 2, 0, 4, 6])
    layer = body_layers(a, b, dynamic)
    assert layer.tolist() == [0, 1, 2, 3, 1, UNREACHED, UNREACHED]
    frozen = frozen_side(a, b, layer, dynamic)
    # (1,0): static lower, not flagged; (1,2): A lower; (3,2): B lower; (4,0): static; (1,4): tie; (5,6): tie
    assert frozen.tolist() == [FREEZE_NONE, FREEZE_A, FREEZE_B, FREEZE_NONE, FREEZE_NONE, FREEZE_NONE]


def test_layer_order_is_ground_up_and_stable() -> None:
    dynamic = np.array([False, True, True, True, True])
    cons = _pair_constraints(np.array([3, 2, 1, 4, 1]), np.array([2, 1, 0, 0, 4]))
    layer = body_layers(cons.body_a, cons.body_b, dynamic)
    order = layer_order(np.array([0, -1, 1, 2, 3, 4]), cons, layer)
    # keys (lower, upper): m0 (2,3), m1 (1,2), m2 (0,1), m3 (0,1), m4 (1,1): ground contacts first in their given
    # order, then the tie within layer 1, then upward; the bubble dropped
    assert order.tolist() == [2, 3, 4, 1, 0]


def test_hazard_order_within_each_layer_pair(pile) -> None:
    """With a window the layer pairs stay ground-up, one after the other, and each pair's manifolds are the greedy
    hazard order of that window: every manifold once, no two within the window sharing a dynamic body inside a pair,
    fewer conflicts than the plain layer order (the kernel stalls less), and a different order (a different solve)."""
    bodies, cons = pile
    dyn = bodies.dynamic
    layer = body_layers(cons.body_a, cons.body_b, dyn)
    sched = make_schedule("pybullet", cons, dyn)
    plain, window = layer_order(sched, cons, layer), 16
    hazard = layer_order(sched, cons, layer, dyn, window)
    real = hazard[hazard >= 0]
    assert sorted(real.tolist()) == sorted(plain.tolist()) and not np.array_equal(real, plain)
    la, lb = layer[cons.body_a], layer[cons.body_b]
    key = np.stack([np.minimum(la, lb), np.maximum(la, lb)], axis=1)
    assert np.all(np.diff(key[real][:, 0] * (1 << 20) + key[real][:, 1]) >= 0)  # pairs ground-up, contiguous

    def conflicts(order: np.ndarray, split_pairs: bool) -> int:
        n = 0
        for i, m in enumerate(order):
            if m < 0:
                continue
            for j in range(max(0, i - window + 1), i):
                k = order[j]
                if k < 0 or (split_pairs and not np.array_equal(key[k], key[m])):
                    continue
                mine = {x for x in (cons.body_a[m], cons.body_b[m]) if dyn[x]}
                n += bool(mine & {x for x in (cons.body_a[k], cons.body_b[k]) if dyn[x]})
        return n
    assert conflicts(hazard, split_pairs=True) == 0
    assert conflicts(hazard, split_pairs=False) < conflicts(plain, split_pairs=False)
    with pytest.raises(ValueError, match="dynamic flags"):
        layer_order(sched, cons, layer, None, window)


def _pair_constraints(a: np.ndarray, b: np.ndarray, points: int = 1, seed: int = 0) -> ConstraintSet:
    rng = np.random.default_rng(seed)
    m = a.shape[0]
    num = np.full(m, points)
    valid = np.arange(4)[None, :] < num[:, None]
    normal = np.tile([0.0, 1.0, 0.0], (m, 1))
    pts = np.where(valid[..., None], rng.normal(scale=0.3, size=(m, 4, 3)), 0.0)
    t0, t1 = plane_space(-normal)
    return ConstraintSet(body_a=a, body_b=b, num_points=num, normal=normal, points=pts,
                         jac_inv=np.where(valid, -0.4, 0.0), bias=np.where(valid, -0.05, 0.0),
                         center=pts.sum(axis=1) / num[:, None], tangent=np.stack([t0, t1], axis=1),
                         f_jac_inv=np.full((m, 2), -0.4), spin_damp=np.zeros(m, dtype=bool))


LAYERS = np.array([0, 1, 2])  # of _two_cubes (its ground contact left out)


def _two_cubes(rng: np.random.Generator, points: int = 4) -> tuple[BodyTable, ConstraintSet]:
    """A static ground 0, a light cube 1 and a heavy cube 2 on it (manifold 2 on 1, A = 2 upper, layers LAYERS; the
    ground contact is left out), moving."""
    bodies = BodyTable(position=np.array([[0.0, -1.0, 0.0], [0.0, 0.5, 0.0], [0.0, 1.5, 0.0]]),
                       orientation=np.tile([0.0, 0.0, 0.0, 1.0], (3, 1)),
                       linear_velocity=np.concatenate([[[0.0, 0.0, 0.0]], rng.normal(scale=0.5, size=(2, 3))]),
                       angular_velocity=np.concatenate([[[0.0, 0.0, 0.0]], rng.normal(scale=0.5, size=(2, 3))]),
                       inv_mass=np.array([0.0, 1.0, 1e-3]),
                       inv_inertia=np.array([[0.0] * 3, [6.0] * 3, [6e-3] * 3]))
    bodies.linear_velocity[2, 1] -= 1.0  # the heavy cube approaching
    corners = np.array([[-0.5, 1.0, -0.5], [0.5, 1.0, -0.5], [0.5, 1.0, 0.5], [-0.5, 1.0, 0.5]])
    valid = np.arange(4) < points
    pts = np.where(valid[:, None], corners, 0.0)[None]
    normal = np.array([[0.0, 1.0, 0.0]])
    t0, t1 = plane_space(-normal)
    cons = ConstraintSet(body_a=np.array([2]), body_b=np.array([1]), num_points=np.array([points]), normal=normal,
                         points=pts, jac_inv=np.where(valid, -0.45, 0.0)[None], bias=np.where(valid, -0.06, 0.0)[None],
                         center=pts.sum(axis=1) / points, tangent=np.stack([t0, t1], axis=1),
                         f_jac_inv=np.array([[-0.5, -0.5]]), spin_damp=np.array([False]))
    return bodies, cons


def test_shock_jac_inv_drops_the_frozen_body() -> None:
    bodies, cons = _two_cubes(np.random.default_rng(SEED))
    shock = shock_constraints(cons, bodies, FLOAT64, LAYERS)
    assert shock.frozen.tolist() == [FREEZE_B]
    r = cons.points[0] - bodies.position[2]
    c = np.cross(r, cons.normal[0])
    expect = -1.0 / (bodies.inv_mass[2] + quadratic_form(np.tile(bodies.inv_inertia[2], (4, 1)), c))
    np.testing.assert_allclose(shock.shock_jac_inv[0], expect, rtol=1e-12)
    assert np.array_equal(shock.jac_inv, cons.jac_inv)  # the ordinary rows untouched
    linear = shock_constraints(cons, bodies, FLOAT64, LAYERS, linear=True)
    np.testing.assert_allclose(linear.shock_jac_inv[0], -1.0 / bodies.inv_mass[2], rtol=1e-12)


@pytest.mark.parametrize("ar", [FLOAT64, FP32, FP16], ids=lambda a: a.name)
@pytest.mark.parametrize("friction", [False, True], ids=["contact", "contact+friction"])
@pytest.mark.parametrize("linear", [False, True], ids=["angular", "linear"])
def test_frozen_body_untouched_by_the_shock_rows(ar, friction, linear) -> None:
    """One iteration, every pass a shock pass: the lower cube's velocities are bit-for-bit those it started with;
    the heavy cube's change (a linear shock: its angular velocity too stays)."""
    rng = np.random.default_rng(SEED)
    for _ in range(5):
        bodies, cons = _two_cubes(rng)
        b = bodies.rounded(ar)
        shock = shock_constraints(cons.rounded(ar), b, ar, LAYERS, linear=linear)
        params = SolverParams(iterations=1, shock_contact=True, shock_friction=friction)
        res = solve(b, shock, np.array([0]), ar, params)
        assert np.any(res.impulses.normal > 0)
        frozen_lin_same = np.array_equal(res.bodies.linear_velocity[1], b.linear_velocity[1])
        frozen_ang_same = np.array_equal(res.bodies.angular_velocity[1], b.angular_velocity[1])
        if friction:
            assert frozen_lin_same and frozen_ang_same
        else:  # the friction pass (not shocked) moves both
            assert not frozen_lin_same
        contact_only = solve(b, shock, np.array([0]), ar, SolverParams(iterations=1, shock_contact=True,
                                                                        friction_coeff=0.0))
        assert np.array_equal(contact_only.bodies.linear_velocity[1], b.linear_velocity[1])
        assert np.array_equal(contact_only.bodies.angular_velocity[1], b.angular_velocity[1])
        assert not np.array_equal(contact_only.bodies.linear_velocity[2], b.linear_velocity[2])
        if linear:
            assert np.array_equal(contact_only.bodies.angular_velocity[2], b.angular_velocity[2])


def test_a_one_point_shock_row_stops_the_upper_body_against_the_frozen_one() -> None:
    """float64, one point: after the shock row the relative normal velocity plus bias is 0 (lambda > 0), as if the
    lower cube were infinitely heavy; the ordinary row splits the change between the two."""
    rng = np.random.default_rng(SEED)
    bodies, cons = _two_cubes(rng, points=1)
    bodies.linear_velocity[2] = [0.3, -1.0, 0.0]  # approaching, the light cube moving up a little and turning
    bodies.linear_velocity[1] = [0.0, 0.2, 0.0]
    bodies.angular_velocity[2] = 0.0
    shock = shock_constraints(cons, bodies, FLOAT64, LAYERS)
    res = solve(bodies, shock, np.array([0]), FLOAT64, SolverParams(iterations=1, shock_contact=True,
                                                                    friction_coeff=0.0))
    v, w = res.bodies.linear_velocity, res.bodies.angular_velocity
    p, n = cons.points[0, 0], cons.normal[0]
    vrel = n @ (v[2] + np.cross(w[2], p - bodies.position[2])) - n @ (v[1] + np.cross(w[1], p - bodies.position[1]))
    assert res.impulses.normal[0, 0] > 0
    assert abs(vrel + cons.bias[0, 0]) < 1e-12


def test_impulse_modes() -> None:
    """keep: the shock pass's impulses; drop: the frozen rows keep those before it (the friction limit too);
    return: the friction limit reads the shock pass's, the call returns those before it. A row with nothing frozen
    keeps its own in every mode."""
    rng = np.random.default_rng(SEED)
    bodies, cons = _two_cubes(rng)
    ground = _pair_constraints(np.array([1]), np.array([0]), points=4)
    both = ConstraintSet(**{k: np.concatenate([getattr(cons, k), getattr(ground, k)])
                            for k in ConstraintSet.__dataclass_fields__})
    shock = shock_constraints(both, bodies, FLOAT64)
    assert shock.frozen.tolist() == [FREEZE_B, FREEZE_NONE]
    order = layer_order(np.array([0, 1]), shock, body_layers(shock.body_a, shock.body_b, bodies.dynamic))
    assert order.tolist() == [1, 0]
    init = Impulses(normal=np.full((2, 4), 0.01), friction=np.zeros((2, 2)))
    run = {mode: solve(bodies, shock, order, FLOAT64, SolverParams(iterations=2, shock_contact=True,
                                                                   shock_impulses=mode), initial=init)
           for mode in ("keep", "drop", "return")}
    first = solve(bodies, shock, order, FLOAT64, SolverParams(iterations=1), initial=init)  # the pass before
    keep, drop, ret = run["keep"].impulses, run["drop"].impulses, run["return"].impulses
    assert not np.array_equal(keep.normal[0], first.impulses.normal[0])
    assert np.array_equal(ret.normal[0], first.impulses.normal[0])  # returned: the pass before the shock pass
    assert np.array_equal(drop.normal[0], first.impulses.normal[0])
    assert np.array_equal(ret.normal[1], keep.normal[1]) and np.array_equal(drop.normal[1], keep.normal[1])
    # the velocities of keep and return are the same (the friction limit reads the shock pass's impulses in both)
    assert np.array_equal(run["keep"].bodies.linear_velocity, run["return"].bodies.linear_velocity)
    with pytest.raises(ValueError, match="shock_impulses"):
        solve(bodies, shock, order, FLOAT64, SolverParams(shock_contact=True, shock_impulses="lose"))


@pytest.fixture(scope="module")
def pile():
    frame = scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2)
    bodies = body_table(frame)
    return bodies, setup_constraints(frame, bodies)


@pytest.mark.parametrize("ar", [FLOAT64, FP32], ids=lambda a: a.name)
def test_off_is_todays_solve_bit_for_bit(pile, ar) -> None:
    """The option off: SolverParams' default and a ShockConstraintSet solved without shock passes give exactly the
    plain solve; the remedies' default is off."""
    bodies, cons = pile
    b, c = bodies.rounded(ar), cons.rounded(ar)
    schedule = make_schedule("pybullet", c, b.dynamic)
    plain = solve(b, c, schedule, ar, SolverParams(iterations=2))
    shock = shock_constraints(c, b, ar)
    assert np.any(shock.frozen != FREEZE_NONE)
    for res in (solve(b, shock, schedule, ar, SolverParams(iterations=2)),
                solve(b, c, schedule, ar, SolverParams(iterations=2, shock_contact=False, shock_friction=False))):
        for f in ("linear_velocity", "angular_velocity"):
            assert np.array_equal(getattr(res.bodies, f), getattr(plain.bodies, f))
        assert np.array_equal(res.impulses.normal, plain.impulses.normal)
        assert np.array_equal(res.impulses.friction, plain.impulses.friction)
    assert not SolverParams().shock_contact and not SolverParams().shock_friction
    assert not COLD.shock and not Remedy("warm", 0.85).shock
    with pytest.raises(ValueError, match="shock rows"):
        solve(b, c, schedule, ar, SolverParams(shock_contact=True))


@pytest.mark.parametrize("ar", [FLOAT64, FP32], ids=lambda a: a.name)
def test_shock_levels_bit_identical_to_sequential(pile, ar) -> None:
    bodies, cons = pile
    b, c = bodies.rounded(ar), cons.rounded(ar)
    layers = body_layers(c.body_a, c.body_b, b.dynamic)
    shock = shock_constraints(c, b, ar, layers)
    order = layer_order(make_schedule("pybullet", c, b.dynamic), shock, layers)
    for params in (SolverParams(iterations=2, shock_contact=True, shock_friction=True),
                   SolverParams(iterations=2, shock_contact=True, shock_impulses="return")):
        vec = solve(b, shock, order, ar, params)
        seq = solve_sequential(b, shock, order, ar, params)
        for f in ("linear_velocity", "angular_velocity"):
            assert np.array_equal(getattr(vec.bodies, f), getattr(seq.bodies, f))
        assert np.array_equal(vec.impulses.normal, seq.impulses.normal)
    assert isinstance(shock.rounded(ar), ShockConstraintSet)
