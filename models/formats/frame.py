"""A frame: the bodies and contact manifolds of one simulation step, as pybullet produced them.

A frame holds the body state *before* a step and the contact manifolds that pybullet's solver used in
that step (points, normals, distances), plus what pybullet's own solver did with them (impulses and
the post-step velocities), so that the same file feeds our GPU-style solver and the check against
Bullet itself.

Conventions (those of Bullet and of ``getContactPoints``):

* y is up, gravity (0, -9.8, 0) unless the metadata says otherwise; SI units (m, s, kg).
* Bodies are in pybullet's creation order; body 0 is the first created (the static ground in the built-in and
  shipped scenes); static bodies have ``inv_mass == 0``.
* Orientation quaternions are (x, y, z, w).
* Manifold m joins ``body_a[m]`` and ``body_b[m]`` (frame body indices, ``body_a < body_b``); manifolds are
  sorted by (body_a, body_b), one per pair in the built-in box scenes; in a file world several may join one pair
  (one per Bullet manifold, e.g. per child of a compound shape; a reported run of more than 4 points is split
  into manifolds of at most 4, ``models.scenes.contact_capture``); ``num_points[m]`` in 1..4 points are valid,
  the rest are zero.
* ``normal_on_b`` points from B to A; ``distance < 0`` is penetration; ``point_on_b`` lies on B.
* Forces are pybullet's reports: impulse / fixed time step (N).

The body contract (what the solver side relies on; every scene, built-in or from a file):

* ``position``, ``orientation``: the world pose of the body's principal-inertia (centre-of-mass) frame: pybullet's
  base frame of a rigid body in maximal coordinates (``getBasePositionAndOrientation``: a URDF's
  ``<inertial><origin>`` is already applied);
* ``inertia_local``: the inertia diagonal in that frame (``getDynamicsInfo``; Bullet computes it from the collision
  shape, the box formula over the shape's AABB for meshes and compounds, unless a URDF is loaded with
  ``URDF_USE_INERTIA_FROM_FILE``), so the world inverse inertia is R diag(1 / inertia_local) R^T with R from
  ``orientation``; zero for static bodies;
* ``friction``: the body's own lateral friction (``getDynamicsInfo``); a pair's coefficient is pybullet's combination
  of its two bodies' (the product), computed by the solver side. The built-in box scenes give every body
  sqrt(pair coefficient);
* ``half_extents``: a built-in box's half extents; in a file world the half extents of the body's AABB in its
  principal frame as pybullet reports it (``getAABB`` at the identity orientation, with the shape's collision
  margin), the world AABB's for static bodies;
* ``shape_index``: the distinct box of a built-in scene; in a file world one index per distinct (half extents,
  inverse mass, inertia).

Files are ``.npz`` without pickled objects (``allow_pickle=False``); the metadata is a JSON string.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field, fields
from enum import Enum
from pathlib import Path
from typing import Any, Mapping

import numpy as np

# A frame names the convention its bodies' inverse inertia follows in meta["bullet_convention"]
# (models/setup/inertia.py defines each convention).
CONVENTION_KEY = "bullet_convention"


class BulletConvention(str, Enum):
    BULLET2 = "bullet2"
    BULLET_GPU = "bullet_gpu"
    WORLD_AXES = "world_axes"


DEFAULT_CONVENTION = BulletConvention.WORLD_AXES


def convention_of(meta: Mapping[str, Any]) -> BulletConvention:
    """The convention a frame's metadata names (``bullet_convention``), or :data:`DEFAULT_CONVENTION`."""
    name = meta.get(CONVENTION_KEY, DEFAULT_CONVENTION.value)
    try:
        return BulletConvention(name)
    except ValueError:
        known = ", ".join(c.value for c in BulletConvention)
        raise ValueError(f"unknown Bullet convention {name!r} (known: {known})") from None


FRAME_VERSION = 1


class FrameError(ValueError):
    """A frame file that is missing, corrupt, truncated or of another version."""


@dataclass
class Frame:
    # bodies (N)
    position: np.ndarray  # (N,3) centre of mass, world
    orientation: np.ndarray  # (N,4) quaternion (x, y, z, w) of the principal-inertia frame, world
    linear_velocity: np.ndarray  # (N,3) m/s
    angular_velocity: np.ndarray  # (N,3) rad/s
    inv_mass: np.ndarray  # (N,) 1/kg, 0 for static bodies
    inertia_local: np.ndarray  # (N,3) inertia diagonal in the principal frame (kg m^2), 0 for static
    half_extents: np.ndarray  # (N,3) box half extents / principal-frame AABB half extents (m)
    shape_index: np.ndarray  # (N,) int32 index into the scene's distinct shapes
    friction: np.ndarray  # (N,) the body's lateral friction (pybullet's; a pair's is the product)
    # manifolds (M), up to 4 points each
    body_a: np.ndarray  # (M,) int32
    body_b: np.ndarray  # (M,) int32
    num_points: np.ndarray  # (M,) int32, 1..4
    point_on_a: np.ndarray  # (M,4,3)
    point_on_b: np.ndarray  # (M,4,3)
    normal_on_b: np.ndarray  # (M,4,3) unit, B -> A
    distance: np.ndarray  # (M,4) m, < 0 penetrating
    normal_force: np.ndarray  # (M,4) N, pybullet's applied impulse / dt
    lateral_friction1: np.ndarray  # (M,4) N
    lateral_dir1: np.ndarray  # (M,4,3)
    lateral_friction2: np.ndarray  # (M,4) N
    lateral_dir2: np.ndarray  # (M,4,3)
    # pybullet's own result of the step (for the check against Bullet)
    post_linear_velocity: np.ndarray  # (N,3)
    post_angular_velocity: np.ndarray  # (N,3)
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def num_bodies(self) -> int:
        return int(self.inv_mass.shape[0])

    @property
    def num_manifolds(self) -> int:
        return int(self.body_a.shape[0])

    @property
    def num_points_total(self) -> int:
        return int(self.num_points.sum())

    @property
    def dt(self) -> float:
        return float(self.meta.get("dt", 1.0 / 60.0))

    @property
    def gravity(self) -> np.ndarray:
        return np.asarray(self.meta.get("gravity", (0.0, -9.8, 0.0)), dtype=np.float64)

    def summary(self) -> str:
        return (
            f"{self.meta.get('scene', '?')}: {self.num_bodies} bodies, {self.num_manifolds} manifolds, "
            f"{self.num_points_total} contact points (step {self.meta.get('step', '?')})"
        )


_ARRAY_FIELDS = [f.name for f in fields(Frame) if f.name != "meta"]
_INT_FIELDS = {"shape_index", "body_a", "body_b", "num_points"}


def validate(frame: Frame) -> None:
    """Check shapes, ranges and the sanity rules of the contact records (raises FrameError)."""
    n, m = frame.num_bodies, frame.num_manifolds
    expected = {
        "position": (n, 3), "orientation": (n, 4), "linear_velocity": (n, 3), "angular_velocity": (n, 3),
        "inv_mass": (n,), "inertia_local": (n, 3), "half_extents": (n, 3), "shape_index": (n,),
        "friction": (n,), "body_a": (m,), "body_b": (m,), "num_points": (m,), "point_on_a": (m, 4, 3),
        "point_on_b": (m, 4, 3), "normal_on_b": (m, 4, 3), "distance": (m, 4), "normal_force": (m, 4),
        "lateral_friction1": (m, 4), "lateral_dir1": (m, 4, 3), "lateral_friction2": (m, 4),
        "lateral_dir2": (m, 4, 3), "post_linear_velocity": (n, 3), "post_angular_velocity": (n, 3),
    }
    for name, shape in expected.items():
        got = getattr(frame, name).shape
        if got != shape:
            raise FrameError(f"field {name} has shape {got}, expected {shape}")
    if m:
        if frame.body_a.min() < 0 or frame.body_b.min() < 0 or max(frame.body_a.max(), frame.body_b.max()) >= n:
            raise FrameError("a manifold names a body index out of range")
        if np.any(frame.body_a == frame.body_b):
            raise FrameError("a manifold joins a body to itself")
        if frame.num_points.min() < 1 or frame.num_points.max() > 4:
            raise FrameError("a manifold has fewer than 1 or more than 4 points")
    for name in _ARRAY_FIELDS:
        arr = getattr(frame, name)
        if name not in _INT_FIELDS and not np.all(np.isfinite(arr)):
            raise FrameError(f"field {name} holds NaN or Inf")


def save(frame: Frame, path: str | os.PathLike[str]) -> Path:
    """Write a frame atomically (a partial file is never left behind)."""
    validate(frame)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {name: np.ascontiguousarray(getattr(frame, name)) for name in _ARRAY_FIELDS}
    meta = dict(frame.meta)
    meta["frame_version"] = FRAME_VERSION
    arrays["meta_json"] = np.array(json.dumps(meta, sort_keys=True))
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp.npz", dir=path.parent)
    os.close(fd)
    try:
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def load(path: str | os.PathLike[str]) -> Frame:
    """Read a frame file without unpickling anything; raise FrameError with one clear line on failure."""
    path = Path(path)
    if not path.is_file():
        raise FrameError(f"frame file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {k: data[k] for k in data.files}
    except ValueError as exc:
        # numpy refuses what only unpickling could read (which could run code): say which case it is
        if "Object arrays" in str(exc):
            raise FrameError(f"frame file {path} holds a pickled Python object (refused: frames are read without "
                             "unpickling)") from None
        if "pickle" in str(exc):
            raise FrameError(f"frame file {path} is corrupt or not an .npz file (numpy would unpickle it: "
                             "refused)") from None
        raise FrameError(f"frame file {path} is corrupt or truncated ({exc.__class__.__name__}: {exc})") from None
    except (OSError, EOFError) as exc:
        raise FrameError(f"frame file {path} is corrupt or truncated ({exc.__class__.__name__}: {exc})") from None
    except Exception as exc:  # zipfile.BadZipFile and friends
        raise FrameError(f"frame file {path} is corrupt or truncated ({exc.__class__.__name__}: {exc})") from None
    if "meta_json" not in contents:
        raise FrameError(f"frame file {path} has no metadata (not a pgs-cosim frame)")
    try:
        meta = json.loads(str(contents.pop("meta_json")))
    except json.JSONDecodeError as exc:
        raise FrameError(f"frame file {path} has unreadable metadata: {exc}") from None
    version = meta.get("frame_version")
    if version != FRAME_VERSION:
        raise FrameError(f"frame file {path} has version {version}, this tool reads version {FRAME_VERSION}; rebuild it")
    missing = [name for name in _ARRAY_FIELDS if name not in contents]
    if missing:
        raise FrameError(f"frame file {path} lacks fields: {', '.join(missing)}")
    kwargs: dict[str, Any] = {}
    for name in _ARRAY_FIELDS:
        arr = contents[name]
        kwargs[name] = arr.astype(np.int32) if name in _INT_FIELDS else arr.astype(np.float64)
    frame = Frame(**kwargs, meta=meta)
    try:
        validate(frame)
    except FrameError as exc:
        raise FrameError(f"frame file {path}: {exc}") from None
    return frame
