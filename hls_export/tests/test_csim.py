"""C simulation of the HLS kernel (hls_export/pgs_kernel.cpp, g++ with the local shims) against the golden model,
bit for bit, through the RTL harness's own file interface and comparison code (sim/harness_run.py,
sim/trace_compare.py): every trace record (one per retired manifold-pass, in retire order) and the body-out
stream, binary32, 4 iterations, on the
stack, the incline and a 4x3x4 pile, in the hazard and the pybullet schedules; plus the status and issued
outputs and the stream accounting (no beat left over, none read from an empty stream); the interleaved pass
order; and the status register's error codes 3 (bad argument) and 1 (constraint TLAST).

Also prints, per case, the records that would read a velocity still in flight in a pipeline holding W records
(W = the RTL's hazard window): where that is not 0, the synthesized kernel (DEPENDENCE false) would differ.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hls_export.csim import SCENES, SCHEDULES, build_csim, run_csim_step, scene_job
from models import scenes
from models.contact_solver import SolverParams
from models.dma_model import get_preset
from models.format_analyzer import inertia_mode_of
from models.kernel_job import KernelJob
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.number_format import FP32
from models.register_map import OFFSET
from sim.harness_run import run_harness, write_inputs
from sim.kernel_build import KernelBuild, default_window
from sim.verilator_build import REPO_ROOT

KB = KernelBuild(FP32)
ROTATED_WORLD = str(REPO_ROOT / "docs" / "rotated_boxes_world.py")  # rotated non-cube boxes, Bullet 2's convention


@pytest.fixture(scope="module")
def csim_exe() -> Path:
    return build_csim(KB)


@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("scene", list(SCENES))
def test_csim_bit_exact(scene: str, schedule: str, csim_exe: Path, tmp_path: Path) -> None:
    job = scene_job(scene, schedule, 4, KB)
    window = default_window(FP32, KB.cons_bits)
    res = run_csim_step(job, tmp_path, csim_exe, KB, window)
    c = res.comparison
    print(f"\n[{scene}/{schedule}] {job.bodies.num_bodies} bodies, {len(job.slots)} manifolds: {c.records} trace "
          f"records and {c.bodies} bodies compared, {c.differing_bits} differing bits; csim {res.registers['wall_s']:.3f} "
          f"s, golden {res.golden_seconds:.2f} s; {res.window_hazards} of {job.manifold_passes} records within "
          f"{window} of a record sharing a dynamic body")
    if c.first_mismatch is not None:
        pytest.fail(c.first_mismatch)
    assert res.bit_exact
    assert c.records == job.manifold_passes and c.bodies == job.bodies.num_bodies


@pytest.mark.parametrize("scene,inertia_words", [(ROTATED_WORLD, 6), ("stack", 1)], ids=["rotated_boxes-full", "stack-scalar"])
def test_csim_inverse_inertia_modes(scene: str, inertia_words: int, tmp_path: Path) -> None:
    """The other inverse-inertia builds (PGS_IINV_W): the rotated non-cube boxes of a Bullet 2 world file (every
    dynamic body a full symmetric 3x3: the 6-word record and product, the build ``KernelBuild.for_job`` picks) and
    the stack's cubes on the 1-word scalar build, bit for bit with the golden model. The boxes keep pybullet's
    default friction (0.5: every pair 0.25, not the kernel's 0.7), so their friction records carry it
    (PGS_MU_W = 1)."""
    frame = scenes.load_or_capture(scene, **KERNEL_TEST_SCENES.get(scene, {}))
    job = KernelJob.from_frame(frame, FP32, SolverParams(4), "hazard", default_window(FP32, KB.cons_bits))
    kb = KernelBuild(FP32, inertia_words=inertia_words, friction_words=job.friction_words)
    assert job.friction_words == (inertia_words == 6)
    assert inertia_mode_of(job.bodies).words == inertia_words
    if inertia_words == 6:
        assert KernelBuild.for_job(job, get_preset("zcu102")) == kb
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(FP32, kb.cons_bits))
    c = res.comparison
    print(f"\n[{Path(scene).stem}/{inertia_words} words] {c.records} trace records and {c.bodies} bodies compared")
    if c.first_mismatch is not None:
        pytest.fail(c.first_mismatch)
    assert res.bit_exact and c.records == job.manifold_passes and c.bodies == job.bodies.num_bodies


def test_csim_interleaved(csim_exe: Path, tmp_path: Path) -> None:
    """options bit 0: contact and friction passes alternate per iteration."""
    job = scene_job("pile", "hazard", 3, KB, interleaved=True)
    res = run_csim_step(job, tmp_path, csim_exe, KB, default_window(FP32, KB.cons_bits))
    assert res.comparison.first_mismatch is None and res.bit_exact


def _status_after(edit: str, csim_exe: Path, tmp_path: Path) -> dict[str, float]:
    job = scene_job("stack", "hazard", 2, KB)
    write_inputs(tmp_path, job, KB)
    if edit == "bad_args":  # num_bodies above PGS_MAX_BODIES
        regs = np.frombuffer((tmp_path / "regs.bin").read_bytes(), dtype="<u4").reshape(-1, 2).copy()
        regs[regs[:, 0] == OFFSET["num_bodies"], 1] = KB.max_bodies + 1
        (tmp_path / "regs.bin").write_bytes(regs.tobytes())
    else:  # TLAST on the first constraint beat instead of the last beat of the first pass
        last = bytearray((tmp_path / "cons_last.bin").read_bytes())
        last[0] = 1
        (tmp_path / "cons_last.bin").write_bytes(bytes(last))
    return run_harness(csim_exe, tmp_path, seed=1, preset=get_preset("ideal"), max_cycles=0)


def test_csim_status_bad_args(csim_exe: Path, tmp_path: Path) -> None:
    """Error code 3: the step ends at once (flag bit 2, first code 3 in bits 15:8), streams untouched."""
    r = _status_after("bad_args", csim_exe, tmp_path)
    assert int(r["status"]) == (1 << 2) | (3 << 8)
    assert r["issued"] == 0 and r["trace_records"] == 0 and r["body_out_beats"] == 0
    assert r["body_in_beats_taken"] == 0 and r["cons_beats_taken"] == 0


def test_csim_status_cons_tlast(csim_exe: Path, tmp_path: Path) -> None:
    """Error code 1: constraint TLAST not exactly on the last beat of each pass (the step still runs)."""
    r = _status_after("tlast", csim_exe, tmp_path)
    assert int(r["status"]) == (1 << 0) | (1 << 8)
    assert r["cons_beats_left"] == 0
