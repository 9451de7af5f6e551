"""The streaming kernel with the soft contact pipe (``SOFT_CONTACT = 1``, Box2D's soft row of
``models/golden/soft_contact.py``: each point's accumulated impulse times a per-call keep factor before the add), with
the impulses in the records (``IMPULSES_IN_RECORDS = 1``: the build the soft closed loop runs on, its relax call
continuing the solve call's impulses).

One Verilator build for every test here (fp32, 512-bit constraint beats: the zcu102 preset's). ``sim.drive.kernel_step``
compares bit for bit the trace, the body-out stream and the impulse-out stream with the golden model of the same
step (``solve`` with ``SolverParams.soft_keep``), and ``sim.compare.retire_cycles.compare_run`` every retire cycle, the
total and the stall and bubble counters with the cycle model's:

* the pile warm-started (non-zero impulses from the first pass on), keep factors of Box2D's 15 Hz critically
  damped contact at substeps of 1/120 s (two values, neither 1), the options bit set: bit-exact, cycle-exact, and
  its results differ from the rigid step's (the test can fail);
* the same step rigid (options bit clear) on the same build: the rigid golden model bit for bit, the same cycles.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import SolverParams, solve
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.golden.soft_contact import SoftContact
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import run_kernel_step

from cocotb_tests.test_kernel_impulses_in_records import warm_start
from sim.compare import retire_cycles

PRESET = get_preset("zcu102")
KEEP = SoftContact(hertz=15.0, damping_ratio=1.0).keep(1.0 / 120.0)


def pile_job(soft: bool) -> KernelJob:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    params = SolverParams(4, soft_keep=KEEP if soft else None)
    job = KernelJob.from_frame(frame, FP32, params, "hazard", default_window(FP32, PRESET.stream_bits))
    return job.impulses_travelling(warm_start(job, 5))


def _run(job: KernelJob, tmp_path: Path):  # noqa: ANN202
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True, soft_contact=True)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    assert agree.ok, agree.first_mismatch
    return res, agree


def test_soft_pile_bit_exact_and_cycle_exact(tmp_path: Path) -> None:
    job = pile_job(soft=True)
    assert 1.0 not in (float(FP32.round(KEEP[0])), float(FP32.round(KEEP[1]))) and KEEP[0] != KEEP[1]
    res, agree = _run(job, tmp_path)
    print(f"\n[pile/fp32/soft keep {KEEP[0]:.4f}, {KEEP[1]:.4f}] {res.cycles:,} cycles; {agree.describe()}")
    rigid = solve(job.bodies, job.cons, job.schedule, job.fmt, replace(job.params, soft_keep=None),
                  initial=job.initial)
    soft = solve(job.bodies, job.cons, job.schedule, job.fmt, job.params, initial=job.initial)
    assert not np.array_equal(soft.impulses.normal, rigid.impulses.normal)
    assert not np.array_equal(soft.bodies.linear_velocity, rigid.bodies.linear_velocity)
    # the multiply is off the critical path: the rigid step's cycles
    assert res.cycles == cycle_model.predict_job(replace(job, params=replace(job.params, soft_keep=None)),
                                                 PRESET).cycles


def test_soft_build_with_the_option_clear_is_the_rigid_kernel(tmp_path: Path) -> None:
    res, agree = _run(pile_job(soft=False), tmp_path)
    print(f"\n[pile/fp32/soft build, rigid call] {res.cycles:,} cycles; {agree.describe()}")
