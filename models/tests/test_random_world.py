"""Random worlds from pybullet_data (models/scenes/random_world.py): what a seed builds, that SCENE_ARGS="seed=N"
reaches it, and the exact reference on ten of them that no test was tuned to (seeds from the SEED environment
variable, printed): every one has a reference, with natural residuals at most 1e-9 m/s and one pass of each kind
moving nothing."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS, Impulses
from models.exact.assembly import ExactReferenceError
from models.exact.reference import exact_reference
from models.scenes import frame_cache, random_world
from models.order.manifold_schedule import make_schedule
from models.exact.residual import pass_change
from models.exact.box_lcp import METHODS as BOX_METHODS
from models.exact.phases import SHARPEN_KEY

WORLDS = 10
# one pass from the reference moves a velocity by at most this (m/s, rad/s): a row's residual r (m/s) moves its
# bodies' w by up to |I^-1 c| / (c.I^-1 c) r >= r / |c| (c the lever arm), 100 r for the centimetre arms of these
# small bodies (measured: 2.2e-9 rad/s from a residual of 1.8e-10 m/s)
MOVE_TOLERANCE = 1e-8
RESIDUALS = ("contact phase: normal LCP |min(lam K, e)| max (m/s)", "friction phase: box residual max (m/s)",
             "friction phase: spin |n.w| max (rad/s)")


def test_a_seed_plans_its_world() -> None:
    """The same seed plans the same world; bodies between 50 and 500 unless given; both up axes and both grounds
    over a few seeds; every group kind appears."""
    plans = [random_world.plan(s) for s in range(12)]
    assert plans[3] == random_world.plan(3)
    assert all(50 <= p.bodies - 1 <= 500 for p in plans)
    assert {p.up for p in plans} == {"y", "z"} and {p.ground for p in plans} == {"plane", "box"}
    assert {k for p in plans for k, _ in p.groups} == set(random_world.GROUP_KINDS)
    assert random_world.plan(3, bodies=77).bodies == 78
    assert random_world.parse_seeds("0-2,7") == [0, 1, 2, 7]
    with pytest.raises(ValueError, match="seeds must be"):
        random_world.parse_seeds("x")


def test_scene_args_seed_reaches_the_world(monkeypatch: pytest.MonkeyPatch) -> None:
    """SCENE_ARGS="seed=N" gives a world file its own seed parameter (the capture functions take a seed of their
    own: before, the two collided)."""
    seen: dict = {}
    monkeypatch.setattr(frame_cache, "load_or_capture", lambda scene, **kw: seen.update(kw, scene=scene))
    _, label = scenes.load_scene("random_world", "seed=7 bodies=60", seed=1)
    assert seen["world_seed"] == "7" and seen["bodies"] == "60" and seen["seed"] == 1
    assert label == "random_world-seed7-bodies60"
    scenes.load_scene("duck_lego_pile", "seed=3")
    assert seen["world_seed"] == "3"
    seen.clear()
    scenes.load_scene("pile", "nx=2")  # a built-in scene's seed stays the capture's
    assert "world_seed" not in seen and seen["nx"] == "2"


def test_a_world_is_built_as_planned_in_either_up_axis() -> None:
    """A z-up and a y-up world: the bodies planned, the world's gravity along its up axis, bodies resting on the
    ground and on each other at the capture step."""
    ups = {random_world.plan(s).up: s for s in range(10)}
    for up, seed in ups.items():
        frame = scenes.capture_frame("random_world", world_seed=seed, bodies=50)
        assert frame.num_bodies == 51 and frame.num_manifolds >= 20
        g = np.asarray(frame.gravity)
        assert np.allclose(g, [0, 0, -9.8] if up == "z" else [0, -9.8, 0]), (up, g)
        assert body_table(frame).inv_inertia.shape[1] == 6  # turned non-cube bodies: Bullet 2's full 3x3 inverse inertia


def _seeds() -> list[int]:
    # a world's seed is a 31-bit integer (pybullet's); CI's seeds (from the commit) reach 2^28, ten times that does not
    base = int(os.environ.get("SEED", "1")) % ((2**31 - 1) // WORLDS)
    return list(range(WORLDS * base, WORLDS * base + WORLDS))


def _certified(seed: int, cache: Path) -> tuple[bool, dict[str, float]]:
    """Seed ``seed``'s world (50 to 150 bodies): whether its exact reference certifies (natural residuals at most
    1e-9 m/s, one contact pass and one friction pass moving no velocity by more than MOVE_TOLERANCE), and the
    reference's details (empty without one); prints what it found."""
    frame = scenes.load_or_capture("random_world", cache_dir=cache, world_seed=seed, bodies=50 + (seed * 7919) % 101)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    try:
        ref = exact_reference(bodies, cons)
    except ExactReferenceError as exc:
        print(f"random world seed {seed}: no exact reference ({exc})")
        return False, {}
    schedule = make_schedule("hazard", cons, bodies.dynamic, window=8)
    worst = max(ref.residuals[k] for k in RESIDUALS)
    no_friction = Impulses(ref.impulses.normal, np.zeros_like(ref.impulses.friction))
    moved = max(pass_change(ref.contact_bodies, no_friction, cons, schedule, CONTACT_PASS),
                pass_change(ref.bodies, ref.impulses, cons, schedule, FRICTION_PASS))
    print(f"random world seed {seed}: {frame.num_bodies} bodies, {frame.num_manifolds} manifolds, residual "
          f"{worst:.1e}, one pass moves {moved:.1e}, {ref.solver}")
    return worst <= 1e-9 and moved <= MOVE_TOLERANCE, ref.details


def test_exact_reference_on_random_worlds(tmp_path: Path) -> None:
    """Ten random worlds of 50 to 150 bodies (seeds 10 SEED .. 10 SEED + 9): each has an exact reference that
    certifies (``_certified``). Any that does not fails the test, naming the seed."""
    failures = [seed for seed in _seeds() if not _certified(seed, tmp_path)[0]]
    assert not failures, (f"random worlds without a certified exact reference: seeds {failures} (one of them again: "
                          f"SEED={failures[0] // WORLDS} .venv/bin/python -m pytest "
                          "models/tests/test_random_world.py -k random_worlds)" if failures else "")


@pytest.mark.parametrize("seed", [114854854, 548183768])
def test_a_near_singular_contact_component_is_certified(seed: int, tmp_path: Path) -> None:
    """Two worlds that CI's seeds drew, each with a contact component of near-null modes where Gauss-Seidel stops
    short (models/exact/box_lcp.py). Seed 114854854: 418 rows of rank 176, eigenvalues 2.6e-7 and 1.7e-6 beside
    1.9e3; seed 548183768: 502 rows of rank 195. Which later method certifies such a component depends on the
    machine's rounding: where they were found, Newton and pivoting stopped short too (6.0e-10 and 2.8e-8 m/s) and the
    proximal point and MPRGP certified them; on a 2026-12-07 machine Newton (and for the second, pivoting) did. The
    world certifies, and some method after Gauss-Seidel was needed (the last resorts themselves:
    models/tests/test_box_lcp.py, with the methods before them made to stop short)."""
    ok, details = _certified(seed, tmp_path)
    assert ok
    assert sum(details[f"{SHARPEN_KEY} by {name}"] for name in BOX_METHODS[1:]) >= 1
