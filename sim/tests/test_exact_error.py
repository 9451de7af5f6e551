"""The report's contact-phase certificate is the one the exact reference was accepted with, named."""

from __future__ import annotations

import pytest

from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.exact import phases
from models.exact.reference import exact_reference
from sim.compare.exact_error import PRIMAL_POINT_KEY, contact_certificate


def test_the_certificate_line_is_the_one_used(monkeypatch: pytest.MonkeyPatch) -> None:
    """On the large-island path (forced on a small pile) the report states the primal-point bound the reference was
    accepted with, in m/s and rad/s, not the impulse-only one; on Clarabel's path, the impulse-only bound, named."""

    frame = scenes.capture_frame("pile", nx=3, ny=2, nz=3, seed=2)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    direct = exact_reference(bodies, cons)
    plain = contact_certificate(bodies, cons, direct.impulses.normal, direct.details)
    assert plain["certificate"].startswith("impulse-only bound")
    assert plain["certified max |dv| (m/s)"] >= 0 and "certified max |dw| (rad/s)" in plain
    monkeypatch.setattr(phases, "DIRECT_ROWS_LIMIT", 0)
    large = exact_reference(bodies, cons)
    used = contact_certificate(bodies, cons, large.impulses.normal, large.details)
    assert used["certificate"].startswith("primal-point bound")
    assert used["certified |u - u*|_M (sqrt(kg) m/s)"] == large.details[PRIMAL_POINT_KEY]
    assert used["certified |u - u*|_M (sqrt(kg) m/s)"] <= used["impulse-only bound from u(lam), not used (sqrt(kg) m/s)"]
    assert used["certified max |dv| (m/s)"] <= large.details["certified max |dv| of the final state (m/s)"]


def test_the_interleaved_reference_claims_no_distance_certificate() -> None:
    """The interleaved order's reference is certified by its coupled residuals only: the report says so instead of
    a sequential contact-phase bound that does not apply to it."""
    from models.golden.contact_solver import SolverParams

    frame = scenes.capture_frame("spin")
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    ref = exact_reference(bodies, cons, SolverParams(interleaved=True))
    got = contact_certificate(bodies, cons, ref.impulses.normal, ref.details)
    assert got["certificate"].startswith("none: the interleaved order") and len(got) == 1
