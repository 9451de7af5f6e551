"""The path of the dynamic bodies through a closed loop, in physical quantities.

``models.closed_loop.loop`` keeps per-step maxima and the net displacement; judging whether a body rests needs more:
a body that jitters and comes back has no net displacement but a long path. :class:`TrajectoryRecorder` wraps the
loop's stepper and keeps, after every step, each dynamic body's position and the velocity it moved with during
that step. The stored velocity is not that: on the GPU, gravity is added after the position update
(``models/golden/integrator.py``), so a body at rest stores ``g*dt`` (0.163 m/s at 1/60 s); the recorder subtracts it.

:class:`Trajectory` then gives per body the largest excursion from the start, the path length (the sum of the
per-step moves) and the speed net of ``g*dt`` at every step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from models.closed_loop.loop import LoopResult, Stepper, StepperFactory, golden_stepper
from models.setup.constraints import BodyTable
from models.golden.contact_solver import Impulses, SolverParams
from models.golden.integrator import IntegrationParams
from models.formats.number_format import Arithmetic


@dataclass(frozen=True)
class Trajectory:
    """Dynamic bodies over the measured steps: ``start`` (N, 3) before the first, ``positions`` and
    ``velocities`` (steps, N, 3) after each, the velocities net of ``g*dt`` (m, m/s)."""

    start: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    def __post_init__(self) -> None:
        if self.positions.shape != self.velocities.shape or self.positions.shape[1:] != self.start.shape:
            raise ValueError(f"trajectory shapes disagree: start {self.start.shape}, positions "
                             f"{self.positions.shape}, velocities {self.velocities.shape}")

    @property
    def steps(self) -> int:
        return int(self.positions.shape[0])

    def excursion(self) -> np.ndarray:
        """(N,) the largest distance of each body from its start over the steps (m)."""
        if not self.steps:
            return np.zeros(self.start.shape[0])
        return np.linalg.norm(self.positions - self.start[None], axis=2).max(axis=0)

    def path_length(self) -> np.ndarray:
        """(N,) the length of each body's path, the sum of its per-step moves (m)."""
        path = np.concatenate([self.start[None], self.positions], axis=0)
        return np.linalg.norm(np.diff(path, axis=0), axis=2).sum(axis=0)

    def speed(self) -> np.ndarray:
        """(steps, N) each body's speed net of ``g*dt`` after each step (m/s)."""
        return np.linalg.norm(self.velocities, axis=2)


class TrajectoryRecorder:
    """Wraps a closed loop's stepper factory and records every step it takes (warm-up steps included)."""

    def __init__(self) -> None:
        self._positions: list[np.ndarray] = []
        self._velocities: list[np.ndarray] = []

    def wrap(self, factory: StepperFactory = golden_stepper) -> StepperFactory:
        def make(ar: Arithmetic, solver: SolverParams, ip: IntegrationParams) -> Stepper:
            advance = factory(ar, solver, ip)
            g_dt = np.asarray(ip.gravity, dtype=np.float64) * ip.dt

            def step(bodies: BodyTable, cons: Any, order: np.ndarray,
                     initial: Optional[Impulses] = None) -> tuple[BodyTable, Impulses]:
                after, impulses = advance(bodies, cons, order, initial)
                dyn = after.dynamic
                self._positions.append(np.asarray(after.position[dyn], dtype=np.float64).copy())
                self._velocities.append(np.asarray(after.linear_velocity[dyn], dtype=np.float64) - g_dt)
                return after, impulses

            return step

        return make

    def trajectory(self, result: LoopResult) -> Trajectory:
        """The measured steps of ``result`` (the last ``result.steps`` recorded; of a step solved in substeps, the
        last kernel call's state), from its measured start."""
        per_step = int(result.extra.get("calls per step", 1))
        calls = len(self._positions)
        if calls < result.steps * per_step:
            raise ValueError(f"recorded {calls} kernel calls, the loop measured {result.steps} steps of {per_step}")
        dyn = result.final.dynamic
        keep = slice(calls - result.steps * per_step + per_step - 1, None, per_step)
        n = int(np.count_nonzero(dyn))
        positions = np.asarray(self._positions[keep]).reshape(result.steps, n, 3)
        velocities = np.asarray(self._velocities[keep]).reshape(result.steps, n, 3)
        return Trajectory(np.asarray(result.start_position[dyn], dtype=np.float64), positions, velocities)
