"""Shock propagation on the RTL kernel (``models/golden/shock_propagation.py``): in a shock pass each record's header
marks the row's frozen body (bits 60, 61) and a linear row (bit 62), and the record carries the shock row's
coefficients. The sequencer feeds the frozen body's inverse mass and inertia to the pipe as 0 and does not write it
back; a linear row's inverse inertias enter as 0 and its spin damping is off. ``sim.drive.kernel_step`` compares bit for
bit the trace, the body-out stream (and the impulse-out stream) with the golden model of the same step. Two builds that
other tests build too:

* the fp32 records design (impulses in the records, two body banks, ``pgs_kernel_e8m23_c512_ir_bk2_dl65``) on a pile of
  256 cubes, one iteration (every pass a shock pass, linear, the friction pass too, the frozen rows' impulses
  returned: the ``warm+sub4+shocklr`` remedy's call with friction shocked): bit-exact with random stream gaps and
  backpressure (the seed is printed, ``SEED=<int>`` overrides it); with deterministic streams every retire cycle
  equals the cycle model's, whose banks see no write of a frozen body (without that rule it predicts other cycles);
* the fp32 kernel with on-chip impulses (``pgs_kernel_e8m23_c512``) on the 4x3x4 pile, 4 iterations, the last
  contact pass a shock pass (angular, impulses kept): bit-exact and cycle-exact, and the step is not the one
  without the shock.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import StepShape
from models.formats.number_format import FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.golden.shock_propagation import FREEZE_NONE
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import golden_step, run_kernel_step
from models.timing import prediction
from models.timing import stream_cycle_model
from sim.compare import retire_cycles
from sim.drive.seed import run_seed

GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")
BIG_PILE = {"nx": 8, "ny": 4, "nz": 8, "seed": 3}  # 256 cubes, 734 manifolds: a bank write a shock pass saves


def _seed() -> int:
    return run_seed()


def pile_job(iterations: int, pile: dict[str, int] = KERNEL_TEST_SCENES["pile"]) -> KernelJob:
    frame = scenes.load_or_capture("pile", **pile)
    return KernelJob.from_frame(frame, FP32, SolverParams(iterations), "hazard", default_window(FP32, PRESET.stream_bits))


def records_shock_job() -> KernelJob:
    return pile_job(1, BIG_PILE).impulses_travelling().shocked(linear=True, friction=True, impulses="return")


def _cycles_without_the_bank_rule(job: KernelJob) -> int:
    """The cycle model of ``job`` as if its shock passes wrote every dynamic body (the banks busy with them)."""
    step = dataclasses.replace(StepShape.of_job(job), frozen=None, shock_passes=())
    return stream_cycle_model.predict(cycle_model.job_shape(job, PRESET, 128), cycle_model.job_timing(job, PRESET, False),
                               step).cycles


def test_the_shock_rows_reach_the_records_build() -> None:
    job = records_shock_job()
    assert KernelBuild.for_job(job, PRESET).name == "pgs_kernel_e8m23_c512_ir_bk2_dl65"
    frozen = int(np.count_nonzero(job.cons.frozen != FREEZE_NONE))
    assert frozen > job.cons.num_manifolds // 2  # most rows of a pile have a lower body
    gold, plain = golden_step(job).final, golden_step(job.unshocked()).final
    assert not np.array_equal(gold.linear_velocity, plain.linear_velocity)  # the runs below can tell them apart


def test_records_build_bit_exact_with_random_backpressure(tmp_path: Path) -> None:
    job, seed = records_shock_job(), _seed()
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE)
    bound = cycle_model.lower_bound(job, PRESET)
    print(f"[pile 8x4x8/fp32/records/shock linear, friction] {res.cycles:,} cycles, model lower bound {bound:,}")
    assert res.bit_exact, res.comparison.first_mismatch
    assert res.cycles >= bound


def _deterministic_run(job: KernelJob, tmp_path: Path, label: str, note: str = "") -> prediction.Prediction:
    """``job`` with deterministic streams: bit-exact, and every retire cycle the cycle model's."""
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    print(f"\n[{label}] {agree.describe()}{note}")
    assert agree.ok, agree.first_mismatch
    return pred


def test_records_build_cycles_match_model(tmp_path: Path) -> None:
    job = records_shock_job()
    without = _cycles_without_the_bank_rule(job)
    pred = _deterministic_run(job, tmp_path, "pile 8x4x8/fp32/records/shock linear, friction",
                              f"; the model with the frozen bodies' writes: {without:,} cycles")
    assert without != pred.cycles  # the step exercises the bank rule


def test_onchip_kernel_last_contact_pass_shocked(tmp_path: Path) -> None:
    job = pile_job(4).shocked()
    assert KernelBuild.for_job(job, PRESET).name == "pgs_kernel_e8m23_c512"
    assert not np.array_equal(golden_step(job).final.linear_velocity,
                              golden_step(job.unshocked()).final.linear_velocity)
    _deterministic_run(job, tmp_path, "pile/fp32/on-chip impulses/last contact pass shocked")


def test_the_window_kernel_refuses_a_shock_job() -> None:
    with pytest.raises(ValueError, match="streaming kernel"):
        pile_job(4).shocked().windowed(4096)
    with pytest.raises(ValueError, match="streaming kernel"):
        pile_job(4).windowed(4096).shocked()
