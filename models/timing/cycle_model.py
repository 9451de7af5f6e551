"""The cycle model of a kernel job: the streaming kernel's (``models/timing/stream_cycle_model.py``) or, for a job
with a record window, the window kernel's (``models/timing/window_cycle_model.py``), behind the compiled harness's
DMA model, with the job's build shape and DMA timing. It predicts, without running Verilator, the cycle every
manifold-pass retires, the stall and bubble counters and the total cycles (``models/timing/prediction.py``).

    pred = predict_job(job, get_preset("zcu102"))
    pred.cycles, pred.retire, pred.explain(812)
"""

from __future__ import annotations

from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.timing.platforms import DmaPreset
from models.timing.prediction import Prediction, check_body_rate
from models.timing.stream_cycle_model import predict
from models.timing.window_cycle_model import predict_window


def job_shape(job: "KernelJob", preset: DmaPreset, body_bits: int) -> KernelShape:
    return KernelShape.of(job.fmt, preset.stream_bits, body_bits, inertia_words=job.inertia_words,
                          impulses_in_records=job.impulses_in_records, friction_words=job.friction_words,
                          body_banks=job.body_banks, tangents_on_chip=job.tangents_on_chip, record_bits=job.record_bits,
                          shared_datapath=job.shared_datapath)


def job_timing(job: "KernelJob", preset: DmaPreset, prefetched: bool) -> DmaTiming:
    return DmaTiming.of(preset, prefetched, job.ddr_read_share(preset.stream_bits))


def predict_job(job: "KernelJob", preset: DmaPreset, prefetched: bool = False, body_bits: int = 128) -> Prediction:
    """The model of ``job`` run by ``sim.drive.kernel_step.run_kernel_step`` with ``preset`` (gap and backpressure 0) on
    body-in and body-out streams of ``body_bits``-bit beats (``make sim BODY_BITS``); a job with a record window
    (``job.record_window``) runs on the window kernel (``models.timing.window_cycle_model``)."""
    shape, dma, step = job_shape(job, preset, body_bits), job_timing(job, preset, prefetched), StepShape.of_job(job)
    if job.record_window is not None:
        return predict_window(shape, dma, step, job.record_window)
    return predict(shape, dma, step)


def check_body_beats(job: "KernelJob", preset: DmaPreset, body_bits: int) -> None:
    """A ValueError where the model cannot take ``job``'s body beats of ``body_bits`` bits on ``preset``: the DDR
    must give one body beat a cycle."""
    check_body_rate(job_shape(job, preset, body_bits), job_timing(job, preset, False))


def lower_bound(job: "KernelJob", preset: DmaPreset, prefetched: bool = False, body_bits: int = 128) -> int:
    """Cycles no run of ``job`` can beat: random stream gaps and backpressure only delay beats (every step of
    the model is a max of earlier events), so the deterministic prediction bounds them from below. The window
    kernel has no such bound (a ValueError): which pass it offers depends on when records arrive and hazards
    clear, so a delay can shorten its step."""
    if job.record_window is not None:
        raise ValueError("the window kernel's cycles under random stream gaps are not bounded by its deterministic "
                         "prediction (its choice of pass changes with them)")
    return predict_job(job, preset, prefetched, body_bits).cycles
