"""The kernel with every adder in its DSP48E2 form (``ADD_SHIFT_DSP = 1``, ``make sim ADD_DSP=1``): fp_add's
``SHIFT_DSP`` form in the lane's shared datapath and the integrate pipe, the same results, flags and latency as the
fabric form. One Verilator build (``pgs_kernel_e8m23_c512_dspadd``: the fp32 streaming kernel, the zcu102 preset's
512-bit beats) for the tests here; ``sim.drive.kernel_step`` compares bit for bit the trace and the body-out stream
with the golden model of the same step:

* the pile with random stream gaps and backpressure (the seed is printed, ``SEED=<int>`` overrides it): bit-exact,
  never faster than the cycle model's lower bound, and the build's elaborated model has the DSP form's registers in
  the lane's datapath and the integrate pipe (a parameter that did not reach them would build the fabric form);
* deterministic streams: every retire cycle, the total and the stall and bubble counters equal the cycle model's.
"""

from __future__ import annotations

from pathlib import Path

from models import scenes
from models.formats.number_format import FP32
from models.golden.contact_solver import SolverParams
from models.kernel.kernel_job import KernelJob
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.timing import cycle_model
from models.timing.platforms import get_preset
from sim.compare import retire_cycles
from sim.compile.artefacts import KernelStore, kernel_store_root
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import run_kernel_step
from sim.drive.seed import run_seed

GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")
DSP_REGISTER = "__DOT__g_dsp_add__DOT__"  # the DSP form's generate block in Verilator's names (rtl/fp/fp_add.sv)


def pile_job() -> KernelJob:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    return KernelJob.from_frame(frame, FP32, SolverParams(4), "hazard",
                                default_window(FP32, PRESET.stream_bits)).with_adders(True)


def dsp_form_elaborated(kb: KernelBuild, where: str) -> bool:
    """Whether the build's model (the kernel store's build of ``kb``, the one the runs here used) has DSP-form
    registers of an fp_add instance under the hierarchy ``where``."""
    build_dir = KernelStore(kernel_store_root()).executable(kb)[0].parent
    words = (w for h in build_dir.glob("*.h") for w in h.read_text().split())
    return any(where in w and DSP_REGISTER in w for w in words)


def test_pile_bit_exact_with_random_backpressure(tmp_path: Path) -> None:
    job, seed = pile_job(), run_seed()
    kb = KernelBuild.for_job(job, PRESET)
    assert kb.name == "pgs_kernel_e8m23_c512_dspadd" and kb.parameters["ADD_SHIFT_DSP"] == 1
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE)
    bound = cycle_model.lower_bound(job, PRESET)
    print(f"[pile/fp32/DSP48E2 adders] {res.cycles:,} cycles with random stalls, model lower bound {bound:,}")
    assert res.bit_exact, res.comparison.first_mismatch
    assert res.cycles >= bound
    # the parameter reached the lane's shared datapath and the integrate pipe (the fabric form has no g_dsp_add)
    assert dsp_form_elaborated(kb, "__DOT__u_datapath__DOT__g_shared__DOT__")
    assert dsp_form_elaborated(kb, "__DOT__u_integrate__DOT__u_integrate__DOT__")


def test_pile_cycles_match_model(tmp_path: Path) -> None:
    job = pile_job()
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    print(f"\n[pile/fp32/DSP48E2 adders] {agree.describe()}; stalls {pred.stalls:,}, bubbles {pred.bubbles:,}")
    assert agree.ok, agree.first_mismatch
