"""Scenes built in pybullet and the frames captured from them (small sizes only; never the full thesis scene)."""

from __future__ import annotations

import itertools
from dataclasses import fields
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from models.formats import frame as frame_mod
from models import scenes
from models.scenes import frame_cache
from models.formats.frame import Frame, load, save, validate

SMALL: dict[str, dict] = {
    "thesis": dict(nx=3, ny=3, nz=3),
    "pile": dict(nx=3, ny=3, nz=3, step=15),
    "stack": dict(n=4),
    "pyramid": dict(n=3),
    "incline": dict(),
    "mass_ratio": dict(),
    "impact": dict(base=2, height=1),
    "spin": dict(),
    "plank": dict(n=2),
    "degenerate": dict(),
}
ARRAYS = [f.name for f in fields(Frame) if f.name != "meta"]


def _same(a: Frame, b: Frame) -> bool:
    return all(getattr(a, k).dtype == getattr(b, k).dtype and getattr(a, k).tobytes() == getattr(b, k).tobytes()
               for k in ARRAYS)


@pytest.fixture(scope="module")
def frames() -> dict[str, Frame]:
    return {name: scenes.capture_frame(name, **kw) for name, kw in SMALL.items()}


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("frames")


def test_every_scene_has_a_small_case() -> None:
    assert set(SMALL) == set(scenes.SCENES) == set(scenes.DEFAULT_CAPTURE_STEP)


@pytest.mark.parametrize("name", list(SMALL))
def test_builder_frame_is_valid(frames: dict[str, Frame], name: str) -> None:
    f = frames[name]
    validate(f)
    assert f.num_manifolds > 0, f.summary()
    assert f.inv_mass[0] == 0.0 and np.all(f.inertia_local[0] == 0.0)
    assert np.all(f.half_extents[0] >= 50.0)  # the ground box is body 0
    dyn = f.inv_mass > 0
    assert np.all(f.inertia_local[dyn] > 0)
    assert np.all(f.body_a < f.body_b)
    key = f.body_a.astype(np.int64) * f.num_bodies + f.body_b
    assert np.all(np.diff(key) > 0), "manifolds sorted by (body_a, body_b), one per pair"
    valid = np.arange(4)[None, :] < f.num_points[:, None]
    # normal_on_b points from B to A: distance = (point_on_a - point_on_b) . normal_on_b (Bullet's refresh rule;
    # a persistent point may also drift tangentially), and the centres lie on their own sides
    along = np.einsum("mpi,mpi->mp", f.point_on_a - f.point_on_b, f.normal_on_b)
    assert np.abs(along - f.distance)[valid].max() < 1e-12
    n = f.normal_on_b[valid]
    ab = (f.position[f.body_a] - f.position[f.body_b])[:, None, :].repeat(4, axis=1)[valid]
    assert np.all(np.einsum("ij,ij->i", n, ab) > 0)
    assert np.all(f.distance[valid] < 0.03)
    assert np.all(f.normal_force[valid] >= 0)
    meta = f.meta
    assert meta["scene"] == name and meta["step"] >= 1 and meta["dt"] == pytest.approx(1 / 60)
    assert meta["gravity"] == [0.0, -9.8, 0.0]
    assert meta["pybullet_version"] == "3.2.7" and meta["pybullet_api_version"] > 0
    assert meta["solver"]["warmStartingFactor"] == 0 and meta["solver"]["deterministicOverlappingPairs"] == 1
    assert np.allclose(f.friction * f.friction, 0.7)


def test_thesis_geometry() -> None:
    spec = scenes.make_spec("thesis", nx=2, ny=3, nz=2)
    assert len(spec.bodies) == 1 + 12
    ground = spec.bodies[0]
    assert ground.mass == 0 and ground.half_extents == (400.0, 400.0, 400.0) and ground.position == (0.0, -400.0, 0.0)
    cubes = iter(spec.bodies[1:])
    for i, j, k in itertools.product(range(2), range(3), range(2)):
        b = next(cubes)
        off = float((j + 1) & 1)
        assert b.position == pytest.approx((off + 2.2 * i, 1 + 2.0 * j, off + 2.2 * k))
        assert b.half_extents == (1.0, 1.0, 1.0) and b.mass == 1.0 and b.orientation == (0, 0, 0, 1)


def test_thesis_initial_manifold_count(frames: dict[str, Frame]) -> None:
    # expected count: (Y-1)(2X-1)(2Z-1) + X Z manifolds while the layers still touch
    x = y = z = 3
    assert frames["thesis"].num_manifolds == (y - 1) * (2 * x - 1) * (2 * z - 1) + x * z
    assert np.all(frames["thesis"].num_points == 4)


def test_per_body_query_matches_global_query() -> None:
    """The kept side of the per-body query is the manifold's own orientation (what the global query reports)."""
    with scenes.build_world("pile", nx=3, ny=3, nz=3) as w:
        for _ in range(20):
            w.step()
        mf = w.manifolds()
        glob = p.getContactPoints(physicsClientId=w.client)
        idx = {int(b): i for i, b in enumerate(w.body_ids)}
        groups = [(k, list(g)) for k, g in itertools.groupby(glob, key=lambda pt: (idx[pt[1]], idx[pt[2]]))]
        groups.sort(key=lambda g: g[0])
        assert len(groups) == len(mf) > 0
        for m, ((a, b), pts) in enumerate(groups):
            assert (a, b) == (mf.body_a[m], mf.body_b[m]) and len(pts) == mf.num_points[m]
            for q, pt in enumerate(pts):
                assert tuple(mf.normal_on_b[m, q]) == pt[7] and tuple(mf.point_on_a[m, q]) == pt[5]
                assert mf.distance[m, q] == pt[8] and mf.normal_force[m, q] == pt[9]
        # from the other side pybullet swaps A/B and negates the normal
        a, b = int(mf.body_a[-1]), int(mf.body_b[-1])
        other = p.getContactPoints(bodyA=int(w.body_ids[b]), bodyB=int(w.body_ids[a]), physicsClientId=w.client)
        assert idx[other[0][1]] == b
        assert np.array_equal(-np.asarray(other[0][7]), mf.normal_on_b[-1, 0] * 1.0)
        assert tuple(mf.point_on_b[-1, 0]) == other[0][5]


def test_world_closes_and_closed_loop_hooks() -> None:
    with scenes.build_world("stack", n=2) as w:
        client = w.client
        mf = w.detect_collisions()
        assert [(int(a), int(b)) for a, b in zip(mf.body_a, mf.body_b)] == [(0, 1), (1, 2)]
        st = w.body_state()
        assert set(st) >= {"position", "orientation", "linear_velocity", "angular_velocity", "inv_mass",
                           "inertia_local", "half_extents", "shape_index", "friction"}
        pos = st["position"].copy()
        pos[2, 1] += 1.0  # lift the top cube
        w.set_body_state(pos, st["orientation"], st["linear_velocity"], st["angular_velocity"])
        assert np.allclose(w.body_state()["position"], pos)
        mf = w.detect_collisions()
        assert [(int(a), int(b)) for a, b in zip(mf.body_a, mf.body_b)] == [(0, 1)]
        with pytest.raises(ValueError):
            w.set_body_state(pos[:2], st["orientation"], st["linear_velocity"], st["angular_velocity"])
    assert not p.isConnected(physicsClientId=client)


def test_save_load_round_trip(frames: dict[str, Frame], tmp_path: Path) -> None:
    for name, f in frames.items():
        path = save(f, tmp_path / f"{name}.npz")
        g = load(path)
        assert _same(f, g)
        meta = dict(g.meta)
        assert meta.pop("frame_version") == frame_mod.FRAME_VERSION
        assert meta == {k: v for k, v in f.meta.items() if k != "frame_version"}


def test_determinism() -> None:
    a = scenes.capture_frame("pile", nx=3, ny=3, nz=3, step=25, seed=7)
    b = scenes.capture_frame("pile", nx=3, ny=3, nz=3, step=25, seed=7)
    # everything but pybullet's own wall-clock timings of the step is reproducible
    timeless = lambda f: {k: v for k, v in f.meta.items() if k != "pybullet_timing_s"}  # noqa: E731
    assert _same(a, b) and timeless(a) == timeless(b)
    assert set(a.meta["pybullet_timing_s"]) >= {"internalSingleStepSimulation", "solveGroup"}
    c = scenes.capture_frame("pile", nx=3, ny=3, nz=3, step=25, seed=8)
    assert not np.array_equal(a.position, c.position)


def test_busiest_within() -> None:
    f = scenes.capture_frame("pile", nx=3, ny=3, nz=3, busiest_within=25)
    counts = []
    with scenes.build_world("pile", nx=3, ny=3, nz=3) as w:
        for _ in range(25):
            w.step()
            counts.append(len(w.manifolds()))
    assert f.num_manifolds == max(counts)
    assert f.meta["step"] == 1 + counts.index(max(counts)) and f.meta["busiest_within"] == 25
    g = scenes.capture_frame("pile", nx=3, ny=3, nz=3, step=f.meta["step"])
    assert all(np.array_equal(getattr(f, k), getattr(g, k)) for k in ARRAYS)


def test_cache(cache_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    a = scenes.load_or_capture("stack", n=3, cache_dir=cache_dir)
    files = sorted(cache_dir.glob("stack_*.npz"))
    assert len(files) == 1

    def boom(*args: object, **kw: object) -> Frame:
        raise AssertionError("cache miss")

    monkeypatch.setattr(frame_cache, "capture_frame", boom)  # the cache's capture
    b = scenes.load_or_capture("stack", n=3, cache_dir=cache_dir)
    assert _same(a, b) and a.meta == b.meta
    assert sorted(cache_dir.glob("stack_*.npz")) == files
    # explicit defaults hit the same entry; other parameters do not
    assert scenes.cache_key("stack", None, None, 0, 10, 1 / 60, dict(n=3)) == \
        scenes.cache_key("stack", 10, None, 0, 10, 1 / 60, dict(n=3, half_extent=0.5))
    keys = {scenes.cache_key("stack", None, None, seed, 10, 1 / 60, dict(n=n)) for seed in (0, 1) for n in (3, 4)}
    assert len(keys) == 4
    with pytest.raises(AssertionError, match="cache miss"):
        scenes.load_or_capture("stack", n=4, cache_dir=cache_dir)


@pytest.mark.parametrize("call", [
    lambda: scenes.build_world("nope"),
    lambda: scenes.build_world("pile", nx=0),
    lambda: scenes.build_world("pile", nx=2.5),
    lambda: scenes.build_world("pile", jitter=0.2),
    lambda: scenes.build_world("stack", friction=-1),
    lambda: scenes.build_world("stack", height=3),
    lambda: scenes.build_world("stack", pybullet_iterations=0),
    lambda: scenes.build_world("stack", seed=-1),
    lambda: scenes.build_world("incline", angle_deg=95),
    lambda: scenes.build_world("incline", box_half_extents=(1, 2)),
    lambda: scenes.build_world("mass_ratio", ratio=0),
    lambda: scenes.build_world("impact", speed=float("nan")),
    lambda: scenes.build_world("thesis", half_extent=0.5),
    lambda: scenes.capture_frame("stack", step=3, busiest_within=4),
    lambda: scenes.capture_frame("stack", step=0),
    lambda: scenes.load_or_capture("stack", n=-2, cache_dir="/nonexistent/never"),
])
def test_bad_parameters_raise_value_error(call) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError) as info:
        call()
    assert "\n" not in str(info.value)


def test_kernel_scene_lists() -> None:
    """The shared scene lists name catalogue scenes with valid parameters; the regression's seeded pile at the
    kernel tests' seed is their pile, and its other scenes do not follow the seed."""
    from models.scenes import kernel_scenes as ks

    for params in [*ks.KERNEL_TEST_SCENES.items(), *ks.REGRESS_SCENES.items(), ("pile", ks.MAKE_SIM_PILE)]:
        scenes.make_spec(params[0], **params[1])
    assert list(ks.REGRESS_SCENES)[:len(ks.KERNEL_TEST_SCENES)] == list(ks.KERNEL_TEST_SCENES)
    assert ks.regress_params("pile", 2) == ks.KERNEL_TEST_SCENES["pile"]
    assert ks.regress_params("pile", 5)["seed"] == 5 and ks.regress_params("stack", 5) == {}
