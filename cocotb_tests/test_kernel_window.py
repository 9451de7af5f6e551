"""The window kernel (``pgs_kernel`` with ``WINDOW`` > 0, ``rtl/pgs_window.sv``, issue 10) against the golden model.

The window kernel reads each manifold's combined record once per fetch and lets the passes of a fetch trail each
other over an on-chip ring; records of several passes interleave at issue and retire. With the lag at least the
slot order's band width D (``models.record_window``), every body sees its updates in the sequential solve's order,
so the trace (put back into pass order) and the body-out stream must equal the golden model's bit for bit. Built
once (fp32, a ring of 1,024 records, ``build/verilator/pgs_kernel_e8m23_c512_w1024x8/``) and run in the compiled
harness (``sim.kernel_run``) through the zcu102 DMA model with random stream gaps and output backpressure
(seeded: the seed is printed, ``SEED=<int>`` overrides it).

* bit-exact: a 4x3x4 pile (108 manifolds) and the stack, Bullet's pass order and the interleaved one, one fetch
  per step (all 8 passes trailing each other: the sweep order, D = 24, and the hazard order, D = 94) and several
  fetches (2 passes per fetch: 4 fetches; 3 passes per fetch: fetches of 3, 3 and 2);
* a lag below D must break the order (the comparison sees it: the check is not vacuous);
* the argument check (error code 3: fetch_passes 0 or above the contexts, lag 0, a trailing the ring cannot hold):
  the step ends at once without reading a stream;
* an early TLAST in a fetch (error code 1): the missing slot is rejected in every pass of the fetch, the step
  ends.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.contact_solver import SolverParams
from models.dma_model import get_preset
from models.number_format import FP32
from models.record_window import fits
from models.schedule import band_width
from sim.kernel_run import (KernelBuild, KernelJob, KernelResult, build_kernel, register_writes, run_harness,
                            run_kernel_step, write_inputs)

DEPTH = 1024
GAP_PERMILLE, BP_PERMILLE = 100, 200
SCENES = {"pile": dict(nx=4, ny=3, nz=4, seed=2), "stack": dict()}
PRESET = get_preset("zcu102")


def _seed() -> int:
    return int(os.environ.get("SEED", "12345"))


def window_job(scene: str, schedule: str, hazard_window: int, interleaved: bool = False,
               fetch_passes: int | None = None) -> KernelJob:
    frame = scenes.load_or_capture(scene, **SCENES[scene])
    job = KernelJob.from_frame(frame, FP32, SolverParams(4, interleaved=interleaved), schedule, hazard_window)
    return job.windowed(DEPTH, fetch_passes=fetch_passes)


def run_window(job: KernelJob, tmp: Path, label: str) -> KernelResult:
    seed = _seed()
    plan = job.record_window
    assert plan is not None
    print(f"\n[{label}] seed {seed} (SEED= overrides); {len(job.slots)} manifolds, D={plan.band}, lag={plan.lag}, "
          f"{plan.fetch_passes} passes per fetch, {plan.fetches(job.params)} fetches")
    res = run_kernel_step(job, PRESET, tmp, seed, GAP_PERMILLE, BP_PERMILLE)
    r = res.registers
    print(f"  {res.cycles} cycles ({res.cycles / job.manifold_passes:.2f} per manifold-pass), stalls {int(r['stalls'])}, "
          f"bubbles {int(r['bubbles'])}, build {res.build_seconds:.1f} s")
    return res


CASES = [  # scene, schedule, hazard window W, interleaved, passes per fetch (None: the plan's)
    ("pile", "sweep", 1, False, None),
    ("pile", "sweep", 1, True, None),
    ("pile", "hazard", 181, False, None),
    ("pile", "hazard", 181, True, 2),
    ("pile", "sweep", 1, True, 3),
    ("stack", "hazard", 181, False, None),
]


@pytest.mark.parametrize("scene,schedule,w,interleaved,fetch", CASES,
                         ids=lambda v: str(v).lower())
def test_window_kernel_bit_exact(scene: str, schedule: str, w: int, interleaved: bool, fetch: int | None,
                                 tmp_path: Path) -> None:
    job = window_job(scene, schedule, w, interleaved, fetch)
    res = run_window(job, tmp_path, f"{scene}/{schedule}/W={w}/{'interleaved' if interleaved else 'bullet'}")
    assert res.comparison.first_mismatch is None, res.comparison.first_mismatch
    assert res.bit_exact
    assert int(res.registers["issued"]) == job.manifold_passes
    # the window streams each record once per fetch: the bytes on the constraint stream say so
    plan = job.record_window
    assert plan is not None
    assert res.stream_bytes["constraints"] == plan.fetches(job.params) * len(job.slots) * 192


def test_window_lag_below_band_breaks_the_order(tmp_path: Path) -> None:
    """lag 1 on a D = 24 order: passes overtake updates of the pass before, the results differ."""
    job = window_job("pile", "sweep", 1, fetch_passes=8)
    plan = job.record_window
    assert plan is not None and plan.band > 1
    import dataclasses

    short = dataclasses.replace(job, record_window=dataclasses.replace(plan, lag=1))
    res = run_window(short, tmp_path, "pile/sweep lag 1")
    assert not res.bit_exact and res.comparison.differing_bits > 0
    assert int(res.registers["status"]) == 0  # the kernel has no way to know: it is the host's plan


def _run_raw(job: KernelJob, tmp: Path, regs: list[tuple[int, int]],
             cons_edit=None) -> dict[str, float]:  # type: ignore[no-untyped-def]
    plan = job.record_window
    assert plan is not None
    kb = KernelBuild(FP32, window=plan.depth, window_ctx=plan.ctx)
    write_inputs(tmp, job, kb)
    (tmp / "regs.bin").write_bytes(np.asarray(regs, dtype="<u4").tobytes())
    if cons_edit is not None:
        cons_edit(tmp)
    exe, _ = build_kernel(kb)
    return run_harness(exe, tmp, _seed(), PRESET, max_cycles=400 * (job.manifold_passes + job.bodies.num_bodies) + 20000)


@pytest.mark.parametrize("lag,fetch", [(75, 0), (75, 9), (0, 2), (342, 4)],
                         ids=["fetch0", "fetch-over-contexts", "lag0", "ring-too-small"])
def test_window_bad_arguments(lag: int, fetch: int, tmp_path: Path) -> None:
    job = window_job("pile", "sweep", 1)
    assert not fits(DEPTH, 8, lag, fetch)
    regs = [(a, v) for a, v in register_writes(job) if a not in (0x90, 0x98)] + [(0x90, lag), (0x98, fetch)]
    r = _run_raw(job, tmp_path, regs)
    assert int(r["status"]) & 0xFF == 1 << 2, f"status 0x{int(r['status']):x}: expected error code 3 alone"
    assert int(r["issued"]) == 0 and int(r["cycles"]) < 100


def test_window_early_tlast(tmp_path: Path) -> None:
    """The first fetch loses its last record (TLAST moves to the record before): error code 1, that slot is
    rejected in the fetch's passes, the second fetch is whole and the step ends."""
    job = window_job("pile", "sweep", 1, fetch_passes=4)
    beats_per = 3
    nm = len(job.slots)

    def cut_first_fetch(run: Path) -> None:
        data = np.frombuffer((run / "cons.bin").read_bytes(), np.uint8).reshape(-1, 64)
        last = np.frombuffer((run / "cons_last.bin").read_bytes(), np.uint8).copy()
        end = nm * beats_per
        keep = np.r_[0:end - beats_per, end:data.shape[0]]
        last[end - beats_per - 1] = 1
        (run / "cons.bin").write_bytes(data[keep].tobytes())
        (run / "cons_last.bin").write_bytes(last[keep].tobytes())

    r = _run_raw(job, tmp_path, register_writes(job), cut_first_fetch)
    assert int(r["status"]) & 0xFF == 1 << 0, f"status 0x{int(r['status']):x}: expected error code 1"
    # the slot is rejected in all 4 passes of the first fetch, and stays rejected in the second fetch's passes
    assert int(r["rejected"]) == 8 and int(r["issued"]) == job.manifold_passes - 8


def test_window_plan_band_matches_schedule() -> None:
    job = window_job("pile", "sweep", 1)
    plan = job.record_window
    assert plan is not None
    assert plan.lag == plan.band == band_width(job.slots, job.cons, job.bodies.dynamic) >= 2
    assert (plan.fetch_passes - 1) * plan.lag + 2 <= DEPTH  # all 8 passes trail each other in the ring
    assert plan.fetch_passes == 8 and plan.fetches(job.params) == 1
