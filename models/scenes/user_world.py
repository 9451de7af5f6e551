"""Worlds from files: a Python world file, a URDF dropped on the ground, and the built-in asset scenes (world files
shipped in ``models/scenes/worlds/``).

A **world file** is a Python file defining::

    CAPTURE_STEP = 60                      # optional: the step captured (1-based), default 60
    BULLET_CONVENTION = "bullet2"          # optional: the frames' convention (models/setup/inertia.py), default bullet2
    def build(pb, data_path: str, **params) -> None:
        pb.loadURDF("duck_vhacd.urdf", [0, 0.1, 0])

``pb`` is the pybullet module bound to the capture's DIRECT client: every call gets ``physicsClientId``, and
``loadURDF``, ``loadSDF`` and ``createMultiBody`` get ``useMaximalCoordinates=True`` (a btRigidBody, as the
kernel and the Bullet 2 reference assume; passing False is refused). ``data_path`` is ``pybullet_data``'s folder
(pybullet's search path; a relative file name found beside the world file is used from there). ``BULLET_CONVENTION``
names the convention of the world's frames (``meta["bullet_convention"]``): ``bullet2``, the default, Bullet 2's
and pybullet's (the true inertia rotated by the body's orientation, each pair's combined friction: the kernel's
6-word body record where a body is turned and non-isotropic, its friction word where a pair's friction is not
0.7), ``bullet_gpu`` or ``world_axes`` (the built-in scenes': the unrotated AABB diagonal and 0.7). ``params`` are
``SCENE_ARGS``, typed by the defaults of ``build``'s keyword parameters. The world is y-up with gravity (0, -9.8, 0)
unless ``build`` sets another; the capture's solver settings (time step, iterations, ...) are applied after ``build``.
Bodies become frame bodies in creation order (frame body 0 is the first body created: the ground, in the shipped
worlds).

A **URDF file** ``SCENE=obj.urdf`` is the world: a static ground box (half extent 50, top at y = 0, friction 1)
and ``count`` copies of the object (default 4) in a row along x, ``pitch`` times the object's size apart
(default 1.5), each turned so that its z axis points up (y) and dropped from ``drop`` m above the ground (default
0.02). Its capture step is 30.

Checks (each a :class:`SceneError`, before anything is written): a missing file, a file without ``build``, an
import or build that fails (pybullet's load errors: a missing or unloadable mesh), a body with a non-fixed joint
(the kernel solves contacts only) and a body of links joined by fixed joints (load it as one rigid body with
``flags=pb.URDF_MERGE_FIXED_LINKS``): pybullet reports no joints in maximal coordinates, so each URDF/SDF is first
loaded in a scratch client in reduced coordinates and its joints read there; a negative mass, a static
(zero-mass) body given a velocity, a dynamic body with a non-positive inertia, NaN or Inf in a pose or velocity, a
body without a collision shape, a world without a dynamic body, and a capture step without contact
(``models.scenes.world``). The catalogue of these cases is ``models.scenes.bad_worlds.WORLD_CATALOGUE``.

The frame cache key of a file world covers the content of the world file and of every file it loads (URDF, SDF,
MJCF, meshes named in them or given to ``createCollisionShape``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pybullet as p
import pybullet_data

from models.formats.frame import CONVENTION_KEY, BulletConvention
from models.scenes.contact_capture import FrameBodies
from models.scenes.world_source import Population
from models.scenes.scene_args import typed_params
from models.scenes.scene_error import SceneError

WORLD_FUNCTION = "build"
DEFAULT_WORLD_STEP = 60
URDF_DROP_STEP = 30
DEFAULT_WORLD_CONVENTION = BulletConvention.BULLET2  # a world file's (and a URDF's) frames, unless it names one
WORLDS_DIR = Path(__file__).parent / "worlds"
# built-in scenes made of pybullet_data's assets: scene name -> world file
ASSET_SCENES: dict[str, Path] = {
    "duck_lego_pile": WORLDS_DIR / "duck_lego_pile.py",
    "jenga_tower": WORLDS_DIR / "jenga_tower.py",
    "random_world": Path(__file__).parent / "random_world.py",  # SCENE_ARGS="seed=N": a random pybullet_data world
}
WORLD_PARTS_FILE = Path(__file__).parent / "world_parts.py"  # what the shipped world files share (in their key)
URDF_DROP_FILE = WORLDS_DIR / "urdf_drop.py"  # the world of SCENE=obj.urdf (its build takes the URDF as a parameter)
_MAXIMAL = {"loadURDF", "loadSDF", "createMultiBody"}
_REFUSED = {"connect", "disconnect", "resetSimulation", "stepSimulation"}
_FILE_ARGS = {"loadURDF": ("fileName", 0), "loadSDF": ("sdfFileName", 0), "loadMJCF": ("mjcfFileName", 0),
              "createCollisionShape": ("fileName", None), "createCollisionShapeArray": ("fileNames", None)}
_REFERENCE = re.compile(r"""(?:filename|file)\s*=\s*["']([^"']+)["']|<uri>\s*([^<\s]+)\s*</uri>""")


def is_world_scene(scene: str) -> bool:
    """A scene name that is a file (``.py``, ``.urdf``) or a built-in asset scene."""
    return scene in ASSET_SCENES or scene.endswith((".py", ".urdf"))


def scene_label(scene: str) -> str:
    """The name of a scene's runs and cache files: a file's stem, or the scene's name."""
    return Path(scene).stem if scene.endswith((".py", ".urdf")) else scene


class BoundClient:
    """The pybullet module with ``physicsClientId`` filled in, recording the files it is asked to load."""

    def __init__(self, client: int, loaded: list[str], folder: Path, data_path: str) -> None:
        self._client, self._loaded, self._folder, self._data_path = client, loaded, folder, data_path
        self._scratch = -1  # a second client, loading files in reduced coordinates to see their joints
        self._inspected: set[tuple[str, int]] = set()

    def close(self) -> None:
        if self._scratch >= 0:
            p.disconnect(physicsClientId=self._scratch)
            self._scratch = -1

    @property
    def client(self) -> int:
        return self._client

    def __getattr__(self, name: str) -> Any:
        attr = getattr(p, name)
        if not callable(attr) or isinstance(attr, type):
            return attr
        if name in _REFUSED:
            raise SceneError(f"a world file may not call {name} (the capture owns the client and its steps)")

        def call(*args: Any, **kw: Any) -> Any:
            args, kw = self._local_files(name, args, kw)
            self._record(name, args, kw)
            self._refuse_joints(name, args, kw)
            if name in _MAXIMAL:
                if not kw.setdefault("useMaximalCoordinates", True):
                    raise SceneError(f"{name}(useMaximalCoordinates=False) refused: the kernel and the Bullet 2 "
                                     "reference assume rigid bodies in maximal coordinates")
            try:
                return attr(*args, **kw, physicsClientId=self._client)
            except TypeError:
                return attr(*args, **kw)  # a helper without a client (quaternion maths)

        return call

    def _local_files(self, name: str, args: tuple[Any, ...], kw: dict[str, Any]) -> tuple[tuple[Any, ...], dict]:
        """A relative file name that exists beside the world file made absolute (pybullet keeps one additional
        search path: pybullet_data's)."""
        if name not in _FILE_ARGS:
            return args, kw
        key, pos = _FILE_ARGS[name]

        def local(v: Any) -> Any:
            if not isinstance(v, str) or Path(v).is_absolute() or Path(v).is_file():
                return v
            found = _resolve(v, [self._folder])
            return str(found) if found is not None else v

        if key in kw:
            kw = {**kw, key: [local(v) for v in kw[key]] if isinstance(kw[key], (list, tuple)) else local(kw[key])}
        elif pos is not None and len(args) > pos:
            args = (*args[:pos], local(args[pos]), *args[pos + 1:])
        return args, kw

    def _refuse_joints(self, name: str, args: tuple[Any, ...], kw: dict[str, Any]) -> None:
        """Refuse a body with joints before it is created: in maximal coordinates pybullet reports no joints, so a
        file is first loaded in a scratch client in reduced coordinates and its joints read there."""
        if name == "createMultiBody":
            err = joint_refusal(list(kw.get("linkJointTypes") or ()), "", "createMultiBody: a body with links")
            if err is not None:
                raise err
            return
        if name not in ("loadURDF", "loadSDF"):
            return
        key, pos = _FILE_ARGS[name]
        file = str(kw.get(key, args[pos] if len(args) > pos else ""))
        flags = int(kw.get("flags", 0)) if name == "loadURDF" else 0
        if (file, flags) in self._inspected:
            return
        if self._scratch < 0:
            self._scratch = p.connect(p.DIRECT)
            p.setAdditionalSearchPath(self._data_path, physicsClientId=self._scratch)
        loader = getattr(p, name)
        uids = loader(file, flags=flags, physicsClientId=self._scratch) if name == "loadURDF" \
            else loader(file, physicsClientId=self._scratch)
        for uid in (uids if isinstance(uids, (tuple, list)) else (uids,)):
            _check_joints(self._scratch, uid, f"{file}: body '{_body_name(self._scratch, uid)}'")
        self._inspected.add((file, flags))

    def _record(self, name: str, args: tuple[Any, ...], kw: dict[str, Any]) -> None:
        if name not in _FILE_ARGS:
            return
        key, pos = _FILE_ARGS[name]
        value = kw.get(key, args[pos] if pos is not None and len(args) > pos else None)
        names = value if isinstance(value, (list, tuple)) else [value]
        self._loaded.extend(str(v) for v in names if v)


def _load_function(path: Path) -> tuple[Callable[..., None], int, dict[str, Any]]:
    if not path.is_file():
        raise SceneError(f"world file {path} does not exist")
    spec = importlib.util.spec_from_file_location(f"pgs_world_{hashlib.sha1(str(path).encode()).hexdigest()[:8]}", path)
    if spec is None or spec.loader is None:
        raise SceneError(f"world file {path} is not a Python file")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        raise SceneError(f"world file {path} failed to import: {exc.__class__.__name__}: {exc}") from None
    fn = getattr(module, WORLD_FUNCTION, None)
    if not callable(fn):
        raise SceneError(f"world file {path} defines no function {WORLD_FUNCTION}(pb, data_path, **params)")
    step = getattr(module, "CAPTURE_STEP", DEFAULT_WORLD_STEP)
    if not isinstance(step, int) or isinstance(step, bool) or step < 1:
        raise SceneError(f"world file {path}: CAPTURE_STEP must be a positive integer, got {step!r}")
    convention = getattr(module, "BULLET_CONVENTION", DEFAULT_WORLD_CONVENTION.value)
    try:
        return fn, step, {CONVENTION_KEY: BulletConvention(convention).value}
    except ValueError:
        known = ", ".join(c.value for c in BulletConvention)
        raise SceneError(f"world file {path}: BULLET_CONVENTION {convention!r} is not one of {known}") from None


@dataclass
class WorldFileSource:
    """A world built by a world file's ``build`` (``models.scenes.world.WorldSource``)."""

    path: Path
    params: dict[str, Any]
    capture_step: int
    build: Callable[..., None] = field(repr=False)
    loaded: list[str] = field(default_factory=list)
    friction_pair: float | None = None
    frame_meta: dict[str, Any] = field(default_factory=dict)

    def populate(self, client: int) -> Population:
        data = pybullet_data.getDataPath()
        p.setAdditionalSearchPath(data, physicsClientId=client)
        self.loaded.clear()
        pb = BoundClient(client, self.loaded, self.path.parent.resolve(), data)
        try:
            self.build(pb, data, **self.params)
        except SceneError:
            raise
        except p.error as exc:
            raise SceneError(f"world {self.path.name}: pybullet refused a call in {WORLD_FUNCTION}: {exc} (a missing "
                             "file or a mesh pybullet cannot load; pybullet's own messages above say which)") from None
        except Exception as exc:
            raise SceneError(f"world {self.path.name}: {WORLD_FUNCTION} failed: {exc.__class__.__name__}: {exc}") from None
        finally:
            pb.close()
        for f in self._content_files():
            bad = nonfinite_obj_vertices(f) if f.suffix.lower() == ".obj" else 0
            if bad:
                raise SceneError(f"world {self.path.name}: mesh {f} has {bad} non-finite vertex coordinate line(s) "
                                 "(nan or inf): pybullet's collision shape and inertia from it are undefined")
        return Population(check_bodies(client, self.path.name))

    def content_digest(self) -> str:
        """A hash of the world file and of every file it loaded (and the files those name)."""
        h = hashlib.sha256(self.path.read_bytes())
        shipped = [WORLD_PARTS_FILE] if self.path.parent.resolve() == WORLDS_DIR.resolve() else []
        for f in [*shipped, *self._content_files()]:
            h.update(str(f.name).encode())
            h.update(f.read_bytes())
        return h.hexdigest()

    def _content_files(self) -> list[Path]:
        roots = [Path.cwd(), self.path.parent, Path(pybullet_data.getDataPath())]
        seen: dict[Path, None] = {}
        todo = [r for r in (_resolve(n, roots) for n in self.loaded) if r is not None]
        while todo:
            f = todo.pop(0)
            if f in seen:
                continue
            seen[f] = None
            if f.suffix.lower() in (".urdf", ".sdf", ".xml", ".mjcf"):
                text = f.read_text(errors="replace")
                for m in _REFERENCE.finditer(text):
                    ref = _resolve(re.sub(r"^(package|model)://", "", m.group(1) or m.group(2)), [f.parent, *roots])
                    if ref is not None:
                        todo.append(ref)
        return list(seen)


def nonfinite_obj_vertices(path: Path) -> int:
    """The vertex lines (``v x y z``) of a Wavefront OBJ file holding a coordinate that is not finite. pybullet loads
    them silently and the shape it builds from them differs from one run to the next (pybullet_data's
    ``random_urdfs/168/168.obj``, whose 35 vertices are all ``nan``: seen as a body with no collision shape in one
    process and as one with a zero inertia diagonal in another)."""
    bad = 0
    with open(path, errors="replace") as fh:
        for line in fh:
            if line.startswith("v "):
                try:
                    bad += not all(math.isfinite(float(x)) for x in line.split()[1:4])
                except ValueError:
                    bad += 1
    return bad


def _resolve(name: str, roots: list[Path]) -> Path | None:
    for root in roots:
        f = (root / name) if not Path(name).is_absolute() else Path(name)
        if f.is_file():
            return f.resolve()
    return None


def check_bodies(client: int, world: str) -> FrameBodies:
    """The frame bodies of the world in ``client`` (creation order), or a SceneError naming the first bad body."""
    ids: list[int] = []
    links: list[int] = []
    for k in range(p.getNumBodies(physicsClientId=client)):
        uid = p.getBodyUniqueId(k, physicsClientId=client)
        label = f"world {world}: body {uid} ({_body_name(client, uid)})"
        _check_joints(client, uid, label)
        _check_link(client, uid, -1, label)
        ids.append(uid)
        links.append(-1)
    if not ids:
        raise SceneError(f"world {world} has no bodies")
    masses = [p.getDynamicsInfo(b, l, physicsClientId=client)[0] for b, l in zip(ids, links)]
    if not any(m > 0 for m in masses):
        raise SceneError(f"world {world} has no dynamic body (every mass is 0): nothing for the kernel to solve")
    return FrameBodies(np.asarray(ids, dtype=np.int64), np.asarray(links, dtype=np.int64))


_JOINT_KINDS = {p.JOINT_REVOLUTE: "revolute", p.JOINT_PRISMATIC: "prismatic", p.JOINT_SPHERICAL: "spherical",
                p.JOINT_PLANAR: "planar", p.JOINT_POINT2POINT: "point-to-point", p.JOINT_GEAR: "gear",
                p.JOINT_FIXED: "fixed"}


def joint_refusal(kinds: list[int], joint: str, what: str) -> SceneError | None:
    """The error for a body with joints of these kinds (None: no joints)."""
    moving = [k for k in kinds if k != p.JOINT_FIXED]
    if moving:
        return SceneError(f"{what} has a {_JOINT_KINDS.get(moving[0], str(moving[0]))} joint{joint}: the kernel "
                          "solves contacts only (no joints); refused")
    if kinds:
        return SceneError(f"{what} has {len(kinds)} fixed joint(s): the kernel solves contacts between single "
                          "rigid bodies; load it as one (flags=pb.URDF_MERGE_FIXED_LINKS)")
    return None


def _body_name(client: int, uid: int) -> str:
    return p.getBodyInfo(uid, physicsClientId=client)[1].decode(errors="replace")


def _check_joints(client: int, uid: int, label: str) -> None:
    n = p.getNumJoints(uid, physicsClientId=client)
    infos = [p.getJointInfo(uid, j, physicsClientId=client) for j in range(n)]
    moving = [i for i in infos if i[2] != p.JOINT_FIXED]
    name = f" '{(moving or infos)[0][1].decode(errors='replace')}'" if infos else ""
    err = joint_refusal([i[2] for i in infos], name, label)
    if err is not None:
        raise err


def _check_link(client: int, uid: int, link: int, label: str) -> None:
    info = p.getDynamicsInfo(uid, link, physicsClientId=client)
    mass, inertia = float(info[0]), np.asarray(info[2], dtype=np.float64)
    pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=client)
    lin, ang = p.getBaseVelocity(uid, physicsClientId=client)
    if not all(math.isfinite(x) for x in (*pos, *orn)):
        raise SceneError(f"{label}: NaN or Inf in its pose {pos}, {orn}")
    lo, hi = p.getAABB(uid, link, physicsClientId=client)
    if not (all(math.isfinite(x) for x in (*lo, *hi)) and all(a < b for a, b in zip(lo, hi))):
        raise SceneError(f"{label}: no collision shape (its AABB is {lo}, {hi})")
    if not all(math.isfinite(x) for x in (*lin, *ang)):
        raise SceneError(f"{label}: NaN or Inf in its velocity")
    if not math.isfinite(mass) or mass < 0:
        raise SceneError(f"{label}: mass {mass} (must be > 0 for a dynamic body, 0 for a static one)")
    if mass == 0 and any(x != 0 for x in (*lin, *ang)):
        raise SceneError(f"{label}: zero mass (static) but moving: a dynamic body needs a mass > 0")
    if mass > 0 and not (np.all(np.isfinite(inertia)) and np.all(inertia > 0)):
        raise SceneError(f"{label}: mass {mass} with inertia {tuple(float(x) for x in inertia)} (a dynamic body needs a positive "
                         "inertia)")


WORLD_SEED = "world_seed"  # how a world's own ``seed`` parameter travels beside the capture's seed (load_scene)


def world_source(scene: str, **params: Any) -> WorldFileSource:
    """The source of a file scene (``.py`` world file, ``.urdf`` object, or a built-in asset scene's name), its
    parameters typed by ``build``'s defaults (a SceneError names an unknown or bad one). ``world_seed`` is handed to
    ``build`` as its ``seed`` (the capture functions take a ``seed`` of their own)."""
    if WORLD_SEED in params:
        params = {("seed" if k == WORLD_SEED else k): v for k, v in params.items()}
    if scene.endswith(".urdf"):
        urdf = Path(scene)
        if not urdf.is_file():
            raise SceneError(f"URDF file {urdf} does not exist")
        fn, _, meta = _load_function(URDF_DROP_FILE)
        typed = typed_params(fn, params, scene, skip=("urdf",))
        return WorldFileSource(URDF_DROP_FILE, {"urdf": str(urdf.resolve()), **typed}, URDF_DROP_STEP, fn,
                               loaded=[str(urdf.resolve())], frame_meta=meta)
    path = ASSET_SCENES.get(scene, Path(scene))
    fn, step, meta = _load_function(path)
    return WorldFileSource(path, typed_params(fn, params, scene), step, fn, frame_meta=meta)


def function_parameters(fn: Callable[..., None]) -> list[str]:
    """The keyword parameters of a world's ``build`` (after ``pb`` and ``data_path``)."""
    return list(inspect.signature(fn).parameters)[2:]
