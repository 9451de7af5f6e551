"""The RTL kernel as the stepper of a closed loop (``models.closed_loop.loop``): every step runs in the compiled harness
and must equal the golden model's bit for bit. The default kernel keeps its impulses on chip and starts every step
from zero: a warm-started loop (``models.closed_loop.loop.Remedy``) is refused on it (:class:`WarmStartUnsupported`).
With ``impulses_in_records=True`` every step runs on the streaming kernel whose impulses travel with the records
(IMPULSES_IN_RECORDS), and a warm start's impulses are the ones the records of each kind's first pass carry.

Shock propagation (``models/golden/shock_propagation.py``) runs on every streaming build: the shock passes' records
carry the frozen-body bits in their headers and the shock rows' words
(``models.kernel.stream_format.pack_constraint_stream``); the impulses a ``"return"`` call puts back on its frozen rows
are the golden model's, after the kernel's every pass matched it. A ``"drop"`` call is refused
(:class:`ShockUnsupported`).

Box2D's soft step (``models/golden/soft_contact.py``: a soft solve call with ``SolverParams.soft_keep``, then a relax
call that continues its impulses) runs with ``soft_contact=True``: every call on the SOFT_CONTACT build, the solve call
with the options bit and the keep factors set, the relax call (rigid, the same kernel and records with the relax bias)
with the bit clear. A soft call asked of a stepper without it is refused (:class:`SoftContactUnsupported`); a relax
call, which starts from the solve's impulses, needs ``impulses_in_records=True`` too.

    run_closed_loop("incline", 5, FP32, 4, stepper=rtl_stepper(get_preset("zcu102"), Path("build/rtl_loop")))
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses, SolverParams
from models.timing.cycle_model import predict_job
from models.timing.platforms import DmaPreset
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import NumberFormat
from models.kernel.stream_format import KERNEL_INERTIA_WORDS
from sim.drive.harness_run import KernelRunError
from sim.drive.kernel_step import golden_step, run_kernel_step
from sim.compare.trace_bits import kernel_bodies


class WarmStartUnsupported(ValueError):
    """A warm start asked of a kernel that starts every step from zero impulses."""


class SoftContactUnsupported(ValueError):
    """A soft contact call (``SolverParams.soft_keep``, models/golden/soft_contact.py) asked of a kernel build without
    the
    soft contact pipe, or of a job the soft build does not run (another inverse-inertia mode)."""


class ShockUnsupported(ValueError):
    """A shock pass (``SolverParams.shock_contact`` / ``shock_friction``, models/golden/shock_propagation.py) the RTL
    kernel
    does not run: one whose frozen rows keep the impulses they held (``shock_impulses="drop"``; the kernel writes every
    row's new impulses)."""


@dataclass(frozen=True)
class RtlCall:
    """One kernel call of a closed loop on the RTL: its cycles (the kernel's counter and the cycle model's
    prediction of the same job), what was compared with the golden model, and whether it was a soft call."""

    rtl_cycles: int
    model_cycles: int
    trace_records: int
    body_records: int
    differing_bits: int
    soft: bool


def _check_soft(params: SolverParams, soft_contact: bool) -> None:
    if params.soft_keep is not None and not soft_contact:
        raise SoftContactUnsupported(
            f"a soft contact call (lam * keep, keep = {params.soft_keep}) needs the kernel build with the soft "
            "contact pipe: rtl_stepper(..., soft_contact=True) (SOFT_CONTACT = 1)")


def rtl_stepper(preset: DmaPreset, work_dir: Path, seed: int = 1, impulses_in_records: bool = False,
                soft_contact: bool = False,
                calls: Optional[list[RtlCall]] = None) -> Callable[..., Callable[..., tuple[BodyTable, Impulses]]]:
    """A closed-loop stepper factory (``models.closed_loop.loop.StepperFactory``) that runs every step on the RTL kernel
    (with the impulses in the records when asked, on the soft contact build when asked) and fails on the first step
    whose trace or body table differs from the golden model. Every factory of one stepper numbers its runs in one
    sequence (a soft step's solve and relax calls are two factories); ``calls`` collects each call's
    :class:`RtlCall`."""
    count = [0]

    def factory(fmt: NumberFormat, params: SolverParams,
                ip: IntegrationParams) -> Callable[..., tuple[BodyTable, Impulses]]:
        _check_soft(params, soft_contact)
        if (params.shock_contact or params.shock_friction) and params.shock_impulses == "drop":
            raise ShockUnsupported("a shock pass whose frozen rows keep the impulses they held (shock_impulses "
                                   "'drop') is golden-model only: the kernel writes every row's new impulses; 'keep' "
                                   "and 'return' (the host puts the frozen rows' impulses back after the call) run")

        def step(bodies: BodyTable, cons: ConstraintSet, order: np.ndarray,
                 initial: Optional[Impulses] = None) -> tuple[BodyTable, Impulses]:
            if initial is not None and not impulses_in_records:
                raise WarmStartUnsupported(
                    "the RTL kernel with on-chip impulses zeroes every impulse at its first pass (pgs_impulse_ram's "
                    "read mux) and reads no initial impulses: warm start it with the impulses in the records "
                    "(rtl_stepper(..., impulses_in_records=True))")
            job = KernelJob(fmt, bodies, cons, order, params, ip)
            if soft_contact and job.inertia_words != KERNEL_INERTIA_WORDS:
                raise SoftContactUnsupported(f"the soft contact build takes {KERNEL_INERTIA_WORDS} inverse-inertia "
                                             f"words per body; this job's bodies need {job.inertia_words}")
            if impulses_in_records:
                job = job.impulses_travelling(initial)
            run_dir = work_dir / f"step{count[0]:05d}"
            golden = golden_step(job)
            res = run_kernel_step(job, preset, run_dir, seed, golden=golden, soft_contact=soft_contact)
            if not res.bit_exact:
                raise KernelRunError(f"closed-loop call {count[0]}: {res.comparison.first_mismatch}")
            count[0] += 1
            if calls is not None:
                c = res.comparison
                calls.append(RtlCall(res.cycles, predict_job(job, preset).cycles, c.records, c.bodies,
                                     c.differing_bits, params.soft_keep is not None))
            # the trace comparison checked every pass's accumulated impulses bit for bit (and, with the impulses in
            # the records, every impulse-out record): the golden ones are the kernel's
            return kernel_bodies(run_dir, job), golden.solved.impulses

        return step

    return factory
