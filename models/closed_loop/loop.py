"""Closed loop: pybullet does collision detection only; our GPU-style solver and integrator do the dynamics.

Each step writes our body state into pybullet, runs ``performCollisionDetection``, turns the manifolds into
constraints, solves them with the reference PGS solver (float64 or a bit-accurate number format) in the
chosen schedule, integrates, and keeps the result. The metrics per step are the ones the hard-case suite
reports: penetration, drift of the bodies from where the loop started, speed, kinetic energy and NaN/Inf.

pybullet's state is moved to the GPU convention when the loop starts (g*dt added to dynamic linear
velocities, see ``constraints.body_table_from_state``): at rest the stored velocity is then -g*dt, as on the GPU.

The inverse inertia follows the loop's Bullet convention (``models/setup/inertia.py``): ``bullet2`` recomputes
``R diag R^T`` from every step's orientation (Bullet 2's ``updateInertiaTensor``) and takes the pairs' combined
friction (per manifold where it differs from the solver's one coefficient); ``bullet_gpu`` registers it once at
the loop's first state and never updates it; ``world_axes`` (the default) keeps the unrotated diagonal.

A :class:`Remedy` changes how a step is solved, never the contacts: ``warm_factor`` > 0 warm starts every step
from the previous one's impulses (``models/golden/warm_start.py``: points matched as Bullet 2 matches them, applied on
the host at setup, the loop carrying the :class:`~models.golden.warm_start.ContactMemory` step to step); ``substeps`` >
1 solves a step as that many kernel calls of dt / n (``models/golden/substep.py``); ``soft`` runs Box2D v3's soft step,
each substep a soft solve call and (``relax``) a relax call (``models/golden/soft_contact.py``); ``shock`` solves
ground-up in layers and makes the last contact pass of each kernel call (of a soft substep: its relax call) a shock pass
(``models/golden/shock_propagation.py``), ``shock_friction`` the last friction pass too. :data:`COLD` (the default) is
Bullet's GPU scheme.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable, Optional

import numpy as np

from models import scenes
from models.setup.constraints import BodyTable, ConstraintSet, body_table_from_state, setup_constraints
from models.golden.contact_solver import Impulses, SolverParams, solve
from models.formats.frame import Frame
from models.formats.frame import CONVENTION_KEY, DEFAULT_CONVENTION, BulletConvention
from models.setup.inertia import convention_inverse_inertia, quat_to_matrix
from models.golden.integrator import IntegrationParams, integrate
from models.formats.number_format import FLOAT64, Arithmetic
from models.order.manifold_schedule import make_schedule
from models.golden.shock_propagation import shock_step
from models.golden.soft_contact import SoftContact, add_gravity, relax_constraints, soft_constraints
from models.golden.substep import ContactPoints, substep_constraints
from models.golden.warm_start import ContactMemory, Contacts, WarmStartReport, apply_impulses, warm_start


# one kernel call: (bodies, constraints, schedule, initial impulses or None: zeros) -> (bodies after solve and
# integration, the accumulated impulses after the last pass); values in the loop's format. ``golden_stepper`` is the
# reference model; ``sim.drive.rtl_stepper.rtl_stepper`` runs the RTL kernel.
Stepper = Callable[[BodyTable, ConstraintSet, np.ndarray, Optional[Impulses]], tuple[BodyTable, Impulses]]
StepperFactory = Callable[[Arithmetic, SolverParams, IntegrationParams], Stepper]


def golden_stepper(ar: Arithmetic, solver: SolverParams, ip: IntegrationParams) -> Stepper:
    def step(bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
             initial: Optional[Impulses] = None) -> tuple[BodyTable, Impulses]:
        res = solve(bodies, cons, order, ar, solver, initial=initial)
        return integrate(res.bodies, ar, ip), res.impulses

    return step


@dataclass(frozen=True)
class Remedy:
    """How each step is solved: warm starting (factor; 0: cold) and substeps (kernel calls of dt / n per step)."""

    name: str
    warm_factor: float = 0.0
    substeps: int = 1
    relax: bool = False  # the last substep without the position correction (models/golden/substep.py); soft: a relax call
    soft: Optional[SoftContact] = None  # Box2D's soft contact (models/golden/soft_contact.py), each substep a kernel call
    shock: bool = False  # shock propagation (models/golden/shock_propagation.py): layer order, the last contact pass frozen
    shock_friction: bool = False  # ... and the last friction pass of each call too
    shock_impulses: str = "keep"  # of the frozen rows: "keep", "drop", "return" (SolverParams.shock_impulses)
    shock_passes: int = 1  # the last n passes of each shocked kind in each call (the scheme: 1)
    shock_linear: bool = False  # a shock row moves the upper body along the normal only (no angular write)
    shock_hazard: bool = False  # each layer pair's manifolds in the hazard order of the loop's window

    def __post_init__(self) -> None:
        if (self.shock_friction or self.shock_hazard) and not self.shock:
            raise ValueError(f"remedy {self.name}: shock_friction and shock_hazard need shock")
        if self.shock and self.soft is not None and not self.relax:
            raise ValueError(f"remedy {self.name}: a soft shock remedy shocks its relax call (needs relax)")
        if self.relax and self.substeps < 2 and self.soft is None:
            raise ValueError(f"remedy {self.name}: a relax substep needs substeps >= 2 (one to correct positions)")
        if self.substeps < 1 or not 0.0 <= self.warm_factor <= 1.0:
            raise ValueError(f"remedy {self.name}: substeps must be >= 1 and the warm-start factor in [0, 1], got "
                             f"{self.substeps} and {self.warm_factor}")

    @property
    def warm(self) -> bool:
        return self.warm_factor > 0.0

    @property
    def calls_per_substep(self) -> int:
        """Kernel calls per substep: a soft substep with relax is a solve call and a relax call."""
        return 2 if self.soft is not None and self.relax else 1

    @property
    def calls_per_step(self) -> int:
        return self.substeps * self.calls_per_substep

    def passes_per_step(self, solver: SolverParams) -> int:
        """Manifold-passes per step, all kernel calls included (a contact and a friction pass per iteration of
        ``solver``, the call's)."""
        return 2 * solver.iterations * self.calls_per_step


COLD = Remedy("cold")


@dataclass
class LoopResult:
    scene: str
    steps: int
    format: str
    iterations: int
    max_penetration: np.ndarray  # (steps,) m, deepest contact at each step's collision detection
    max_speed: np.ndarray  # (steps,) m/s after each step
    median_speed: np.ndarray  # (steps,)
    kinetic_energy: np.ndarray  # (steps,) J
    nonfinite: np.ndarray  # (steps,) count of NaN/Inf values in the body state
    manifolds: np.ndarray  # (steps,)
    drift: np.ndarray  # (N_dynamic,) |x_end - x_start| per dynamic body (m)
    final: BodyTable
    start_position: np.ndarray
    extra: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, float]:
        return {
            "steps": self.steps,
            "max penetration (m)": float(np.max(self.max_penetration, initial=0.0)),
            "max drift (m)": float(np.max(self.drift, initial=0.0)),
            "median drift (m)": float(np.median(self.drift)) if self.drift.size else 0.0,
            "max speed (m/s)": float(np.max(self.max_speed, initial=0.0)),
            "final median speed (m/s)": float(self.median_speed[-1]) if self.steps else 0.0,
            "final kinetic energy (J)": float(self.kinetic_energy[-1]) if self.steps else 0.0,
            "NaN/Inf values": int(np.sum(self.nonfinite)),
        }


def _kinetic_energy(bodies: BodyTable, inertia_local: np.ndarray) -> float:
    """Translational plus rotational energy with the true inertia (the angular velocity in the principal frame)."""
    dyn = bodies.dynamic
    mass = 1.0 / bodies.inv_mass[dyn]
    v2 = np.sum(bodies.linear_velocity[dyn] ** 2, axis=1)
    w_body = np.einsum("nji,nj->ni", quat_to_matrix(bodies.orientation[dyn]), bodies.angular_velocity[dyn])
    rot = np.sum(inertia_local[dyn] * w_body * w_body, axis=1)
    return float(0.5 * np.sum(mass * v2) + 0.5 * np.sum(rot))


def _contact_frame(world: scenes.SceneWorld, bodies: BodyTable, mf: scenes.Manifolds, state: dict[str, np.ndarray],
                   gravity: np.ndarray, convention: BulletConvention) -> Frame:
    """A Frame view of this step's contacts (only the fields the constraint setup reads are meaningful)."""
    n = bodies.num_bodies
    return Frame(position=bodies.position, orientation=bodies.orientation, linear_velocity=bodies.linear_velocity,
                 angular_velocity=bodies.angular_velocity, inv_mass=bodies.inv_mass,
                 inertia_local=state["inertia_local"], half_extents=state["half_extents"],
                 shape_index=state["shape_index"], friction=state["friction"], **mf.as_dict(),
                 post_linear_velocity=np.zeros((n, 3)), post_angular_velocity=np.zeros((n, 3)),
                 meta={"dt": world.dt, "gravity": gravity.tolist(), "scene": world.scene,
                       CONVENTION_KEY: convention.value})


def run_closed_loop(scene: str, steps: int, ar: Arithmetic = FLOAT64, iterations: int = 4,
                    schedule: str = "pybullet", window: int = 64, settle_steps: int = 0, warmup_steps: int = 0,
                    seed: int = 0, stepper: StepperFactory = golden_stepper,
                    convention: BulletConvention = DEFAULT_CONVENTION, remedy: Remedy = COLD,
                    **params: Any) -> LoopResult:
    """Run ``steps`` closed-loop steps of a scene and measure them, inertia and friction in ``convention``.

    ``settle_steps`` of pybullet's own solver come first; then ``warmup_steps`` of our own loop, which are
    not measured (a stack sinks to the GPU solver's 5 mm resting penetration per contact); drift is
    measured from the end of the warm-up. ``stepper`` makes the function that solves and integrates each kernel
    call; ``remedy`` says how a step is solved (the warm-start report and the kernel calls land in ``extra``).
    """
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    with scenes.build_world(scene, seed=seed, **params) as world:
        for _ in range(settle_steps):
            world.step()
        state = world.body_state()
        gravity = np.asarray(scenes.GRAVITY, dtype=np.float64)
        ip = IntegrationParams(dt=world.dt / remedy.substeps, gravity=tuple(gravity))
        solver = SolverParams(iterations=iterations, shock_contact=remedy.shock,
                              shock_friction=remedy.shock_friction, shock_impulses=remedy.shock_impulses,
                              shock_passes=remedy.shock_passes)  # bullet2's pairs carry their friction per manifold
        bodies = body_table_from_state(state, gravity, world.dt, convention=convention).rounded(ar)
        advance = stepper(ar, solver, ip) if remedy.soft is None else _SoftCalls.of(stepper, ar, solver, ip, remedy)
        carried = _RemedyState()
        dyn = bodies.dynamic
        rows: dict[str, list[float]] = {k: [] for k in ("pen", "vmax", "vmed", "ke", "bad", "man")}
        start = bodies.position.copy()
        for step in range(warmup_steps + steps):
            if step == warmup_steps:
                start = bodies.position.copy()
                rows = {k: [] for k in rows}
            if convention is BulletConvention.BULLET2:
                bodies.inv_inertia = ar.round(convention_inverse_inertia(
                    convention, bodies.orientation, bodies.inv_mass, state["inertia_local"], state["half_extents"]))
            world.set_body_state(bodies.position, bodies.orientation, bodies.linear_velocity, bodies.angular_velocity)
            mf = world.detect_collisions()
            frame = _contact_frame(world, bodies, mf, state, gravity, convention)
            cons = setup_constraints(frame, bodies, solver.friction_coeff).rounded(ar)
            order = make_schedule(schedule, cons, dyn, window)
            if remedy.shock:
                cons, order = shock_step(cons, bodies, order, ar, remedy.shock_linear,
                                         window if remedy.shock_hazard else 0)
            bodies = (_remedy_step(remedy, advance, bodies, cons, order, mf, ar, solver, ip.dt, carried)
                      if remedy.soft is None else _soft_step(remedy, advance, bodies, cons, order, mf, ar, solver,
                                                             carried))
            valid = np.arange(4)[None, :] < mf.num_points[:, None]
            speed = np.linalg.norm(bodies.linear_velocity[dyn], axis=1)
            rows["pen"].append(float(np.max(-mf.distance[valid], initial=0.0)))
            rows["vmax"].append(float(np.max(speed, initial=0.0)))
            rows["vmed"].append(float(np.median(speed)) if speed.size else 0.0)
            rows["ke"].append(_kinetic_energy(bodies, state["inertia_local"]))
            rows["bad"].append(int(sum(np.sum(~np.isfinite(getattr(bodies, f))) for f in
                                       ("position", "orientation", "linear_velocity", "angular_velocity"))))
            rows["man"].append(len(mf))
    return LoopResult(
        scene=scene, steps=steps, format=ar.name, iterations=iterations,
        max_penetration=np.asarray(rows["pen"]), max_speed=np.asarray(rows["vmax"]),
        median_speed=np.asarray(rows["vmed"]), kinetic_energy=np.asarray(rows["ke"]),
        nonfinite=np.asarray(rows["bad"]), manifolds=np.asarray(rows["man"]),
        drift=np.linalg.norm(bodies.position[dyn] - start[dyn], axis=1), final=bodies, start_position=start,
        extra={"remedy": remedy.name, "passes per step": remedy.passes_per_step(solver),
               "kernel calls": carried.calls, "calls per step": remedy.calls_per_step, "warm start": carried.report.as_dict(),
               "last step": carried.last},
    )


@dataclass
class _RemedyState:
    """What the loop carries from step to step for its remedy."""

    memory: Optional[ContactMemory] = None  # the last step's contacts and impulses (warm starting)
    report: WarmStartReport = field(default_factory=WarmStartReport)
    calls: int = 0
    last: Optional["StepInput"] = None


@dataclass(frozen=True)
class StepInput:
    """What the loop's last step was solved from: the bodies before any warm start was applied, the constraints as
    set up (the collision detection's bias), the schedule, and the warm start's initial impulses (None: cold)."""

    bodies: BodyTable
    cons: ConstraintSet
    order: np.ndarray
    initial: Optional[Impulses]


def _step_start(remedy: Remedy, bodies: BodyTable, cons: ConstraintSet, order: np.ndarray, mf: scenes.Manifolds,
                ar: Arithmetic, solver: SolverParams,
                state: _RemedyState) -> tuple[Optional[Impulses], Optional[Contacts]]:
    """A step's start: a warm remedy's initial impulses from the carried memory and the step's contacts (which the
    next step's memory is kept of), else (None, None); what the step is solved from recorded in ``state.last``."""
    initial: Optional[Impulses] = None
    contacts: Optional[Contacts] = None
    if remedy.warm:
        contacts = Contacts.of(mf.body_a, mf.body_b, mf.num_points, mf.point_on_a, bodies)
        ws = warm_start(state.memory, contacts, cons, solver.friction_coeff, remedy.warm_factor)
        state.report.add(ws.report)
        initial = Impulses(ar.round(ws.impulses.normal), ar.round(ws.impulses.friction))
    state.last = StepInput(bodies, cons, order, initial)
    return initial, contacts


def _contact_points(cons: ConstraintSet, mf: scenes.Manifolds, bodies: BodyTable) -> tuple[np.ndarray, ContactPoints]:
    """The step's valid points (K, 4) and the contact points the substeps' separations are measured at."""
    valid = np.arange(4)[None, :] < mf.num_points[:, None]
    return valid, ContactPoints(cons.body_a, cons.body_b, valid, mf.normal_on_b[:, 0, :], mf.point_on_a,
                                mf.point_on_b, bodies.position.astype(np.float64),
                                bodies.orientation.astype(np.float64))


def _remember(state: _RemedyState, contacts: Optional[Contacts], cons: ConstraintSet, impulses: Impulses) -> None:
    """A warm remedy's memory for the next step: the step's contacts and its last call's impulses."""
    if contacts is not None:
        state.memory = ContactMemory.of(contacts, cons, impulses)


def _remedy_step(remedy: Remedy, advance: Stepper, bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
                 mf: scenes.Manifolds, ar: Arithmetic, solver: SolverParams, call_dt: float,
                 state: _RemedyState) -> BodyTable:
    """One step: the warm start from the carried memory (if warm), then the remedy's kernel calls."""
    initial, contacts = _step_start(remedy, bodies, cons, order, mf, ar, solver, state)
    points = _contact_points(cons, mf, bodies)[1] if remedy.substeps > 1 else None
    for k in range(remedy.substeps):
        call = cons if points is None else substep_constraints(
            cons, points, bodies, call_dt, ar, relax=remedy.relax and k == remedy.substeps - 1)
        if initial is not None:
            bodies = apply_impulses(bodies, call, initial, ar)
        bodies, impulses = advance(bodies, call, order, initial)
        state.calls += 1
        if remedy.warm:
            initial = impulses  # Box2D's warm start between substeps: the accumulated impulses in full
    _remember(state, contacts, cons, impulses)
    return bodies


@dataclass(frozen=True)
class _SoftCalls:
    """The kernel calls of a soft substep: ``solve`` (the soft update, then the position update; gravity too when
    there is no relax call) and ``relax`` (rigid, then no position update: gravity is added after it)."""

    solve: Stepper
    relax: Optional[Stepper]
    h: float
    gravity: tuple[float, float, float]

    @staticmethod
    def of(stepper: StepperFactory, ar: Arithmetic, solver: SolverParams, ip: IntegrationParams,
           remedy: Remedy) -> "_SoftCalls":
        assert remedy.soft is not None
        soft = replace(solver, soft_keep=remedy.soft.keep(ip.dt))
        if not remedy.relax:
            return _SoftCalls(stepper(ar, soft, ip), None, ip.dt, ip.gravity)
        # a shock remedy shocks the substep's last contact pass, its relax call's: the soft call has none
        soft = replace(soft, shock_contact=False, shock_friction=False)
        still = (0.0, 0.0, 0.0)
        return _SoftCalls(stepper(ar, soft, replace(ip, gravity=still)),
                          stepper(ar, solver, IntegrationParams(dt=0.0, gravity=still, damping=1.0)), ip.dt,
                          ip.gravity)


def _soft_step(remedy: Remedy, calls: Any, bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
               mf: scenes.Manifolds, ar: Arithmetic, solver: SolverParams, state: _RemedyState) -> BodyTable:
    """One step in Box2D v3's substeps (``models/golden/soft_contact.py``): per substep of h = dt / n the warm start
    (accumulated impulses applied on the host), a soft solve call with the bias from each point's separation now,
    the position update, then (``remedy.relax``) a relax call on the separation after it, and gravity ``g h``.

    In the GPU convention the stored velocity already holds the substep's gravity when a call starts (Box2D adds it
    at the substep's start): the solve call sees what Box2D's solve sees, the relax call sees the velocities after
    the position update without the next substep's gravity, as in Box2D."""
    assert remedy.soft is not None
    initial, contacts = _step_start(remedy, bodies, cons, order, mf, ar, solver, state)
    valid, points = _contact_points(cons, mf, bodies)
    impulses = Impulses.zeros(cons.num_manifolds)
    for _ in range(remedy.substeps):
        call = soft_constraints(cons, points.separation(bodies), valid, bodies, calls.h, remedy.soft, ar)
        if initial is not None:
            bodies = apply_impulses(bodies, call, initial, ar)
        bodies, impulses = calls.solve(bodies, call, order, initial)
        state.calls += 1
        if calls.relax is not None:
            rows = relax_constraints(cons, points.separation(bodies), valid, calls.h, ar)
            bodies, impulses = calls.relax(bodies, rows, order, impulses)  # continues the solve's impulses
            bodies = add_gravity(bodies, ar, calls.gravity, calls.h)
            state.calls += 1
        initial = impulses if remedy.warm else None
    _remember(state, contacts, cons, impulses)
    return bodies
