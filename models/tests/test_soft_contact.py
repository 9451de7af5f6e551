"""Box2D's soft contact: the spring-damper scales, the host's rows, the kernel's one added multiply, and the pass
count of a soft remedy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.closed_loop.loop import Remedy
from models.golden.contact_solver import Impulses, SolverParams, solve
from models.formats.number_format import BF16, FLOAT64, FP16, FP32
from models.golden.soft_contact import SoftContact, Softness, relax_constraints, soft_constraints
from models.closed_loop.hard_cases import REMEDIES, call_iterations
from models.tests.test_substep import _two_boxes

H = 1.0 / 120.0


def test_softness_is_box2d_spring_damper() -> None:
    s = Softness.of(30.0, 10.0, H)
    omega = 2 * math.pi * 30.0
    a1 = 20.0 + H * omega
    assert s.bias_rate == pytest.approx(omega / a1)
    assert s.impulse_scale == pytest.approx(1.0 / (1.0 + H * omega * a1))
    assert s.mass_scale + s.impulse_scale == pytest.approx(1.0)  # keep = 1 - impulseScale = massScale
    assert Softness.of(0.0, 10.0, H) == Softness(0.0, 1.0, 0.0)  # hertz 0: rigid
    soft = SoftContact()
    assert soft.contact_hertz(H) == 30.0 and soft.contact_hertz(1 / 60) == 15.0  # a quarter of the substep rate
    dyn, static = soft.softness(1 / 240)
    assert static == Softness.of(60.0, 10.0, 1 / 240) and dyn == Softness.of(30.0, 10.0, 1 / 240)
    assert soft.softness(H)[1] == Softness.of(30.0, 10.0, H)  # the static one capped at a quarter too
    with pytest.raises(ValueError):
        SoftContact(hertz=float("nan"))
    with pytest.raises(ValueError):
        SoftContact(max_push=0.0)


def test_rows_bias_and_mass_scale() -> None:
    bodies, cons, _ = _two_boxes()
    valid = np.array([[True, False, False, False]])
    soft = SoftContact()
    _, static = soft.softness(H)
    deep = soft_constraints(cons, np.array([[-0.002, 0, 0, 0]]), valid, bodies, H, soft, FLOAT64)
    assert deep.bias[0, 0] == pytest.approx(static.bias_rate * -0.002)  # A sits on the static ground
    assert deep.jac_inv[0, 0] == pytest.approx(-0.5 * static.mass_scale)
    assert np.array_equal(deep.bias[0, 1:], np.zeros(3)) and np.array_equal(deep.jac_inv[0, 1:], np.zeros(3))
    far = soft_constraints(cons, np.array([[-5.0, 0, 0, 0]]), valid, bodies, H, soft, FLOAT64)
    assert far.bias[0, 0] == -soft.max_push  # the push-out is capped
    apart = soft_constraints(cons, np.array([[0.001, 0, 0, 0]]), valid, bodies, H, soft, FLOAT64)
    assert apart.bias[0, 0] == pytest.approx(0.001 / H) and apart.jac_inv[0, 0] == -0.5  # speculative: rigid
    relax = relax_constraints(cons, np.array([[-0.002, 0, 0, 0]]), valid, H, FLOAT64)
    assert relax.bias[0, 0] == 0.0 and relax.jac_inv[0, 0] == -0.5
    assert relax_constraints(cons, np.array([[0.001, 0, 0, 0]]), valid, H, FLOAT64).bias[0, 0] == pytest.approx(0.001 / H)


@pytest.mark.parametrize("ar", [FLOAT64, FP32, FP16, BF16], ids=lambda a: a.name)
def test_the_soft_update_is_box2d_rounded_in_its_order(ar) -> None:
    """One row, a warm-started impulse, falling at 0.3 m/s: the kernel's update, op by op in the format, is
    lam' = max(round(lam * keep) + round(round(vrel + b) * jac_inv), 0); in float64 Box2D's update."""
    bodies, cons, _ = _two_boxes()
    bodies.linear_velocity[0] = [0.0, -0.3, 0.0]
    soft = SoftContact()
    row = soft_constraints(cons, np.array([[-0.002, 0, 0, 0]]), np.array([[True, False, False, False]]), bodies, H,
                           soft, FLOAT64).rounded(ar)
    lam0 = ar.round(np.array([[0.05, 0, 0, 0]]))
    bodies = bodies.rounded(ar)
    params = SolverParams(iterations=1, soft_keep=soft.keep(H))
    res = solve(bodies, row, np.array([0]), ar, params, initial=Impulses(lam0, np.zeros((1, 2))))
    keep = ar.const(soft.keep(H)[1])  # a row with the static ground
    vrel = bodies.linear_velocity[0, 1]  # n = +y, the point under A's centre: no angular term, B static
    delta = ar.mul(ar.add(vrel, row.bias[0, 0]), row.jac_inv[0, 0])
    expect = ar.max(ar.add(ar.mul(lam0[0, 0], keep), delta), ar.const(0.0))
    assert res.impulses.normal[0, 0] == expect
    if ar is FLOAT64:
        _, st = soft.softness(H)
        m_eff = 0.5  # -jac_inv = 1 / K
        box2d = max(0.0, 0.05 - st.mass_scale * m_eff * (-0.3 + st.bias_rate * -0.002) - st.impulse_scale * 0.05)
        assert res.impulses.normal[0, 0] == pytest.approx(box2d, rel=1e-12)
    rigid = solve(bodies, row, np.array([0]), ar, SolverParams(iterations=1, soft_keep=(1.0, 1.0)),
                  initial=Impulses(lam0, np.zeros((1, 2))))
    plain = solve(bodies, row, np.array([0]), ar, SolverParams(iterations=1), initial=Impulses(lam0, np.zeros((1, 2))))
    assert np.array_equal(rigid.impulses.normal, plain.impulses.normal)  # keep 1: today's update, bit for bit
    assert np.array_equal(rigid.bodies.linear_velocity, plain.bodies.linear_velocity)


def test_a_soft_remedy_counts_every_call_in_the_budget() -> None:
    r = REMEDIES["warm1+soft+sub2+relax"]
    assert r.calls_per_step == 4 and call_iterations(4, r) == 1
    assert r.passes_per_step(SolverParams(iterations=call_iterations(4, r))) == 8
    r4 = REMEDIES["warm1+soft+sub4"]
    assert r4.calls_per_step == 4 and r4.passes_per_step(SolverParams(iterations=call_iterations(4, r4))) == 8
    assert Remedy("s", soft=SoftContact(), relax=True).calls_per_step == 2  # one substep: solve and relax calls
