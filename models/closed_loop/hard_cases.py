"""The hard-case suite: scenes that break PGS solvers, run closed loop and judged on physical quantities.

Every case runs ``models.closed_loop.loop.run_closed_loop`` (pybullet collision detection, our solver and integrator)
for a stated number of steps, in a number format and an iteration count, with a
``models.closed_loop.trajectory.TrajectoryRecorder`` on its stepper, and is judged on

* max penetration: the deepest contact collision detection saw over the measured steps,
* per body the largest excursion from where the measured steps began, and its path length (the sum of its
  per-step moves: a body that jitters and comes back has no net displacement but a long path),
* speed net of ``g*dt``: a body at rest stores a velocity of g*dt = 0.163 m/s (the GPU convention: gravity is
  added after the position update), which is not motion; the judge subtracts it,
* NaN/Inf values in the body state (always 0 to pass),

with kinetic energy over time kept for the plots. The limits are defined once (:data:`LIMITS`), each from
Bullet's own contact constants (``models.setup.constraints``: the slop ``POSITION_DRIFT`` = 5 mm at which the bias holds
a resting contact, the bias factor ``POSITION_COEFF``) or the case's physics, with the reason stated. A format or
iteration count that fails a case is a finding to report, not a test failure: ``make stability`` prints the
table and ``make test`` runs a quick subset whose expected outcomes are asserted.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from models.closed_loop.loop import COLD, LoopResult, Remedy, Stepper, StepperFactory, golden_stepper, run_closed_loop
from models.setup.constraints import POSITION_COEFF, POSITION_DRIFT, BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses, SolverParams
from models.timing.cycle_model import predict_job
from models.timing.platforms import DmaPreset, get_preset
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import Arithmetic, NumberFormat
from models.golden.soft_contact import SoftContact
from models.golden.warm_start import WARMSTART_FACTOR
from models.scenes import GRAVITY
from models.scenes.world import DEFAULT_DT
from models.closed_loop.trajectory import Trajectory, TrajectoryRecorder

G = float(np.linalg.norm(GRAVITY))  # m/s^2


@dataclass(frozen=True)
class Limit:
    """One threshold: its value, unit and why it has that value."""

    value: float
    unit: str
    reason: str

    def __str__(self) -> str:
        return f"{self.value:.3g} {self.unit}"


LIMITS: dict[str, Limit] = {
    "rest penetration": Limit(
        2 * POSITION_DRIFT, "m",
        "twice Bullet's slop: the bias holds a resting contact at the slop depth (positionDrift, 5 mm) and removes "
        "a fifth of any further depth per step, so a contact one more slop deep has sunk past what the bias allows"),
    "rest speed": Limit(
        POSITION_COEFF * POSITION_DRIFT / DEFAULT_DT, "m/s",
        "the separating speed the bias gives a contact one slop deeper than its rest depth (0.2 x 5 mm / dt): "
        "slower than that, net of g*dt, a body is settling under the bias, not moving"),
    "rest excursion": Limit(
        POSITION_DRIFT, "m",
        "one slop: after the warm-up a resting body's contacts are at their rest depth, so it may sink by the slop "
        "at most"),
    "rest path": Limit(
        2 * POSITION_DRIFT, "m",
        "two slops: sink by the slop and come back once; a longer path over the measured steps is jitter"),
}


def impact_penetration(speed: float) -> Limit:
    """The deepest contact allowed when a body arrives at ``speed``: no continuous collision detection, so its
    first contact can be one step's travel deep."""
    return Limit(LIMITS["rest penetration"].value + speed * DEFAULT_DT, "m",
                 f"rest penetration plus one step of travel at {speed:g} m/s: without continuous collision "
                 "detection the first contact appears up to v*dt deep")


def impact_speed(speed: float, steps: int) -> Limit:
    """The fastest any body may move after a hit at ``speed``: restitution 0, so contacts add no energy."""
    return Limit(speed + G * steps * DEFAULT_DT, "m/s",
                 f"the projectile's {speed:g} m/s plus free fall over the run: contacts (restitution 0) add no "
                 "energy, an explosion does")


def slide_distance(angle_deg: float, friction: float, steps: int) -> Limit:
    """Half the distance Coulomb friction lets a box slide down the slope in ``steps`` steps."""
    a = math.radians(angle_deg)
    accel = G * (math.sin(a) - friction * math.cos(a))
    t = steps * DEFAULT_DT
    return Limit(0.25 * accel * t * t, "m",
                 f"half of a t^2/2 with a = g (sin {angle_deg:g} deg - {friction:g} cos {angle_deg:g} deg) = "
                 f"{accel:.3g} m/s^2 over {t:.3g} s: the box slides, not creeps")


@dataclass(frozen=True)
class Thresholds:
    """A case's limits; ``None``: not judged."""

    max_penetration: Limit = LIMITS["rest penetration"]
    max_excursion: Limit | None = None  # bodies that must rest
    max_path: Limit | None = None  # bodies that must rest
    min_excursion: Limit | None = None  # a body that must move
    max_speed: Limit | None = None  # net of g*dt, over the measured steps
    max_final_speed: Limit | None = None  # net of g*dt, at the last step

    def items(self) -> list[tuple[str, Limit]]:
        return [(f.name, getattr(self, f.name)) for f in dataclasses.fields(self) if getattr(self, f.name)]


AT_REST = Thresholds(max_excursion=LIMITS["rest excursion"], max_path=LIMITS["rest path"],
                     max_speed=LIMITS["rest speed"])
COMES_TO_REST = Thresholds(max_final_speed=LIMITS["rest speed"])


@dataclass(frozen=True)
class HardCase:
    name: str
    scene: str
    params: dict[str, Any]
    steps: int
    limits: Callable[[int], Thresholds]  # the thresholds of a run of that many measured steps
    description: str
    warmup_steps: int = 0  # our loop, not measured (stacks sink to the GPU solver's resting penetration)
    settle_steps: int = 0  # pybullet's own solver first

    def thresholds(self, steps: int | None = None) -> Thresholds:
        return self.limits(steps or self.steps)

    def run(self, ar: Arithmetic, iterations: int, steps: int | None = None,
            stepper: StepperFactory = golden_stepper, remedy: Remedy = COLD) -> tuple[LoopResult, Trajectory]:
        """The case closed loop with ``iterations`` per step (a remedy of n substeps: ceil(iterations / n) per
        kernel call); every kernel call priced by the cycle model (``extra["kernel cycles per step"]``)."""
        recorder, pricer = TrajectoryRecorder(), KernelPricer()
        result = run_closed_loop(self.scene, steps or self.steps, ar, call_iterations(iterations, remedy),
                                 schedule="pybullet", warmup_steps=self.warmup_steps, settle_steps=self.settle_steps,
                                 stepper=recorder.wrap(pricer.wrap(stepper)), remedy=remedy, **self.params)
        result.extra["kernel cycles per step"] = pricer.per_step(result)
        return result, recorder.trajectory(result)


def call_iterations(iterations: int, remedy: Remedy) -> int:
    """Iterations of each kernel call when a step of ``iterations`` is split into the remedy's kernel calls
    (substeps, and a soft substep's solve and relax calls)."""
    return -(-iterations // remedy.calls_per_step)


class KernelPricer:
    """Wraps a stepper factory and prices every kernel call with the exact cycle model
    (``models/timing/cycle_model.py``, the streaming kernel on ``preset``: body streams in and out of every call
    included; a float64 loop: NaN)."""

    def __init__(self, preset: DmaPreset | None = None) -> None:
        self.preset = preset or get_preset("zcu102")
        self.cycles: list[int] = []

    def wrap(self, factory: StepperFactory) -> StepperFactory:
        def make(ar: Arithmetic, solver: SolverParams, ip: IntegrationParams) -> Stepper:
            advance = factory(ar, solver, ip)

            def step(bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
                     initial: Impulses | None = None) -> tuple[BodyTable, Impulses]:
                if isinstance(ar, NumberFormat):  # float64 has no kernel to price
                    self.cycles.append(predict_job(KernelJob(ar, bodies, cons, order, solver, ip), self.preset).cycles)
                return advance(bodies, cons, order, initial)

            return step

        return make

    def per_step(self, result: LoopResult) -> float:
        """Mean kernel cycles per measured step (all its calls)."""
        calls = result.steps * int(result.extra.get("calls per step", 1))
        if len(self.cycles) < calls:
            return float("nan")
        return float(np.sum(self.cycles[len(self.cycles) - calls:])) / result.steps


# the remedies the suite compares (models.closed_loop.loop.Remedy): Bullet GPU's cold start, Bullet 2's warm start,
# the warm start with Box2D-style substeps (models/golden/substep.py), the last substep relaxed; warm1: Box2D's full
# warm start (factor 1)
REMEDIES: dict[str, Remedy] = {r.name: r for r in (
    COLD, Remedy("warm", WARMSTART_FACTOR), Remedy("warm+sub2", WARMSTART_FACTOR, 2),
    Remedy("warm+sub4", WARMSTART_FACTOR, 4), Remedy("warm+sub2+relax", WARMSTART_FACTOR, 2, relax=True),
    Remedy("warm1+sub2+relax", 1.0, 2, relax=True),
    # Box2D v3's soft step (models/golden/soft_contact.py): per substep a soft solve call, the position update and a
    # relax call (2 substeps x 2 calls x 1 iteration = 8 manifold-passes at 4 iterations), or 4 soft substeps without
    # relax
    Remedy("soft+sub2+relax", 0.0, 2, relax=True, soft=SoftContact()),
    Remedy("warm+soft+sub2+relax", WARMSTART_FACTOR, 2, relax=True, soft=SoftContact()),
    Remedy("warm1+soft+sub2+relax", 1.0, 2, relax=True, soft=SoftContact()),
    Remedy("warm1+soft+sub4", 1.0, 4, soft=SoftContact()),
    # tuned (docs/stability.md): Box2D's 30 Hz rings on resting piles at 1 iteration per call; 15 Hz with Box2D's
    # damping ratio 10, and 15 Hz critically damped (ratio 1), which holds the plank and the pyramid
    Remedy("warm1+soft15+sub2+relax", 1.0, 2, relax=True, soft=SoftContact(hertz=15.0)),
    Remedy("warm1+soft15z1+sub2+relax", 1.0, 2, relax=True, soft=SoftContact(hertz=15.0, damping_ratio=1.0)),
    # shock propagation (models/golden/shock_propagation.py): ground-up layer order, the last contact pass of each
    # kernel call (of a soft substep: its relax call) freezes each contact's lower body; "shockf": the last friction
    # pass too
    Remedy("shock", 0.0, shock=True), Remedy("warm+shock", WARMSTART_FACTOR, shock=True),
    Remedy("warm+shockf", WARMSTART_FACTOR, shock=True, shock_friction=True),
    Remedy("warm1+shock", 1.0, shock=True), Remedy("warm1+shockf", 1.0, shock=True, shock_friction=True),
    Remedy("warm+sub2+shock", WARMSTART_FACTOR, 2, shock=True),
    Remedy("warm+sub2+shockf", WARMSTART_FACTOR, 2, shock=True, shock_friction=True),
    # "shockv": the shock passes correct velocities only (their impulses dropped, not carried to the next step)
    Remedy("shockv", 0.0, shock=True, shock_impulses="drop"),
    Remedy("warm+shockv", WARMSTART_FACTOR, shock=True, shock_impulses="drop"),
    Remedy("warm+shockfv", WARMSTART_FACTOR, shock=True, shock_friction=True, shock_impulses="drop"),
    Remedy("warm1+shockv", 1.0, shock=True, shock_impulses="drop"),
    Remedy("warm1+shockfv", 1.0, shock=True, shock_friction=True, shock_impulses="drop"),
    Remedy("warm+sub2+shockv", WARMSTART_FACTOR, 2, shock=True, shock_impulses="drop"),
    Remedy("warm1+soft15z1+sub2+relax+shockv", 1.0, 2, relax=True,
           soft=SoftContact(hertz=15.0, damping_ratio=1.0), shock=True, shock_impulses="drop"),
    # "shock2": the last two contact passes of each call are shock passes (a deviation from the scheme's one)
    Remedy("warm+shock2v", WARMSTART_FACTOR, shock=True, shock_impulses="drop", shock_passes=2),
    Remedy("warm+shock2", WARMSTART_FACTOR, shock=True, shock_passes=2),
    Remedy("warm+shock3v", WARMSTART_FACTOR, shock=True, shock_impulses="drop", shock_passes=3),
    # "shockl": a linear shock (the shock rows move the upper body along the normal only, no angular write)
    Remedy("warm+shocklv", WARMSTART_FACTOR, shock=True, shock_impulses="drop", shock_linear=True),
    Remedy("warm+shockl", WARMSTART_FACTOR, shock=True, shock_linear=True),
    Remedy("warm+sub2+shocklv", WARMSTART_FACTOR, 2, shock=True, shock_impulses="drop", shock_linear=True),
    Remedy("warm+shockflv", WARMSTART_FACTOR, shock=True, shock_friction=True, shock_impulses="drop",
           shock_linear=True),
    Remedy("warm+sub2+shockflv", WARMSTART_FACTOR, 2, shock=True, shock_friction=True, shock_impulses="drop",
           shock_linear=True),
    Remedy("warm1+sub2+shocklv", 1.0, 2, shock=True, shock_impulses="drop", shock_linear=True),
    Remedy("warm+sub4+shocklv", WARMSTART_FACTOR, 4, shock=True, shock_impulses="drop", shock_linear=True),
    Remedy("warm1+soft15z1+sub2+relax+shocklv", 1.0, 2, relax=True,
           soft=SoftContact(hertz=15.0, damping_ratio=1.0), shock=True, shock_impulses="drop", shock_linear=True),
    # "...r": the frozen rows' shock impulses kept for the call's friction limit, not returned (not carried)
    Remedy("warm+shocklr", WARMSTART_FACTOR, shock=True, shock_impulses="return", shock_linear=True),
    Remedy("warm+sub2+shocklr", WARMSTART_FACTOR, 2, shock=True, shock_impulses="return", shock_linear=True),
    Remedy("warm+sub4+shocklr", WARMSTART_FACTOR, 4, shock=True, shock_impulses="return", shock_linear=True),
    Remedy("warm+sub4+shockl", WARMSTART_FACTOR, 4, shock=True, shock_linear=True),
    # "...h": each layer pair's manifolds in the hazard order of the loop's window (the kernel's pipeline kept full)
    Remedy("warm+sub4+shocklrh", WARMSTART_FACTOR, 4, shock=True, shock_impulses="return", shock_linear=True,
           shock_hazard=True),
    Remedy("warm+sub4+shockflv", WARMSTART_FACTOR, 4, shock=True, shock_friction=True, shock_impulses="drop",
           shock_linear=True),
    Remedy("warm+sub4+shockflr", WARMSTART_FACTOR, 4, shock=True, shock_friction=True, shock_impulses="return",
           shock_linear=True),
    Remedy("warm+sub4+shockv", WARMSTART_FACTOR, 4, shock=True, shock_impulses="drop"),
    Remedy("warm+sub4+shockr", WARMSTART_FACTOR, 4, shock=True, shock_impulses="return"),
    Remedy("warm1+soft15z1+sub2+relax+shock", 1.0, 2, relax=True, soft=SoftContact(hertz=15.0, damping_ratio=1.0),
           shock=True),
    Remedy("warm1+soft15z1+sub2+relax+shockf", 1.0, 2, relax=True, soft=SoftContact(hertz=15.0, damping_ratio=1.0),
           shock=True, shock_friction=True))}


def _always(thresholds: Thresholds) -> Callable[[int], Thresholds]:
    return lambda steps: thresholds


def _sliding(angle_deg: float, friction: float) -> Callable[[int], Thresholds]:
    return lambda steps: Thresholds(min_excursion=slide_distance(angle_deg, friction, steps))


def _impact(speed: float) -> Callable[[int], Thresholds]:
    return lambda steps: Thresholds(max_penetration=impact_penetration(speed), max_speed=impact_speed(speed, steps),
                                    max_final_speed=LIMITS["rest speed"])


CASES: dict[str, HardCase] = {c.name: c for c in (
    HardCase("stack20", "stack", {"n": 20}, 120, _always(AT_REST), "20 cubes in a tower; must stand",
             warmup_steps=30),
    HardCase("pyramid10", "pyramid", {"n": 10}, 120, _always(AT_REST),
             "2-D pyramid, base of 10 (55 cubes); must stand", warmup_steps=30),
    HardCase("mass_ratio", "mass_ratio", {"ratio": 1000.0}, 120, _always(AT_REST),
             "a 1000 kg cube on four 1 kg cubes; must stand", warmup_steps=30),
    HardCase("incline20", "incline", {"angle_deg": 20.0, "friction": 0.7}, 120, _always(AT_REST),
             "box on a 20 deg slope, friction 0.7 (tan 20 deg = 0.36): must stay put", warmup_steps=10),
    HardCase("incline40", "incline", {"angle_deg": 40.0, "friction": 0.7}, 120, _sliding(40.0, 0.7),
             "box on a 40 deg slope, friction 0.7 (tan 40 deg = 0.84): must slide (2.1 m in 2 s by Coulomb)",
             warmup_steps=10),
    HardCase("impact", "impact", {"speed": 20.0}, 60, _impact(20.0),
             "a cube hitting a 3x2x3 block at 20 m/s; no explosion, the block settles"),
    HardCase("spin", "spin", {"spin": 15.0}, 240, _always(COMES_TO_REST),
             "a cube spinning at 15 rad/s lands on a corner; comes to rest within 4 s"),
    HardCase("plank", "plank", {"n": 5}, 120, _always(AT_REST),
             "a plank carrying 5x5 cubes: one body with 26 manifolds; must rest", warmup_steps=30),
    HardCase("degenerate", "degenerate", {}, 120, _always(COMES_TO_REST),
             "cubes on an edge (2 points), a corner (1 point), tilted 1e-4 rad, stacked exactly; settle, no NaN"),
)}
ITERATIONS = (1, 4, 10, 30)

FIGURES = ["passes per step", "kernel cycles per step", "max penetration (m)", "max excursion (m)", "max path length (m)", "max net displacement (m)",
           "max speed net of g dt (m/s)", "final max speed net of g dt (m/s)", "final kinetic energy (J)",
           "NaN/Inf values"]
# threshold field -> (figure it bounds, True: an upper bound, what a failure says)
CHECKS: dict[str, tuple[str, bool, str]] = {
    "max_penetration": ("max penetration (m)", True, "penetration"),
    "max_excursion": ("max excursion (m)", True, "excursion"),
    "max_path": ("max path length (m)", True, "path"),
    "min_excursion": ("max excursion (m)", False, "moved only"),
    "max_speed": ("max speed net of g dt (m/s)", True, "speed"),
    "max_final_speed": ("final max speed net of g dt (m/s)", True, "final speed"),
}


@dataclass
class Verdict:
    case: str
    format: str
    iterations: int  # per step (all substeps)
    figures: dict[str, float]
    failures: list[str] = field(default_factory=list)  # what each failed check says
    failed_checks: list[str] = field(default_factory=list)  # their Thresholds fields ("nonfinite" for NaN/Inf)
    remedy: str = COLD.name

    @property
    def passed(self) -> bool:
        return not self.failures


def figures(result: LoopResult, path: Trajectory) -> dict[str, float]:
    """The judged figures of a run: maxima over the dynamic bodies (speeds net of g*dt)."""
    speed = path.speed()
    return {"passes per step": int(result.extra.get("passes per step", 2 * result.iterations)),
            "kernel cycles per step": float(result.extra.get("kernel cycles per step", float("nan"))),
            "max penetration (m)": float(np.max(result.max_penetration, initial=0.0)),
            "max excursion (m)": float(np.max(path.excursion(), initial=0.0)),
            "max path length (m)": float(np.max(path.path_length(), initial=0.0)),
            "max net displacement (m)": float(np.max(result.drift, initial=0.0)),
            "max speed net of g dt (m/s)": float(np.max(speed, initial=0.0)),
            "final max speed net of g dt (m/s)": float(np.max(speed[-1], initial=0.0)) if path.steps else 0.0,
            "final kinetic energy (J)": float(result.kinetic_energy[-1]) if result.steps else 0.0,
            "NaN/Inf values": int(np.sum(result.nonfinite))}


def judge(case: HardCase, result: LoopResult, path: Trajectory, iterations: int | None = None) -> Verdict:
    """Judge a run against the case's thresholds for the run's length (a NaN figure fails every bound);
    ``iterations`` per step (default: the loop's per call)."""
    fig = figures(result, path)
    failures, failed = ([f"{fig['NaN/Inf values']} NaN/Inf values"], ["nonfinite"]) if fig["NaN/Inf values"] \
        else ([], [])
    for name, limit in case.thresholds(result.steps).items():
        key, upper, word = CHECKS[name]
        ok = fig[key] <= limit.value if upper else fig[key] >= limit.value
        if not ok:
            failures.append(f"{word} {fig[key]:.3g} {limit.unit} {'>' if upper else '<'} {limit}")
            failed.append(name)
    return Verdict(case.name, result.format, iterations or result.iterations, fig, failures, failed,
                   str(result.extra.get("remedy", COLD.name)))
