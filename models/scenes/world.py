"""A scene in pybullet (a DIRECT client), stepped, and its contacts captured as a frame.

A world comes from a source (``models.scenes.world_source``): a built-in box scene (:class:`SpecSource`,
``models.scenes.specs``) or a file world (``models.scenes.user_world``: a Python world file, a URDF, an asset
scene). Every body is created with ``useMaximalCoordinates=True`` (a btRigidBody, so that pybullet runs Bullet
2's ``btSequentialImpulseConstraintSolver`` rows, see ``models/golden/bullet2_solver.py``): frame body index i is the
i-th body created and ``SceneWorld.body_ids[i]`` its pybullet unique id. Gravity is (0, -9.8, 0) unless a world
file sets another. Mass, inertia diagonal and lateral friction come from ``getDynamicsInfo``
(``models.formats.frame``'s body contract).

Friction: pybullet combines the two bodies' lateral friction as the product muA*muB, so in a built-in scene every
body is given ``sqrt(friction)`` (``Frame.friction``) and a pair gets ``sqrt(f)*sqrt(f)`` (= f to one rounding);
a file world's bodies keep their own.

Conventions of ``getContactPoints(bodyA=b)`` (checked against the global query in the tests): the queried
body is always reported as A; the manifold's own orientation (body0 = the body created first, i.e. the
smaller frame index) is reported unchanged when the queried body is body0; from the other side pybullet
swaps the points and negates the normal. We keep the manifold's own side (queried from the smaller frame index,
or read from the other side and turned back exactly: ``models.scenes.contact_capture``), so ``normal_on_b``
points from B to A, ``distance < 0`` is penetration and the points are in the manifold's own order -- exactly
the rows the solver built.
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

from models.scenes.bullet_profile import profiled_step
from models.formats.frame import Frame, validate
from models.scenes.contact_capture import FrameBodies, Manifolds, query_plan, read_manifolds
from models.scenes.world_source import Population, WorldSource
from models.scenes.specs import DEFAULT_CAPTURE_STEP, SceneSpec, float_param, int_param, make_spec
from models.scenes.scene_error import SceneError
from models.scenes.user_world import is_world_scene, scene_label, world_source

GRAVITY = (0.0, -9.8, 0.0)
DEFAULT_DT = 1.0 / 60.0
# pybullet settings the Bullet 2 reference solver (models/golden/bullet2_solver.py) needs; recorded in the metadata.
CONTACT_ERP = 0.08
CONTACT_SLOP = 1e-5
SPLIT_IMPULSE = 1
SPLIT_IMPULSE_THRESHOLD = -0.04
CONTACT_BREAKING_THRESHOLD = 0.02


@dataclass
class SpecSource:
    """A built-in scene of boxes (``models.scenes.specs``): every body a box, given ``sqrt(friction)``."""

    spec: SceneSpec
    capture_step: int | None = None

    @property
    def params(self) -> dict[str, Any]:
        return self.spec.params

    @property
    def friction_pair(self) -> float | None:
        return self.spec.friction

    @property
    def frame_meta(self) -> dict[str, Any]:
        return {}

    def populate(self, client: int) -> Population:
        c = client
        shapes: dict[tuple[float, float, float], int] = {}
        shape_ids: list[int] = []
        body_friction = math.sqrt(self.spec.friction)
        ids = []
        for b in self.spec.bodies:
            key = tuple(float(x) for x in b.half_extents)
            if key not in shapes:
                shapes[key] = len(shapes)
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
        return Population(
            FrameBodies(np.asarray(ids, dtype=np.int64), np.full(len(ids), -1, dtype=np.int64)),
            np.asarray([b.half_extents for b in self.spec.bodies], dtype=np.float64),
            np.asarray([shapes[tuple(float(x) for x in b.half_extents)] for b in self.spec.bodies], dtype=np.int32))


class SceneWorld:
    """A pybullet DIRECT client holding one scene; use as a context manager (or call close())."""

    def __init__(self, source: WorldSource, scene: str, seed: int, dt: float, pybullet_iterations: int,
                 workers: int | None = None) -> None:
        self.source, self.scene, self.seed, self.dt = source, scene, seed, dt
        self.pybullet_iterations = pybullet_iterations
        self.workers = 1 if workers is None else int_param("workers", workers, 1, 256)
        self.client = p.connect(p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not connect to pybullet")
        try:
            self._build()
        except BaseException:
            self.close()
            raise

    # -- construction
    def _settings(self) -> None:
        c = self.client
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSolverIterations=self.pybullet_iterations,
                                    warmStartingFactor=0, deterministicOverlappingPairs=1, solverResidualThreshold=0,
                                    numSubSteps=0, physicsClientId=c)

    def _build(self) -> None:
        c = self.client
        p.resetSimulation(physicsClientId=c)
        self._settings()
        p.setGravity(*GRAVITY, physicsClientId=c)
        pop = self.source.populate(c)
        self._settings()  # a world file may have changed them
        eng = p.getPhysicsEngineParameters(physicsClientId=c)
        self.gravity = [float(eng[f"gravityAcceleration{a}"]) for a in "XYZ"]
        self.bodies = pop.bodies
        self.body_ids = pop.bodies.ids
        self.body_links = pop.bodies.links
        info = [p.getDynamicsInfo(int(b), int(l), physicsClientId=c) for b, l in zip(self.body_ids, self.body_links)]
        mass = np.asarray([i[0] for i in info], dtype=np.float64)
        self.dynamic = mass > 0
        self.inv_mass = np.where(self.dynamic, 1.0 / np.where(self.dynamic, mass, 1.0), 0.0)
        self.inertia_local = np.asarray([i[2] if i[0] > 0 else (0.0, 0.0, 0.0) for i in info], dtype=np.float64)
        self.friction = np.asarray([i[1] for i in info], dtype=np.float64)
        self.steps_done = 0
        self.measured_extents = pop.half_extents is None
        self.half_extents = self._world_half_extents() if pop.half_extents is None else pop.half_extents
        self.shape_index = distinct_shapes(self.half_extents, self.inv_mass, self.inertia_local) \
            if pop.shape_index is None else pop.shape_index
        dyn = self.half_extents[self.dynamic]
        self._max_depth = 2.0 * float(dyn.max()) if dyn.size else 1.0

    def _world_half_extents(self) -> np.ndarray:
        """Half extents of each body's current world AABB (pybullet's getAABB)."""
        c = self.client
        out = np.empty((self.num_bodies, 3))
        for i, (b, l) in enumerate(zip(self.body_ids.tolist(), self.body_links.tolist())):
            lo, hi = p.getAABB(b, l, physicsClientId=c)
            out[i] = 0.5 * (np.asarray(hi) - np.asarray(lo))
        return out

    def measure_local_half_extents(self) -> np.ndarray:
        """Half extents of each dynamic body's AABB in its own (centre-of-mass) frame: every dynamic body is turned
        to the identity orientation and its getAABB read (this changes the world: only once a capture is done).
        Static bodies keep their world AABB's half extents."""
        c = self.client
        out = self._world_half_extents()
        for i in np.flatnonzero(self.dynamic).tolist():
            b = int(self.body_ids[i])
            pos, _ = p.getBasePositionAndOrientation(b, physicsClientId=c)
            p.resetBasePositionAndOrientation(b, pos, (0.0, 0.0, 0.0, 1.0), physicsClientId=c)
            lo, hi = p.getAABB(b, -1, physicsClientId=c)
            out[i] = 0.5 * (np.asarray(hi) - np.asarray(lo))
        return out

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
        for i, bid in enumerate(self.body_ids.tolist()):  # every frame body is a base (jointed bodies are refused)
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

    def manifolds(self, progress: bool = False, full: bool = False) -> Manifolds:
        """The current contact manifolds, from per-body queries (the global query is corrupt at scale): those of
        a vertex cover of the broadphase (``models.scenes.contact_capture``), or of every body with ``full``;
        the same manifolds either way."""
        if full:
            queried = np.arange(self.num_bodies)
        else:
            queried = query_plan(self.client, self.bodies, self.dynamic, self._plan_margin())
        # boxes make one manifold per pair: the readers may consume their copies of the world
        out = read_manifolds(self.client, self.bodies, queried, self.workers, progress,
                             consume=isinstance(self.source, SpecSource))
        self._check_manifolds(out)
        return out

    def _plan_margin(self) -> float:
        """How far a body may have moved in the last step, plus the contact breaking threshold (m): the AABB growth
        that finds every pair the step's broadphase had."""
        c = self.client
        dyn = np.flatnonzero(self.dynamic).tolist()
        if not dyn:
            return CONTACT_BREAKING_THRESHOLD
        vel = [p.getBaseVelocity(int(self.body_ids[i]), physicsClientId=c) for i in dyn]
        v = max(float(np.linalg.norm(lin)) for lin, _ in vel)
        w = max(float(np.linalg.norm(ang)) for _, ang in vel)
        reach = float(np.linalg.norm(self.half_extents[dyn], axis=1).max())
        return CONTACT_BREAKING_THRESHOLD + 2.0 * self.dt * (v + w * reach) + 0.01

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
                workers: int | None = None, **params: Any) -> SceneWorld:
    """A built-in scene (``models.scenes.specs``), an asset scene or a world file (``.py``/``.urdf``,
    ``models.scenes.user_world``) built in a fresh DIRECT client. ``workers``: forked contact readers (default 1:
    in-process; the result does not depend on it)."""
    int_param("pybullet_iterations", pybullet_iterations, 1, 10000)
    dt = float_param("dt", dt, 0.0, 1.0, lo_open=True)
    source: WorldSource
    if is_world_scene(scene):
        source = world_source(scene, **params)
    else:
        source = SpecSource(make_spec(scene, seed, **params))
        if len(source.spec.bodies) > 5000:
            print(f"[{scene}] creating {len(source.spec.bodies)} bodies in pybullet", file=sys.stderr, flush=True)
    return SceneWorld(source, scene_label(scene), int(seed), dt, int(pybullet_iterations), workers)


def distinct_shapes(half_extents: np.ndarray, inv_mass: np.ndarray, inertia_local: np.ndarray) -> np.ndarray:
    """One shape index per distinct (half extents, inverse mass, inertia), to 9 significant digits (a measured
    AABB varies in its last bits with the body's turn), numbered in order of first appearance."""
    rows = np.column_stack([half_extents, inv_mass[:, None], inertia_local])
    scale = np.where(rows == 0, 1.0, 10.0 ** np.floor(np.log10(np.abs(np.where(rows == 0, 1.0, rows)))))
    _, first, inverse = np.unique(np.round(rows / scale, 8) * scale, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(first.shape[0], dtype=np.int64)
    rank[np.argsort(first)] = np.arange(first.shape[0])
    return rank[inverse.ravel()].astype(np.int32)


def _frame_from(world: SceneWorld, state: dict[str, np.ndarray], mf: Manifolds, post: dict[str, np.ndarray],
                step: int, extra_meta: dict[str, Any]) -> Frame:
    meta = {
        "scene": world.scene,
        "params": world.source.params,
        "seed": world.seed,
        "step": step,
        "dt": world.dt,
        "gravity": world.gravity,
        "friction_pair": world.source.friction_pair,
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
                  workers: int | None = None, **params: Any) -> Frame:
    """Run the scene with pybullet's own solver and capture one step (1-based: the step-th stepSimulation).

    The frame holds the body state before that step, the manifolds pybullet's solver used in it (read right
    after stepSimulation) and pybullet's post-step velocities. With ``busiest_within=K`` the step with the
    most manifolds among steps 1..K is captured (contact queries after every step: cheap only for small
    scenes). With neither, the scene's default step (DEFAULT_CAPTURE_STEP, or a world file's CAPTURE_STEP)."""
    _check_steps(step, busiest_within)
    with build_world(scene, seed=seed, pybullet_iterations=pybullet_iterations, dt=dt, workers=workers,
                     **params) as world:
        return capture_in(world, step, busiest_within, progress)


def _check_steps(step: int | None, busiest_within: int | None) -> None:
    if step is not None and busiest_within is not None:
        raise SceneError("give either step or busiest_within, not both")


def capture_in(world: SceneWorld, step: int | None = None, busiest_within: int | None = None,
               progress: bool | None = None) -> Frame:
    """:func:`capture_frame` in a world just built (no step taken yet)."""
    _check_steps(step, busiest_within)
    scene = world.scene
    if busiest_within is not None:
        busiest_within = int_param("busiest_within", busiest_within, 1, 100000)
    else:
        default = world.source.capture_step or DEFAULT_CAPTURE_STEP.get(scene, 1)
        step = int_param("step", default if step is None else step, 1, 1000000)
    if progress is None:
        progress = world.num_bodies > 5000
    t0 = time.monotonic()
    last_step = step if busiest_within is None else busiest_within
    best: Frame | None = None
    extra = {**world.source.frame_meta, **({"busiest_within": busiest_within} if busiest_within is not None else {})}
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
    if world.measured_extents:  # a file world: each body's own AABB (turns the bodies: the capture is done)
        best.half_extents = world.measure_local_half_extents()
        best.shape_index = distinct_shapes(best.half_extents, world.inv_mass, world.inertia_local)
        if best.num_manifolds == 0:
            raise SceneError(f"world {scene} has no contact at step {best.meta['step']}: nothing for the kernel to "
                             "solve (drop the bodies onto something, or capture a later step)")
    if progress:
        print(f"[{scene}] captured {best.summary()} in {time.monotonic() - t0:.1f} s", file=sys.stderr, flush=True)
    return best
