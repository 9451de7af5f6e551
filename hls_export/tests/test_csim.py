"""C simulation of the HLS kernel (hls_export/pgs_kernel.cpp, g++ with the local shims) against the golden model,
bit for bit, through the RTL harness's own file interface and comparison code (sim/drive/harness_run.py,
sim/compare/trace_bits.py): every trace record (one per retired manifold-pass, in retire order) and the body-out
stream, binary32, 4 iterations, on the
stack, the incline and a 4x3x4 pile, in the hazard and the pybullet schedules; plus the status and issued
outputs and the stream accounting (no beat left over, none read from an empty stream); the interleaved pass
order; and the status register's error codes 3 (bad argument) and 1 (constraint TLAST). At extremes: every real word of
the pile's step drawn over its format's whole range (``models.kernel.extreme_stimulus``, seed printed, SEED= overrides),
binary32 and binary16, bit for bit through thousands of overflows, NaNs and flushed results. (The records designs
at extremes are known failures, ``test_csim_window.py::test_csim_window_at_extremes``, marked strict: their impulses
turn non-finite, and the C++ does not follow the RTL's rejection of such records, error 5; see hls_export/README.md.)

The records design (PGS_IMPULSES_IN_RECORDS=1: the impulses travel with the records, the kernel writes them to
m_axis_imp, the testbench's DMA writes them to the impulse buffer the next passes' records are read with): binary16 and
binary32 on the pile and the stack, cold and warm-started (random initial impulses, seed printed, SEED= overrides),
the interleaved pass order, and the rotated boxes (PGS_MU_W=1, PGS_IINV_W=6), bit for bit in the trace, the body-out
stream and the impulse-out records (one per slot and pass, TLAST per pass); and that a one-bit change is seen: in a
host-given impulse word (named in the trace), in an impulse-out record (named there), and not in a word the DMA
replaces (a later pass's record: the buffer's value wins).

Also prints, per case, the records that would read a velocity still in flight in a pipeline holding W records
(W = the RTL's hazard window): where that is not 0, the synthesized kernel (DEPENDENCE false) would differ.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hls_export.csim import (RECORDS_FORMATS, RECORDS_SCENES, SCENES, SCHEDULES, build_csim, records_build,
                             run_csim_step, run_written_step, scene_job, warm_start)
from hls_export.tests.csim_checks import assert_bit_exact
from models import scenes
from models.kernel import stream_format as sf
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.extreme_stimulus import extreme_magnitudes
from models.kernel.kernel_job import KernelJob
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.formats.number_format import FP16, FP32
from models.kernel.register_map import OFFSET
from sim.drive.harness_run import run_harness, write_inputs
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import golden_step
from sim.compare.trace_bits import Comparison, compare_impulse_out
from sim.compile.verilator_build import REPO_ROOT
from sim.drive.seed import run_seed

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
    assert_bit_exact(res, job, f"{scene}/{schedule}, {job.bodies.num_bodies} bodies, {len(job.slots)} manifolds",
                     f"csim {res.registers['wall_s']:.3f} s, golden {res.golden_seconds:.2f} s; {res.window_hazards} "
                     f"of {job.manifold_passes} records within {window} of a record sharing a dynamic body")


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # the golden model's NaNs: the point
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.parametrize("fmt_name", ["fp32", "fp16"])
def test_csim_at_extremes(fmt_name: str, tmp_path: Path) -> None:
    kb = KernelBuild({"fp32": FP32, "fp16": FP16}[fmt_name])
    seed = run_seed()
    job = extreme_magnitudes(scene_job("pile", "hazard", 4, kb), seed)
    res = run_csim_step(job, tmp_path, build_csim(kb), kb)
    assert_bit_exact(res, job, f"pile/hazard at extremes, {fmt_name}, seed {seed} (SEED= overrides)")


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
    assert job.bodies.inertia_mode.words == inertia_words
    if inertia_words == 6:
        assert KernelBuild.for_job(job, get_preset("zcu102")) == kb
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(FP32, kb.cons_bits))
    assert_bit_exact(res, job, f"{Path(scene).stem}/{inertia_words} words")


@pytest.mark.parametrize("fmt_name", ["fp32", "fp16"])
def test_csim_each_kind_on_its_own_arithmetic(fmt_name: str, tmp_path: Path) -> None:
    """PGS_SHARED_DATAPATH = 0 (the RTL's two pipes per lane): each kind's manifold-pass on pgs_solver.h's own
    arithmetic instead of the generated shared datapath; bit for bit the golden model's too (and so the shared one's),
    interleaved passes, with the impulses in the records as the fitting designs."""
    kb = KernelBuild({"fp32": FP32, "fp16": FP16}[fmt_name], impulses_in_records=True, shared_datapath=False)
    job = scene_job("pile", "hazard", 3, kb, interleaved=True)
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(kb.fmt, kb.cons_bits, shared_datapath=False))
    assert "_split" in str(build_csim(kb))
    assert_bit_exact(res, job, f"pile/hazard, {fmt_name}, each kind on its own arithmetic")


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


# --- the records design ---------------------------------------------------------------------------------------
def _seed() -> int:
    return run_seed()


def _records_job(scene: str, fmt_name: str, start: str, interleaved: bool = False) -> KernelJob:
    job = scene_job(scene, "hazard", 4, records_build(RECORDS_FORMATS[fmt_name]), interleaved)
    if start == "warm":
        seed = _seed()
        print(f"\nwarm start seed {seed} (SEED={seed} reproduces)")
        job = job.impulses_travelling(warm_start(job, seed))
    return job


def _check_records(job: KernelJob, tmp_path: Path, label: str) -> None:
    kb = records_build(job.fmt, job)
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(job.fmt, kb.cons_bits))
    assert_bit_exact(res, job, f"records {label}", f"{int(res.registers['impulse_out_records'])} impulse-out records "
                     f"compared; csim {res.registers['wall_s']:.3f} s, golden {res.golden_seconds:.2f} s")
    assert int(res.registers["impulse_out_records"]) == job.manifold_passes


@pytest.mark.parametrize("start", ["cold", "warm"])
@pytest.mark.parametrize("scene", RECORDS_SCENES)
@pytest.mark.parametrize("fmt_name", list(RECORDS_FORMATS))
def test_csim_records_bit_exact(fmt_name: str, scene: str, start: str, tmp_path: Path) -> None:
    _check_records(_records_job(scene, fmt_name, start), tmp_path, f"{fmt_name} {scene} {start}")


def test_csim_records_interleaved(tmp_path: Path) -> None:
    """Contact and friction passes alternate: each friction pass reads the lam its contact pass just wrote."""
    _check_records(_records_job("pile", "fp16", "warm", interleaved=True), tmp_path, "fp16 pile interleaved warm")


@pytest.mark.parametrize("fmt_name", list(RECORDS_FORMATS))
def test_csim_records_per_manifold_friction(fmt_name: str, tmp_path: Path) -> None:
    """The rotated boxes: per-manifold friction (PGS_MU_W = 1: the coefficient word shifts the friction record's
    impulse words) and the full inverse inertia (PGS_IINV_W = 6), warm-started."""
    frame = scenes.load_or_capture(ROTATED_WORLD)
    fmt = RECORDS_FORMATS[fmt_name]
    job = KernelJob.from_frame(frame, fmt, SolverParams(4), "hazard", default_window(fmt, 512)).impulses_travelling()
    job = job.impulses_travelling(warm_start(job, _seed()))
    assert job.friction_words == 1 and job.inertia_words == 6
    _check_records(job, tmp_path, f"{fmt_name} rotated boxes warm")


def _flip_lam_bit(run_dir: Path, job: KernelJob, kb: KernelBuild, pass_index: int, slot: int, bit: int) -> None:
    """Flip one bit of lam[0] in the contact record of ``slot`` in contact pass ``pass_index`` (not interleaved:
    the contact passes come first) of cons.bin."""
    lay = job.stream_layout(kb.cons_bits)
    record = pass_index * len(job.slots) + slot
    pos = record * lay.contact_bytes * 8 + sf.HEADER_BITS + sf.CONTACT_LAM_WORD * lay.word_bits
    data = bytearray((run_dir / "cons.bin").read_bytes())
    data[(pos + bit) // 8] ^= 1 << ((pos + bit) % 8)
    (run_dir / "cons.bin").write_bytes(bytes(data))


@pytest.mark.parametrize("pass_index,seen", [(0, True), (1, False)], ids=["host-given", "dma-replaced"])
def test_csim_records_one_bit_in_an_impulse_word(pass_index: int, seen: bool, tmp_path: Path) -> None:
    """One bit of a warm start's lam[0] flipped in the first contact pass's record (the host-given impulse the pass
    starts from) makes the run differ, named in the trace; the same bit in the second contact pass's record does
    not (the DMA streams that record with the impulse the first pass wrote, not with cons.bin's word)."""
    job = _records_job("pile", "fp16", "warm")
    kb = records_build(job.fmt, job)
    slot = int(np.flatnonzero(job.cons.jac_inv[job.slots, 0] != 0)[0])  # a slot whose point 0 is active
    write_inputs(tmp_path, job, kb)
    _flip_lam_bit(tmp_path, job, kb, pass_index, slot, job.fmt.man_bits - 1)
    res = run_written_step(job, tmp_path, build_csim(kb), kb, default_window(job.fmt, kb.cons_bits))
    print(f"\n[pass {pass_index} slot {slot} lam[0] bit {job.fmt.man_bits - 1} flipped] "
          f"{res.comparison.first_mismatch}")
    assert res.bit_exact != seen
    if seen:
        assert f"slot {slot}," in str(res.comparison.first_mismatch)


def test_csim_records_one_bit_in_an_impulse_out_record(tmp_path: Path) -> None:
    """One bit flipped in the impulse-out file after a bit-exact run: compare_impulse_out names the record, its
    pass and slot and the word."""
    job = _records_job("stack", "fp16", "cold")
    kb = records_build(job.fmt, job)
    assert run_csim_step(job, tmp_path, build_csim(kb), kb).bit_exact
    data = bytearray((tmp_path / "imp_out.bin").read_bytes())
    rec = len(job.slots) + 3  # pass 1, slot 3, word 1
    data[rec * sf.impulse_out_bytes(job.fmt) + job.fmt.width // 8] ^= 0x01
    (tmp_path / "imp_out.bin").write_bytes(bytes(data))
    cmp = Comparison()
    compare_impulse_out(tmp_path, job, golden_step(job).records, cmp)
    print(f"\n[one bit in imp_out.bin] {cmp.first_mismatch}")
    assert cmp.differing_bits == 1
    assert f"impulse-out record {rec} (pass 1, slot 3) word 1" in str(cmp.first_mismatch)
