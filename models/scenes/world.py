"""A scene in pybullet (a DIRECT client), stepped, and its contacts captured as a frame.

Every body is created with ``useMaximalCoordinates=True`` (a btRigidBody, so that pybullet runs Bullet 2's
``btSequentialImpulseConstraintSolver`` rows, see ``models/bullet2_solver.py``), in the order of the scene's
spec: frame body index i is the i-th body created and ``SceneWorld.body_ids[i]`` its pybullet unique id.
Gravity is (0, -9.8, 0).

Friction: pybullet combines the two bodies' lateral friction as the product muA*muB, so every body is given
``sqrt(friction)`` (``Frame.friction``) and a pair gets ``sqrt(f)*sqrt(f)`` (= f to one rounding).

Conventions of ``getContactPoints(bodyA=b)`` (checked against the global query in the tests): the queried
body is always reported as A; the manifold's own orientation (body0 = the body created first, i.e. the
smaller frame index) is reported unchanged when the queried body is body0; from the other side pybullet
swaps the points and negates the normal. We keep the side queried from the smaller frame index, so
``normal_on_b`` points from B to A, ``distance < 0`` is penetration and the points are in the manifold's
own order -- exactly the rows the solver built.
"""

from __future__ import annotations

import importlib.metadata
import math
import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pybullet as p

from models.bullet_profile import profiled_step
from models.frame import Frame, validate
from models.scenes.specs import DEFAULT_CAPTURE_STEP, SceneError, SceneSpec, float_param, int_param, make_spec

GRAVITY = (0.0, -9.8, 0.0)
DEFAULT_DT = 1.0 / 60.0
# pybullet settings the Bullet 2 reference solver (models/bullet2_solver.py) needs; recorded in the metadata.
CONTACT_ERP = 0.08
CONTACT_SLOP = 1e-5
SPLIT_IMPULSE = 1
SPLIT_IMPULSE_THRESHOLD = -0.04
CONTACT_BREAKING_THRESHOLD = 0.02


@dataclass
class Manifolds:
    """Contact manifolds in frame indices (the manifold fields of Frame)."""

    body_a: np.ndarray
    body_b: np.ndarray
    num_points: np.ndarray
    point_on_a: np.ndarray
    point_on_b: np.ndarray
    normal_on_b: np.ndarray
    distance: np.ndarray
    normal_force: np.ndarray
    lateral_friction1: np.ndarray
    lateral_dir1: np.ndarray
    lateral_friction2: np.ndarray
    lateral_dir2: np.ndarray

    def __len__(self) -> int:
        return int(self.body_a.shape[0])

    def as_dict(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


class SceneWorld:
    """A pybullet DIRECT client holding one scene; use as a context manager (or call close())."""

    def __init__(self, spec: SceneSpec, scene: str, seed: int, dt: float, pybullet_iterations: int) -> None:
        self.spec, self.scene, self.seed, self.dt = spec, scene, seed, dt
        if len(spec.bodies) > 5000:
            print(f"[{scene}] creating {len(spec.bodies)} bodies in pybullet", file=sys.stderr, flush=True)
        self.pybullet_iterations = pybullet_iterations
        self.client = p.connect(p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not connect to pybullet")
        try:
            self._build()
        except BaseException:
            self.close()
            raise

    # -- construction
    def _build(self) -> None:
        c = self.client
        p.resetSimulation(physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSolverIterations=self.pybullet_iterations,
                                    warmStartingFactor=0, deterministicOverlappingPairs=1, solverResidualThreshold=0,
                                    numSubSteps=0, physicsClientId=c)
        p.setGravity(*GRAVITY, physicsClientId=c)
        shapes: dict[tuple[float, float, float], int] = {}
        shape_ids: list[int] = []
        self.shape_half_extents: list[tuple[float, float, float]] = []
        body_friction = math.sqrt(self.spec.friction)
        ids = []
        for b in self.spec.bodies:
            key = tuple(float(x) for x in b.half_extents)
            if key not in shapes:
                shapes[key] = len(shapes)
                self.shape_half_extents.append(key)
                shape_ids.append(p.createCollisionShape(p.GEOM_BOX, halfExtents=key, physicsClientId=c))
            bid = p.createMultiBody(baseMass=b.mass, baseCollisionShapeIndex=shape_ids[shapes[key]],
                                    basePosition=b.position, baseOrientation=b.orientation,
                                    useMaximalCoordinates=True, physicsClientId=c)
            if bid < 0:
                raise RuntimeError("pybullet could not create a body")
            p.changeDynamics(bid, -1, lateralFriction=body_friction, restitution=0.0, physicsClientId=c)
            if b.mass > 0:
                p.changeDynamics(bid, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=c)
                if any(b.linear_velocity) or any(b.angular_velocity):
                    p.resetBaseVelocity(bid, b.linear_velocity, b.angular_velocity, physicsClientId=c)
            ids.append(bid)
        self.body_ids = np.asarray(ids, dtype=np.int64)
        self.shape_index = np.asarray([shapes[tuple(float(x) for x in b.half_extents)] for b in self.spec.bodies],
                                      dtype=np.int32)
        self.half_extents = np.asarray([b.half_extents for b in self.spec.bodies], dtype=np.float64)
        self.dynamic = np.asarray([b.mass > 0 for b in self.spec.bodies])
        self._index_of = {int(bid): i for i, bid in enumerate(ids)}
        self.steps_done = 0
        dyn = self.half_extents[self.dynamic]
        self._max_depth = 2.0 * float(dyn.max()) if dyn.size else 1.0
        static_info = [p.getDynamicsInfo(int(b), -1, physicsClientId=c) for b in self.body_ids]
        self.inv_mass = np.asarray([1.0 / i[0] if i[0] > 0 else 0.0 for i in static_info])
        self.inertia_local = np.asarray([i[2] if i[0] > 0 else (0.0, 0.0, 0.0) for i in static_info], dtype=np.float64)
        self.friction = np.asarray([i[1] for i in static_info], dtype=np.float64)

    def close(self) -> None:
        if getattr(self, "client", -1) >= 0:
            try:
                p.disconnect(physicsClientId=self.client)
            finally:
                self.client = -1

    def __enter__(self) -> "SceneWorld":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def num_bodies(self) -> int:
        return int(self.body_ids.shape[0])

    # -- stepping and state
    def step(self) -> None:
        p.stepSimulation(physicsClientId=self.client)
        self.steps_done += 1

    def body_state(self) -> dict[str, np.ndarray]:
        c = self.client
        n = self.num_bodies
        pos = np.empty((n, 3))
        orn = np.empty((n, 4))
        lin = np.empty((n, 3))
        ang = np.empty((n, 3))
        for i, bid in enumerate(self.body_ids.tolist()):
            pos[i], orn[i] = p.getBasePositionAndOrientation(bid, physicsClientId=c)
            lin[i], ang[i] = p.getBaseVelocity(bid, physicsClientId=c)
        return dict(position=pos, orientation=orn, linear_velocity=lin, angular_velocity=ang,
                    inv_mass=self.inv_mass.copy(), inertia_local=self.inertia_local.copy(),
                    half_extents=self.half_extents.copy(), shape_index=self.shape_index.copy(),
                    friction=self.friction.copy())

    def set_body_state(self, position: np.ndarray, orientation: np.ndarray, linear_velocity: np.ndarray,
                       angular_velocity: np.ndarray) -> None:
        """Set the state of the dynamic bodies; arrays are over all frame bodies (static rows are ignored)."""
        n = self.num_bodies
        arrs = [np.asarray(a, dtype=np.float64) for a in (position, orientation, linear_velocity, angular_velocity)]
        for a, w in zip(arrs, (3, 4, 3, 3)):
            if a.shape != (n, w):
                raise ValueError(f"set_body_state: expected an array of shape {(n, w)}, got {a.shape}")
        c = self.client
        for i in np.flatnonzero(self.dynamic).tolist():
            bid = int(self.body_ids[i])
            p.resetBasePositionAndOrientation(bid, arrs[0][i].tolist(), arrs[1][i].tolist(), physicsClientId=c)
            p.resetBaseVelocity(bid, arrs[2][i].tolist(), arrs[3][i].tolist(), physicsClientId=c)

    def detect_collisions(self, progress: bool = False) -> Manifolds:
        p.performCollisionDetection(physicsClientId=self.client)
        return self.manifolds(progress=progress)

    def manifolds(self, progress: bool = False) -> Manifolds:
        """The current contact manifolds, from per-body queries (the global query is corrupt at scale)."""
        c = self.client
        index_of = self._index_of
        n = self.num_bodies
        groups: list[list[int]] = []  # [i, j, number of points], in query order
        chunks: list[np.ndarray] = []  # the kept points, 19 floats each (see _COLUMNS)
        t0 = time.monotonic()
        last = t0
        for i, bid in enumerate(self.body_ids.tolist()):
            pts = p.getContactPoints(bodyA=bid, physicsClientId=c)
            cur = -1
            seen: set[int] = set()
            kept: list[tuple[float, ...]] = []
            for pt in pts:
                if pt[1] != bid:
                    raise RuntimeError(f"getContactPoints(bodyA={bid}) reported body {pt[1]} as A")
                j = index_of.get(pt[2])
                if j is None:
                    raise RuntimeError(f"contact with unknown pybullet body id {pt[2]}")
                if j <= i:  # the other side's query keeps this pair
                    continue
                if j != cur:
                    if j in seen:
                        raise RuntimeError(f"the points of pair ({i}, {j}) are not consecutive")
                    seen.add(j)
                    cur = j
                    groups.append([i, j, 0])
                groups[-1][2] += 1
                kept.append((*pt[5], *pt[6], *pt[7], pt[8], pt[9], pt[10], *pt[11], pt[12], *pt[13]))
            if kept:
                chunks.append(np.asarray(kept, dtype=np.float64))
            if progress and time.monotonic() - last > 10.0:
                last = time.monotonic()
                print(f"  contact query: {i + 1}/{n} bodies, {len(groups)} manifolds, {last - t0:.0f} s",
                      file=sys.stderr, flush=True)
        data = np.concatenate(chunks) if chunks else np.zeros((0, 19))
        g = np.asarray(groups, dtype=np.int64).reshape(-1, 3)
        bad = np.flatnonzero(g[:, 2] > 4)
        if bad.size:
            i, j, k = g[bad[0]]
            raise RuntimeError(f"pair ({i}, {j}) has {k} contact points (> 4): corrupt contact report")
        m = g.shape[0]
        starts = np.concatenate([[0], np.cumsum(g[:, 2])[:-1]]) if m else np.zeros(0, np.int64)
        gid = np.repeat(np.arange(m), g[:, 2])
        slot = np.arange(data.shape[0]) - np.repeat(starts, g[:, 2])
        rank = np.empty(m, np.int64)  # manifolds sorted by (body_a, body_b); stable
        rank[np.lexsort((g[:, 1], g[:, 0]))] = np.arange(m)
        row = rank[gid]

        def per_point(cols: slice | int) -> np.ndarray:
            width = () if isinstance(cols, int) else (3,)
            arr = np.zeros((m, 4) + width)
            arr[row, slot] = data[:, cols]
            return arr

        order = np.argsort(rank)
        out = Manifolds(
            body_a=g[order, 0].astype(np.int32), body_b=g[order, 1].astype(np.int32),
            num_points=g[order, 2].astype(np.int32),
            point_on_a=per_point(slice(0, 3)), point_on_b=per_point(slice(3, 6)), normal_on_b=per_point(slice(6, 9)),
            distance=per_point(9), normal_force=per_point(10), lateral_friction1=per_point(11),
            lateral_dir1=per_point(slice(12, 15)), lateral_friction2=per_point(15), lateral_dir2=per_point(slice(16, 19)))
        self._check_manifolds(out)
        return out

    def _check_manifolds(self, m: Manifolds) -> None:
        if len(m) == 0:
            return
        valid = np.arange(4)[None, :] < m.num_points[:, None]
        d = m.distance[valid]
        hi = CONTACT_BREAKING_THRESHOLD + 0.05
        if d.max() > hi or d.min() < -self._max_depth:
            raise RuntimeError(f"contact distance out of the sane range [{-self._max_depth}, {hi}]: "
                               f"[{d.min()}, {d.max()}] (corrupt contact report)")
        norms = np.linalg.norm(m.normal_on_b[valid], axis=1)
        if np.abs(norms - 1.0).max() > 1e-6:
            raise RuntimeError("a contact normal is not a unit vector (corrupt contact report)")
        if m.body_b.max() >= self.num_bodies or m.body_a.min() < 0 or np.any(m.body_a >= m.body_b):
            raise RuntimeError("a manifold names a body index out of range")
        if np.any(~self.dynamic[m.body_a] & ~self.dynamic[m.body_b]):
            raise RuntimeError("a manifold joins two static bodies")

    def capture_step(self, progress: bool = False, extra_meta: dict[str, Any] | None = None) -> Frame:
        """Record the state, run one pybullet step, and return it as a frame (state before, manifolds used,
        pybullet's post-step velocities)."""
        state = self.body_state()
        timing = profiled_step(self.client, self.step)  # pybullet's own timers (seconds) of this very step
        mf = self.manifolds(progress=progress)
        meta = {"pybullet_timing_s": timing, **(extra_meta or {})}
        return _frame_from(self, state, mf, self.body_state(), self.steps_done, meta)

    def solver_settings(self) -> dict[str, Any]:
        eng = p.getPhysicsEngineParameters(physicsClientId=self.client)
        return {
            "numSolverIterations": int(self.pybullet_iterations),
            "fixedTimeStep": float(self.dt),
            "numSubSteps": 0,
            "warmStartingFactor": 0.0,
            "deterministicOverlappingPairs": 1,
            "solverResidualThreshold": 0.0,
            "contactERP": CONTACT_ERP,
            "contactSlop": CONTACT_SLOP,
            "useSplitImpulse": SPLIT_IMPULSE,
            "splitImpulsePenetrationThreshold": SPLIT_IMPULSE_THRESHOLD,
            "contactBreakingThreshold": CONTACT_BREAKING_THRESHOLD,
            "frictionCombine": "product",
            "restitution": 0.0,
            "maximalCoordinates": True,
            "engine_reported": {k: (float(v) if isinstance(v, float) else v) for k, v in eng.items()},
        }


def build_world(scene: str, seed: int = 0, pybullet_iterations: int = 10, dt: float = DEFAULT_DT,
                **params: Any) -> SceneWorld:
    int_param("pybullet_iterations", pybullet_iterations, 1, 10000)
    dt = float_param("dt", dt, 0.0, 1.0, lo_open=True)
    spec = make_spec(scene, seed, **params)
    return SceneWorld(spec, scene, int(seed), dt, int(pybullet_iterations))


def _frame_from(world: SceneWorld, state: dict[str, np.ndarray], mf: Manifolds, post: dict[str, np.ndarray],
                step: int, extra_meta: dict[str, Any]) -> Frame:
    meta = {
        "scene": world.scene,
        "params": world.spec.params,
        "seed": world.seed,
        "step": step,
        "dt": world.dt,
        "gravity": list(GRAVITY),
        "friction_pair": world.spec.friction,
        "pybullet_api_version": int(p.getAPIVersion(physicsClientId=world.client)),
        "pybullet_version": importlib.metadata.version("pybullet"),
        "solver": world.solver_settings(),
        **extra_meta,
    }
    frame = Frame(**state, **mf.as_dict(), post_linear_velocity=post["linear_velocity"],
                  post_angular_velocity=post["angular_velocity"], meta=meta)
    validate(frame)
    return frame


def capture_frame(scene: str, step: int | None = None, busiest_within: int | None = None, seed: int = 0,
                  pybullet_iterations: int = 10, dt: float = DEFAULT_DT, progress: bool | None = None,
                  **params: Any) -> Frame:
    """Run the scene with pybullet's own solver and capture one step (1-based: the step-th stepSimulation).

    The frame holds the body state before that step, the manifolds pybullet's solver used in it (read right
    after stepSimulation) and pybullet's post-step velocities. With ``busiest_within=K`` the step with the
    most manifolds among steps 1..K is captured (per-body queries after every step: cheap only for small
    scenes). With neither, DEFAULT_CAPTURE_STEP[scene] is used."""
    if step is not None and busiest_within is not None:
        raise SceneError("give either step or busiest_within, not both")
    if busiest_within is not None:
        busiest_within = int_param("busiest_within", busiest_within, 1, 100000)
    else:
        step = DEFAULT_CAPTURE_STEP.get(scene, 1) if step is None else step
        step = int_param("step", step, 1, 1000000)
    with build_world(scene, seed=seed, pybullet_iterations=pybullet_iterations, dt=dt, **params) as world:
        if progress is None:
            progress = world.num_bodies > 5000
        t0 = time.monotonic()
        last_step = step if busiest_within is None else busiest_within
        best: Frame | None = None
        extra = {"busiest_within": busiest_within} if busiest_within is not None else {}
        for s in range(1, last_step + 1):
            if busiest_within is None and s != step:
                world.step()
            else:
                frame = world.capture_step(progress=progress, extra_meta=extra)
                if best is None or frame.num_manifolds > best.num_manifolds:
                    best = frame
            if progress:
                print(f"[{scene}] step {s}/{last_step} done ({time.monotonic() - t0:.1f} s)", file=sys.stderr, flush=True)
        assert best is not None
        if progress:
            print(f"[{scene}] captured {best.summary()} in {time.monotonic() - t0:.1f} s", file=sys.stderr, flush=True)
        return best
