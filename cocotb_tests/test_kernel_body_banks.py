"""The records design in fp32 with its body velocities in true dual-port banks (``BODY_BANKS = 2``,
``rtl/pgs_body_vel_banks.sv``): one Verilator build (``pgs_kernel_e8m23_c512_ir_bk2_dl65``, the zcu102 preset's
512-bit beats) for every test here. ``sim.drive.kernel_step`` compares bit for bit the trace, the body-out stream and
the impulse-out stream with the golden model of the same step:

* the pile and the 10-cube stack with random stream gaps and backpressure on every stream (the seed is printed,
  ``SEED=<int>`` overrides it): bit-exact, never faster than the cycle model's lower bound;
* deterministic streams: every retire cycle, the total and the stall and bubble counters equal the cycle model's,
  on the pile, the stack, and both with every body moved into bank 0 (a record then waits whenever a manifold
  retires with a write: the busy-bank rule on every retire).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from models import scenes
from models.timing import cycle_model
from models.kernel.body_banks import RECORDS_BANKS
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.tests.test_body_banks import spread_bodies
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import run_kernel_step
from sim.compare import retire_cycles
from sim.drive.seed import run_seed

GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")


def _seed() -> int:
    return run_seed()


def scene_job(scene: str) -> KernelJob:
    frame = scenes.load_or_capture(scene, **KERNEL_TEST_SCENES[scene])
    return KernelJob.from_frame(frame, FP32, SolverParams(4), "hazard",
                                default_window(FP32, PRESET.stream_bits)).impulses_travelling()


def test_the_build_is_banked() -> None:
    kb = KernelBuild.for_job(scene_job("stack"), PRESET)
    assert kb.parameters["BODY_BANKS"] == RECORDS_BANKS and kb.name == "pgs_kernel_e8m23_c512_ir_bk2_dl65"


@pytest.mark.parametrize("scene", ["pile", "stack"])
def test_bit_exact_with_random_backpressure(scene: str, tmp_path: Path) -> None:
    job, seed = scene_job(scene), _seed()
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE)
    bound = cycle_model.lower_bound(job, PRESET)
    print(f"[{scene}/fp32/impulses in records/{RECORDS_BANKS} body banks] {res.cycles:,} cycles, model lower bound "
          f"{bound:,}")
    assert res.bit_exact, res.comparison.first_mismatch
    assert int(res.registers["impulse_out_records"]) == job.manifold_passes
    assert res.cycles >= bound


@pytest.mark.parametrize("which", ["pile", "stack", "pile-bank0", "stack-bank0"])
def test_cycles_match_model(which: str, tmp_path: Path) -> None:
    job = scene_job(which.split("-")[0])
    if which.endswith("bank0"):
        job = spread_bodies(job, RECORDS_BANKS)
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    busy = pred.stall_cycles_by_cause()["body bank busy with a retire write"]
    print(f"\n[{which}/fp32/impulses in records/{RECORDS_BANKS} body banks] {agree.describe()}; stalls "
          f"{pred.stalls:,} ({busy:,} on a busy bank), bubbles {pred.bubbles:,}")
    assert agree.ok, agree.first_mismatch
    if which != "stack":
        assert busy > 0  # the rule is exercised
