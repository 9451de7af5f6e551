"""MuJoCo's PGS solver on the same frame: a CPU engine users know, as a peer of the FPGA kernel.

The frame's bodies become an MJCF model (:func:`frame_mjcf`): every dynamic body a box (the frame's half extents) on a
free joint at its pose, with the frame's mass and the scheme's inertia (the body table's world inverse inertia,
turned into a full inertia in the body frame); every static body a box geom of the world body. The state is the
frame's (pybullet's velocities before the step; MuJoCo adds gravity in its own step), and MuJoCo takes one step with
its projected Gauss-Seidel solver (``mjSOL_PGS``), cold (warm start disabled, as Bullet's GPU solver), a fixed number
of sweeps (``tolerance`` 0) or its defaults (100 sweeps, tolerance 1e-8). The constraint solver is timed alone
(``data.timer[mjTIMER_CONSTRAINT]``, a ``mjcb_time`` clock of ``time.perf_counter``), beside the whole step.

What differs from the scheme the kernel solves (so its error against the scheme's exact reference holds the model
difference as well as the iteration error; the converged MuJoCo row shows the model difference alone):

* its own collision detection: MuJoCo's box-box contacts (up to 8 points a pair, penetrating ones only: margin 0),
  not the frame's pybullet manifolds (up to 4 points, speculative ones within 2 cm too);
* soft constraints: every contact row is regularised (``solref`` 0.02 s / damping ratio 1, ``solimp`` defaults), so
  a contact yields a little and the stabilisation acts over 0.02 s instead of Bullet's bias 0.2 (d + 5 mm) / dt;
* the friction cone: pyramidal, mu per pair (edges of the pyramid), where the scheme has a box of two tangents at the
  manifold centroid limited by mu times the manifold's summed normal impulse, plus Bullet's spin damping;
* friction per pair: MuJoCo takes the larger of the two geoms' coefficients; each geom is given the smallest
  coefficient of its manifolds in the scheme (:func:`geom_friction`), which reproduces every manifold's coefficient
  when each manifold has a body at its minimum (the thesis frame: 0.7 everywhere); the rest is counted;
* one PGS sweep updates contact and friction rows together (no "contact passes, then friction passes"), in MuJoCo's
  own row order, in float64;
* the integrator: semi-implicit Euler with gravity inside the step, no angular damping. Its velocities are put into
  the scheme's bookkeeping by the scheme's own integrator (v + g dt, w * 0.99) before they are compared.

Its limits on large scenes are measured by :func:`scaling` (``sim/peers.py`` reports them): every body in one MJCF
model, one ``mjData`` arena (``memory``) sized for the contacts and the broadphase (:func:`arena_bytes`).
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.formats.frame import Frame
from models.golden.integrator import IntegrationParams, integrate
from models.formats.number_format import FLOAT64

import mujoco

CONSTRAINT_TIMER = mujoco.mjtTimer.mjTIMER_CONSTRAINT
STEP_TIMER = mujoco.mjtTimer.mjTIMER_STEP
COLLISION_TIMER = mujoco.mjtTimer.mjTIMER_POS_COLLISION
MAKE_TIMER = mujoco.mjtTimer.mjTIMER_POS_MAKE
DEFAULT_ITERATIONS = 100  # MuJoCo's defaults (mjOption)
# warnings after which a step is not the frame's (contacts or rows left out for want of arena memory)
DROPPING_WARNINGS = (mujoco.mjtWarning.mjWARN_CONTACTFULL, mujoco.mjtWarning.mjWARN_CNSTRFULL)


class MujocoCapacityError(RuntimeError):
    """A MuJoCo step that left contacts or constraint rows out (its arena was too small)."""

DEFAULT_TOLERANCE = 1e-8


@dataclass(frozen=True)
class MujocoSettings:
    """The solver options of a MuJoCo run."""

    iterations: int = 4
    tolerance: float = 0.0  # 0: always ``iterations`` sweeps
    cone: str = "pyramidal"

    def label(self) -> str:
        stop = "fixed" if self.tolerance == 0 else f"tolerance {self.tolerance:g}"
        return f"MuJoCo {mujoco.__version__} PGS, {self.iterations} sweeps ({stop}), {self.cone} cone"


def _quat_wxyz(q_xyzw: np.ndarray) -> np.ndarray:
    return np.asarray(q_xyzw)[..., [3, 0, 1, 2]]


def rotation_matrices(q_xyzw: np.ndarray) -> np.ndarray:
    """(N,3,3) rotation matrices of unit quaternions (x, y, z, w)."""
    x, y, z, w = (np.asarray(q_xyzw, dtype=np.float64)[:, k] for k in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1)], axis=-2)


def _world_inverse_inertia(inv_inertia: np.ndarray) -> np.ndarray:
    """(N,3,3) from the body table's 3 (diagonal) or 6 (xx yy zz xy xz yz) words."""
    n = inv_inertia.shape[0]
    out = np.zeros((n, 3, 3))
    for k in range(3):
        out[:, k, k] = inv_inertia[:, k]
    if inv_inertia.shape[1] == 6:
        for k, (i, j) in enumerate(((0, 1), (0, 2), (1, 2))):
            out[:, i, j] = out[:, j, i] = inv_inertia[:, 3 + k]
    return out


def local_inertia(bodies: BodyTable, idx: np.ndarray) -> np.ndarray:
    """(K,6) the scheme's inertia of bodies ``idx`` in their body frames: R^T (I^-1_world)^-1 R, as MJCF's
    ``fullinertia`` (xx yy zz xy xz yz)."""
    inv_world = _world_inverse_inertia(bodies.inv_inertia[idx])
    rot = rotation_matrices(bodies.orientation[idx])
    local = np.einsum("nji,njk,nkl->nil", rot, np.linalg.inv(inv_world), rot)
    return np.stack([local[:, 0, 0], local[:, 1, 1], local[:, 2, 2], local[:, 0, 1], local[:, 0, 2], local[:, 1, 2]],
                    axis=1)


def scheme_friction(cons: ConstraintSet, friction_coeff: float) -> np.ndarray:
    """(M,) each manifold's friction coefficient in the scheme (its own where it carries one, else the solver's)."""
    return cons.friction[:, 0].copy() if cons.per_manifold_friction else np.full(cons.num_manifolds, friction_coeff)


def geom_friction(cons: ConstraintSet, num_bodies: int, friction_coeff: float) -> tuple[np.ndarray, int]:
    """Each body's geom friction under MuJoCo's max rule: the smallest coefficient of its manifolds (bodies in none:
    the solver's), and how many manifolds MuJoCo then gives another coefficient than the scheme."""
    mu = scheme_friction(cons, friction_coeff)
    per_body = np.full(num_bodies, np.inf)
    np.minimum.at(per_body, cons.body_a, mu)
    np.minimum.at(per_body, cons.body_b, mu)
    per_body[~np.isfinite(per_body)] = friction_coeff
    mujoco_mu = np.maximum(per_body[cons.body_a], per_body[cons.body_b])
    return per_body, int(np.count_nonzero(~np.isclose(mujoco_mu, mu, rtol=0, atol=1e-12)))


ARENA_PER_BODY = 128 << 10  # contacts, rows and their Jacobians: 85 to 91 kB a body measured on the thesis frame
BROADPHASE_BYTES_PER_PAIR = 4  # mj_broadphase takes about 2 n^2 bytes of the arena, twice (38,881 geoms: 3.02 GB each)


def arena_bytes(dynamic_bodies: int, geoms: int) -> int:
    """The mjData arena a frame needs (``<size memory>``): the contacts' share per dynamic body (measured: 85 to 91 kB
    a body on blocks of 1,000 and 3,000 bodies of the thesis frame) and the broadphase's, quadratic in the geoms
    (``mj_stackAlloc`` asked 3.02 GB for the 38,881 geoms of the thesis frame, with as much already taken). Pages are
    only touched on use, but the address space is reserved."""
    return int(max(64 << 20, dynamic_bodies * ARENA_PER_BODY + BROADPHASE_BYTES_PER_PAIR * geoms * geoms))


def frame_mjcf(frame: Frame, bodies: BodyTable, geom_mu: np.ndarray, settings: MujocoSettings,
               keep: Optional[np.ndarray] = None) -> str:
    """The MJCF model of the frame's bodies (``keep``: their indices, default all) at the frame's poses."""
    idx = np.arange(frame.num_bodies) if keep is None else np.asarray(keep, dtype=np.int64)
    dyn = bodies.dynamic[idx]
    g = np.asarray(frame.gravity, dtype=np.float64)
    quat = _quat_wxyz(frame.orientation[idx])
    size = frame.half_extents[idx]
    pos = frame.position[idx]
    inertia = local_inertia(bodies, idx[dyn])

    def vec(v: np.ndarray) -> str:
        return " ".join(repr(float(x)) for x in v)

    lines = ['<mujoco model="frame">',
             f'  <option timestep="{float(frame.dt)!r}" gravity="{vec(g)}" solver="PGS" '
             f'iterations="{settings.iterations}" tolerance="{float(settings.tolerance)!r}" cone="{settings.cone}">',
             '    <flag warmstart="disable"/>', '  </option>',
             f'  <size memory="{arena_bytes(int(dyn.sum()), int(idx.shape[0]))}"/>', '  <worldbody>']

    k_dyn = 0
    for k, body in enumerate(idx.tolist()):
        geom = (f'<geom type="box" size="{vec(size[k])}" friction="{float(geom_mu[body])!r} 0 0" condim="3"')
        if not dyn[k]:
            lines.append(f'    {geom} pos="{vec(pos[k])}" quat="{vec(quat[k])}"/>')
            continue
        lines.append(f'    <body name="b{body}" pos="{vec(pos[k])}" quat="{vec(quat[k])}"><freejoint/>'
                     f'<inertial pos="0 0 0" mass="{1.0 / float(bodies.inv_mass[body])!r}" '
                     f'fullinertia="{vec(inertia[k_dyn])}"/>{geom}/></body>')
        k_dyn += 1
    lines += ['  </worldbody>', '</mujoco>']
    return "\n".join(lines)


@dataclass(frozen=True)
class MujocoStep:
    """One MuJoCo step of a frame: its timings (median of ``runs``, ms) and what it found."""

    settings: MujocoSettings
    bodies: int  # dynamic bodies in the model
    contacts: int  # data.ncon
    rows: int  # data.nefc: constraint rows (pyramid edges)
    runs: int
    constraint_ms: float  # mjTIMER_CONSTRAINT: the constraint solver alone
    step_ms: float  # mjTIMER_STEP: the whole step (collision, constraint set-up, solver, integration)
    collision_ms: float
    make_ms: float  # building the constraint rows (Jacobians, regularisation)
    compile_s: float  # MJCF to mjModel
    friction_mismatches: int  # manifolds whose MuJoCo friction differs from the scheme's
    final: BodyTable  # MuJoCo's velocities in the scheme's bookkeeping (integrated by the scheme's integrator)


class MujocoFrame:
    """A frame as a compiled MuJoCo model, steppable from the frame's state."""

    def __init__(self, frame: Frame, bodies: BodyTable, cons: ConstraintSet, settings: MujocoSettings,
                 friction_coeff: float, keep: Optional[np.ndarray] = None):
        if settings.iterations < 1 or not settings.tolerance >= 0:
            raise ValueError(f"MuJoCo needs iterations >= 1 and tolerance >= 0, got {settings}")
        self.frame, self.bodies, self.settings = frame, bodies, settings
        self.keep = np.arange(frame.num_bodies) if keep is None else np.sort(np.asarray(keep, dtype=np.int64))
        self.geom_mu, self.friction_mismatches = geom_friction(cons, frame.num_bodies, friction_coeff)
        t0 = time.perf_counter()
        self.model = mujoco.MjModel.from_xml_string(frame_mjcf(frame, bodies, self.geom_mu, settings, self.keep))
        self.compile_s = time.perf_counter() - t0
        self.data = mujoco.MjData(self.model)
        self.dynamic = self.keep[bodies.dynamic[self.keep]]  # frame indices, in the model's body order
        rot = rotation_matrices(frame.orientation[self.dynamic])
        w_local = np.einsum("nji,nj->ni", rot, frame.angular_velocity[self.dynamic])
        self._qvel = np.concatenate([frame.linear_velocity[self.dynamic], w_local], axis=1).ravel()
        self._rot = rot

    def reset(self) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self.data.qvel[:] = self._qvel

    def step(self) -> None:
        self.reset()
        mujoco.mj_step(self.model, self.data)

    def _step_within_arena(self) -> None:
        try:
            self.step()
        except mujoco.FatalError as exc:
            if "out of memory" not in str(exc):
                raise
            raise MujocoCapacityError(f"MuJoCo's arena of {self.model.narena:,} bytes is too small for this model: "
                                      f"{str(exc).splitlines()[0]}") from exc

    def final(self, ip: IntegrationParams) -> BodyTable:
        """MuJoCo's post-step velocities (angular ones to world axes at the frame's orientation) for every frame
        body (the others keep the frame's, as the scheme's table holds them), integrated by the scheme's integrator
        so that they compare with the scheme's steps (v + g dt, w * 0.99; positions are not compared)."""
        qvel = self.data.qvel.reshape(-1, 6)
        solved = self.bodies.copy()
        solved.linear_velocity[self.dynamic] = qvel[:, :3]
        solved.angular_velocity[self.dynamic] = np.einsum("nij,nj->ni", self._rot, qvel[:, 3:])
        return integrate(solved, FLOAT64, ip)

    def timed(self, runs: int, ip: IntegrationParams) -> MujocoStep:
        """The step's timers, median of ``runs`` steps from the frame's state (after one warm-up step when ``runs`` >
        1; a single run is the first step, as a user of a model this large gets it)."""
        if runs < 1:
            raise ValueError(f"runs must be >= 1, got {runs}")
        previous = mujoco.get_mjcb_time()
        mujoco.set_mjcb_time(time.perf_counter)
        try:
            if runs > 1:
                self._step_within_arena()
            samples = []
            for _ in range(runs):
                self._step_within_arena()
                t = self.data.timer
                samples.append([t[k].duration * 1e3 for k in (CONSTRAINT_TIMER, STEP_TIMER, COLLISION_TIMER,
                                                                 MAKE_TIMER)])
        finally:
            mujoco.set_mjcb_time(previous)
        dropped = {w.name: self.data.warning[w].number for w in DROPPING_WARNINGS if self.data.warning[w].number}
        if dropped:
            raise MujocoCapacityError(f"MuJoCo dropped contacts or constraint rows ({dropped}): its arena of "
                                      f"{self.model.narena:,} bytes is too small for this model")
        med = [statistics.median(col) for col in zip(*samples)]
        return MujocoStep(self.settings, int(self.dynamic.shape[0]), int(self.data.ncon), int(self.data.nefc), runs,
                          *med, self.compile_s, self.friction_mismatches, self.final(ip))


def step_frame(frame: Frame, bodies: BodyTable, cons: ConstraintSet, settings: MujocoSettings,
               friction_coeff: float, ip: IntegrationParams, runs: int = 5,
               keep: Optional[np.ndarray] = None) -> MujocoStep:
    """Compile the frame (or the bodies ``keep``) and time ``runs`` steps (see :class:`MujocoFrame`)."""
    return MujocoFrame(frame, bodies, cons, settings, friction_coeff, keep).timed(runs, ip)


def nearest_bodies(frame: Frame, dynamic: np.ndarray, count: int) -> np.ndarray:
    """The frame's static bodies and its ``count`` dynamic bodies nearest the lowest corner of the pile (a block of
    the pile that grows with ``count``, for the scaling study)."""
    dyn = np.flatnonzero(dynamic)
    if not 1 <= count <= dyn.shape[0]:
        raise ValueError(f"count must be in 1..{dyn.shape[0]}, got {count}")
    corner = frame.position[dyn].min(axis=0)
    dist = np.linalg.norm(frame.position[dyn] - corner, axis=1)
    chosen = dyn[np.argsort(dist, kind="stable")[:count]]
    return np.sort(np.concatenate([np.flatnonzero(~dynamic), chosen]))

