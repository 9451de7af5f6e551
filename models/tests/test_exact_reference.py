"""The exact reference is a fixed point of the project's own passes; bad input gives ExactReferenceError; the cache
round-trips and never leaves half a file; the error metrics."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.golden.contact_solver import (CONTACT_PASS, FRICTION_PASS, Impulses, SolverParams, run_pass,
                                          schedule_levels, solve)
from models.exact.phases import Budget
from models.exact.assembly import ExactReferenceError
from models.exact.reference import exact_reference
from models.exact.cache import cache_key, cached_exact_reference
from models.formats.number_format import FLOAT64
from models.order.manifold_schedule import make_schedule
from models.exact.solution_error import solution_error
from models.exact import phases
from models.exact.residual import pass_change

# one pass from the exact state moves no velocity by more than this (m/s, rad/s); measured: 1e-14 on the pile
FIXED_POINT_TOLERANCE = 1e-9
RESIDUAL_TOLERANCE = 1e-9  # m/s (rad/s for the spin row)
REACHED_TOLERANCE = 1e-8  # m/s, rad/s: 4,000 friction passes from the exact contact state end this close to the
# reference (measured on the mixed shapes world: 1.8e-12 after 3,000)


@pytest.fixture(scope="module")
def pile():
    frame = scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, window=8)
    return bodies, cons, schedule, exact_reference(bodies, cons)


def _assert_fixed_point_and_small_residuals(ref, cons, schedule) -> None:
    """One contact pass from the contact state and one friction pass from the final state move nothing; the
    natural residuals are small."""
    no_friction = Impulses(ref.impulses.normal, np.zeros_like(ref.impulses.friction))
    assert pass_change(ref.contact_bodies, no_friction, cons, schedule, CONTACT_PASS) <= FIXED_POINT_TOLERANCE
    assert pass_change(ref.bodies, ref.impulses, cons, schedule, FRICTION_PASS) <= FIXED_POINT_TOLERANCE
    for key in ("contact phase: normal LCP |min(lam K, e)| max (m/s)", "friction phase: box residual max (m/s)",
                "friction phase: spin |n.w| max (rad/s)"):
        assert ref.residuals[key] <= RESIDUAL_TOLERANCE, (key, ref.residuals[key])


def test_exact_state_is_a_fixed_point_of_one_contact_and_one_friction_pass(pile) -> None:
    bodies, cons, schedule, ref = pile
    no_friction = Impulses(ref.impulses.normal, np.zeros_like(ref.impulses.friction))
    assert pass_change(ref.contact_bodies, no_friction, cons, schedule, CONTACT_PASS) <= FIXED_POINT_TOLERANCE
    assert pass_change(ref.bodies, ref.impulses, cons, schedule, FRICTION_PASS) <= FIXED_POINT_TOLERANCE
    # the check can fail: from the 4-iteration state both passes still move velocities by far more
    four = solve(bodies, cons, schedule, FLOAT64, SolverParams(iterations=4))
    assert pass_change(four.bodies, four.impulses, cons, schedule, FRICTION_PASS) > 100 * FIXED_POINT_TOLERANCE
    assert np.abs(four.bodies.linear_velocity - ref.bodies.linear_velocity).max() > 1e-3
    # and the exact state really differs from the start
    assert np.abs(ref.bodies.linear_velocity - bodies.linear_velocity).max() > 0.1


def test_natural_residuals_are_small(pile) -> None:
    _, _, _, ref = pile
    for key in ("contact phase: normal LCP |min(lam K, e)| max (m/s)", "friction phase: box residual max (m/s)",
                "friction phase: spin |n.w| max (rad/s)"):
        assert ref.residuals[key] <= RESIDUAL_TOLERANCE, (key, ref.residuals[key])
    assert np.all(ref.impulses.normal >= 0)
    limit = 0.7 * ref.impulses.normal.sum(axis=1)
    assert np.all(np.abs(ref.impulses.friction) <= limit[:, None] + 1e-12)


def test_bad_input_gives_a_clear_error(pile) -> None:
    bodies, cons, _, _ = pile
    nan = bodies.copy()
    nan.linear_velocity[1, 0] = np.nan
    with pytest.raises(ExactReferenceError, match="NaN or Inf"):
        exact_reference(nan, cons)
    with pytest.raises(ExactReferenceError, match="time budget"):
        exact_reference(bodies, cons, budget=Budget(time_s=0.0))
    with pytest.raises(ExactReferenceError, match="memory"):
        exact_reference(bodies, cons, budget=Budget(memory_bytes=1000))
    # infeasible: a manifold doubled with its normal reversed, both rows demanding separation
    m = 0
    pick = np.array([m, m])
    twin = dataclasses.replace(cons, **{f.name: getattr(cons, f.name)[pick].copy()
                                        for f in dataclasses.fields(cons)})
    twin.normal[1] *= -1.0
    twin.bias[:] = np.where(twin.jac_inv != 0, -10.0, 0.0)
    with pytest.raises(ExactReferenceError, match="Infeasible.*the contact phase has no fixed point .*bodies "
                                                  f"{cons.body_a[m]}-{cons.body_b[m]}.*; certified: "):
        exact_reference(bodies, twin)
    # degenerate: a dynamic body whose inverse inertia is not positive definite
    flat = bodies.copy()
    flat.inv_inertia[int(np.flatnonzero(bodies.dynamic)[0])] = [1.0, 0.0, 1.0]
    with pytest.raises(ExactReferenceError, match="not positive definite"):
        exact_reference(flat, cons)


def test_cache_round_trip_and_nothing_half_written(pile, tmp_path: Path) -> None:
    bodies, cons, _, ref = pile
    first, path, hit = cached_exact_reference(bodies, cons, tmp_path)
    assert not hit and path.is_file() and path.name == f"exact_{cache_key(bodies, cons, SolverParams())}.npz"
    again, path2, hit2 = cached_exact_reference(bodies, cons, tmp_path)
    assert hit2 and path2 == path
    for a, b in ((again.bodies.linear_velocity, first.bodies.linear_velocity),
                 (again.contact_bodies.angular_velocity, first.contact_bodies.angular_velocity),
                 (again.impulses.normal, first.impulses.normal), (again.impulses.friction, first.impulses.friction)):
        assert np.array_equal(a, b)
    assert again.residuals == first.residuals
    np.testing.assert_allclose(first.bodies.linear_velocity, ref.bodies.linear_velocity, atol=1e-8)
    # another scheme setting is another key
    assert cache_key(bodies, cons, SolverParams(friction_coeff=0.5)) != cache_key(bodies, cons, SolverParams())
    # a truncated file is recomputed and replaced
    path.write_bytes(path.read_bytes()[:100])
    third, _, hit3 = cached_exact_reference(bodies, cons, tmp_path)
    assert not hit3 and np.array_equal(third.bodies.linear_velocity, first.bodies.linear_velocity)
    assert [p.name for p in tmp_path.iterdir() if p.is_file()] == [path.name]  # no temporary file left
    # a failed solve writes no reference, only the record of the failure, which a later run with no larger
    # budget reports at once and a larger budget retries (and removes once it succeeds)
    failed = tmp_path / "failed"
    with pytest.raises(ExactReferenceError, match="time budget"):
        cached_exact_reference(bodies, cons, failed, budget=Budget(time_s=0.0))
    assert [p.name for p in failed.iterdir()] == [path.name.replace(".npz", ".failed.json")]
    with pytest.raises(ExactReferenceError, match="earlier attempt"):
        cached_exact_reference(bodies, cons, failed, budget=Budget(time_s=0.0))
    _, retried, hit4 = cached_exact_reference(bodies, cons, failed)
    assert not hit4 and [p.name for p in failed.iterdir()] == [retried.name]


def test_solution_error_metrics(pile) -> None:
    bodies, _, _, _ = pile
    ours = bodies.copy()
    dyn = bodies.dynamic
    idx = np.flatnonzero(dyn)
    ours.linear_velocity[idx[0]] += [3.0, 4.0, 0.0]  # |dv| = 5 on one body
    ours.angular_velocity[idx[:2]] += [0.0, 0.0, 2.0]
    err = solution_error(ours, bodies, dyn)
    assert err.max_dv == pytest.approx(5.0) and err.median_dv == 0.0
    assert err.max_dw == pytest.approx(2.0)
    assert 0 < err.p99_dv <= 5.0
    v_scale = np.linalg.norm(bodies.linear_velocity[dyn], axis=1).max()
    assert err.relative_dv == pytest.approx(5.0 / v_scale)


def test_contact_phase_bound_holds_and_vanishes_at_the_limit(pile) -> None:
    """The certificate bounds the true distance of a PGS iterate and is small at the exact contact state."""
    from models.exact.bound import contact_phase_bound

    bodies, cons, schedule, ref = pile
    at_limit = contact_phase_bound(bodies, cons, ref.impulses.normal)
    assert at_limit["certified max |dv| (m/s)"] < 1e-4
    out, imp = bodies.copy(), Impulses.zeros(cons.num_manifolds)
    levels = schedule_levels(schedule, cons, bodies.dynamic)
    for it in range(20):
        run_pass(out, imp, cons, levels, FLOAT64, CONTACT_PASS, it, SolverParams(), schedule)
    bound = contact_phase_bound(bodies, cons, imp.normal)
    dv = np.linalg.norm(out.linear_velocity - ref.contact_bodies.linear_velocity, axis=1).max()
    dw = np.linalg.norm(out.angular_velocity - ref.contact_bodies.angular_velocity, axis=1).max()
    assert 1e-3 < dv <= bound["certified max |dv| (m/s)"] and dw <= bound["certified max |dw| (rad/s)"]
    with pytest.raises(ExactReferenceError, match="negative"):
        contact_phase_bound(bodies, cons, -np.ones_like(imp.normal))


def test_bounded_solve_enforces_the_budget_from_outside(pile, monkeypatch: pytest.MonkeyPatch) -> None:
    """The bounded solve returns the same reference, and stops a solve that outlasts its time or memory budget."""
    from models.exact import reference as er

    bodies, cons, _, ref = pile
    got = er.exact_reference_bounded(bodies, cons)
    assert np.array_equal(got.bodies.linear_velocity, ref.bodies.linear_velocity)
    with pytest.raises(ExactReferenceError, match="memory"):  # the estimate refuses before solving
        er.exact_reference_bounded(bodies, cons, budget=Budget(memory_bytes=1000))

    def hang(prob: phases.QpProblem, limit: float) -> phases.QpSolution:  # a solver that never checks its time limit
        import time
        time.sleep(60)
        return phases.clarabel_solve(prob, limit)

    monkeypatch.setattr(er, "BUDGET_GRACE_S", 0.0)
    with pytest.raises(ExactReferenceError, match="was stopped"):
        er.exact_reference_bounded(bodies, cons, budget=Budget(time_s=0.5), solver=hang)


ITERATION_KEYS = {"ipm": "body-space interior point iterations", "mprgp": "iterative (MPRGP) iterations"}


@pytest.mark.parametrize("method", ["ipm", "mprgp"])
def test_large_island_path_reaches_the_direct_reference_and_certifies_it(pile, monkeypatch: pytest.MonkeyPatch,
                                                                         method: str) -> None:
    """Islands above DIRECT_ROWS_LIMIT are solved by the body-space interior point (or MPRGP) and certified: on the
    pile (forced onto that path) it agrees with Clarabel's dual solve, is a fixed point of both passes, its
    certificate bounds the true distance, and a solve stopped early is refused (its certificate exceeds what is
    accepted)."""
    from models.exact import body_space_ipm
    from models.exact import large_island as li

    bodies, cons, schedule, ref = pile
    monkeypatch.setattr(phases, "DIRECT_ROWS_LIMIT", 0)
    monkeypatch.setattr(li, "LARGE_ISLAND_METHOD", method)
    it = exact_reference(bodies, cons)
    assert it.details[f"contact phase: {ITERATION_KEYS[method]}"] > 0
    assert it.details[f"friction phase: {ITERATION_KEYS[method]}"] > 0
    dv = np.linalg.norm(it.bodies.linear_velocity - ref.bodies.linear_velocity, axis=1).max()
    dw = np.linalg.norm(it.bodies.angular_velocity - ref.bodies.angular_velocity, axis=1).max()
    assert dv <= 1e-8 and dw <= 1e-8
    assert dv <= it.details["certified max |dv| of the final state (m/s)"] <= li.CERTIFIED_ACCEPT
    assert dw <= it.details["certified max |dw| of the final state (rad/s)"] <= li.CERTIFIED_ACCEPT
    _assert_fixed_point_and_small_residuals(it, cons, schedule)
    if method == "mprgp":
        monkeypatch.setattr(li, "ITERATIVE_TOLERANCE", 1e-2)  # stops far from the limit
    else:
        monkeypatch.setattr(body_space_ipm, "MAX_ITERATIONS", 4)
    with pytest.raises(ExactReferenceError, match="certified"):
        exact_reference(bodies, cons)


def test_body_space_path_agrees_with_clarabel_on_the_stack(monkeypatch: pytest.MonkeyPatch) -> None:
    """The stack (one column of cubes, every manifold spin-damped) through the body-space interior point: the same
    exact state as Clarabel's dual QPs, a fixed point of both passes."""

    frame = scenes.capture_frame("stack")
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, window=8)
    ref = exact_reference(bodies, cons)
    monkeypatch.setattr(phases, "DIRECT_ROWS_LIMIT", 0)
    it = exact_reference(bodies, cons)
    assert it.details["contact phase: large island solved by ipm"] == 1.0
    for a, b in ((it.contact_bodies, ref.contact_bodies), (it.bodies, ref.bodies)):
        assert np.abs(a.linear_velocity - b.linear_velocity).max() <= 1e-8
        assert np.abs(a.angular_velocity - b.angular_velocity).max() <= 1e-8
    no_friction = Impulses(it.impulses.normal, np.zeros_like(it.impulses.friction))
    assert pass_change(it.contact_bodies, no_friction, cons, schedule, CONTACT_PASS) <= FIXED_POINT_TOLERANCE
    assert pass_change(it.bodies, it.impulses, cons, schedule, FRICTION_PASS) <= FIXED_POINT_TOLERANCE


def test_body_space_time_budget_gives_no_reference(pile, monkeypatch: pytest.MonkeyPatch) -> None:
    """A large island's interior point that runs out of time gives ExactReferenceError (rendered "no exact
    reference (reason)"), not a number."""
    from models.exact import large_island as li

    bodies, cons, _, _ = pile
    monkeypatch.setattr(phases, "DIRECT_ROWS_LIMIT", 0)
    monkeypatch.setattr(li, "CONTACT_TIME_SHARE", 1e-12)
    with pytest.raises(ExactReferenceError, match="contact phase: body-space interior point hit the time budget"):
        exact_reference(bodies, cons)


def test_mprgp_solves_a_small_box_qp() -> None:
    """MPRGP against the optimality conditions of a random box QP with a singular Hessian."""
    from models.exact.mprgp import mprgp

    rng = np.random.default_rng(3)
    B = rng.standard_normal((12, 20))
    H = B.T @ B  # rank 12 of 20
    g = B.T @ rng.standard_normal(12)  # in H's range: bounded below with free rows
    lo = np.where(np.arange(20) % 3 == 0, -np.inf, -0.5)
    hi = np.where(np.arange(20) % 4 == 0, np.inf, 0.3)
    res = mprgp(lambda v: H @ v, np.diag(H).copy(), g, lo, hi, np.zeros(20), 1e-12, 100000, 30.0)
    assert res.converged and np.all(res.x >= lo) and np.all(res.x <= hi)
    grad = H @ res.x + g
    natural = res.x - np.clip(res.x - grad, lo, hi)
    assert np.abs(natural).max() < 1e-9
    assert np.sum((res.x == lo) | (res.x == hi)) > 0  # some bounds are active: the test exercises them


def test_a_solve_killed_from_outside_is_reported_and_not_recorded(pile, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """A solving process killed by a signal (the machine's OOM killer) says so, and the cache records no failure:
    it says nothing about the problem, so the next run tries again."""
    import os
    import signal

    from models.exact import reference as er
    from models.exact import cache as erc

    bodies, cons, _, _ = pile

    def killed(prob: phases.QpProblem, limit: float) -> phases.QpSolution:
        os.kill(os.getpid(), signal.SIGKILL)
        raise AssertionError("unreachable")

    with pytest.raises(er.ExactReferenceInterrupted, match="killed by signal 9"):
        er.exact_reference_bounded(bodies, cons, solver=killed)

    def interrupted(*args: object, **kw: object) -> er.ExactReference:
        raise er.ExactReferenceInterrupted("killed by signal 9 from outside")

    monkeypatch.setattr(erc, "exact_reference_bounded", interrupted)
    with pytest.raises(ExactReferenceError, match="signal 9"):
        cached_exact_reference(bodies, cons, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_contact_phase_bound_from_a_primal_point(pile) -> None:
    """The bound from a primal point (the interior point's path) holds for perturbed impulses and primal points, and
    is far tighter than the bound from u(lam) alone when the primal point is the exact one."""
    from models.exact.bound import contact_phase_bound
    from models.exact.assembly import Layout, contact_rows

    bodies, cons, _, ref = pile
    layout = Layout(bodies)
    rows, active = contact_rows(layout, cons)
    exact = layout.velocity(ref.contact_bodies)
    m = 1.0 / layout.inv_m
    rng = np.random.default_rng(7)
    key = "certified |u - u*|_M (sqrt(kg) m/s)"
    for scale in (1e-6, 1e-3):
        normal = ref.impulses.normal * (1.0 + scale * rng.uniform(-1, 1, ref.impulses.normal.shape))
        u = layout.velocity(bodies) + layout.inv_m * (rows.J.T @ normal[active])
        true = float(np.sqrt(np.sum(m * (u - exact) ** 2)))
        for primal in (exact, exact + scale * rng.standard_normal(exact.shape)):
            bound = contact_phase_bound(bodies, cons, normal, primal)[key]
            assert true <= bound, (scale, true, bound)
    tight = contact_phase_bound(bodies, cons, ref.impulses.normal, exact)[key]
    assert tight <= 1e-5 and tight < contact_phase_bound(bodies, cons, ref.impulses.normal * (1 + 1e-6))[key]


@pytest.fixture(scope="module")
def mixed_shapes():
    """A user world in Bullet 2's convention: every dynamic body a full 3x3 inverse inertia, per-manifold friction,
    spin-damped contacts whose normals are no eigenvectors of the inertia."""
    frame, _ = scenes.load_scene("docs/mixed_shapes_world.py")
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, window=8)
    return bodies, cons, schedule, exact_reference(bodies, cons)


def _friction_passes(ref, cons, schedule, passes: int):
    out = ref.contact_bodies.copy()
    imp = Impulses(ref.impulses.normal.copy(), np.zeros_like(ref.impulses.friction))
    levels = schedule_levels(schedule, cons, out.dynamic)
    for it in range(passes):
        run_pass(out, imp, cons, levels, FLOAT64, FRICTION_PASS, it, SolverParams(), schedule)
    return out


def _distance(a, b) -> float:
    return float(max(np.abs(a.linear_velocity - b.linear_velocity).max(),
                     np.abs(a.angular_velocity - b.angular_velocity).max()))


def test_full_inverse_inertia_reference_is_the_passes_limit(mixed_shapes, monkeypatch: pytest.MonkeyPatch) -> None:
    """Full 3x3 inverse inertia: the reference is a fixed point of one pass of each kind, and the friction passes
    from its contact state reach it (the damping moves w along n, so the limit is the non-symmetric box problem's
    solution, models/exact/damped_friction.py); the convex QP that damps along I^-1 n is a fixed point of
    one pass too, but not what the passes reach: the check can fail."""

    bodies, cons, schedule, ref = mixed_shapes
    assert bodies.inv_inertia.shape[1] == 6 and cons.per_manifold_friction
    assert ref.details["friction phase: non-symmetric box problem (damping off the inertia's eigenvectors) "
                       "components"] >= 1
    _assert_fixed_point_and_small_residuals(ref, cons, schedule)
    limit = cons.friction[:, 0] * ref.impulses.normal.sum(axis=1)
    assert np.all(np.abs(ref.impulses.friction) <= limit[:, None] + 1e-12)
    reached = _friction_passes(ref, cons, schedule, 4000)
    assert _distance(reached, ref.bodies) <= REACHED_TOLERANCE
    monkeypatch.setattr(phases, "EIGEN_TOLERANCE", np.inf)  # the convex QP, as if the damping moved w along I^-1 n
    qp = exact_reference(bodies, cons)
    assert pass_change(qp.bodies, qp.impulses, cons, schedule, FRICTION_PASS) <= FIXED_POINT_TOLERANCE
    assert _distance(reached, qp.bodies) > 1e-3


def test_almost_solved_qp_that_the_polish_does_not_certify_gives_no_reference(pile,
                                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """A solver that ends only "almost solved" and a polish that cannot sharpen it: no reference, with the residual."""

    bodies, cons, _, _ = pile

    def almost(prob: phases.QpProblem, limit: float) -> phases.QpSolution:
        sol = phases.clarabel_solve(prob, limit)
        return phases.QpSolution(sol.x, sol.z * 1.01 + 1e-3, sol.iterations, sol.seconds, almost=True)

    monkeypatch.setattr(phases, "POLISH_ROUNDS", 0)
    monkeypatch.setattr(phases, "PIVOT_TARGET", np.inf)  # nor does pivoting re-solve it
    with pytest.raises(ExactReferenceError, match="contact QP only almost solved and its natural residual"):
        exact_reference(bodies, cons, solver=almost)


def test_damped_friction_that_does_not_certify_gives_no_reference(mixed_shapes,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The non-symmetric box problem's methods (Gauss-Seidel, Newton, pivoting) all stopped before the natural
    residual certifies: no reference, with the spin row that made it no QP, the residual reached and each method's."""
    from models.exact import box_lcp

    bodies, cons, _, _ = mixed_shapes
    monkeypatch.setattr(box_lcp, "GS_MAX_SWEEPS", 1)
    monkeypatch.setattr(box_lcp, "NEWTON_MAX_ITERATIONS", 0)
    monkeypatch.setattr(box_lcp, "PIVOT_ROWS_LIMIT", 0)
    with pytest.raises(ExactReferenceError, match="no eigenvector.*non-symmetric box problem stopped at a natural "
                                                  "residual.*Gauss-Seidel.*Newton.*pivoted"):
        exact_reference(bodies, cons)


def test_diagonal_tables_take_the_same_path_through_3x3_blocks(pile, monkeypatch: pytest.MonkeyPatch) -> None:
    """The block (3x3) mass matrix on a diagonal scene gives the diagonal path's reference to 1e-12."""
    from models.exact import assembly as asm

    bodies, cons, _, ref = pile
    monkeypatch.setattr(asm.Layout, "_mass", lambda self, inv_mass: asm.block_mass(inv_mass, self.inertia_inv))
    blocks = exact_reference(bodies, cons)
    assert _distance(blocks.bodies, ref.bodies) <= 1e-12
    assert _distance(blocks.contact_bodies, ref.contact_bodies) <= 1e-12


def test_full_inertia_on_the_body_space_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """The body-space interior point with 3x3 blocks: the stack with its cubes' inverse inertia rotated (full 3x3)
    and no spin damping agrees with Clarabel's dual solve and is a fixed point of both passes; with the damping (its
    directions no eigenvectors of the rotated inertia) a large island is refused by name."""
    from models.setup.inertia import rotate_diagonal

    frame = scenes.capture_frame("stack")
    bodies = body_table(frame)
    dyn = bodies.dynamic
    turn = np.array([np.sin(0.2), np.sin(0.3), 0.0, 1.0])
    m = rotate_diagonal(np.tile(turn / np.linalg.norm(turn), (int(dyn.sum()), 1)),
                        bodies.inv_inertia[dyn] * [1.0, 1.5, 2.0])
    six = np.zeros((bodies.num_bodies, 6))
    six[dyn] = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], m[:, 0, 1], m[:, 0, 2], m[:, 1, 2]], axis=1)
    full = dataclasses.replace(bodies, inv_inertia=six)
    damped = setup_constraints(frame, full)
    cons = dataclasses.replace(damped, spin_damp=np.zeros_like(damped.spin_damp))
    schedule = make_schedule("hazard", cons, full.dynamic, window=8)
    ref = exact_reference(full, cons)
    monkeypatch.setattr(phases, "DIRECT_ROWS_LIMIT", 0)
    it = exact_reference(full, cons)
    assert it.details["contact phase: large island solved by ipm"] == 1.0
    assert _distance(it.bodies, ref.bodies) <= 1e-8 and _distance(it.contact_bodies, ref.contact_bodies) <= 1e-8
    no_friction = Impulses(it.impulses.normal, np.zeros_like(it.impulses.friction))
    assert pass_change(it.contact_bodies, no_friction, cons, schedule, CONTACT_PASS) <= FIXED_POINT_TOLERANCE
    assert pass_change(it.bodies, it.impulses, cons, schedule, FRICTION_PASS) <= FIXED_POINT_TOLERANCE
    assert pass_change(ref.bodies, ref.impulses, cons, schedule, FRICTION_PASS) <= FIXED_POINT_TOLERANCE
    with pytest.raises(ExactReferenceError, match="no eigenvector.*non-symmetric"):
        exact_reference(full, damped)


def _interleavedpass_change(state, imp: Impulses, cons, schedule) -> float:
    """How far one interleaved iteration (a contact pass, then a friction pass) moves the velocities."""
    params = SolverParams(interleaved=True)
    out, imp = state.copy(), imp.copy()
    levels = schedule_levels(schedule, cons, state.dynamic)
    for kind in (CONTACT_PASS, FRICTION_PASS):
        run_pass(out, imp, cons, levels, FLOAT64, kind, 0, params, schedule)
    return _distance(out, state)


def test_interleaved_reference_is_a_fixed_point_of_the_interleaved_passes() -> None:
    """The interleaved order's coupled fixed point (alternation, models/exact/interleaved.py) on a small
    pile: certified by the coupled natural residuals, and one interleaved iteration from it moves nothing; the
    sequential order's limit is no fixed point of the interleaved passes (the check can fail)."""
    frame = scenes.capture_frame("pile", nx=3, ny=2, nz=3, seed=2)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, window=8)
    ref = exact_reference(bodies, cons, SolverParams(interleaved=True))
    assert ref.details["interleaved: alternations (contact QP, then friction problem)"] > 1
    for key in ("contact phase: normal LCP |min(lam K, e)| max (m/s)", "friction phase: box residual max (m/s)",
                "friction phase: spin |n.w| max (rad/s)"):
        assert ref.residuals[key] <= RESIDUAL_TOLERANCE, (key, ref.residuals[key])
    assert _interleavedpass_change(ref.bodies, ref.impulses, cons, schedule) <= FIXED_POINT_TOLERANCE
    sequential = exact_reference(bodies, cons)
    assert _interleavedpass_change(sequential.bodies, sequential.impulses, cons, schedule) > 1e-4
    assert cache_key(bodies, cons, SolverParams(interleaved=True)) != cache_key(bodies, cons, SolverParams())


def test_interleaved_alternation_that_does_not_certify_gives_no_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """On the stack the alternation stalls (measured: coupled residual 1.4e-3 m/s after 300 alternations): no
    certified fixed point, so no reference, with the reason."""
    from models.exact import interleaved as ei

    frame = scenes.capture_frame("stack")
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    monkeypatch.setattr(ei, "MAX_ALTERNATIONS", 20)
    with pytest.raises(ExactReferenceError, match="interleaved order: the alternation stopped after 20 "
                                                  "alternations.*no certified fixed point"):
        exact_reference(bodies, cons, SolverParams(interleaved=True))
