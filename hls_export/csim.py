"""C simulation of the HLS kernel (``hls_export/pgs_kernel.cpp``), checked bit for bit against the golden model.

The testbench ``hls_export/pgs_csim_main.cpp`` is a drop-in for the RTL kernel's Verilator harness: the same
command line and the same files. So one step runs exactly as ``sim.drive.kernel_step.run_kernel_step`` runs the RTL,
with the same pieces (``sim.drive.harness_run``, ``sim.compare.trace_bits``): ``write_inputs`` packs the streams
(``models/kernel/stream_format.py``), ``run_harness`` runs the executable, ``read_trace`` / ``compare_trace_bits`` /
``compare_body_out`` compare every retired manifold-pass and the body-out stream with ``golden_step``. The trace's cycle
field holds the record index (C simulation is untimed).

The executable is built with g++ (``-ffp-contract=off``, no ``-ffast-math``) against the Vitis HLS headers
when they are on the include path (the records design: always the shims, whose streams block across threads), else
against the shims in ``hls_export/shims/``, into
``build/hls_csim/<name>/pgs_csim``; it is rebuilt when a source under ``hls_export/`` is newer or the command
changed.

The records design (``PGS_IMPULSES_IN_RECORDS=1``, the RTL's ``IMPULSES_IN_RECORDS``: the impulses travel with
the records and leave on ``m_axis_imp``) is built for a ``KernelBuild`` with ``impulses_in_records``; its testbench
plays the DMA (``hls_export/pgs_csim_dma.h``) and writes the impulse-out records, which ``compare_impulse_out``
checks too. Formats: ``KernelBuild.fmt``'s exponent and mantissa bits (``PGS_EXP_BITS``, ``PGS_MAN_BITS``).

The soft contact build (``PGS_SOFT_CONTACT=1``, the RTL's ``SOFT_CONTACT``: Box2D's soft row, ``lam * keep`` before
the add, ``models/golden/soft_contact.py``) is built for a ``KernelBuild`` with ``soft_contact``; ``--designs soft``
runs the records design with it on the records scenes and formats, warm-started, each step once with the soft row (keep
factors of :data:`SOFT_KEEP`, the options bit set) and once rigid (the bit clear), against the golden model of each.

The records design with the tangent basis derived on chip (``PGS_TANGENTS_ON_CHIP=1``, the RTL's
``TANGENTS_ON_CHIP``: the friction record carries no t0, t1, the friction pass derives them from n in the format,
``models/setup/tangent_basis.py``) is built for a ``KernelBuild`` with ``tangents_on_chip`` (and
``impulses_in_records``: the C++ refuses it without); ``--designs tangents`` runs it on the records scenes and formats,
cold and warm-started, against the golden model of ``KernelJob.tangents_derived()``.

Shock propagation (``models/golden/shock_propagation.py``: in a shock pass each manifold row may have one body frozen, a
static body for that row, and a linear row has no inverse inertia and no spin damping) needs no build option: the
host sets the header's frozen-A, frozen-B and linear bits in a shock pass's records and streams that pass's shock
rows' jac_inv / f_jac_inv, and the kernel reads the bits (``pgs_kernel.cpp`` ``shock_row``). ``--designs shock`` runs
the records design on the records scenes and formats, warm-started, each step of :data:`SHOCKS` (``KernelJob.shocked``,
the frozen rows' impulses returned) with one iteration whose passes are all shock passes and with ``--iters``
iterations whose last contact (and friction) pass is, against the golden model of each.

The window design (``PGS_WINDOW`` > 0 with ``PGS_IMPULSES_IN_RECORDS=1``, the RTL's window kernel with the impulses
in the records: each fetch of the records serves passes of one kind over an on-chip ring, the passes trailing each
other by ``lag`` records, an impulse ring carrying the impulses from pass to pass, the fetch's last pass writing them
out) is built for a ``KernelBuild`` with ``window`` (the ring's records), ``window_ctx`` and ``lanes`` (``PGS_LANES``)
and ``impulses_in_records`` (:func:`window_build` of a window job, :func:`window_job`); its testbench's DMA streams the
fetches (``impulse_plan.bin``'s beats per record), and the comparison sorts its trace into the sequential order.
``--designs window`` runs it in binary32 with one lane and binary16 with two (the RTL's fitting designs) on the
records scenes, in the hazard and the sweep order (``--window-schedules``), cold and warm-started.

``make csim`` (``python -m hls_export.csim``) runs five designs: the on-chip one in binary32 on the stack, the
incline and a 4x3x4 pile in the hazard and the pybullet schedules, the records design in binary16 and binary32 on
the pile and the stack, cold and warm-started, the same with the tangents derived on chip, the shock steps and the
window design (``--designs onchip``, ``records``, ``tangents``, ``shock`` or ``window`` runs one; ``soft`` is not in
the default); it prints a table and exits 1 on any difference.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from models import scenes
from models.kernel import stream_format as sf
from models.golden.contact_solver import Impulses, SolverParams
from models.timing.platforms import get_preset
from models.formats.frame import Frame
from models.formats.number_format import FP16, FP32, NumberFormat
from models.kernel.kernel_job import KernelJob
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.golden.soft_contact import SoftContact
from sim.drive.harness_run import run_harness, write_inputs
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import golden_step
from sim.compare.trace_bits import (Comparison, compare_body_out, compare_impulse_out, compare_trace_bits, read_trace,
                                    writing_passes)
from sim.compile.verilator_build import REPO_ROOT, build_lock

HLS_DIR = Path(__file__).resolve().parent
BUILD_ROOT = REPO_ROOT / "build" / "hls_csim"
SOURCES = [HLS_DIR / "pgs_kernel.cpp", HLS_DIR / "pgs_csim_main.cpp"]
CXXFLAGS = ["-std=c++14", "-O2", "-ffp-contract=off", "-fno-fast-math", "-Wall", "-Wextra", "-Werror",
            "-Wno-unknown-pragmas", "-Wno-unused-label", "-pthread"]

# scenes of make csim and of the test: the RTL kernel tests' frames (models/scenes/kernel_scenes.py), in this order
SCENES: dict[str, dict[str, Any]] = {name: KERNEL_TEST_SCENES[name] for name in ("stack", "incline", "pile")}
SCHEDULES = ("hazard", "pybullet")
# the records design in make csim: formats, scenes, cold / warm start
RECORDS_FORMATS: dict[str, NumberFormat] = {"fp16": FP16, "fp32": FP32}
RECORDS_SCENES = ("pile", "stack")
EXTRA_SCENES: dict[str, dict[str, Any]] = {"thesis": {"seed": 1}}  # by name only (not in make csim): the thesis frame
WARM_SEED = 7  # the warm start's random impulses (make csim)
# the soft design's keep factors: Box2D's 15 Hz critically damped contact at substeps of 1/120 s (two values, not 1)
SOFT_KEEP = SoftContact(hertz=15.0, damping_ratio=1.0).keep(1.0 / 120.0)
# the window design (PGS_WINDOW, the RTL's window kernel with the impulses in the records) in make csim: lanes per
# format (the RTL's fitting designs: fp32 one lane, fp16 two), the ring's records (the RTL window tests' build), the
# schedules its slots follow (hazard: the lanes nearly all full; sweep: a banded order, small lag, many empty lanes)
WINDOW_LANES: dict[str, int] = {"fp16": 2, "fp32": 1}
WINDOW_DEPTH = 1024
WINDOW_SCHEDULES = ("hazard", "sweep")
# the shock design's steps: (linear, friction) of KernelJob.shocked; with friction the friction passes are shocked too
# (angular+friction: the frozen body's spin damping is computed and not written back, which only it shows)
SHOCKS: dict[str, tuple[bool, bool]] = {"angular": (False, False), "linear": (True, False),
                                        "linear+friction": (True, True), "angular+friction": (False, True)}


class CsimError(RuntimeError):
    """The C simulation could not be built or run."""


def csim_name(kb: KernelBuild) -> str:
    return (f"pgs_csim_c{kb.cons_bits}_b{kb.max_bodies}_m{kb.max_manifolds}"
            + (f"_e{kb.fmt.exp_bits}m{kb.fmt.man_bits}" if kb.fmt != FP32 else "")
            + (f"_w{kb.window}x{kb.window_ctx}" if kb.window else "")
            + (f"_l{kb.lanes}" if kb.lanes > 1 else "")
            + (f"_i{kb.inertia_words}" if kb.inertia_words != sf.KERNEL_INERTIA_WORDS else "")
            + ("_ir" if kb.impulses_in_records else "")
            + ("_mu" if kb.friction_words else "")
            + ("_tb" if kb.tangents_on_chip else "")
            + ("_soft" if kb.soft_contact else "")
            + ("" if kb.shared_datapath else "_split"))


def compile_cpp(sources: Sequence[Path], exe: Path, defines: Sequence[str] = (), cxx: str = "g++") -> Path:
    """Compile ``sources`` (with the kernel's flags and include path) into ``exe`` unless it was built by the same
    command and is newer than every source and header under ``hls_export/``."""
    compile_to = [cxx, *CXXFLAGS, *defines, f"-I{HLS_DIR}", *map(str, sources), "-o"]
    cmd = [*compile_to, str(exe)]
    stamp = exe.with_suffix(".cmd")
    deps = [*sources, *HLS_DIR.glob("*.h"), *(HLS_DIR / "generated").glob("*.h"), *(HLS_DIR / "shims").glob("*.h")]
    with build_lock(exe.parent):  # another process may be building (or running) the same executable
        if (exe.is_file() and stamp.is_file() and stamp.read_text() == " ".join(cmd)
                and exe.stat().st_mtime >= max(p.stat().st_mtime for p in deps)):
            return exe
        exe.parent.mkdir(parents=True, exist_ok=True)
        partial = exe.with_name(f"{exe.name}.{os.getpid()}.partial")
        proc = subprocess.run([*compile_to, str(partial)], capture_output=True, text=True)
        if proc.returncode != 0:
            partial.unlink(missing_ok=True)
            raise CsimError(f"{' '.join(cmd)}\n{proc.stdout}{proc.stderr}")
        partial.replace(exe)  # a running copy keeps its own inode
        stamp.write_text(" ".join(cmd))
    return exe


def csim_defines(kb: KernelBuild) -> list[str]:
    """The compiler's defines of the testbench and kernel for ``kb``'s format, stream widths, table sizes, impulse
    store (on chip, or in the records) and kernel (streaming, or the window kernel with the impulses in the records:
    ``kb.window``, ``window_ctx``, ``lanes``); a combination the C++ refuses raises a ValueError here."""
    if kb.friction_sign_bug:
        raise ValueError("the HLS kernel has no pipe variants")
    if kb.window and not kb.impulses_in_records:  # the C++'s static_assert, before a compile
        raise ValueError("the HLS window kernel is written with the impulses in the records only "
                         "(PGS_IMPULSES_IN_RECORDS = 1): no on-chip impulse RAM")
    if kb.lanes > 4:  # KernelBuild keeps lanes a power of two, above 1 only in the window kernel
        raise ValueError(f"{kb.lanes} lanes: the HLS window kernel has 1, 2 or 4")
    if kb.fmt.exp_bits > 8 or kb.fmt.man_bits > 23:
        raise ValueError(f"the HLS kernel holds values in a C++ float: {kb.fmt.name} does not fit")
    if kb.tangents_on_chip and not kb.impulses_in_records:  # the C++'s static_assert, before a compile
        raise ValueError("the HLS kernel derives the tangents on chip (PGS_TANGENTS_ON_CHIP) in the records design "
                         "only (PGS_IMPULSES_IN_RECORDS = 1)")
    defines = [f"-DPGS_EXP_BITS={kb.fmt.exp_bits}", f"-DPGS_MAN_BITS={kb.fmt.man_bits}",
               f"-DPGS_MAX_BODIES={kb.max_bodies}", f"-DPGS_MAX_MANIFOLDS={kb.max_manifolds}",
               f"-DPGS_CONS_W={kb.cons_bits}", f"-DPGS_BODY_IN_W={kb.body_in_bits}",
               f"-DPGS_BODY_OUT_W={kb.body_out_bits}", f"-DPGS_IINV_W={kb.inertia_words}",
               f"-DPGS_MU_W={kb.friction_words}", f"-DPGS_IMPULSES_IN_RECORDS={int(kb.impulses_in_records)}",
               f"-DPGS_SOFT_CONTACT={int(kb.soft_contact)}", f"-DPGS_TANGENTS_ON_CHIP={int(kb.tangents_on_chip)}",
               f"-DPGS_SHARED_DATAPATH={int(kb.shared_datapath)}"]
    if kb.window:
        defines += [f"-DPGS_WINDOW={kb.window}", f"-DPGS_WINDOW_CTX={kb.window_ctx}", f"-DPGS_LANES={kb.lanes}"]
    if kb.impulses_in_records:  # the testbench's DMA thread needs the blocking, thread-safe local streams
        defines.append("-DPGS_FORCE_SHIMS")
    return defines


def build_csim(kb: KernelBuild = KernelBuild(FP32), cxx: str = "g++") -> Path:
    """The testbench executable for ``kb`` (:func:`csim_defines`), rebuilt when stale."""
    return compile_cpp(SOURCES, BUILD_ROOT / csim_name(kb) / "pgs_csim", csim_defines(kb), cxx)


@dataclass
class CsimResult:
    registers: dict[str, float]  # result.txt
    comparison: Comparison
    golden_seconds: float

    @property
    def bit_exact(self) -> bool:
        return self.comparison.first_mismatch is None and self.comparison.differing_bits == 0

    @property
    def window_hazards(self) -> int:
        return int(self.registers["window_hazards"])


def run_csim_step(job: KernelJob, run_dir: Path, exe: Path, kb: KernelBuild = KernelBuild(FP32),
                  window: int = 128) -> CsimResult:
    """Run one step of ``job`` through the C simulation and compare it with the golden model (never raises on a
    mismatch: see ``comparison``). ``window``: records in flight assumed by the ``window_hazards`` count."""
    write_inputs(run_dir, job, kb)  # the records design: impulse_plan.bin too (the DMA's pass plan)
    return run_written_step(job, run_dir, exe, kb, window)


def run_written_step(job: KernelJob, run_dir: Path, exe: Path, kb: KernelBuild, window: int = 128) -> CsimResult:
    """:func:`run_csim_step` on the input files already in ``run_dir`` (``write_inputs``; a test may edit them)."""
    golden = golden_step(job)
    env = dict(os.environ, PGS_HAZARD_WINDOW=str(window))
    regs = run_harness(exe, run_dir, seed=1, preset=get_preset("ideal"), max_cycles=0, env=env)
    cmp = Comparison()
    compare_trace_bits(read_trace(run_dir / "trace.bin", job.fmt, kb.trace_bytes), golden.records, job, cmp)
    compare_body_out(run_dir, job, kb, golden.final, cmp)
    if job.impulses_in_records:
        compare_impulse_out(run_dir, job, golden.records, cmp)
        if int(regs["impulse_out_records"]) != impulse_out_records(job):
            cmp.fail(f"{int(regs['impulse_out_records'])} impulse-out records, expected {impulse_out_records(job)}")
    if int(regs["status"]) != 0:
        cmp.fail(f"kernel status 0x{int(regs['status']):x} after a good frame")
    if int(regs["issued"]) != job.manifold_passes:
        cmp.fail(f"kernel issued {int(regs['issued'])} manifold-passes, expected {job.manifold_passes}")
    left = (int(regs["cons_beats_left"]) + int(regs["cons_beats_unsent"]) + int(regs["body_in_beats_left"])
            + int(regs["empty_reads"]))
    if left:
        cmp.fail(f"stream beats left over, not sent or read while empty: {left}")
    return CsimResult(regs, cmp, golden.seconds)


def impulse_out_records(job: KernelJob) -> int:
    """The impulse-out records of a step whose impulses travel with the records: one per slot and pass (the
    streaming kernel), one per window record and fetch (the window kernel)."""
    lanes = job.record_window.lanes if job.record_window is not None else 1
    return len(writing_passes(job)) * len(job.slots) // lanes


def scene_frame(scene: str) -> Frame:
    """The frame of a ``SCENES`` (or ``EXTRA_SCENES``) scene."""
    params = SCENES.get(scene, EXTRA_SCENES.get(scene))
    if params is None:
        raise ValueError(f"scene {scene!r}: expected one of {', '.join([*SCENES, *EXTRA_SCENES])}")
    return scenes.load_or_capture(scene, **params)


def scene_job(scene: str, schedule: str, iterations: int = 4, kb: KernelBuild = KernelBuild(FP32),
              interleaved: bool = False) -> KernelJob:
    """One step of a ``SCENES`` scene in ``kb``'s format, ordered by ``schedule`` (hazard window = the RTL's); with
    ``kb.impulses_in_records`` the step of the records design, starting from zeros; with ``kb.tangents_on_chip``
    its friction tangents derived from the normals in the format (``KernelJob.tangents_derived``)."""
    job = KernelJob.from_frame(scene_frame(scene), kb.fmt, SolverParams(iterations, interleaved=interleaved), schedule,
                               default_window(kb.fmt, kb.cons_bits))
    job = job.impulses_travelling() if kb.impulses_in_records else job
    return job.tangents_derived() if kb.tangents_on_chip else job


def window_job(scene: str, fmt: NumberFormat, lanes: int, schedule: str = "hazard", iterations: int = 4,
               fetch_passes: int | None = None, interleaved: bool = False, depth: int = WINDOW_DEPTH) -> KernelJob:
    """One step of a ``SCENES`` scene on the window kernel with the impulses in the records, starting from zeros:
    its manifolds ordered by ``schedule`` (hazard: the RTL's hazard window for the format; sweep: window 1), planned
    for a ring of ``depth`` records of ``lanes`` slots, ``fetch_passes`` passes per fetch (None: the most of one
    kind)."""
    window = default_window(fmt, sf.DEFAULT_CONS_BEAT_BITS) if schedule == "hazard" else 1
    params = SolverParams(iterations, interleaved=interleaved)
    job = KernelJob.from_frame(scene_frame(scene), fmt, params, schedule, window)
    return job.impulses_travelling().windowed(depth, fetch_passes=fetch_passes, lanes=lanes)


def window_build(job: KernelJob) -> KernelBuild:
    """The window design's build for a window ``job``: its plan's ring, passes per fetch at most and lanes, its
    format, inverse-inertia and friction-coefficient words."""
    plan = job.record_window
    if plan is None or not job.impulses_in_records:
        raise ValueError("the window design runs a window job whose impulses travel with the records")
    return KernelBuild(job.fmt, window=plan.depth, window_ctx=plan.ctx, lanes=plan.lanes, impulses_in_records=True,
                       inertia_words=job.inertia_words, friction_words=job.friction_words)


def warm_start(job: KernelJob, seed: int) -> Impulses:
    """Random initial impulses for ``job`` (as ``cocotb_tests/test_kernel_impulses_in_records.py``): non-negative
    normal impulses, friction impulses within a tenth of their sum (inside the friction limit), in the job's format."""
    rng = np.random.default_rng(seed)
    m = job.cons.num_manifolds
    normal = job.fmt.round(rng.uniform(0.0, 0.5, (m, 4)))
    friction = job.fmt.round(rng.uniform(-0.05, 0.05, (m, 2)) * normal.sum(axis=1, keepdims=True))
    return Impulses(normal, friction)


def records_build(fmt: NumberFormat, job: KernelJob | None = None, soft_contact: bool = False,
                  tangents_on_chip: bool = False, body_bits: int = 128) -> KernelBuild:
    """The records design's build for ``fmt`` (and ``job``'s friction-coefficient and inverse-inertia words; with
    the soft contact row where asked; with the tangents derived on chip where asked or ``job`` derives them), with
    body streams of ``body_bits`` (PGS_BODY_IN_W = PGS_BODY_OUT_W)."""
    if job is None:
        return KernelBuild(fmt, impulses_in_records=True, soft_contact=soft_contact,
                           tangents_on_chip=tangents_on_chip, body_in_bits=body_bits, body_out_bits=body_bits)
    return KernelBuild(fmt, impulses_in_records=True, inertia_words=job.inertia_words,
                       friction_words=job.friction_words, soft_contact=soft_contact,
                       tangents_on_chip=tangents_on_chip or job.tangents_on_chip, body_in_bits=body_bits,
                       body_out_bits=body_bits)


def soft_jobs(cold: KernelJob) -> dict[str, KernelJob]:
    """The soft design's steps of a records job: warm-started (:data:`WARM_SEED`), with the soft row (keep factors
    :data:`SOFT_KEEP`) and rigid (the same records, the options bit clear)."""
    warm = cold.impulses_travelling(warm_start(cold, WARM_SEED))
    return {"soft": replace(warm, params=replace(warm.params, soft_keep=SOFT_KEEP)), "rigid": warm}


def shock_job(cold: KernelJob, shock: str) -> KernelJob:
    """The shock design's step of a records job: ``KernelJob.shocked`` with :data:`SHOCKS` ``[shock]``, one shock
    pass of each shocked kind, the frozen rows' impulses returned, warm-started (:data:`WARM_SEED`)."""
    linear, friction = SHOCKS[shock]
    job = cold.shocked(linear=linear, friction=friction, impulses="return", passes=1)
    return job.impulses_travelling(warm_start(job, WARM_SEED))


def _print_row(case: str, res: CsimResult) -> None:
    c = res.comparison
    verdict = "bit-exact" if res.bit_exact else f"MISMATCH: {c.first_mismatch}"
    imp = int(res.registers.get("impulse_out_records", 0))
    print(f"{case:<34} {c.records:>15,} {c.bodies:>7,} {imp:>11,} {c.differing_bits:>14} {res.window_hazards:>14,} "
          f"{res.registers['wall_s']:>7.3f} {res.golden_seconds:>8.2f}  {verdict}")


def _cold_and_warm_rows(cold: KernelJob, kb: KernelBuild, out: Path, case: str) -> int:
    """Run ``cold`` and its warm start (:data:`WARM_SEED`) on ``kb``'s build (run directories ``out``-cold and -warm),
    print a row each; returns how many were not bit-exact."""
    exe, bad = build_csim(kb), 0
    for start, job in (("cold", cold), ("warm", cold.impulses_travelling(warm_start(cold, WARM_SEED)))):
        res = run_csim_step(job, out.with_name(f"{out.name}-{start}"), exe, kb, default_window(cold.fmt, kb.cons_bits))
        bad += not res.bit_exact
        _print_row(f"{case} {start}", res)
    return bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", default="onchip,records,tangents,shock,window", help="comma-separated: onchip "
                    "(impulses on chip, binary32), records (impulses in the records, PGS_IMPULSES_IN_RECORDS=1), "
                    "tangents (records with the tangents derived on chip, PGS_TANGENTS_ON_CHIP=1), soft (records with "
                    "the soft contact row, PGS_SOFT_CONTACT=1; not in the default), shock (records with shock passes, "
                    "1 and --iters iterations), window (the window kernel with the impulses in the records, "
                    "PGS_WINDOW=--window-ring, PGS_LANES 1 in fp32 and 2 in fp16)")
    ap.add_argument("--scenes", default=",".join(SCENES),
                    help="on-chip design, comma-separated, from " + ", ".join(SCENES))
    ap.add_argument("--schedules", default=",".join(SCHEDULES))
    ap.add_argument("--records-scenes", default=",".join(RECORDS_SCENES),
                    help="records design, comma-separated, from " + ", ".join([*SCENES, *EXTRA_SCENES]))
    ap.add_argument("--records-formats", default=",".join(RECORDS_FORMATS))
    ap.add_argument("--window-schedules", default=",".join(WINDOW_SCHEDULES),
                    help="window design: the slot orders, comma-separated, from " + ", ".join(WINDOW_SCHEDULES))
    ap.add_argument("--window-ring", type=int, default=WINDOW_DEPTH,
                    help="window design: the ring's records (PGS_WINDOW; the fitting thesis designs' is 8192)")
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--body-bits", type=int, default=128, choices=(128, 256),
                    help="records and tangents designs: the body streams' beat (make sim's BODY_BITS)")
    ap.add_argument("--out", type=Path, default=REPO_ROOT / "build" / "hls_csim" / "runs")
    args = ap.parse_args(argv)
    designs = args.designs.split(",")
    unknown = set(designs) - {"onchip", "records", "tangents", "soft", "shock", "window"}
    if unknown:
        ap.error(f"unknown design(s) {sorted(unknown)}: onchip, records, tangents, soft, shock, window")
    print(f"{'case':<34} {'manifold-passes':>15} {'bodies':>7} {'imp-out rec':>11} {'differing bits':>14} "
          f"{'window hazards':>14} {'csim s':>7} {'golden s':>8}  result")
    bad = 0
    if "onchip" in designs:
        kb = KernelBuild(FP32)
        exe = build_csim(kb)
        window = default_window(FP32, kb.cons_bits)
        for scene in args.scenes.split(","):
            for schedule in args.schedules.split(","):
                res = run_csim_step(scene_job(scene, schedule, args.iters, kb), args.out / f"{scene}-{schedule}",
                                    exe, kb, window)
                bad += not res.bit_exact
                _print_row(f"onchip fp32 {scene}/{schedule}", res)
    for design in ("records", "tangents"):
        if design not in designs:
            continue
        for fname in args.records_formats.split(","):
            fmt = RECORDS_FORMATS[fname]
            for scene in args.records_scenes.split(","):
                cold = scene_job(scene, "hazard", args.iters, records_build(fmt, tangents_on_chip=design == "tangents",
                                                                            body_bits=args.body_bits))
                kb = records_build(fmt, cold, body_bits=args.body_bits)
                bad += _cold_and_warm_rows(cold, kb, args.out / f"{design}-{fname}-{scene}",
                                           f"{design} {fname} {scene}/hazard")
    if "window" in designs:
        for fname in args.records_formats.split(","):
            fmt, lanes = RECORDS_FORMATS[fname], WINDOW_LANES[fname]
            for scene in args.records_scenes.split(","):
                for schedule in args.window_schedules.split(","):
                    cold = window_job(scene, fmt, lanes, schedule, args.iters, depth=args.window_ring)
                    out = args.out / f"window-{fname}-{scene}-{schedule}"
                    case = f"window {fname} l{lanes} {scene}/{schedule}"
                    bad += _cold_and_warm_rows(cold, window_build(cold), out, case)
    if "soft" in designs:
        for fname in args.records_formats.split(","):
            fmt = RECORDS_FORMATS[fname]
            for scene in args.records_scenes.split(","):
                cold = scene_job(scene, "hazard", args.iters, records_build(fmt))
                kb = records_build(fmt, cold, soft_contact=True)
                exe = build_csim(kb)
                for row, job in soft_jobs(cold).items():
                    res = run_csim_step(job, args.out / f"soft-{fname}-{scene}-{row}", exe, kb,
                                        default_window(fmt, kb.cons_bits))
                    bad += not res.bit_exact
                    _print_row(f"soft {fname} {scene}/hazard warm {row}", res)
    if "shock" in designs:
        for fname in args.records_formats.split(","):
            fmt = RECORDS_FORMATS[fname]
            for scene in args.records_scenes.split(","):
                for iters in sorted({1, args.iters}):
                    cold = scene_job(scene, "hazard", iters, records_build(fmt))
                    kb = records_build(fmt, cold)
                    exe = build_csim(kb)
                    for shock in SHOCKS:
                        job = shock_job(cold, shock)
                        res = run_csim_step(job, args.out / f"shock-{fname}-{scene}-i{iters}-{shock}", exe, kb,
                                            default_window(fmt, kb.cons_bits))
                        bad += not res.bit_exact
                        _print_row(f"shock {fname} {scene} i{iters} {shock}", res)
    print("window hazards: records naming a dynamic body that one of the records before them in the pass (the window "
          "design: in the fetch's pass schedule; the RTL's hazard window for the format) names too; the synthesized "
          "kernel (DEPENDENCE false on the velocities) "
          "equals this C simulation only where that is 0 for a window of at least its pipeline's records in flight.")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
