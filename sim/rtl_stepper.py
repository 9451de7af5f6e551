"""The RTL kernel as the stepper of a closed loop (``models.closed_loop``): every step runs in the compiled harness
and must equal the golden model's bit for bit.

    run_closed_loop("incline", 5, FP32, 4, stepper=rtl_stepper(get_preset("zcu102"), Path("build/rtl_loop")))
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from models.constraints import BodyTable, ConstraintSet
from models.contact_solver import SolverParams
from models.dma_model import DmaPreset
from models.integrator import IntegrationParams
from models.kernel_job import KernelJob
from models.number_format import NumberFormat
from sim.harness_run import KernelRunError
from sim.kernel_step import run_kernel_step
from sim.trace_compare import kernel_bodies


def rtl_stepper(preset: DmaPreset, work_dir: Path, seed: int = 1) -> Callable[..., Callable[..., BodyTable]]:
    """A closed-loop stepper factory (``models.closed_loop.StepperFactory``) that runs every step on the RTL kernel
    and fails on the first step whose trace or body table differs from the golden model."""

    def factory(fmt: NumberFormat, params: SolverParams, ip: IntegrationParams) -> Callable[..., BodyTable]:
        count = [0]

        def step(bodies: BodyTable, cons: ConstraintSet, order: np.ndarray) -> BodyTable:
            job = KernelJob(fmt, bodies, cons, order, params, ip)
            run_dir = work_dir / f"step{count[0]:05d}"
            res = run_kernel_step(job, preset, run_dir, seed)
            if not res.bit_exact:
                raise KernelRunError(f"closed-loop step {count[0]}: {res.comparison.first_mismatch}")
            count[0] += 1
            return kernel_bodies(run_dir, job)

        return step

    return factory
