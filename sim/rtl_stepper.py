"""The RTL kernel as the stepper of a closed loop (``models.closed_loop``): every step runs in the compiled harness
and must equal the golden model's bit for bit. The default kernel keeps its impulses on chip and starts every step
from zero: a warm-started loop (``models.closed_loop.Remedy``) is refused on it (:class:`WarmStartUnsupported`); a soft
step (Box2D's soft contact) is refused on every build (:class:`SoftContactUnsupported`). With
``impulses_in_records=True`` every step runs on the streaming kernel whose impulses travel with the records
(IMPULSES_IN_RECORDS), and a warm start's impulses are the ones the records of each kind's first pass carry.

    run_closed_loop("incline", 5, FP32, 4, stepper=rtl_stepper(get_preset("zcu102"), Path("build/rtl_loop")))
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

import numpy as np

from models.constraints import BodyTable, ConstraintSet
from models.contact_solver import Impulses, SolverParams
from models.dma_model import DmaPreset
from models.integrator import IntegrationParams
from models.kernel_job import KernelJob
from models.number_format import NumberFormat
from sim.harness_run import KernelRunError
from sim.kernel_step import golden_step, run_kernel_step
from sim.trace_compare import kernel_bodies


class WarmStartUnsupported(ValueError):
    """A warm start asked of a kernel that starts every step from zero impulses."""


class SoftContactUnsupported(ValueError):
    """A soft contact step (``SolverParams.soft_keep``, models/soft_contact.py) asked of the RTL kernel, whose contact
    pipe has no ``lam * keep`` multiply yet (docs/stability.md, the soft step's RTL next step)."""


def rtl_stepper(preset: DmaPreset, work_dir: Path, seed: int = 1,
                impulses_in_records: bool = False) -> Callable[..., Callable[..., tuple[BodyTable, Impulses]]]:
    """A closed-loop stepper factory (``models.closed_loop.StepperFactory``) that runs every step on the RTL kernel
    (with the impulses in the records when asked) and fails on the first step whose trace or body table differs
    from the golden model."""

    def factory(fmt: NumberFormat, params: SolverParams,
                ip: IntegrationParams) -> Callable[..., tuple[BodyTable, Impulses]]:
        if params.soft_keep is not None:
            raise SoftContactUnsupported(
                f"the RTL kernel's contact pipe has no soft-contact multiply (lam * keep, keep = {params.soft_keep}): "
                "run soft remedies on the golden model (docs/stability.md)")
        count = [0]

        def step(bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
                 initial: Optional[Impulses] = None) -> tuple[BodyTable, Impulses]:
            if initial is not None and not impulses_in_records:
                raise WarmStartUnsupported(
                    "the RTL kernel with on-chip impulses zeroes every impulse at its first pass (pgs_impulse_ram's "
                    "read mux) and reads no initial impulses: warm start it with the impulses in the records "
                    "(rtl_stepper(..., impulses_in_records=True))")
            job = KernelJob(fmt, bodies, cons, order, params, ip)
            if impulses_in_records:
                job = job.impulses_travelling(initial)
            run_dir = work_dir / f"step{count[0]:05d}"
            golden = golden_step(job)
            res = run_kernel_step(job, preset, run_dir, seed, golden=golden)
            if not res.bit_exact:
                raise KernelRunError(f"closed-loop step {count[0]}: {res.comparison.first_mismatch}")
            count[0] += 1
            # the trace comparison checked every pass's accumulated impulses bit for bit (and, with the impulses in
            # the records, every impulse-out record): the golden ones are the kernel's
            return kernel_bodies(run_dir, job), golden.solved.impulses

        return step

    return factory
