"""The reference PGS solver: level vectorization is bit-identical to the sequential loop, physics sanity."""

from __future__ import annotations

import numpy as np
import pytest

from models import scenes
from models.setup.constraints import body_table, gpu_inverse_inertia, setup_constraints
from models.golden.contact_solver import SolverParams, solve, solve_sequential
from models.golden.integrator import IntegrationParams, cos_poly, integrate, sin_poly
from models.formats.number_format import BF16, FLOAT64, FP16, FP32
from models.order.manifold_schedule import make_schedule

FIELDS = ("linear_velocity", "angular_velocity")


@pytest.fixture(scope="module")
def pile():
    frame = scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2)
    bodies = body_table(frame)
    return frame, bodies, setup_constraints(frame, bodies)


def _identical(r1, r2) -> bool:
    same = all(np.array_equal(getattr(r1.bodies, f), getattr(r2.bodies, f), equal_nan=True) for f in FIELDS)
    return same and np.array_equal(r1.impulses.normal, r2.impulses.normal) and np.array_equal(
        r1.impulses.friction, r2.impulses.friction)


@pytest.mark.parametrize("ar", [FLOAT64, FP32, FP16, BF16], ids=lambda a: a.name)
@pytest.mark.parametrize("kind", ["pybullet", "hazard"])
def test_levels_bit_identical_to_sequential(pile, ar, kind) -> None:
    frame, bodies, cons = pile
    schedule = make_schedule(kind, cons, bodies.dynamic, window=8)
    b, c = bodies.rounded(ar), cons.rounded(ar)
    vec = solve(b, c, schedule, ar, SolverParams(iterations=1))
    seq = solve_sequential(b, c, schedule, ar, SolverParams(iterations=1))
    assert vec.levels < cons.num_manifolds  # the vectorization really groups manifolds
    assert _identical(vec, seq)


def test_setup_fields(pile) -> None:
    frame, bodies, cons = pile
    assert cons.num_manifolds == frame.num_manifolds > 20
    used = np.arange(4)[None, :] < cons.num_points[:, None]
    assert np.all(cons.jac_inv[used] < 0) and np.all(cons.jac_inv[~used] == 0)
    assert np.allclose(np.linalg.norm(cons.normal, axis=1), 1.0, atol=1e-9)
    t = cons.tangent
    assert np.allclose(np.einsum("mi,mi->m", t[:, 0], cons.normal), 0, atol=1e-12)
    assert np.allclose(np.einsum("mi,mi->m", t[:, 1], cons.normal), 0, atol=1e-12)
    assert np.all(cons.spin_damp[bodies.inv_mass[cons.body_a] == 0])
    # Bullet GPU's box inertia for a unit-mass cube of half-extent 1: 1/I = 0.36761
    inv = gpu_inverse_inertia(np.array([[1.0, 1.0, 1.0]]), np.array([1.0]))
    assert inv[0, 0] == pytest.approx(0.36761, abs=5e-6)


def test_projection_and_statics(pile) -> None:
    frame, bodies, cons = pile
    schedule = make_schedule("pybullet", cons, bodies.dynamic)
    res = solve(bodies, cons, schedule, FLOAT64, SolverParams(iterations=4))
    assert np.all(res.impulses.normal >= 0)
    limit = 0.7 * res.impulses.normal.sum(axis=1)
    assert np.all(np.abs(res.impulses.friction) <= limit[:, None] * (1 + 1e-12))
    static = ~bodies.dynamic
    for f in FIELDS:
        assert np.array_equal(getattr(res.bodies, f)[static], getattr(bodies, f)[static])
    # contacts only push: every body's change of linear velocity is the sum of its manifolds' impulses (the normal
    # ones non-negative, above) applied along +n to body A and -n to body B, friction along -t on A and +t on B;
    # the tolerance is float64's: the solver adds the impulses one point at a time, this sums them per body first
    lam_n, lam_t = res.impulses.normal.sum(axis=1), res.impulses.friction
    impulse = (cons.normal * lam_n[:, None] - cons.tangent[:, 0] * lam_t[:, :1] - cons.tangent[:, 1] * lam_t[:, 1:])
    dv = np.zeros_like(bodies.linear_velocity)
    np.add.at(dv, cons.body_a, impulse * bodies.inv_mass[cons.body_a, None])
    np.add.at(dv, cons.body_b, -impulse * bodies.inv_mass[cons.body_b, None])
    assert np.abs(lam_n).max() > 0.01  # the pile's contacts push
    np.testing.assert_allclose(res.bodies.linear_velocity - bodies.linear_velocity, dv, rtol=0, atol=1e-12)


def test_interleaved_order_differs(pile) -> None:
    frame, bodies, cons = pile
    schedule = make_schedule("pybullet", cons, bodies.dynamic)
    a = solve(bodies, cons, schedule, FLOAT64, SolverParams(iterations=4))
    b = solve(bodies, cons, schedule, FLOAT64, SolverParams(iterations=4, interleaved=True))
    assert not np.array_equal(a.bodies.linear_velocity, b.bodies.linear_velocity)


@pytest.mark.parametrize("ar,tol", [(FP32, 1e-4), (FP16, 5e-2)], ids=["fp32", "fp16"])
def test_rounded_modes_close_to_float64(pile, ar, tol) -> None:
    frame, bodies, cons = pile
    schedule = make_schedule("hazard", cons, bodies.dynamic, window=8)
    ref = solve(bodies, cons, schedule, FLOAT64, SolverParams(iterations=4))
    got = solve(bodies.rounded(ar), cons.rounded(ar), schedule, ar, SolverParams(iterations=4))
    scale = np.abs(ref.bodies.linear_velocity).max()
    err = np.abs(got.bodies.linear_velocity - ref.bodies.linear_velocity).max() / scale
    print(f"{ar.name}: max velocity error relative to max speed {err:.2e}")
    assert err < tol


def test_integrator_keeps_unit_quaternions(pile) -> None:
    frame, bodies, cons = pile
    spun = bodies.copy()
    spun.angular_velocity[spun.dynamic] = np.random.default_rng(0).normal(0, 60, (int(spun.dynamic.sum()), 3))
    for ar in (FLOAT64, FP32):
        out = integrate(spun.rounded(ar), ar, IntegrationParams())
        norms = np.linalg.norm(out.orientation[spun.dynamic], axis=1)
        assert np.allclose(norms, 1.0, atol=4e-7)
        assert np.array_equal(out.position[~spun.dynamic], spun.position[~spun.dynamic])


def test_sin_cos_polynomials_against_libm() -> None:
    """The hardware's sin/cos against float32 libm on the integrator's range |x| <= pi/8 (Bullet's float math)."""
    x = FP32.round(np.linspace(-np.pi / 8, np.pi / 8, 200_001))
    for poly, ref in ((sin_poly, np.sin), (cos_poly, np.cos)):
        ours = poly(FP32, x)
        libm = ref(x.astype(np.float32)).astype(np.float64)
        ulp = np.spacing(np.abs(libm).astype(np.float32)).astype(np.float64)
        worst = float(np.max(np.abs(ours - libm) / ulp))
        exact = float(np.max(np.abs(ours - ref(x)) / ulp))
        print(f"{poly.__name__}: max {worst:.1f} ulp from float32 libm, {exact:.1f} ulp from the exact value")
        assert worst <= 2.0 and exact <= 2.0
