"""Worlds from files (models/scenes/user_world.py), SCENE_ARGS, the contact capture's cover and forked readers,
and the world bad-input catalogue (models/kernel/bad_input.py); small worlds only."""

from __future__ import annotations

import math
import textwrap
from dataclasses import fields
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from models import scenes
from models.scenes.bad_worlds import WORLD_CASES, WORLD_CATALOGUE
from models.formats.frame import Frame, validate
from models.scenes import contact_capture, frame_cache, world as world_mod
from models.scenes.scene_args import split_scene_args

ARRAYS = [f.name for f in fields(Frame) if f.name != "meta"]

# spheres, a capsule, a cylinder, a turned non-cube box, a convex mesh; masses 0.5..3, frictions 0.3..0.9
SHAPES_WORLD = '''
CAPTURE_STEP = 10

def build(pb, data_path, friction=0.6, box_mass=2.0):
    h = 50.0
    ground = pb.createMultiBody(0.0, pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[h, h, h]), basePosition=[0, -h, 0])
    pb.changeDynamics(ground, -1, lateralFriction=1.0)
    sphere = pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.2)
    capsule = pb.createCollisionShape(pb.GEOM_CAPSULE, radius=0.1, height=0.4)
    cylinder = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=0.15, height=0.3)
    box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.4, 0.1, 0.25])
    mesh = pb.createCollisionShape(pb.GEOM_MESH, fileName="duck_vhacd.obj", meshScale=[0.05, 0.05, 0.05])
    up = pb.getQuaternionFromEuler([-1.5707963, 0, 0])
    bodies = [
        (1.0, sphere, [0.0, 0.199, 0.0], [0, 0, 0, 1], 0.3),
        (0.5, sphere, [0.0, 0.598, 0.0], [0, 0, 0, 1], 0.9),
        (1.5, capsule, [1.0, 0.099, 0.0], pb.getQuaternionFromEuler([1.5707963, 0, 0.3]), friction),
        (3.0, cylinder, [2.0, 0.149, 0.0], up, friction),
        (box_mass, box, [3.0, 0.099, 0.0], pb.getQuaternionFromEuler([0, 0.7, 0]), 0.5),
        (1.0, mesh, [4.0, 0.06, 0.0], up, 0.8),
    ]
    for mass, shape, pos, orn, mu in bodies:
        uid = pb.createMultiBody(mass, shape, basePosition=pos, baseOrientation=orn)
        pb.changeDynamics(uid, -1, lateralFriction=mu, restitution=0.0,
                          activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
'''
BOX_URDF = '''<?xml version="1.0"?>
<robot name="brick"><link name="base">
  <inertial><origin rpy="0 0 0.5" xyz="0 0 0"/><mass value="2"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  <collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision>
</link></robot>
'''

FIXED_URDF = '''<?xml version="1.0"?>
<robot name="pair">
  <link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>
  <joint name="weld" type="fixed"><parent link="a"/><child link="b"/><origin xyz="0.2 0 0"/></joint>
</robot>
'''


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture()
def shapes_world(tmp_path: Path) -> Path:
    return _write(tmp_path, "shapes.py", SHAPES_WORLD)


def _same(a: object, b: object, names: list[str]) -> bool:
    return all(getattr(a, k).dtype == getattr(b, k).dtype and getattr(a, k).tobytes() == getattr(b, k).tobytes()
               for k in names)


def test_world_file_frame(shapes_world: Path, tmp_path: Path) -> None:
    f = scenes.load_or_capture(str(shapes_world), cache_dir=tmp_path / "frames")
    validate(f)
    assert f.meta["scene"] == "shapes" and f.meta["step"] == 10 and f.meta["params"] == {}
    assert f.num_bodies == 7 and f.num_manifolds >= 6
    assert f.inv_mass[0] == 0 and np.allclose(1 / f.inv_mass[1:], [1.0, 0.5, 1.5, 3.0, 2.0, 1.0])
    assert np.allclose(f.friction, [1.0, 0.3, 0.9, 0.6, 0.6, 0.5, 0.8])  # per body, as given to pybullet
    assert set(f.body_a.tolist()) | set(f.body_b.tolist()) == set(range(7))  # every body touches something
    # the box's inertia in its own frame (pybullet's), its half extents measured in that frame
    assert np.allclose(f.inertia_local[5], 2.0 / 3.0 * np.array([0.1**2 + 0.25**2, 0.4**2 + 0.25**2, 0.4**2 + 0.1**2]))
    assert np.allclose(f.half_extents[5], [0.4, 0.1, 0.25], atol=1e-9)
    assert np.allclose(f.half_extents[1], 0.2, atol=1e-9)
    assert f.shape_index[1] != f.shape_index[2] and len(set(f.shape_index.tolist())) == 7
    assert np.all(f.num_points <= 4) and np.all(f.inertia_local[1:] > 0)


def test_world_file_names_its_convention(shapes_world: Path, tmp_path: Path) -> None:
    """``BULLET_CONVENTION`` puts the world's convention into its frames' metadata (none: Bullet 2's, the default
    of world files); an unknown one is refused before anything is written."""
    named = _write(tmp_path, "shapes_axes.py", 'BULLET_CONVENTION = "world_axes"\n' + SHAPES_WORLD)
    f = scenes.load_or_capture(str(named), cache_dir=tmp_path / "frames")
    assert f.meta["bullet_convention"] == "world_axes"
    default = scenes.load_or_capture(str(shapes_world), cache_dir=tmp_path / "frames")
    assert default.meta["bullet_convention"] == "bullet2"
    bad = _write(tmp_path, "shapes_bad.py", 'BULLET_CONVENTION = "bullet4"\n' + SHAPES_WORLD)
    with pytest.raises(scenes.SceneError, match="BULLET_CONVENTION 'bullet4' is not one of bullet2, bullet_gpu"):
        scenes.load_or_capture(str(bad), cache_dir=tmp_path / "bad_frames")
    assert not (tmp_path / "bad_frames").exists()


def test_world_cache_follows_content(shapes_world: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache = tmp_path / "frames"
    a = scenes.load_or_capture(str(shapes_world), cache_dir=cache)
    files = sorted(cache.glob("shapes_*.npz"))
    assert len(files) == 1

    def boom(*args: object, **kw: object) -> Frame:
        raise AssertionError("cache miss")

    monkeypatch.setattr(frame_cache, "capture_in", boom)
    b = scenes.load_or_capture(str(shapes_world), cache_dir=cache)
    assert _same(a, b, ARRAYS)
    with pytest.raises(AssertionError, match="cache miss"):  # another parameter
        scenes.load_or_capture(str(shapes_world), cache_dir=cache, box_mass="2.5")
    shapes_world.write_text(shapes_world.read_text() + "\n# edited\n")
    with pytest.raises(AssertionError, match="cache miss"):  # the world file's content
        scenes.load_or_capture(str(shapes_world), cache_dir=cache)


def test_urdf_content_and_its_mesh_in_the_key(tmp_path: Path) -> None:
    obj = tmp_path / "part.obj"
    obj.write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    urdf = _write(tmp_path, "part.urdf", BOX_URDF.replace('<box size="0.4 0.2 0.1"/>', '<mesh filename="part.obj"/>'))
    world = _write(tmp_path, "w.py", f"def build(pb, data_path):\n    pb.loadURDF({str(urdf)!r})\n")
    src = scenes.user_world.world_source(str(world))
    with scenes.build_world(str(world)) as w:
        first = w.source.content_digest()
        assert len(w.source._content_files()) == 2  # the URDF and the mesh it names
    obj.write_text(obj.read_text() + "v 0 0 0.2\n")
    with scenes.build_world(str(world)) as w:
        assert w.source.content_digest() != first
    assert src.params == {}


def test_urdf_drop_and_inertial_frame(tmp_path: Path) -> None:
    urdf = _write(tmp_path, "brick.urdf", BOX_URDF)
    f = scenes.capture_frame(str(urdf), count=2)
    assert f.meta["scene"] == "brick" and f.meta["step"] == 30
    assert f.num_bodies == 3 and f.inv_mass[0] == 0 and np.allclose(f.inv_mass[1:], 0.5)
    assert {(int(a), int(b)) for a, b in zip(f.body_a, f.body_b)} == {(0, 1), (0, 2)}
    # frame.orientation is the principal (inertial) frame: the URDF's inertial rpy (0.5 about the link's z, which the
    # drop turns to the world's y) composed with the turn; the two bricks rest flat, so it is still there
    from models.scenes.world_parts import Z_UP_TO_Y_UP, quat_mul
    expected = quat_mul(Z_UP_TO_Y_UP, (0.0, 0.0, math.sin(0.25), math.cos(0.25)))
    for q in f.orientation[1:]:
        assert abs(abs(float(np.dot(q, expected))) - 1.0) < 1e-4


def test_scene_args_typed() -> None:
    params = split_scene_args("nx=3 ny=2 nz=3 friction=0.4 stagger=false")
    spec = scenes.make_spec("pile", 0, **params)
    assert spec.params["nx"] == 3 and spec.params["friction"] == 0.4 and spec.params["stagger"] is False
    assert scenes.make_spec("incline", 0, **split_scene_args("box_half_extents=0.4,0.2,0.3")).params[
        "box_half_extents"] == [0.4, 0.2, 0.3]
    key = scenes.cache_key("thesis", None, None, 0, 10, 1 / 60, split_scene_args("nx=36 ny=30"))
    assert key == scenes.cache_key("thesis", None, None, 0, 10, 1 / 60, {})  # typed values: the same key
    for text, phrase in (("nope=1", "unknown parameter 'nope'"), ("nx=2.5", "must be an integer"),
                         ("stagger=maybe", "must be a bool"), ("nx", "not key=value"), ("nx=1 nx=2", "twice")):
        with pytest.raises(scenes.SceneError, match=phrase):
            scenes.make_spec("pile", 0, **split_scene_args(text))


def test_asset_scenes(tmp_path: Path) -> None:
    jenga = scenes.capture_frame("jenga_tower", levels=2)
    assert jenga.num_bodies == 7 and sorted(set(jenga.friction.round(6).tolist())) == [0.5, 1.0]
    assert np.allclose(jenga.half_extents[1:], [0.075, 0.015, 0.025], atol=2e-3) or \
        np.allclose(np.sort(jenga.half_extents[1:], axis=1), [0.015, 0.025, 0.075], atol=2e-3)
    pile = scenes.capture_frame("duck_lego_pile", nx=2, nz=1, layers=1, step=30)
    assert pile.num_bodies == 3 and pile.num_manifolds >= 2
    assert set(scenes.ASSET_SCENES) == {"duck_lego_pile", "jenga_tower", "random_world"}


@pytest.mark.parametrize("scene, params", [("thesis", dict(nx=3, ny=4, nz=3)), ("pile", dict(nx=3, ny=2, nz=3)),
                                           ("shapes", {})])
def test_cover_and_forked_readers_match_every_body(scene: str, params: dict, shapes_world: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    name = str(shapes_world) if scene == "shapes" else scene
    with scenes.build_world(name, **params) as w:
        for _ in range(3 if scene != "pile" else 12):
            w.step()
        full = w.manifolds(full=True)
        plan = contact_capture.query_plan(w.client, w.bodies, w.dynamic, w._plan_margin())
        assert len(plan) < w.num_bodies
        in_plan = np.isin(w.bodies.ids, w.bodies.ids[plan])
        groups, _ = contact_capture._read_rows(w.client, w.bodies, in_plan, w.bodies.ids[plan])
        if scene == "thesis":  # the cover is the ground and every other layer: the layers below are read turned back
            assert groups[:, 3].any()
        assert _same(full, w.manifolds(), list(full.__dataclass_fields__))
        monkeypatch.setattr(contact_capture, "PARALLEL_MIN_QUERIES", 1)
        w.workers = 3  # forked readers; consuming ones in the box scenes
        assert _same(full, w.manifolds(), list(full.__dataclass_fields__))
        if scene != "shapes":  # boxes: one manifold per pair, so a consuming reader is exact
            consumed = contact_capture.read_manifolds(w.client, w.bodies, plan, 1, consume=True)
            assert _same(full, consumed, list(full.__dataclass_fields__))
        assert _same(full, w.manifolds(full=True), list(full.__dataclass_fields__))  # the world itself untouched


def test_runs_longer_than_four_points_are_split() -> None:
    # pair (0, 2): a run of 6 points, then a run of 2; pair (0, 1): 3 points
    g = np.array([[0, 2, 6, 0], [0, 1, 3, 0], [0, 2, 2, 0]])
    data = np.arange(11 * 19, dtype=np.float64).reshape(11, 19)
    m = contact_capture._assemble(g, data)
    assert m.body_a.tolist() == [0, 0, 0, 0] and m.body_b.tolist() == [1, 2, 2, 2]
    assert m.num_points.tolist() == [3, 4, 2, 2]
    assert m.distance[1].tolist() == data[0:4, 9].tolist() and m.distance[2, :2].tolist() == data[4:6, 9].tolist()
    assert m.distance[3, :2].tolist() == data[9:11, 9].tolist() and m.distance[0, :3].tolist() == data[6:9, 9].tolist()


# -- the world bad-input catalogue: one maker per case, each a SceneError with its phrase and nothing written
_SPHERE = "pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.1)"
_GROUND = ("    g = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[5, 5, 5])\n"
           "    pb.createMultiBody(0, g, basePosition=[0, -5, 0])\n")


def _world(body: str, head: str = "") -> Callable[[Path], tuple[str, dict]]:
    def make(folder: Path) -> tuple[str, dict]:
        text = head + "def build(pb, data_path):\n" + _GROUND + textwrap.indent(textwrap.dedent(body), "    ")
        return str(_write(folder, "bad.py", text)), {}
    return make


def _bad_mesh(folder: Path) -> tuple[str, dict]:
    urdf = _write(folder, "bad.urdf", BOX_URDF.replace('<box size="0.4 0.2 0.1"/>', '<mesh filename="none.obj"/>'))
    return str(urdf), {}


BAD_WORLDS: dict[str, Callable[[Path], tuple[str, dict]]] = {
    "missing_file": lambda folder: (str(folder / "absent.py"), {}),
    "no_function": lambda folder: (str(_write(folder, "bad.py", "def make(pb, data_path):\n    pass\n")), {}),
    "import_error": lambda folder: (str(_write(folder, "bad.py", "raise RuntimeError('broken')\n")), {}),
    "unknown_parameter": lambda folder: (_world(f"pb.createMultiBody(1, {_SPHERE}, basePosition=[0, 0.1, 0])\n")(folder)[0],
                                         {"colour": "red"}),
    "jointed_body": _world(f"""
        s = {_SPHERE}
        pb.createMultiBody(1, s, basePosition=[0, 0.1, 0], linkMasses=[1], linkCollisionShapeIndices=[s],
            linkVisualShapeIndices=[-1], linkPositions=[[0, 0.3, 0]], linkOrientations=[[0, 0, 0, 1]],
            linkInertialFramePositions=[[0, 0, 0]], linkInertialFrameOrientations=[[0, 0, 0, 1]],
            linkParentIndices=[0], linkJointTypes=[pb.JOINT_REVOLUTE], linkJointAxis=[[0, 0, 1]])
        """),
    "fixed_links": lambda folder: (_write(folder, "pair.urdf", FIXED_URDF) and
                                   _world("pb.loadURDF('pair.urdf', [0, 0.1, 0])\n")(folder)),
    "negative_mass": _world(f"pb.createMultiBody(-1, {_SPHERE}, basePosition=[0, 0.1, 0])\n"),
    "moving_static": _world(f"""
        b = pb.createMultiBody(0, {_SPHERE}, basePosition=[0, 0.1, 0])
        pb.resetBaseVelocity(b, [1, 0, 0])
        """),
    "zero_inertia": _world(f"""
        b = pb.createMultiBody(1, {_SPHERE}, basePosition=[0, 0.1, 0])
        pb.changeDynamics(b, -1, mass=1.0, localInertiaDiagonal=[0, 0, 0])
        """),
    "nan_pose": _world(f"pb.createMultiBody(1, {_SPHERE}, basePosition=[float('nan'), 0.1, 0])\n"),
    "bad_mesh": _bad_mesh,
    "no_collision_shape": _world("pb.createMultiBody(1, -1, basePosition=[0, 0.1, 0])\n"),
    "nan_mesh": _world("pb.loadURDF('random_urdfs/168/168.urdf', [0, 0.1, 0])\n"),
    "no_dynamic_body": _world(f"pb.createMultiBody(0, {_SPHERE}, basePosition=[0, 0.1, 0])\n"),
    "no_contact": _world(f"pb.createMultiBody(1, {_SPHERE}, basePosition=[0, 3, 0])\n", head="CAPTURE_STEP = 1\n"),
}


def test_every_world_case_is_made() -> None:
    assert set(BAD_WORLDS) == set(WORLD_CASES) and len(WORLD_CASES) == len(WORLD_CATALOGUE)


@pytest.mark.parametrize("case", [c.name for c in WORLD_CATALOGUE])
def test_bad_world_is_a_clear_error_with_nothing_written(case: str, tmp_path: Path) -> None:
    scene, params = BAD_WORLDS[case](tmp_path)
    cache = tmp_path / "frames"
    with pytest.raises(scenes.SceneError) as info:
        scenes.load_or_capture(scene, cache_dir=cache, **params)
    assert WORLD_CASES[case].message in str(info.value) and "\n" not in str(info.value)
    assert not cache.exists() or not any(cache.iterdir())


def test_fixed_links_merged_are_one_body(tmp_path: Path) -> None:
    _write(tmp_path, "pair.urdf", FIXED_URDF)
    world = _write(tmp_path, "merged.py", "CAPTURE_STEP = 5\n" "def build(pb, data_path):\n" + _GROUND +
                   "    pb.loadURDF('pair.urdf', [0, 0.1, 0], flags=pb.URDF_MERGE_FIXED_LINKS)\n")
    f = scenes.capture_frame(str(world))
    assert f.num_bodies == 2 and np.isclose(1 / f.inv_mass[1], 2.0)


def test_make_sim_refuses_a_bad_world_and_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    from sim import run

    scene, _ = BAD_WORLDS["jointed_body"](tmp_path)
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "sim"
    assert run.main(["--scene", scene, "--mode", "model", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "contacts only" in err
    assert not (tmp_path / "build" / "frames").exists() or not any((tmp_path / "build" / "frames").iterdir())
    assert not out.exists() or not any(out.iterdir())


def test_world_module_is_not_needed_for_builtin_scenes() -> None:
    assert not scenes.is_world_scene("thesis") and scenes.is_world_scene("jenga_tower")
    assert scenes.scene_label("a/b/c.urdf") == "c" and scenes.scene_label("pile") == "pile"
    assert world_mod.distinct_shapes(np.array([[1.0, 1, 1], [1 + 1e-12, 1, 1]]), np.ones(2), np.ones((2, 3))).tolist() \
        == [0, 0]
