"""The streaming kernel whose impulses travel with the records (``IMPULSES_IN_RECORDS = 1``: no impulse RAM; the
records carry the impulses their pass starts from, the kernel writes the updated ones to ``m_axis_imp``, and the
harness's DMA model writes them to the DDR impulse buffer the next passes' records read).

One Verilator build for every test here (fp16, 512-bit constraint beats: the zcu102 preset's): ``sim.drive.kernel_step``
compares bit for bit the trace, the body-out stream and the impulse-out stream (one record per slot and pass,
TLAST per pass) with the golden model of the same step:

* the pile with random stream gaps and backpressure on every output (the impulse-out stream included; the seed is
  printed, ``SEED=<int>`` overrides it); its cycles never beat the cycle model's lower bound;
* deterministic streams on the pile and on 10 independent manifolds (where every pass waits for its predecessor's
  impulse writes: the read-after-write rule across passes): every retire cycle, the total and the stall and bubble
  counters equal the cycle model's;
* a warm start: random non-negative initial normal impulses and friction impulses within the limit, bit-exact
  against ``solve(..., initial=...)``, cycles exact; also with the passes interleaved (contact, friction, ...:
  each friction pass reads the lam its contact pass just wrote);
* body streams of 256-bit beats (``make sim IMPULSE_STORE=records BODY_BITS=256``, its own build): the body load
  and the integration's body-out take fewer beats, bit-exact and every retire cycle the cycle model's with the
  same beats (``predict_job(..., body_bits=256)``), fewer cycles than on 128-bit beats.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import Impulses, SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.tests.test_impulses_in_records import independent_stack_job
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import run_kernel_step
from sim.compare import retire_cycles
from sim.drive.seed import run_seed

GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")


def _seed() -> int:
    return run_seed()


def pile_job(interleaved: bool = False) -> KernelJob:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    return KernelJob.from_frame(frame, FP16, SolverParams(4, interleaved=interleaved), "hazard",
                                default_window(FP16, PRESET.stream_bits)).impulses_travelling()


def warm_start(job: KernelJob, seed: int) -> Impulses:
    """Random non-negative normal impulses, friction impulses within a tenth of their sum (inside the friction
    limit), rounded to the job's format."""
    rng = np.random.default_rng(seed)
    m = job.cons.num_manifolds
    normal = job.fmt.round(rng.uniform(0.0, 0.5, (m, 4)))
    friction = job.fmt.round(rng.uniform(-0.05, 0.05, (m, 2)) * normal.sum(axis=1, keepdims=True))
    return Impulses(normal, friction)


def test_pile_bit_exact_with_random_backpressure(tmp_path: Path) -> None:
    job, seed = pile_job(), _seed()
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE)
    bound = cycle_model.lower_bound(job, PRESET)
    print(f"[pile/fp16/impulses in records] {res.cycles:,} cycles ({res.cycles / job.manifold_passes:.3f} per "
          f"manifold-pass), model lower bound {bound:,}; impulse-out records {int(res.registers['impulse_out_records'])}")
    assert res.bit_exact, res.comparison.first_mismatch
    assert int(res.registers["impulse_out_records"]) == job.manifold_passes
    assert res.cycles >= bound


@pytest.mark.parametrize("which", ["pile", "independent", "warm-pile", "interleaved-warm-pile"])
def test_cycles_match_model(which: str, tmp_path: Path) -> None:
    if which == "independent":
        job = independent_stack_job(FP16).impulses_travelling()
    else:
        job = pile_job(interleaved=which.startswith("interleaved"))
        if which.endswith("warm-pile"):
            job = job.impulses_travelling(warm_start(job, _seed()))
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    print(f"\n[{which}/fp16/impulses in records] {agree.describe()}; stalls {pred.stalls:,}, bubbles {pred.bubbles:,}")
    assert agree.ok, agree.first_mismatch


def test_wide_body_streams_cycle_exact(tmp_path: Path) -> None:
    """256-bit body beats: the fp16 body-in record (272 bits) in 2 beats instead of 3, body-out (208) in 1 instead
    of 2; the model with the 128-bit beats would not match this run."""
    job = pile_job()
    pred = cycle_model.predict_job(job, PRESET, body_bits=256)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True, body_bits=256)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    narrow = cycle_model.predict_job(job, PRESET).cycles
    print(f"\n[pile/fp16/impulses in records/256-bit body beats] {agree.describe()}; 128-bit beats: {narrow:,} cycles")
    assert agree.ok, agree.first_mismatch
    assert (pred.shape.body_in_beats, pred.shape.body_out_beats) == (2, 1) and res.cycles < narrow
