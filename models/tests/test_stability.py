"""The hard-case judge on made-up trajectories: the physical quantities it judges and the limits it uses."""

from __future__ import annotations

import numpy as np
import pytest

from models.closed_loop.loop import LoopResult
from models.setup.constraints import POSITION_DRIFT, BodyTable
from models.golden.integrator import IntegrationParams
from models.formats.number_format import FLOAT64, Arithmetic
from models.golden.contact_solver import SolverParams
from models.closed_loop.hard_cases import CASES, LIMITS, judge, slide_distance
from models.closed_loop.trajectory import Trajectory, TrajectoryRecorder

IP = IntegrationParams()
G_DT = np.asarray(IP.gravity) * IP.dt  # what a body at rest stores (gravity is added after the position update)


def _bodies(position: np.ndarray, velocity: np.ndarray) -> BodyTable:
    """One static ground (body 0) and the dynamic bodies at ``position`` with stored ``velocity``."""
    n = position.shape[0] + 1
    pad = lambda a: np.vstack([np.zeros((1, 3)), a])  # noqa: E731
    return BodyTable(pad(position), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), pad(velocity), np.zeros((n, 3)),
                     np.r_[0.0, np.ones(n - 1)], np.r_[[[0.0] * 3], np.ones((n - 1, 3))])


def _recorded_loop(positions: np.ndarray, stored_velocities: np.ndarray, start: np.ndarray,
                   penetration: float = 0.005) -> tuple[LoopResult, Trajectory]:
    """A closed loop that took ``positions`` (steps, N, 3) with ``stored_velocities``, recorded through the
    stepper wrapper the hard cases use."""
    steps = positions.shape[0]
    script = iter(range(steps))

    def scripted(ar: Arithmetic, solver: SolverParams, ip: IntegrationParams):  # noqa: ANN202
        def step(bodies: BodyTable, cons: object, order: np.ndarray, initial: object = None) -> tuple:
            k = next(script)
            return _bodies(positions[k], stored_velocities[k]), None
        return step

    recorder = TrajectoryRecorder()
    advance = recorder.wrap(scripted)(FLOAT64, SolverParams(), IP)
    final = None
    for _ in range(steps):
        final, _ = advance(_bodies(start, stored_velocities[0]), None, np.zeros(0, dtype=np.int64), None)
    assert final is not None
    result = LoopResult(scene="made-up", steps=steps, format="float64", iterations=4,
                        max_penetration=np.full(steps, penetration), max_speed=np.zeros(steps),
                        median_speed=np.zeros(steps), kinetic_energy=np.zeros(steps),
                        nonfinite=np.zeros(steps, dtype=int), manifolds=np.ones(steps),
                        drift=np.linalg.norm(positions[-1] - start, axis=1), final=final,
                        start_position=np.vstack([np.zeros((1, 3)), start]))
    return result, recorder.trajectory(result)


def test_a_body_at_rest_passes_net_of_g_dt() -> None:
    """Stored velocity g*dt (0.163 m/s, over the rest-speed limit) and no motion: at rest."""
    assert np.linalg.norm(G_DT) > LIMITS["rest speed"].value  # the check below fails if g*dt were not removed
    start = np.array([[0.0, 0.5, 0.0], [0.0, 1.5, 0.0]])
    steps = 120
    result, path = _recorded_loop(np.repeat(start[None], steps, axis=0), np.tile(G_DT, (steps, 2, 1)), start)
    assert np.allclose(path.speed(), 0.0)
    verdict = judge(CASES["stack20"], result, path)
    assert verdict.passed, verdict.failures
    assert verdict.figures["max speed net of g dt (m/s)"] < 1e-12


def test_a_body_that_jitters_and_comes_back_fails_the_drift_check() -> None:
    """+-3 mm every step, back at the start at the end: no net displacement, no excursion past the slop, but a
    path of 0.36 m over 120 steps."""
    start = np.array([[0.0, 0.5, 0.0]])
    steps = 120
    offsets = np.where(np.arange(steps) % 2 == 0, 0.003, 0.0)
    positions = start[None] + offsets[:, None, None] * np.array([1.0, 0.0, 0.0])
    result, path = _recorded_loop(positions, np.tile(G_DT, (steps, 1, 1)), start)  # stored speeds say rest
    verdict = judge(CASES["stack20"], result, path)
    assert verdict.figures["max net displacement (m)"] == pytest.approx(0.0, abs=1e-15)
    assert verdict.figures["max excursion (m)"] == pytest.approx(0.003)
    assert verdict.figures["max path length (m)"] == pytest.approx(0.36)
    assert verdict.failures == [f"path 0.36 m > {LIMITS['rest path']}"]


def test_a_body_that_moves_faster_than_the_rest_speed_fails() -> None:
    """Net of g*dt, 0.1 m/s of real motion on one step fails the rest-speed limit (0.06 m/s)."""
    start = np.array([[0.0, 0.5, 0.0]])
    steps = 10
    stored = np.tile(G_DT, (steps, 1, 1))
    stored[4, 0, 0] += 0.1
    result, path = _recorded_loop(np.repeat(start[None], steps, axis=0), stored, start)
    failures = judge(CASES["incline20"], result, path).failures
    assert failures == [f"speed 0.1 m/s > {LIMITS['rest speed']}"]


def test_penetration_is_judged_against_the_slop() -> None:
    start = np.array([[0.0, 0.5, 0.0]])
    steps = 5
    at_rest = (np.repeat(start[None], steps, axis=0), np.tile(G_DT, (steps, 1, 1)), start)
    assert LIMITS["rest penetration"].value == pytest.approx(2 * POSITION_DRIFT)
    assert judge(CASES["stack20"], *_recorded_loop(*at_rest, penetration=POSITION_DRIFT)).passed
    failures = judge(CASES["stack20"], *_recorded_loop(*at_rest, penetration=0.011)).failures
    assert failures == [f"penetration 0.011 m > {LIMITS['rest penetration']}"]


def test_the_sliding_box_must_cover_half_the_coulomb_distance() -> None:
    """incline40 at 120 steps: a = g (sin 40 - 0.7 cos 40) = 1.04 m/s^2, 2 s: 2.09 m; half of it is required."""
    assert slide_distance(40.0, 0.7, 120).value == pytest.approx(0.5 * 0.5 * 1.0443 * 4.0, rel=1e-3)
    start = np.array([[0.0, 0.5, 0.0]])
    steps = 120
    crawl = start[None] + (np.arange(1, steps + 1) * 0.005)[:, None, None] * np.array([1.0, 0.0, 0.0])
    failures = judge(CASES["incline40"], *_recorded_loop(crawl, np.tile(G_DT, (steps, 1, 1)), start)).failures
    assert failures == [f"moved only 0.6 m < {slide_distance(40.0, 0.7, 120)}"]
