"""The hard-case suite: scenes that break PGS solvers, run closed loop and judged against stated thresholds.

Every case runs ``models.closed_loop.run_closed_loop`` (pybullet collision detection, our solver and integrator)
for a stated number of steps, in a number format and an iteration count, and is judged on

* max penetration (deepest contact seen by collision detection over the measured steps),
* drift of the dynamic bodies over the measured steps (for cases whose bodies must rest: an upper bound; for
  a box that must slide: a lower bound),
* max speed over the measured steps, and the largest speed at the last step (bodies that must come to rest),
* NaN/Inf values in the body state (always 0 to pass),

with kinetic energy over time kept for the plots. A body at rest keeps a stored speed of g*dt = 0.163 m/s (the GPU
convention: gravity is added after the position update), which the speed thresholds allow for. Thresholds are per case (:data:`CASES`); a format or iteration
count that fails a case is a finding to report, not a test failure: ``make stability`` prints the table and
``make test`` runs a quick subset whose expected outcomes are asserted.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from .closed_loop import LoopResult, run_closed_loop
from .number_format import Arithmetic

INF = math.inf


@dataclass(frozen=True)
class Thresholds:
    max_penetration: float = 0.05  # m
    max_drift: float = INF  # m, bodies that must rest
    min_drift: float = 0.0  # m, a body that must move
    max_speed: float = INF  # m/s over the measured steps
    max_final_speed: float = INF  # m/s at the last step


@dataclass(frozen=True)
class HardCase:
    name: str
    scene: str
    params: dict[str, Any]
    steps: int
    thresholds: Thresholds
    description: str
    warmup_steps: int = 0  # our loop, not measured (stacks sink to the GPU solver's resting penetration)
    settle_steps: int = 0  # pybullet's own solver first

    def run(self, ar: Arithmetic, iterations: int, steps: int | None = None) -> LoopResult:
        return run_closed_loop(self.scene, steps or self.steps, ar, iterations, schedule="pybullet",
                               warmup_steps=self.warmup_steps, settle_steps=self.settle_steps, **self.params)


CASES: dict[str, HardCase] = {c.name: c for c in (
    HardCase("stack20", "stack", {"n": 20}, 120, Thresholds(max_penetration=0.05, max_drift=0.05),
             "20 cubes in a tower; must stand", warmup_steps=30),
    HardCase("pyramid10", "pyramid", {"n": 10}, 120, Thresholds(max_penetration=0.05, max_drift=0.05),
             "2-D pyramid, base of 10 (55 cubes); must stand", warmup_steps=30),
    HardCase("mass_ratio", "mass_ratio", {"ratio": 1000.0}, 120, Thresholds(max_penetration=0.05, max_drift=0.05),
             "a 1000 kg cube on four 1 kg cubes; must stand", warmup_steps=30),
    HardCase("incline20", "incline", {"angle_deg": 20.0, "friction": 0.7}, 120,
             Thresholds(max_penetration=0.02, max_drift=0.01),
             "box on a 20 deg slope, friction 0.7 (tan 20 deg = 0.36): must stay put", warmup_steps=10),
    HardCase("incline40", "incline", {"angle_deg": 40.0, "friction": 0.7}, 120,
             Thresholds(max_penetration=0.02, min_drift=1.0),
             "box on a 40 deg slope, friction 0.7 (tan 40 deg = 0.84): must slide (2.1 m in 2 s without drag)",
             warmup_steps=10),
    HardCase("impact", "impact", {"speed": 20.0}, 60, Thresholds(max_penetration=0.5, max_final_speed=3.0),
             "a cube hitting a 3x2x3 block at 20 m/s; no explosion, the block settles", ),
    HardCase("spin", "spin", {"spin": 15.0}, 240, Thresholds(max_penetration=0.05, max_final_speed=0.5),
             "a cube spinning at 15 rad/s lands on a corner; comes to rest within 4 s"),
    HardCase("plank", "plank", {"n": 5}, 120, Thresholds(max_penetration=0.05, max_drift=0.05),
             "a plank carrying 5x5 cubes: one body with 26 manifolds; must rest", warmup_steps=30),
    HardCase("degenerate", "degenerate", {}, 120, Thresholds(max_penetration=0.05, max_final_speed=0.5),
             "cubes on an edge (2 points), a corner (1 point), tilted 1e-4 rad, stacked exactly; settle, no NaN"),
)}
ITERATIONS = (1, 4, 10, 30)


@dataclass
class Verdict:
    case: str
    format: str
    iterations: int
    figures: dict[str, float]
    failures: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return not self.failures


def judge(case: HardCase, result: LoopResult) -> Verdict:
    """Judge a run; a run shorter than the case's own step count scales the slide distance it must cover
    (constant acceleration: distance grows with the square of the time)."""
    s = result.summary()
    t = case.thresholds
    if result.steps != case.steps:
        t = dataclasses.replace(t, min_drift=t.min_drift * (result.steps / case.steps) ** 2)
    final_max_speed = float(result.max_speed[-1]) if result.steps else 0.0
    figures = {"max penetration (m)": s["max penetration (m)"], "max drift (m)": s["max drift (m)"],
               "max speed (m/s)": s["max speed (m/s)"], "final max speed (m/s)": final_max_speed,
               "final kinetic energy (J)": s["final kinetic energy (J)"], "NaN/Inf values": s["NaN/Inf values"]}
    checks = [
        (figures["NaN/Inf values"] == 0, f"{figures['NaN/Inf values']} NaN/Inf values"),
        (figures["max penetration (m)"] <= t.max_penetration,
         f"penetration {figures['max penetration (m)']:.3g} m > {t.max_penetration:g}"),
        (figures["max drift (m)"] <= t.max_drift, f"drift {figures['max drift (m)']:.3g} m > {t.max_drift:g}"),
        (figures["max drift (m)"] >= t.min_drift, f"moved {figures['max drift (m)']:.3g} m < {t.min_drift:g}"),
        (figures["max speed (m/s)"] <= t.max_speed, f"speed {figures['max speed (m/s)']:.3g} m/s > {t.max_speed:g}"),
        (final_max_speed <= t.max_final_speed, f"final speed {final_max_speed:.3g} m/s > {t.max_final_speed:g}"),
    ]
    return Verdict(case.name, result.format, result.iterations, figures, [msg for ok, msg in checks if not ok])
