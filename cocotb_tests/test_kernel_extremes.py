"""The kernel on steps whose every real word spans its format's whole range (``models.kernel.extreme_stimulus``).

The test scenes keep values within a few orders of magnitude of 1, so they reach the operators' exception paths
only where one value is forced (a spinning cube). Here every word of the body and constraint records and every
integration operand takes a random sign and a log-uniform magnitude from the smallest subnormal to the largest
finite value: thousands of operator results overflow, underflow or turn invalid in one step, at different
operators in different records, and infinities and NaNs flow into the next passes and into integration. The step
must still be bit-exact with the golden model (the trace, NaN payloads included, and the body-out stream), and the
kernel's three event counters must equal the golden model's count of every operator's flags
(``sim.drive.kernel_step.golden_step``'s ``events``: the golden model's count through its own arithmetic), each of
them in the hundreds or thousands.

The kernels whose impulses travel with the records check the impulse words they read back like any record word:
a manifold whose record carries a non-finite impulse is rejected from that pass (the streaming kernel) or fetch (the
window kernel) on, error 5 (``rtl/README.md``, "Bad input"). The golden model makes the same check
(``KernelJob.record_checks``), so their steps are bit-exact too, with the rejected manifold-passes, the status and
the issue counters predicted (``sim.drive.kernel_step.check_counters``), and the event counters count only the issued
manifold-passes, as the prediction does. The kernel checks a friction record's impulse words,
not a contact record's, so the rejections come at the friction passes: all of them where the contact passes run
first (nearly every normal impulse is non-finite by then), some in the interleaved order, where each friction
pass of the fp16 two-lane run is a fetch of its own.

Five builds the suite already makes (no build of their own): the streaming kernel in fp32
(``build/verilator/pgs_kernel_e8m23_c512``) and fp16 (``..._e5m10_c512``), the two-lane fp32 window kernel
(``..._e8m23_c512_w1024x8_l2_dl129``) and the window kernels with the impulses in the records, the fitting designs'
RTL with a ring of 1,024 (fp32 one lane, ``..._e8m23_c512_w1024x8_ir_bk8``; fp16 two lanes,
``..._e5m10_c512_w1024x8_l2_ir_bk16_dl129``, in the interleaved order), each on the pile through the zcu102 DMA
model with random stream gaps and output backpressure. The seed draws the values and the stream timing; it is printed,
and ``SEED=<int>`` reruns one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest

from models import scenes
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.extreme_stimulus import extreme_magnitudes
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import EVENT_NAMES, FP16, FP32, NumberFormat
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import golden_step, run_kernel_step
from sim.drive.seed import run_seed

PRESET = get_preset("zcu102")
GAP_PERMILLE, BP_PERMILLE = 100, 200
MIN_EVENTS = 50  # each counter's floor on the pile (seeds 1 to 40: at least 133 invalid, 277 underflow)


def _seed() -> int:
    return run_seed()


@dataclass(frozen=True)
class Case:
    fmt: NumberFormat
    window: int = 0  # 0: the streaming kernel (hazard order); else the window kernel's ring (sweep order)
    lanes: int = 1
    records: bool = False  # the impulses travel with the records (a cold start; the extremes draw a warm one)
    interleaved: bool = False  # the pass order (with the impulses in the records: a fetch per pass)

    @property
    def label(self) -> str:
        return f"{self.fmt.name}-" + (f"window{self.window}-l{self.lanes}" if self.window else "stream") + \
            ("-records" if self.records else "") + ("-interleaved" if self.interleaved else "")

    def job(self, seed: int) -> KernelJob:
        frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
        job = KernelJob.from_frame(frame, self.fmt, SolverParams(4, interleaved=self.interleaved),
                                   "sweep" if self.window else "hazard",
                                   default_window(self.fmt, PRESET.stream_bits, window_kernel=self.window > 0))
        if self.records:
            job = job.impulses_travelling()
        if self.window:
            job = job.windowed(self.window, lanes=self.lanes)
        return extreme_magnitudes(job, seed)


CASES = [Case(FP32), Case(FP16), Case(FP32, window=1024, lanes=2), Case(FP32, window=1024, records=True),
         Case(FP16, window=1024, lanes=2, records=True, interleaved=True)]


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # the golden model's NaNs: the point
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.label)
def test_kernel_at_extremes(case: Case, tmp_path: Path) -> None:
    seed = _seed()
    job = case.job(seed)
    golden = golden_step(job)
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE, golden=golden)
    r = res.registers
    got = {name: int(r[f"fp_{name}"]) for name in EVENT_NAMES}
    want = golden.events.as_dict()
    print(f"\n[{case.label}] seed {seed} (SEED= overrides): {res.cycles} cycles, status {int(r['status']):#x}, "
          f"{int(r['rejected'])} manifold-passes rejected; floating-point events: kernel {got}, golden model "
          f"{want}; {res.comparison.records} trace records, {res.comparison.bodies} bodies, "
          f"{res.comparison.differing_bits} differing bits")
    assert res.comparison.first_mismatch is None, res.comparison.first_mismatch  # status and counters included
    assert res.bit_exact
    # good input: every word finite, every dynamic body's masses positive; with the impulses in the records the
    # extremes' impulses turn non-finite, and the rejections are the golden model's (checked above)
    assert (int(r["rejected"]) > 0) == case.records
    assert got == want, "the kernel's floating-point event counters differ from the golden model's count"
    assert min(got.values()) >= MIN_EVENTS, got
    assert int(r["fp_status"]) == 0b111
