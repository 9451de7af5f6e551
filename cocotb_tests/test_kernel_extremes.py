"""The kernel on steps whose every real word spans its format's whole range (``models.extreme_stimulus``).

The test scenes keep values within a few orders of magnitude of 1, so they reach the operators' exception paths
only where one value is forced (a spinning cube). Here every word of the body and constraint records and every
integration operand takes a random sign and a log-uniform magnitude from the smallest subnormal to the largest
finite value: thousands of operator results overflow, underflow or turn invalid in one step, at different
operators in different records, and infinities and NaNs flow into the next passes and into integration. The step
must still be bit-exact with the golden model (the trace, NaN payloads included, and the body-out stream), and the
kernel's three event counters must equal the golden model's count of every operator's flags
(``tb.fp_events.predicted_events``), each of them in the hundreds or thousands.

Three builds the suite already makes (no build of their own): the streaming kernel in fp32
(``build/verilator/pgs_kernel_e8m23_c512``) and fp16 (``..._e5m10_c512``), and the two-lane fp32 window kernel
(``..._e8m23_c512_w1024x8_l2``), each on the pile through the zcu102 DMA model with random stream gaps and output
backpressure. The seed draws the values and the stream timing; it is printed, and ``SEED=<int>`` reruns one.

The kernels whose impulses travel with the records are not run here: they check the impulse words they read back
as a record's words, so a non-finite impulse rejects its manifold in the next pass (error 5), which the golden
model's solve does not do (``rtl/README.md``, "Bad input").
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import pytest

from models import scenes
from models.contact_solver import SolverParams
from models.dma_model import get_preset
from models.extreme_stimulus import extreme_magnitudes
from models.kernel_job import KernelJob
from models.number_format import FP16, FP32, NumberFormat
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.kernel_build import default_window
from sim.kernel_step import run_kernel_step
from tb.fp_events import predicted_events

PRESET = get_preset("zcu102")
GAP_PERMILLE, BP_PERMILLE = 100, 200
EVENT_NAMES = ("overflow", "underflow", "invalid")
MIN_EVENTS = 100  # each counter's floor on the pile (seeds 1 to 40: at least 313 invalid, 2,082 underflow)


def _seed() -> int:
    return int(os.environ.get("SEED", "20261205"))


@dataclass(frozen=True)
class Case:
    fmt: NumberFormat
    window: int = 0  # 0: the streaming kernel (hazard order); else the window kernel's ring (sweep order)
    lanes: int = 1

    @property
    def label(self) -> str:
        return f"{self.fmt.name}-" + (f"window{self.window}-l{self.lanes}" if self.window else "stream")

    def job(self, seed: int) -> KernelJob:
        frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
        job = KernelJob.from_frame(frame, self.fmt, SolverParams(4), "sweep" if self.window else "hazard",
                                   default_window(self.fmt, PRESET.stream_bits))
        if self.window:
            job = job.windowed(self.window, lanes=self.lanes)
        return extreme_magnitudes(job, seed)


CASES = [Case(FP32), Case(FP16), Case(FP32, window=1024, lanes=2)]


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # the golden model's NaNs: the point
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.label)
def test_kernel_at_extremes(case: Case, tmp_path: Path) -> None:
    seed = _seed()
    job = case.job(seed)
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE)
    r = res.registers
    got = {name: int(r[f"fp_{name}"]) for name in EVENT_NAMES}
    want = predicted_events(job).as_dict()
    print(f"\n[{case.label}] seed {seed} (SEED= overrides): {res.cycles} cycles, status {int(r['status']):#x}; "
          f"floating-point events: kernel {got}, golden model {want}; {res.comparison.records} trace records, "
          f"{res.comparison.bodies} bodies, {res.comparison.differing_bits} differing bits")
    assert res.comparison.first_mismatch is None, res.comparison.first_mismatch
    assert res.bit_exact
    assert int(r["rejected"]) == 0  # good input: every word finite, every dynamic body's masses positive
    assert got == want, "the kernel's floating-point event counters differ from the golden model's count"
    assert min(got.values()) >= MIN_EVENTS, got
    assert int(r["fp_status"]) == 0b111
