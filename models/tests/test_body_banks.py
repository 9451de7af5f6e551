"""The banked body velocities (models/kernel/body_banks.py): the port rule, which builds use the banks, and the cycle
model's stall when a bank is busy (the RTL side: cocotb_tests/test_kernel_body_banks.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.kernel.body_banks import WINDOW_BANKS, RECORDS_BANKS, busy, check_banks, default_body_banks
from models.setup.constraints import BodyTable
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.formats.number_format import FP16, FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.timing import prediction
from models.timing import stream_cycle_model

PRESET = get_preset("zcu102")


def spread_bodies(job: KernelJob, stride: int) -> KernelJob:
    """``job`` with body k moved to index ``stride * k`` and static zero bodies between: with ``stride`` a multiple
    of the banks every body lies in bank 0, so each read pair fills that bank's two ports."""
    b, n = job.bodies, job.bodies.num_bodies
    out = {}
    for f in dataclasses.fields(BodyTable):
        col = getattr(b, f.name)
        full = np.zeros((n * stride,) + col.shape[1:], dtype=col.dtype)
        if f.name == "orientation":
            full[:, 3] = 1.0
        full[::stride] = col
        out[f.name] = full
    cons = dataclasses.replace(job.cons, body_a=job.cons.body_a * stride, body_b=job.cons.body_b * stride)
    return dataclasses.replace(job, bodies=BodyTable(**out), cons=cons)


def pile_job(fmt=FP32) -> KernelJob:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    return KernelJob.from_frame(frame, fmt, SolverParams(4), "hazard", 24).impulses_travelling()


def test_port_rule() -> None:
    assert not busy(4, (1, 2), (5, 6))  # banks 1, 2 | 1, 2: two accesses each
    assert busy(4, (1, 5), (9,))  # bank 1 asked three times
    assert not busy(4, (1, 5), ())  # two reads of one bank: its two ports
    assert busy(1, (0, 1), (2,)) and not busy(1, (0, 1), ())  # one bank: every retire write blocks the reads
    assert not busy(2, (0, 1), (2, 3))
    for bad in (-1, 3, 6):
        with pytest.raises(ValueError, match="power of two"):
            check_banks(bad)


def test_the_records_design_in_fp32_uses_the_banks() -> None:
    assert default_body_banks(FP32, True, False) == RECORDS_BANKS
    assert default_body_banks(FP16, True, False) == 0  # its live-value table fits: unchanged
    assert default_body_banks(FP32, False, False) == 0 and default_body_banks(FP32, False, True) == 0
    # the window kernel with the impulses in the records banks them in every format, with any lanes
    assert default_body_banks(FP16, True, True) == default_body_banks(FP32, True, True) == WINDOW_BANKS == 8
    assert default_body_banks(FP16, True, True, lanes=2) == 2 * WINDOW_BANKS and default_body_banks(FP16, False, True, 2) == 0
    assert pile_job().body_banks == RECORDS_BANKS and pile_job(FP16).body_banks == 0


def test_a_busy_bank_stalls_the_issue_in_the_model() -> None:
    """Every body in bank 0: a record waits whenever a manifold retires with a dynamic body; spread over the banks
    the stalls are rare; the multiport memory (0 banks) has none, and the banks never make a run faster."""
    job = pile_job()
    spread = spread_bodies(job, RECORDS_BANKS)
    normal, packed = (cycle_model.predict_job(j, PRESET) for j in (job, spread))
    busy_normal = normal.stall_cycles_by_cause()["body bank busy with a retire write"]
    busy_packed = packed.stall_cycles_by_cause()["body bank busy with a retire write"]
    assert busy_packed > busy_normal > 0 and packed.cycles > normal.cycles
    shape = dataclasses.replace(KernelShape.of(FP32, PRESET.stream_bits, impulses_in_records=True),
                                body_banks=0)
    step = StepShape.of_job(spread)
    dma = DmaTiming.of(PRESET, False, spread.ddr_read_share(PRESET.stream_bits))
    multiport = stream_cycle_model.predict(shape, dma, step)
    assert "body bank busy with a retire write" not in multiport.stall_cycles_by_cause()
    assert multiport.cycles < packed.cycles
    k = int(np.flatnonzero(packed.cause == prediction.BANK_BUSY)[0])
    assert "body-velocity bank busy" in packed.explain(k)
    # the stalled record issues in the first cycle no manifold retires with a write into its bank
    assert not np.isin(packed.issue, packed.retire).any()
