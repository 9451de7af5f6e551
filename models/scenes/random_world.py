"""Random worlds from ``pybullet_data`` that no test was tuned to (``make sim SCENE=random_world SCENE_ARGS="seed=N"``;
a world file in the format of ``models/scenes/user_world.py``, registered as the asset scene ``random_world``).

The seed picks everything: the ground (pybullet's ``plane.urdf`` or a static box, its friction), the up axis (z-up
with gravity (0, 0, -9.8), as pybullet's own assets are, or y-up with every asset turned z -> y and the default
gravity), the number of bodies (``bodies``, 50 to 500 unless given) and how they are grouped, each group on its own
patch of ground:

* **towers** of ``jenga/jenga.urdf``, three blocks a level side by side, each level turned a quarter;
* **rows** of jenga blocks side by side on the ground, one or two layers (the upper crosswise);
* **stacks** of ``cube_small.urdf`` cubes, each turned about the vertical;
* **heaps** of ducks (``duck_vhacd.urdf``), lego bricks, small spheres and cubes, teddies (``teddy_vhacd.urdf``) and
  ``random_urdfs`` objects, dropped in jittered layers, every one turned at random (an object whose mesh holds
  non-finite vertices, pybullet_data's 168, is drawn again).

Each dynamic body gets a lateral friction drawn in [0.3, 1.0] (per-pair friction, Bullet 2's product) and no
restitution. The world is captured at ``CAPTURE_STEP`` (the bodies have landed on the ground and on each other).
``describe(seed)`` (and ``python -m models.scenes.random_world --seeds 0-9``) says what a seed builds.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from models.scenes.specs import int_param
from models.scenes.user_world import nonfinite_obj_vertices

CAPTURE_STEP = 12
MIN_BODIES, MAX_BODIES = 50, 500
CELL = 0.5  # m: the patch of ground of each group
JENGA = "jenga/jenga.urdf"
JENGA_LENGTH, JENGA_WIDTH, JENGA_HEIGHT = 0.15, 0.05, 0.03  # its collision box (z-up)
CUBE = "cube_small.urdf"
CUBE_SIZE = 0.05
HEAP_ASSETS = (("duck_vhacd.urdf", 1.0), ("lego/lego.urdf", 2.0), ("sphere_small.urdf", 1.0),
               ("cube_small.urdf", 1.0), ("teddy_vhacd.urdf", 1.0), ("random_urdfs", 1.0))
RANDOM_URDFS = 1000  # random_urdfs/000 .. 999
GROUP_KINDS = ("tower", "row", "stack", "heap")
GROUND_HALF_EXTENT = 5.0
CLEARANCE = 0.003  # m: a heap object is placed at least this far above the ground and from the bodies placed before


class Plan(NamedTuple):
    """What a seed builds (z-up coordinates; the y-up worlds turn every pose). (No dataclass: the capture loads this
    file as a world file, outside ``sys.modules``.)"""

    up: str  # "z" or "y"
    ground: str  # "plane" or "box"
    ground_friction: float
    groups: list[tuple[str, int]]  # (kind, size: levels of a tower, blocks of a row, cubes of a stack, heap objects)

    @property
    def bodies(self) -> int:
        return 1 + sum(3 * n if kind == "tower" else n for kind, n in self.groups)


def plan(seed: int, bodies: int = 0) -> Plan:
    """The world of ``seed`` (``bodies`` dynamic bodies, or 0: the seed picks 50 to 500)."""
    rng = np.random.default_rng(seed)
    drawn = int(rng.integers(MIN_BODIES, MAX_BODIES + 1))  # drawn either way: the rest of the plan is the seed's
    target = drawn if bodies == 0 else bodies
    up = "z" if rng.random() < 0.5 else "y"
    ground = "plane" if rng.random() < 0.5 else "box"
    friction = float(rng.uniform(0.5, 1.0))
    groups: list[tuple[str, int]] = []
    left = target
    while left > 0:
        kind = GROUP_KINDS[int(rng.choice(len(GROUP_KINDS), p=[0.3, 0.2, 0.15, 0.35]))]
        if kind == "tower":
            size = min(int(rng.integers(3, 13)), max(left // 3, 1))
            used = 3 * size
        else:
            lo, hi = {"row": (3, 11), "stack": (2, 9), "heap": (8, 41)}[kind]
            size = min(int(rng.integers(lo, hi)), left)
            used = size
        if used > left:  # a tower does not fit: the rest is a heap
            kind, size, used = "heap", left, left
        groups.append((kind, size))
        left -= used
    return Plan(up, ground, friction, groups)


def describe(seed: int, bodies: int = 0) -> str:
    p = plan(seed, bodies)
    counts = {k: sum(1 for g in p.groups if g[0] == k) for k in GROUP_KINDS}
    return (f"seed {seed}: {p.bodies - 1} dynamic bodies, {p.up}-up, ground {p.ground} (friction "
            f"{p.ground_friction:.2f}); " + ", ".join(f"{n} {k}{'s' if n != 1 else ''}" for k, n in counts.items()))


class _Frame:
    """Poses given z-up, turned into the world's up axis; the world AABBs of the bodies placed so far."""

    def __init__(self, pb: Any, up: str, data_path: str) -> None:
        self.pb = pb
        self.data_path = data_path
        self.turn = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)) if up == "y" else (0.0, 0.0, 0.0, 1.0)
        self.axis = 1 if up == "y" else 2  # the world's up axis
        self.boxes: list[np.ndarray] = []  # (2, 3) world AABB of each dynamic body placed

    def pose(self, pos: list[float], orn: tuple[float, ...]) -> tuple[list[float], tuple[float, ...]]:
        p, q = self.pb.multiplyTransforms([0.0, 0.0, 0.0], self.turn, pos, orn)
        return list(p), tuple(q)

    def clear(self, uid: int) -> None:
        """Lift a body just placed until its AABB is above the ground and clear of every body placed before (a
        turned compound dropped into another would be caught inside it: contacts that cannot all separate)."""
        box = np.asarray(self.pb.getAABB(uid), dtype=np.float64)
        lift = max(CLEARANCE - box[0, self.axis], 0.0)
        others = np.asarray(self.boxes).reshape(-1, 2, 3)
        while True:
            moved = box + lift * np.eye(3)[self.axis]
            overlap = np.all((moved[0] < others[:, 1] + CLEARANCE) & (moved[1] > others[:, 0] - CLEARANCE), axis=1)
            if not overlap.any():
                break
            lift = float(others[overlap, 1, self.axis].max() + 2 * CLEARANCE - box[0, self.axis])
        if lift > 0.0:
            pos, orn = self.pb.getBasePositionAndOrientation(uid)
            self.pb.resetBasePositionAndOrientation(uid, [x + lift * (k == self.axis) for k, x in enumerate(pos)],
                                                    orn)
        self.boxes.append(box + lift * np.eye(3)[self.axis])


def build(pb: Any, data_path: str, seed: int = 0, bodies: int = 0) -> None:
    seed = int_param("seed", seed, 0, 2**31 - 1)
    bodies = 0 if bodies == 0 else int_param("bodies", bodies, MIN_BODIES, MAX_BODIES)
    p = plan(seed, bodies)
    rng = np.random.default_rng([seed, 1])
    frame = _Frame(pb, p.up, data_path)
    if p.up == "z":
        pb.setGravity(0.0, 0.0, -9.8)
    _ground(pb, frame, p)
    side = math.ceil(math.sqrt(len(p.groups)))
    for k, (kind, size) in enumerate(p.groups):
        centre = np.array([(k % side - (side - 1) / 2) * CELL, (k // side - (side - 1) / 2) * CELL])
        turn = float(rng.uniform(0.0, 2 * math.pi))
        {"tower": _tower, "row": _row, "stack": _stack, "heap": _heap}[kind](pb, frame, rng, centre, turn, size)


def _ground(pb: Any, frame: _Frame, p: Plan) -> None:
    if p.ground == "plane":
        pos, orn = frame.pose([0.0, 0.0, 0.0], (0.0, 0.0, 0.0, 1.0))
        uid = pb.loadURDF("plane.urdf", pos, orn)
    else:
        h = GROUND_HALF_EXTENT
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[h, h, h])
        pos, orn = frame.pose([0.0, 0.0, -h], (0.0, 0.0, 0.0, 1.0))
        uid = pb.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=pos, baseOrientation=orn)
    pb.changeDynamics(uid, -1, lateralFriction=p.ground_friction, restitution=0.0)


def _place(pb: Any, frame: _Frame, rng: np.random.Generator, urdf: str, pos: list[float], orn: tuple[float, ...],
           scale: float = 1.0, clear: bool = False) -> int:
    wpos, worn = frame.pose(pos, orn)
    uid = pb.loadURDF(urdf, wpos, worn, globalScaling=scale)
    if clear:
        frame.clear(uid)
    else:  # built with its gaps: recorded for the heaps that come later
        frame.boxes.append(np.asarray(pb.getAABB(uid), dtype=np.float64))
    pb.changeDynamics(uid, -1, lateralFriction=float(rng.uniform(0.3, 1.0)), restitution=0.0,
                      activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING)
    return uid


def _broken_random_urdf(data_path: str, n: int) -> bool:
    """``random_urdfs`` object n's mesh holds non-finite vertices (``nonfinite_obj_vertices``: pybullet_data 4.x's
    168): never placed."""
    mesh = Path(data_path) / "random_urdfs" / f"{n:03d}" / f"{n:03d}.obj"
    return mesh.is_file() and nonfinite_obj_vertices(mesh) > 0


def _about_z(angle: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))


def _at(centre: np.ndarray, turn: float, x: float, y: float, z: float) -> list[float]:
    c, s = math.cos(turn), math.sin(turn)
    return [float(centre[0] + c * x - s * y), float(centre[1] + s * x + c * y), z]


def _tower(pb: Any, frame: _Frame, rng: np.random.Generator, centre: np.ndarray, turn: float, levels: int) -> None:
    gap = 0.0005
    for level in range(levels):
        angle = turn + math.pi / 2 * (level % 2)
        z = JENGA_HEIGHT / 2 + gap + level * (JENGA_HEIGHT + gap)
        for k in (-1, 0, 1):
            across = k * (JENGA_WIDTH + 0.001)
            x, y = (0.0, across) if level % 2 == 0 else (across, 0.0)
            _place(pb, frame, rng, JENGA, _at(centre, turn, x, y, z), _about_z(angle))


def _row(pb: Any, frame: _Frame, rng: np.random.Generator, centre: np.ndarray, turn: float, count: int) -> None:
    lower = count if count < 6 else (count + 1) // 2
    gap = 0.0005
    for k in range(count):
        layer, i = (0, k) if k < lower else (1, k - lower)
        if layer == 0:
            x, y, angle = 0.0, (i - (lower - 1) / 2) * (JENGA_WIDTH + 0.001), turn
        else:
            x, y, angle = (i - (count - lower - 1) / 2) * (JENGA_WIDTH + 0.001), 0.0, turn + math.pi / 2
        z = JENGA_HEIGHT / 2 + gap + layer * (JENGA_HEIGHT + gap)
        _place(pb, frame, rng, JENGA, _at(centre, turn, x, y, z), _about_z(angle))


def _stack(pb: Any, frame: _Frame, rng: np.random.Generator, centre: np.ndarray, turn: float, count: int) -> None:
    for k in range(count):
        z = CUBE_SIZE / 2 + 0.0005 + k * (CUBE_SIZE + 0.0005)
        jitter = rng.uniform(-0.005, 0.005, 2)
        _place(pb, frame, rng, CUBE, _at(centre, turn, float(jitter[0]), float(jitter[1]), z),
               _about_z(float(rng.uniform(0.0, 2 * math.pi))))


def _heap(pb: Any, frame: _Frame, rng: np.random.Generator, centre: np.ndarray, turn: float, count: int) -> None:
    side = 3
    pitch = 0.12
    for k in range(count):  # each lifted onto what lies below it (``_Frame.clear``): a short drop
        i, j = divmod(k % (side * side), side)
        name, scale = HEAP_ASSETS[int(rng.integers(len(HEAP_ASSETS)))]
        if name == "random_urdfs":
            n = int(rng.integers(RANDOM_URDFS))
            while _broken_random_urdf(frame.data_path, n):  # drawn again: the other worlds stay as they were
                n = int(rng.integers(RANDOM_URDFS))
            name = f"random_urdfs/{n:03d}/{n:03d}.urdf"
        x, y = (i - 1) * pitch + float(rng.uniform(-0.015, 0.015)), (j - 1) * pitch + float(rng.uniform(-0.015, 0.015))
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        _place(pb, frame, rng, name, _at(centre, turn, x, y, 0.0), tuple(float(v) for v in q), scale, clear=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m models.scenes.random_world", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", default="0-9", help="seeds: a-b or a,b,c")
    args = ap.parse_args(argv)
    for seed in parse_seeds(args.seeds):
        print(describe(seed))
    return 0


def parse_seeds(text: str) -> list[int]:
    """``"0-29"`` or ``"1,4,7"`` (or a mix: ``"0-3,9"``) as a list of seeds."""
    out: list[int] = []
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            out.extend(range(int(lo), int(hi) + 1) if sep else [int(lo)])
        except ValueError:
            raise ValueError(f"seeds must be a-b or a,b,c (non-negative integers), got {text!r}") from None
    if not out or min(out) < 0:
        raise ValueError(f"seeds must be a-b or a,b,c (non-negative integers), got {text!r}")
    return out


if __name__ == "__main__":
    raise SystemExit(main())
