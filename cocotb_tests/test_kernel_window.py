"""The window kernel (``pgs_kernel`` with ``WINDOW`` > 0, ``rtl/pgs_window.sv``) against the golden model.

The window kernel reads each manifold's combined record once per fetch and lets the passes of a fetch trail each
other over an on-chip ring; records of several passes interleave at issue and retire. With the lag at least the
slot order's band width D (``models.kernel.record_window``), every body sees its updates in the sequential solve's
order, so the trace (put back into pass order) and the body-out stream must equal the golden model's bit for bit. Built
once (fp32, a ring of 1,024 records of two issue lanes, ``build/verilator/pgs_kernel_e8m23_c512_w1024x8_l2/``: every
manifold-pass of a record issues in the same cycle into its lane's pipes) and run in the compiled harness
(``sim.drive.kernel_step``) through the zcu102 DMA model with random stream gaps and output backpressure (seeded: the
seed is printed, ``SEED=<int>`` overrides it). The one-lane window kernel is the same RTL with ``LANES`` = 1 (linted by
``make lint``; ``make sim RECORD_WINDOW=...`` runs it); CI builds the two-lane one, which exercises the lane logic as
well.

* bit-exact: a 4x3x4 pile (108 manifolds) and the stack, Bullet's pass order and the interleaved one, one fetch
  per step (all 8 passes trailing each other: the sweep order and the hazard order) and several fetches (2 passes
  per fetch: 4 fetches; 3 passes per fetch: fetches of 3, 3 and 2), records padded with empty lanes where the
  next manifold shares a body (``models.kernel.record_window.lane_slots``);
* a lag below D must break the order (the comparison sees it: the check is not vacuous);
* the argument check (error code 3: fetch_passes 0 or above the contexts, lag 0, a trailing the ring cannot hold,
  num_manifolds not a multiple of the lanes): the step ends at once without reading a stream;
* an early TLAST in a fetch (error code 1): the missing record's slots are rejected in every pass, the step ends;
* lanes that collide (the host groups manifolds sharing a dynamic body into one record, error code 4): the later
  lane is rejected in every pass, and the step equals the golden model's with that manifold left out, bit for
  bit;
* the cycle model (``models/timing/window_cycle_model.py``): with deterministic streams (gap 0, backpressure 0) every
  retire cycle, the stall and bubble counters, the rejected count and the total cycles are the model's, on the two-lane
  build and on a one-lane build (``build/verilator/pgs_kernel_e8m23_c512_w1024x8``, DEPTH 1024): the pile with the sweep
  and hazard orders, one and several fetches, both pass orders, the stack; a larger pile whose fetch is DDR-bound
  (bubbles), one with more records than the ring (ring room), rejected lanes (colliding, static pairs), 12 passes over 8
  contexts with a lag below the band (the pass-start rule; timing only), the ideal DMA.
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
from models.formats.number_format import FP32
from models.kernel.stream_format import StreamLayout
from models.kernel.record_window import fits
from models.order.manifold_schedule import band_width
from models.kernel.kernel_job import KernelJob
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.drive.harness_run import register_writes, run_harness, write_inputs
from sim.compile.kernel_build import KernelBuild, build_kernel
from sim.drive.kernel_step import KernelResult, golden_step, run_kernel_step
from sim.compare.trace_bits import Comparison, compare_body_out, compare_trace_bits, read_trace
from models.timing import prediction
from sim.compare import retire_cycles
from sim.drive.seed import run_seed

DEPTH = 1024
LANES = 2
GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")
RECORD_BYTES = StreamLayout(FP32).window_bytes  # one lane's combined record (3 beats of 512 bits)


def _seed() -> int:
    return run_seed()


def window_job(scene: str, schedule: str, hazard_window: int, interleaved: bool = False,
               fetch_passes: int | None = None, lanes: int = LANES, iterations: int = 4,
               scene_params: dict[str, int] | None = None) -> KernelJob:
    frame = scenes.load_or_capture(scene, **(KERNEL_TEST_SCENES[scene] if scene_params is None else scene_params))
    job = KernelJob.from_frame(frame, FP32, SolverParams(iterations, interleaved=interleaved), schedule, hazard_window)
    return job.windowed(DEPTH, fetch_passes=fetch_passes, lanes=lanes)


def run_window(job: KernelJob, tmp: Path, label: str) -> KernelResult:
    seed = _seed()
    plan = job.record_window
    assert plan is not None
    print(f"\n[{label}] seed {seed} (SEED= overrides); {len(job.slots)} slots ({plan.empty_lanes} empty lanes), "
          f"D={plan.band} records, lag={plan.lag}, "
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
    assert res.stream_bytes["constraints"] == plan.fetches(job.params) * len(job.slots) * RECORD_BYTES


def test_window_lag_below_band_breaks_the_order(tmp_path: Path) -> None:
    """lag 1 on an order whose band D is several records: passes overtake updates of the pass before, the results
    differ."""
    job = window_job("pile", "sweep", 1, fetch_passes=8)
    plan = job.record_window
    assert plan is not None and plan.band > 1
    short = dataclasses.replace(job, record_window=dataclasses.replace(plan, lag=1))
    res = run_window(short, tmp_path, "pile/sweep lag 1")
    assert not res.bit_exact and res.comparison.differing_bits > 0
    assert int(res.registers["status"]) == 0  # the kernel has no way to know: it is the host's plan


def _run_raw(job: KernelJob, tmp: Path, regs: list[tuple[int, int]],
             cons_edit=None) -> dict[str, float]:  # type: ignore[no-untyped-def]
    plan = job.record_window
    assert plan is not None
    kb = KernelBuild.for_job(job, PRESET)
    write_inputs(tmp, job, kb)
    (tmp / "regs.bin").write_bytes(np.asarray(regs, dtype="<u4").tobytes())
    if cons_edit is not None:
        cons_edit(tmp)
    exe, _ = build_kernel(kb)
    return run_harness(exe, tmp, _seed(), PRESET, max_cycles=400 * (job.manifold_passes + job.bodies.num_bodies) + 20000)


@pytest.mark.parametrize("lag,fetch,odd", [(75, 0, 0), (75, 9, 0), (0, 2, 0), (342, 4, 0), (10, 2, 1)],
                         ids=["fetch0", "fetch-over-contexts", "lag0", "ring-too-small", "slots-not-whole-records"])
def test_window_bad_arguments(lag: int, fetch: int, odd: int, tmp_path: Path) -> None:
    job = window_job("pile", "sweep", 1)
    assert not fits(DEPTH, 8, lag, fetch) or odd
    regs = [(a, v - odd if a == 0x18 else v) for a, v in register_writes(job) if a not in (0x90, 0x98)]
    regs += [(0x90, lag), (0x98, fetch)]
    r = _run_raw(job, tmp_path, regs)
    assert int(r["status"]) & 0xFF == 1 << 2, f"status 0x{int(r['status']):x}: expected error code 3 alone"
    assert int(r["issued"]) == 0 and int(r["cycles"]) < 100


def test_window_early_tlast(tmp_path: Path) -> None:
    """The first fetch loses its last record (TLAST moves to the record before): error code 1, the record's slots
    are rejected in the fetch's passes, the second fetch is whole and the step ends."""
    job = window_job("pile", "sweep", 1, fetch_passes=4)
    beats_per = 3 * LANES
    nm = len(job.slots) // LANES  # records per fetch
    lost = int(np.count_nonzero(job.slots[-LANES:] >= 0))

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
    # every lane of the missing record is rejected in the 4 passes of the first fetch (a truncated record has no
    # empty lanes); its manifolds stay rejected in the second fetch's passes, where an empty lane is just empty
    assert lost >= 1 and int(r["rejected"]) == 4 * LANES + 4 * lost
    assert int(r["issued"]) == job.manifold_passes - 8 * lost
    # the step is the golden model's without those manifolds, every other record under its own slot
    kept = job.slots.copy()
    kept[-LANES:] = -1
    _assert_golden_without(job, kept, tmp_path)


def test_window_plan_band_matches_schedule() -> None:
    job = window_job("pile", "sweep", 1)
    plan = job.record_window
    assert plan is not None
    assert plan.lag == plan.band == band_width(job.slots, job.cons, job.bodies.dynamic, LANES) >= 2
    assert (plan.fetch_passes - 1) * plan.lag + 2 <= DEPTH  # all 8 passes trail each other in the ring
    assert plan.fetch_passes == 8 and plan.fetches(job.params) == 1


def test_window_lanes_collide(tmp_path: Path) -> None:
    """The host pairs manifolds into records without the lane plan (some records' two manifolds share a dynamic
    body): the kernel rejects the later lane of each such record in every pass (error code 4), so that no two lanes
    write one body; the step then equals the golden model's with those manifolds left out, bit for bit."""
    job = window_job("pile", "sweep", 1)
    plan = job.record_window
    assert plan is not None
    order = job.slots[job.slots >= 0]
    naive = np.concatenate([order, np.full(-len(order) % LANES, -1)])   # consecutive manifolds, no padding
    dyn = job.bodies.dynamic
    cons = job.cons
    kept = naive.copy()
    for r in range(0, len(naive), LANES):   # what the kernel does: a lane sharing a body with an earlier one goes
        seen: set[int] = set()
        for k in range(r, r + LANES):
            m = int(naive[k])
            if m < 0:
                continue
            mine = {int(x) for x in (cons.body_a[m], cons.body_b[m]) if dyn[x]}
            if mine & seen:
                kept[k] = -1
            else:
                seen |= mine
    collisions = int(np.count_nonzero(kept != naive))
    assert collisions >= 1
    lag = band_width(naive, cons, dyn, LANES)
    sent = dataclasses.replace(job, record_window=dataclasses.replace(plan, slots=naive, lag=lag, band=lag))
    r = _run_raw(sent, tmp_path, register_writes(sent))
    print(f"\n[lanes collide] seed {_seed()}: {collisions} of {len(naive) // LANES} records collide; "
          f"status 0x{int(r['status']):x}, rejected {int(r['rejected'])}")
    assert int(r["status"]) & 0xFF == 1 << 3, f"status 0x{int(r['status']):x}: expected error code 4 alone"
    assert int(r["rejected"]) == collisions * 8 and int(r["issued"]) == 8 * int(np.count_nonzero(kept >= 0))
    _assert_golden_without(sent, kept, tmp_path)


def _assert_golden_without(sent: KernelJob, kept: np.ndarray, run: Path) -> None:
    """The run of ``sent`` in ``run`` equals, bit for bit, the golden model's step over the slots ``kept`` (the
    manifolds the kernel rejected set to -1)."""
    plan = sent.record_window
    assert plan is not None
    expected = dataclasses.replace(sent, schedule=kept, record_window=dataclasses.replace(plan, slots=kept))
    golden = golden_step(expected)
    kb = KernelBuild.for_job(sent, PRESET)
    cmp = Comparison()
    compare_trace_bits(read_trace(run / "trace.bin", sent.fmt, kb.trace_bytes), golden.records, expected, cmp)
    compare_body_out(run, expected, kb, golden.final, cmp)
    assert cmp.first_mismatch is None and cmp.differing_bits == 0, cmp.first_mismatch


# --- the cycle model: every retire cycle of deterministic runs ---------------------------------------------------
BIG_PILE = {"nx": 8, "ny": 8, "nz": 5, "seed": 3}  # 971 manifolds: the DDR-bound fetch leaves bubbles
ROOM_PILE = {"nx": 10, "ny": 10, "nz": 5, "seed": 4}  # 1,582 manifolds: more records than the ring of 1,024


@dataclasses.dataclass(frozen=True)
class CycleCase:
    """A window kernel step for the cycle comparison: ``window_job``'s arguments, then what differs from the plan."""

    scene: str
    schedule: str
    hazard_window: int
    interleaved: bool = False
    fetch_passes: int | None = None
    lanes: int = LANES
    iterations: int = 4
    scene_params: dict[str, int] | None = None
    lag: int | None = None  # in place of the plan's (below the band: the timing holds, the result is not the golden's)
    edit: str = ""  # "collide": records of consecutive manifolds; "static": 5 dynamic bodies made static
    preset: str = "zcu102"

    def job(self) -> KernelJob:
        job = window_job(self.scene, self.schedule, self.hazard_window, self.interleaved, None, self.lanes,
                         self.iterations, self.scene_params)
        plan = job.record_window
        assert plan is not None
        lag = self.lag or plan.lag
        slots = plan.slots
        if self.edit == "collide":  # the lane plan skipped: consecutive manifolds, colliding lanes rejected
            order = job.slots[job.slots >= 0]
            slots = np.concatenate([order, np.full(-len(order) % self.lanes, -1)])
            lag = band_width(slots, job.cons, job.bodies.dynamic, self.lanes)
        if self.edit == "static":  # their manifolds with the ground join two static bodies: rejected
            inv = job.bodies.inv_mass.copy()
            inv[np.flatnonzero(job.bodies.dynamic)[::7][:5]] = 0.0
            job = dataclasses.replace(job, bodies=dataclasses.replace(job.bodies, inv_mass=inv))
        fetch = self.fetch_passes or plan.fetch_passes
        if not fits(DEPTH, plan.ctx, lag, fetch):  # the plan's passes per fetch trail too far at this lag
            fetch = max(f for f in range(1, plan.ctx + 1) if fits(DEPTH, plan.ctx, lag, f))
        return dataclasses.replace(job, record_window=dataclasses.replace(plan, lag=lag, fetch_passes=fetch,
                                                                          slots=slots))


CYCLE_CASES = {
    "pile-sweep-1fetch": CycleCase("pile", "sweep", 1),
    "pile-sweep-2fetches": CycleCase("pile", "sweep", 1, fetch_passes=2),
    "pile-sweep-interleaved-3": CycleCase("pile", "sweep", 1, True, 3),
    "pile-hazard-1fetch": CycleCase("pile", "hazard", 181),
    "pile-hazard-interleaved-2": CycleCase("pile", "hazard", 181, True, 2),
    "pile-hazard-3": CycleCase("pile", "hazard", 181, fetch_passes=3),
    "stack-hazard": CycleCase("stack", "hazard", 181),
    "stack-sweep-interleaved-2": CycleCase("stack", "sweep", 1, True, 2),
    "big-hazard-8fetches": CycleCase("pile", "hazard", 181, fetch_passes=1, scene_params=BIG_PILE),
    "big-hazard-ideal-dma": CycleCase("pile", "hazard", 181, scene_params=BIG_PILE, preset="ideal"),
    "ring-room-sweep": CycleCase("pile", "sweep", 1, fetch_passes=8, scene_params=ROOM_PILE),
    "lanes-collide": CycleCase("pile", "sweep", 1, edit="collide"),
    "static-pairs": CycleCase("pile", "hazard", 181, fetch_passes=2, scene_params=BIG_PILE, edit="static"),
    "12-passes-lag1": CycleCase("pile", "hazard", 181, fetch_passes=4, iterations=6, lag=1),
    "l1-pile-hazard-interleaved-2": CycleCase("pile", "hazard", 181, True, 2, lanes=1),
    "l1-stack-hazard-3": CycleCase("stack", "hazard", 181, fetch_passes=3, lanes=1),
    "l1-12-passes-lag2": CycleCase("pile", "hazard", 181, True, 2, lanes=1, iterations=6, lag=2),
    "l1-ring-room-hazard-lag3": CycleCase("pile", "hazard", 181, fetch_passes=8, lanes=1, scene_params=ROOM_PILE,
                                          lag=3),
}


def assert_cycles_match(name: str, pred: prediction.Prediction, res: KernelResult, job: KernelJob,
                        extra: str = "") -> None:
    """A deterministic run against the cycle model: every retire cycle (the trace's retire order, lanes of a cycle lane
    by lane), the stall and bubble counters, the total cycles and the rejected count; on a difference the message
    names the first differing record and the model's reasons for its cycle. ``extra``: printed with the figures."""
    agree = retire_cycles.compare_run(pred, res, job.slots)
    print(f"\n[{name}] {agree.describe()}; stalls {pred.stall_cycles_by_cause()}, bubbles {pred.bubbles:,}, rejected "
          f"{pred.rejected}; {extra}")
    assert agree.ok, agree.first_mismatch
    assert agree.exact == agree.records == int(res.registers["issued"])
    assert int(res.registers["rejected"]) == pred.rejected


@pytest.mark.parametrize("name", list(CYCLE_CASES))
def test_window_cycles_match_model(name: str, tmp_path: Path) -> None:
    """Deterministic streams: every retire cycle (in the trace's retire order, lanes of a cycle lane by lane), the
    stall and bubble counters, the rejected count and the total cycles equal the cycle model's; on a difference the
    message names the first differing record and the model's reasons for its cycle."""
    case = CYCLE_CASES[name]
    job = case.job()
    preset = get_preset(case.preset)
    pred = cycle_model.predict_job(job, preset)
    assert pred.overwritten == 0, "the ring would lose records (the model's precondition for an exact comparison)"
    res = run_kernel_step(job, preset, tmp_path, _seed(), 0, 0, keep_trace=True)
    assert_cycles_match(name, pred, res, job, f"ring room waits {int(np.count_nonzero(pred.room_wait))}")
    plan = job.record_window
    assert plan is not None
    if not case.edit and plan.lag >= plan.band:
        assert res.bit_exact, res.comparison.first_mismatch
