"""Substeps: the bias of each call follows the bodies' motion since the collision detection, a step makes n calls
of dt / n, and the hard-case judge sees one state per step."""

from __future__ import annotations

import numpy as np
import pytest

from models.closed_loop.loop import Remedy
from models.setup.constraints import POSITION_COEFF, POSITION_DRIFT, BodyTable, ConstraintSet, plane_space
from models.formats.number_format import FLOAT64, FP32
from models.closed_loop.hard_cases import CASES, call_iterations
from models.golden.substep import ContactPoints, substep_constraints


def _two_boxes() -> tuple[BodyTable, ConstraintSet, ContactPoints]:
    """Box A (body 0) resting 2 mm deep on the static ground (body 1), one point under it, normal +y (B to A)."""
    bodies = BodyTable(position=np.array([[0.0, 0.498, 0.0], [0.0, 0.0, 0.0]]),
                       orientation=np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)), linear_velocity=np.zeros((2, 3)),
                       angular_velocity=np.zeros((2, 3)), inv_mass=np.array([1.0, 0.0]),
                       inv_inertia=np.array([[6.0, 6.0, 6.0], [0.0, 0.0, 0.0]]))
    n = np.array([[0.0, 1.0, 0.0]])
    pa = np.zeros((1, 4, 3))
    pa[0, 0] = [0.5, -0.002, 0.5]
    pb = np.zeros((1, 4, 3))
    pb[0, 0] = [0.5, 0.0, 0.5]
    valid = np.array([[True, False, False, False]])
    t0, t1 = plane_space(-n)
    cons = ConstraintSet(body_a=np.array([0]), body_b=np.array([1]), num_points=np.array([1]), normal=n, points=pb,
                         jac_inv=np.array([[-0.5, 0, 0, 0]]), bias=np.zeros((1, 4)), center=pb[:, 0],
                         tangent=np.stack([t0, t1], axis=1), f_jac_inv=np.array([[-0.5, -0.5]]),
                         spin_damp=np.zeros(1, bool))
    points = ContactPoints(cons.body_a, cons.body_b, valid, n, pa, pb, bodies.position.copy(),
                           bodies.orientation.copy())
    return bodies, cons, points


def test_the_bias_follows_the_separation_since_the_collision_detection() -> None:
    bodies, cons, points = _two_boxes()
    dt = 1.0 / 120.0
    at_detection = substep_constraints(cons, points, bodies, dt, FLOAT64)
    assert np.isclose(at_detection.bias[0, 0], (-0.002 + POSITION_DRIFT) * POSITION_COEFF / dt)
    assert np.array_equal(at_detection.bias[0, 1:], np.zeros(3))  # unused points stay 0
    lifted = bodies.copy()
    lifted.position[0, 1] += 0.003  # A rose 3 mm: the point is 1 mm apart now
    assert np.isclose(substep_constraints(cons, points, lifted, dt, FLOAT64).bias[0, 0],
                      (0.001 + POSITION_DRIFT) * POSITION_COEFF / dt)
    tilted = bodies.copy()  # A turned 0.01 rad about z: its point at x = 0.5 rises by about 5 mm
    tilted.orientation[0] = [0.0, 0.0, np.sin(0.005), np.cos(0.005)]
    d = substep_constraints(cons, points, tilted, dt, FLOAT64).bias[0, 0] * dt / POSITION_COEFF - POSITION_DRIFT
    assert d == pytest.approx(-0.002 + 0.5 * np.sin(0.01) + 0.5 * (1 - np.cos(0.01)), abs=1e-6)


def test_the_relax_substep_drops_the_position_correction_only() -> None:
    bodies, cons, points = _two_boxes()
    dt = 1.0 / 120.0
    deep = bodies.copy()
    deep.position[0, 1] -= 0.01  # 12 mm deep: the bias pushes apart (negative), relax removes it
    assert substep_constraints(cons, points, deep, dt, FLOAT64).bias[0, 0] < 0.0
    assert substep_constraints(cons, points, deep, dt, FLOAT64, relax=True).bias[0, 0] == 0.0
    # 2 mm deep (less than the slop): the positive bias that lets the contact close stays
    assert np.array_equal(substep_constraints(cons, points, bodies, dt, FLOAT64, relax=True).bias,
                          substep_constraints(cons, points, bodies, dt, FLOAT64).bias)


def test_a_step_in_substeps_makes_n_calls_and_the_judge_sees_one_state_per_step() -> None:
    remedy = Remedy("warm+sub2", 0.85, 2)
    result, path = CASES["incline20"].run(FP32, 4, steps=3, remedy=remedy)
    assert result.extra["kernel calls"] == 2 * (3 + CASES["incline20"].warmup_steps)
    assert result.iterations == call_iterations(4, remedy) == 2 and result.extra["passes per step"] == 8
    assert path.steps == 3 and np.array_equal(path.positions[-1], result.final.position[result.final.dynamic])
    assert result.extra["kernel cycles per step"] > 0


def test_a_remedy_out_of_range_is_refused() -> None:
    with pytest.raises(ValueError, match="substeps"):
        Remedy("none", 0.85, 0)
    with pytest.raises(ValueError, match="factor"):
        Remedy("over", 1.5)
    with pytest.raises(ValueError, match="relax"):
        Remedy("relax alone", 0.85, 1, relax=True)
