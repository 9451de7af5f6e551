"""Constraint residual, the converged solve, and pybullet's profiler parsing."""

from __future__ import annotations

import numpy as np
import pytest

from models import scenes
from models.scenes.bullet_profile import parse_chrome_trace
from models.setup.constraints import body_table, setup_constraints
from models.golden.contact_solver import (CONTACT_PASS, Impulses, SolverParams, run_pass, schedule_levels, solve,
                                          solve_converged)
from models.formats.number_format import FLOAT64
from models.exact.residual import contact_error, contact_residual
from models.order.manifold_schedule import make_schedule


@pytest.fixture(scope="module")
def pile():
    frame = scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    return bodies, cons, make_schedule("hazard", cons, bodies.dynamic, window=8)


def test_residual_vanishes_at_the_contact_fixed_point(pile) -> None:
    """After contact passes converge, every point satisfies the LCP conditions the residual measures."""
    bodies, cons, schedule = pile
    out, imp = bodies.copy(), Impulses.zeros(cons.num_manifolds)
    levels = schedule_levels(schedule, cons, bodies.dynamic)
    for it in range(300):
        run_pass(out, imp, cons, levels, FLOAT64, CONTACT_PASS, it, SolverParams(), schedule)
    e, active = contact_error(out, cons)
    lam = imp.normal[active]
    assert np.all(lam >= 0)
    res = contact_residual(out, cons, imp.normal)
    assert res["max normal velocity violation (m/s)"] < 1e-3  # slow PGS convergence: 1.1e-4 after 400 passes
    assert res["max complementarity |lambda * e| (N*s*m/s)"] < 1e-3
    # one pass is far from it: the measure is not trivially zero
    out1, imp1 = bodies.copy(), Impulses.zeros(cons.num_manifolds)
    run_pass(out1, imp1, cons, levels, FLOAT64, CONTACT_PASS, 0, SolverParams(), schedule)
    assert contact_residual(out1, cons, imp1.normal)["max normal velocity violation (m/s)"] > 1e-2
    assert e.shape == cons.jac_inv.shape


def test_converged_solve_is_the_limit_of_more_iterations() -> None:
    """On the sliding incline (one manifold) PGS converges; fewer iterations are further from the limit. (Piles
    converge far more slowly: 3,000 passes leave 2e-5 m/s of change per pass on the 4x3x4 pile.)"""
    frame = scenes.capture_frame("incline", angle_deg=40.0)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("pybullet", cons, bodies.dynamic)
    conv = solve_converged(bodies, cons, schedule, FLOAT64, tolerance=1e-12, max_passes=3000)
    assert conv.converged and conv.last_change <= 1e-12
    errs = []
    for iters in (1, 2, 4):
        v = solve(bodies, cons, schedule, FLOAT64, SolverParams(iterations=iters)).bodies.linear_velocity
        errs.append(np.abs(v - conv.result.bodies.linear_velocity).max())
    assert errs[0] > errs[1] > errs[2]


def test_converged_solve_reports_an_exhausted_budget(pile) -> None:
    bodies, cons, schedule = pile
    conv = solve_converged(bodies, cons, schedule, FLOAT64, tolerance=0.0, max_passes=3)
    assert not conv.converged and conv.contact_passes == 3 and conv.friction_passes == 3


def test_parse_chrome_trace() -> None:
    text = ('{"traceEvents":[\n{"cat":"timing","pid":1,"tid":0,"ts":100.000 ,"ph":"B","name":"solveGroup27",'
            '"args":{}},\n{"cat":"timing","pid":1,"tid":0,"ts":100.500 ,"ph":"B","name":"inner3","args":{}},\n'
            '{"cat":"timing","pid":1,"tid":0,"ts":140.000 ,"ph":"E","name":"inner3","args":{}},\n'
            '{"cat":"timing","pid":1,"tid":0,"ts":173.000 ,"ph":"E","name":"solveGroup27","args":{}},\n'
            '{"cat":"timing","pid":1,"tid":0,"ts":200.000 ,"ph":"B","name":"solveGroup31","args":{}},\n'
            '{"cat":"timing","pid":1,"tid":0,"ts":210.000 ,"ph":"E","name":"solveGroup31","args":{}}\n]}')
    t = parse_chrome_trace(text)
    assert t["solveGroup"] == pytest.approx(83e-6) and t["inner"] == pytest.approx(39.5e-6)


def test_converged_solve_stops_when_its_rate_cannot_reach_the_tolerance(pile) -> None:
    """With a time budget, a kind stops once the last RATE_WINDOW passes' rate says the tolerance is out of reach
    within its share, and says how many passes it would still need; without one it runs to max_passes."""
    from models.golden.contact_solver import RATE_WINDOW, _passes_needed

    assert _passes_needed(1e-3, 1e-4, 100, 1e-9) == pytest.approx(500.0)
    assert _passes_needed(1e-4, 1e-4, 100, 1e-9) == float("inf")
    import time

    bodies, cons, schedule = pile
    t0 = time.monotonic()
    conv = solve_converged(bodies, cons, schedule, FLOAT64, tolerance=1e-30, max_passes=10 ** 6, time_budget_s=30.0,
                           hopeless_after=RATE_WINDOW)
    assert time.monotonic() - t0 < 25.0  # stopped by the projection, not the budget
    assert not conv.converged
    assert conv.contact_passes % RATE_WINDOW == 0 and conv.friction_passes % RATE_WINDOW == 0
    assert conv.projected[0] > 0 and conv.projected[1] > 0
    capped = solve_converged(bodies, cons, schedule, FLOAT64, tolerance=1e-30, max_passes=RATE_WINDOW + 7)
    assert capped.contact_passes == RATE_WINDOW + 7  # no budget: no projection stops it
    patient = solve_converged(bodies, cons, schedule, FLOAT64, tolerance=1e-30, max_passes=2 * RATE_WINDOW + 3,
                              time_budget_s=30.0, hopeless_after=2 * RATE_WINDOW + 3)
    assert patient.contact_passes == 2 * RATE_WINDOW + 3  # not judged hopeless before hopeless_after
