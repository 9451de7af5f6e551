"""The window kernel whose impulses travel with the records (``WINDOW`` > 0 and ``IMPULSES_IN_RECORDS = 1``: no
impulse RAM for every manifold slot; each fetch serves passes of one kind and streams that kind's records with the
impulses the fetch starts from, an on-chip impulse ring as deep as the record ring carries them from pass to pass
within the fetch, and the last pass of each fetch writes them to ``m_axis_imp``, which the harness's DMA model
writes to the DDR impulse buffer the next fetch's records are read with).

Two Verilator builds, each with a ring of 1,024 records and the zcu102 preset's 512-bit beats: fp32 with one lane
and the body velocities in eight banks (``pgs_kernel_e8m23_c512_w1024x8_ir_bk8``, the build of ``make sim
RECORD_WINDOW=... IMPULSE_STORE=records``), and fp16 with two lanes, its delay lines from 129 deep marked for block RAM
(``..._e5m10_c512_w1024x8_l2_ir_bk16_dl129``).
``sim.drive.kernel_step`` compares bit for bit the trace (put back into pass order), the body-out stream and the
impulse-out stream (one record per window record and fetch, TLAST per fetch) with the golden model of the same step:

* the pile and the stack, random stream gaps and backpressure on every stream (the impulse-out stream included;
  the seed is printed, ``SEED=<int>`` overrides it), one, two and four passes per fetch (8, 4 and 2 fetches);
* a warm start (random non-negative normal impulses and friction impulses within the limit), one lane and two;
* the argument check: fetches that would serve contact and friction passes together (3 passes per fetch of 4
  iterations; 2 per fetch with the kinds interleaved) end the step at once with error code 3;
* the cycle model (``models/timing/window_cycle_model.py``: the last-pass start rule, the impulse-out FIFO, the fetches'
  read-after-write turnaround, the banks' busy rule): with deterministic streams (gap 0, backpressure 0) every retire
  cycle, the stall and bubble counters, the rejected and impulse-out counts and the total cycles are the model's, on
  both builds (the pile with 4, 2 and 1 passes per fetch, the stack, a warm start, larger piles: 971 manifolds, and
  1,582, more than the ring holds; manifolds that share no body, whose next fetch waits for the turnaround; every
  body moved into bank 0, where each retire's writes keep the offered record's reads waiting).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.kernel.register_map import OFFSET
from models.order.manifold_schedule import band_width
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.drive.harness_run import harness_cycle_limit, register_writes, run_harness, write_inputs
from sim.compile.kernel_build import KernelBuild, build_kernel, default_window
from sim.drive.kernel_step import KernelResult, run_kernel_step

from cocotb_tests.test_kernel_impulses_in_records import warm_start
from cocotb_tests.test_kernel_window import BIG_PILE, ROOM_PILE, _assert_golden_without, _run_raw, assert_cycles_match
from models.kernel.body_banks import WINDOW_BANKS
from models.tests.test_body_banks import spread_bodies
from models.tests.test_impulses_in_records import independent_stack_job
from sim.drive.seed import run_seed

DEPTH = 1024
GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")


def _seed() -> int:
    return run_seed()


def window_records_job(scene: str, fmt: NumberFormat = FP32, lanes: int = 1, fetch_passes: int | None = None,
                       interleaved: bool = False, warm: bool = False,
                       scene_params: dict[str, int] | None = None, one_bank: bool = False) -> KernelJob:
    """``one_bank``: every body moved into bank 0 (``spread_bodies``): the busy-bank rule on every retire."""
    frame = scenes.load_or_capture(scene, **(KERNEL_TEST_SCENES[scene] if scene_params is None else scene_params))
    job = KernelJob.from_frame(frame, fmt, SolverParams(4, interleaved=interleaved), "hazard",
                               default_window(fmt, PRESET.stream_bits)).impulses_travelling()
    if one_bank:
        job = spread_bodies(job, WINDOW_BANKS * lanes)  # a multiple of the build's banks: bank 0
    if warm:
        job = job.impulses_travelling(warm_start(job, _seed()))
    return job.windowed(DEPTH, fetch_passes=fetch_passes, lanes=lanes)


def run(job: KernelJob, tmp: Path, label: str) -> KernelResult:
    seed, plan = _seed(), job.record_window
    assert plan is not None
    print(f"\n[{label}] seed {seed} (SEED={seed} reproduces); {len(job.slots)} slots, {plan.fetch_passes} passes per "
          f"fetch, {plan.fetches(job.params)} fetches, lag {plan.lag}, {job.body_banks} body banks")
    res = run_kernel_step(job, PRESET, tmp, seed, GAP_PERMILLE, BP_PERMILLE)
    print(f"  {res.cycles:,} cycles, stalls {int(res.registers['stalls']):,}, impulse-out records "
          f"{int(res.registers['impulse_out_records'])}")
    return res


@pytest.mark.parametrize("scene,fetch", [("pile", None), ("pile", 2), ("pile", 1), ("stack", None)],
                         ids=["pile-fetch4", "pile-fetch2", "pile-fetch1", "stack-fetch4"])
def test_bit_exact_one_lane_banked(scene: str, fetch: int | None, tmp_path: Path) -> None:
    job = window_records_job(scene, fetch_passes=fetch)
    plan = job.record_window
    assert plan is not None and job.body_banks == WINDOW_BANKS and plan.fetch_passes == (fetch or 4)
    res = run(job, tmp_path, f"{scene}/fp32/window records/{plan.fetch_passes} passes per fetch")
    assert res.bit_exact, res.comparison.first_mismatch
    # one impulse-out record per slot and fetch: the last pass of each fetch writes, no other
    assert int(res.registers["impulse_out_records"]) == plan.fetches(job.params) * len(job.slots)
    assert res.stream_bytes["constraints"] == plan.fetches(job.params) * len(job.slots) * 128  # 2 beats a record


@pytest.mark.parametrize("fmt,lanes", [(FP32, 1), (FP16, 2)], ids=["fp32-1lane", "fp16-2lanes"])
def test_warm_start(fmt: NumberFormat, lanes: int, tmp_path: Path) -> None:
    job = window_records_job("pile", fmt, lanes, warm=True)
    res = run(job, tmp_path, f"pile/{fmt.name}/window records/{lanes} lane(s)/warm start")
    assert res.bit_exact, res.comparison.first_mismatch


def test_two_lanes_stack(tmp_path: Path) -> None:
    job = window_records_job("stack", FP16, 2, fetch_passes=2)
    plan = job.record_window
    assert plan is not None
    res = run(job, tmp_path, "stack/fp16/window records/2 lanes")
    assert res.bit_exact, res.comparison.first_mismatch
    assert int(res.registers["impulse_out_records"]) == plan.fetches(job.params) * len(job.slots) // 2


@pytest.mark.parametrize("fetch,interleaved", [(3, False), (2, True)], ids=["fetch3-of-4", "fetch2-interleaved"])
def test_mixed_fetch_refused(fetch: int, interleaved: bool, tmp_path: Path) -> None:
    """A fetch that would serve both kinds: the kernel's argument check (error code 3), no stream read."""
    job = window_records_job("pile", interleaved=interleaved, fetch_passes=1)
    kb = KernelBuild.for_job(job, PRESET)
    write_inputs(tmp_path, job, kb, PRESET.impulse_turnaround_cycles)
    regs = [(a, fetch if a == OFFSET["fetch_passes"] else v) for a, v in register_writes(job)]
    (tmp_path / "regs.bin").write_bytes(np.asarray(regs, dtype="<u4").tobytes())
    exe, _ = build_kernel(kb)
    r = run_harness(exe, tmp_path, _seed(), PRESET, harness_cycle_limit(job))
    assert int(r["status"]) & 0xFF == 1 << 2, f"status 0x{int(r['status']):x}: expected error code 3 alone"
    assert int(r["issued"]) == 0 and int(r["cycles"]) < 100
    with pytest.raises(ValueError, match="one kind"):
        window_records_job("pile", interleaved=interleaved, fetch_passes=fetch)


# --- the cycle model: every retire cycle of deterministic runs ---------------------------------------------------
def independent_window_job(fmt: NumberFormat, lanes: int, fetch_passes: int) -> KernelJob:
    """The stack's 10 manifolds re-pointed at the ground and one cube each (no two share a dynamic body,
    ``models.tests.test_impulses_in_records``): no hazard between the manifolds, so the next fetch's records wait
    on the critical path for the turnaround after the fetch before's impulse-out records."""
    return independent_stack_job(fmt).impulses_travelling().windowed(DEPTH, fetch_passes=fetch_passes, lanes=lanes)


CYCLE_CASES: dict[str, Callable[[], KernelJob]] = {
    "fp32-pile-fetch4": lambda: window_records_job("pile"),
    "fp32-pile-fetch2": lambda: window_records_job("pile", fetch_passes=2),
    "fp32-pile-fetch1": lambda: window_records_job("pile", fetch_passes=1),
    "fp32-stack-fetch4": lambda: window_records_job("stack"),
    "fp32-pile-one-bank": lambda: window_records_job("pile", one_bank=True),
    "fp32-pile-warm": lambda: window_records_job("pile", warm=True),
    "fp32-more-records-than-the-ring": lambda: window_records_job("pile", fetch_passes=1, scene_params=ROOM_PILE),
    "fp32-big-fetch4": lambda: window_records_job("pile", scene_params=BIG_PILE),
    "fp32-independent-fetch4": lambda: independent_window_job(FP32, 1, 4),
    "fp32-independent-fetch1": lambda: independent_window_job(FP32, 1, 1),
    "fp16-2lanes-pile": lambda: window_records_job("pile", FP16, 2),
    "fp16-2lanes-stack-fetch2": lambda: window_records_job("stack", FP16, 2, fetch_passes=2),
    "fp16-2lanes-big-fetch1": lambda: window_records_job("pile", FP16, 2, fetch_passes=1, scene_params=BIG_PILE),
    "fp16-2lanes-independent-fetch2": lambda: independent_window_job(FP16, 2, 2),
    "fp16-2lanes-one-bank": lambda: window_records_job("pile", FP16, 2, one_bank=True),
}


@pytest.mark.parametrize("name", list(CYCLE_CASES))
def test_cycles_match_model(name: str, tmp_path: Path) -> None:
    """Deterministic streams: every retire cycle (the trace's retire order), the stall and bubble counters, the
    rejected count, the impulse-out records and the total cycles equal the cycle model's; the step stays the golden
    model's bit for bit. On a difference the message names the first differing record and the model's reasons."""
    job = CYCLE_CASES[name]()
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, _seed(), 0, 0, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    assert_cycles_match(name, pred, res, job, "manifold-passes whose record the turnaround held back: "
                        f"{int(np.count_nonzero(pred.raw_wait)):,}")
    assert int(res.registers["impulse_out_records"]) == pred.impulse_out.size


def test_two_lanes_over_a_banks_ports(tmp_path: Path) -> None:
    """Two lanes on banked body velocities, the host pairing consecutive manifolds without the lane plan (every body
    moved into bank 0, so a record's second manifold would have its lanes read that bank four times; some pairs
    also share a dynamic body): the kernel rejects the later lane of each such record in every pass (error code 4),
    and the step equals the golden model's with those manifolds left out, bit for bit."""
    job = window_records_job("pile", FP16, 2, one_bank=True)
    plan = job.record_window
    assert plan is not None and job.body_banks == 2 * WINDOW_BANKS and np.all(plan.slots[1::2] == -1)
    order = job.slots[job.slots >= 0]
    naive = np.concatenate([order, np.full(-len(order) % 2, -1)])  # consecutive manifolds, no padding
    kept = naive.copy()
    kept[1::2] = -1  # every second lane would read bank 0 a third and fourth time
    lag = band_width(naive, job.cons, job.bodies.dynamic, 2)
    sent = dataclasses.replace(job, record_window=dataclasses.replace(plan, slots=naive, lag=lag, band=lag))
    r = _run_raw(sent, tmp_path, register_writes(sent))
    rejected = int(np.count_nonzero(kept != naive))
    print(f"\n[two lanes over a bank's ports] {rejected} of {len(naive) // 2} records; status "
          f"0x{int(r['status']):x}, rejected {int(r['rejected'])}")
    assert int(r["status"]) & 0xFF == 1 << 3, f"status 0x{int(r['status']):x}: expected error code 4 alone"
    assert int(r["rejected"]) == rejected * 8 and int(r["issued"]) == 8 * int(np.count_nonzero(kept >= 0))
    _assert_golden_without(sent, kept, tmp_path)


def test_rejected_in_an_earlier_fetch(tmp_path: Path) -> None:
    """A contact record with a non-finite word (error 5) in the first fetch: the kernel rejects the slot in the
    contact passes, and in every pass of the friction fetch although that fetch's record is finite (the
    rejected-slot flag read as the record was written into the ring): the step equals the golden model's without
    that manifold, bit for bit."""
    job = window_records_job("pile", fetch_passes=4)
    plan = job.record_window
    assert plan is not None and plan.fetches(job.params) == 2
    k = 17  # the slot whose contact record is broken
    beat_bytes, beats = PRESET.stream_bits // 8, KernelBuild.for_job(job, PRESET).layout.window_beats

    def nan_in_first_fetch(run: Path) -> None:
        data = bytearray((run / "cons.bin").read_bytes())
        at = k * beats * beat_bytes + 8  # the record's first word (n.x), after the 64-bit header
        data[at:at + 4] = np.float32(np.nan).tobytes()
        (run / "cons.bin").write_bytes(bytes(data))

    r = _run_raw(job, tmp_path, register_writes(job), nan_in_first_fetch)
    assert int(r["status"]) & 0xFF == 1 << 4, f"status 0x{int(r['status']):x}: expected error code 5 alone"
    assert int(r["rejected"]) == 8 and int(r["issued"]) == 8 * (len(job.slots) - 1)
    kept = job.slots.copy()
    kept[k] = -1
    _assert_golden_without(job, kept, tmp_path)
