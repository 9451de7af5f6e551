"""C simulation of the HLS kernel (``hls_export/pgs_kernel.cpp``), checked bit for bit against the golden model.

The testbench ``hls_export/pgs_csim_main.cpp`` is a drop-in for the RTL kernel's Verilator harness: the same
command line and the same files. So one step runs exactly as ``sim.kernel_step.run_kernel_step`` runs the RTL,
with the same pieces (``sim.harness_run``, ``sim.trace_compare``): ``write_inputs`` packs the streams (``models/stream_format.py``),
``run_harness`` runs the executable, ``read_trace`` / ``compare_trace`` / ``compare_body_out`` compare every
retired manifold-pass and the body-out stream with ``golden_step``. The trace's cycle field holds the record
index (C simulation is untimed).

The executable is built with g++ (``-ffp-contract=off``, no ``-ffast-math``) against the Vitis HLS headers
when they are on the include path, else against the shims in ``hls_export/shims/``, into
``build/hls_csim/<name>/pgs_csim``; it is rebuilt when a source under ``hls_export/`` is newer or the command
changed.

``make csim`` (``python -m hls_export.csim``) runs the stack, the incline and a 4x3x4 pile in the hazard and the
pybullet schedules and prints a table; it exits 1 on any difference.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from models import scenes
from models import stream_format as sf
from models.contact_solver import SolverParams
from models.dma_model import get_preset
from models.number_format import FP32
from models.kernel_job import KernelJob
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.harness_run import run_harness, write_inputs
from sim.kernel_build import KernelBuild, default_window
from sim.kernel_step import golden_step
from sim.trace_compare import Comparison, compare_body_out, compare_trace, read_trace
from sim.verilator_build import REPO_ROOT

HLS_DIR = Path(__file__).resolve().parent
BUILD_ROOT = REPO_ROOT / "build" / "hls_csim"
SOURCES = [HLS_DIR / "pgs_kernel.cpp", HLS_DIR / "pgs_csim_main.cpp"]
CXXFLAGS = ["-std=c++14", "-O2", "-ffp-contract=off", "-fno-fast-math", "-Wall", "-Wextra", "-Werror",
            "-Wno-unknown-pragmas", "-Wno-unused-label"]

# scenes of make csim and of the test: the RTL kernel tests' frames (models/scenes/kernel_scenes.py), in this order
SCENES: dict[str, dict[str, Any]] = {name: KERNEL_TEST_SCENES[name] for name in ("stack", "incline", "pile")}
SCHEDULES = ("hazard", "pybullet")


class CsimError(RuntimeError):
    """The C simulation could not be built or run."""


def csim_name(kb: KernelBuild) -> str:
    return (f"pgs_csim_c{kb.cons_bits}_b{kb.max_bodies}_m{kb.max_manifolds}"
            + (f"_i{kb.inertia_words}" if kb.inertia_words != sf.KERNEL_INERTIA_WORDS else "")
            + ("_mu" if kb.friction_words else ""))


def compile_cpp(sources: Sequence[Path], exe: Path, defines: Sequence[str] = (), cxx: str = "g++") -> Path:
    """Compile ``sources`` (with the kernel's flags and include path) into ``exe`` unless it was built by the same
    command and is newer than every source and header under ``hls_export/``."""
    cmd = [cxx, *CXXFLAGS, *defines, f"-I{HLS_DIR}", *map(str, sources), "-o", str(exe)]
    stamp = exe.with_suffix(".cmd")
    deps = [*sources, *HLS_DIR.glob("*.h"), *(HLS_DIR / "generated").glob("*.h"), *(HLS_DIR / "shims").glob("*.h")]
    if (exe.is_file() and stamp.is_file() and stamp.read_text() == " ".join(cmd)
            and exe.stat().st_mtime >= max(p.stat().st_mtime for p in deps)):
        return exe
    exe.parent.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise CsimError(f"{' '.join(cmd)}\n{proc.stdout}{proc.stderr}")
    stamp.write_text(" ".join(cmd))
    return exe


def build_csim(kb: KernelBuild = KernelBuild(FP32), cxx: str = "g++") -> Path:
    """The testbench executable for ``kb``'s stream widths and table sizes (binary32 only), rebuilt when stale."""
    if kb.fmt != FP32:
        raise ValueError(f"the HLS kernel is binary32 only, not {kb.fmt.name}")
    defines = [f"-DPGS_MAX_BODIES={kb.max_bodies}", f"-DPGS_MAX_MANIFOLDS={kb.max_manifolds}",
               f"-DPGS_CONS_W={kb.cons_bits}", f"-DPGS_BODY_IN_W={kb.body_in_bits}",
               f"-DPGS_BODY_OUT_W={kb.body_out_bits}", f"-DPGS_IINV_W={kb.inertia_words}",
               f"-DPGS_MU_W={kb.friction_words}"]
    return compile_cpp(SOURCES, BUILD_ROOT / csim_name(kb) / "pgs_csim", defines, cxx)


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
    write_inputs(run_dir, job, kb)
    golden = golden_step(job)
    env = dict(os.environ, PGS_HAZARD_WINDOW=str(window))
    regs = run_harness(exe, run_dir, seed=1, preset=get_preset("ideal"), max_cycles=0, env=env)
    cmp = Comparison()
    compare_trace(read_trace(run_dir / "trace.bin", job.fmt, kb.trace_bytes), golden.records, job, cmp)
    compare_body_out(run_dir, job, kb, golden.final, cmp)
    if int(regs["status"]) != 0:
        cmp.fail(f"kernel status 0x{int(regs['status']):x} after a good frame")
    if int(regs["issued"]) != job.manifold_passes:
        cmp.fail(f"kernel issued {int(regs['issued'])} manifold-passes, expected {job.manifold_passes}")
    left = int(regs["cons_beats_left"]) + int(regs["body_in_beats_left"]) + int(regs["empty_reads"])
    if left:
        cmp.fail(f"stream beats left over or read while empty: {left}")
    return CsimResult(regs, cmp, golden.seconds)


def scene_job(scene: str, schedule: str, iterations: int = 4, kb: KernelBuild = KernelBuild(FP32),
              interleaved: bool = False) -> KernelJob:
    """One step of a ``SCENES`` scene in binary32, ordered by ``schedule`` (hazard window = the RTL's)."""
    frame = scenes.load_or_capture(scene, **SCENES[scene])
    return KernelJob.from_frame(frame, FP32, SolverParams(iterations, interleaved=interleaved), schedule,
                                default_window(FP32, kb.cons_bits))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated, from " + ", ".join(SCENES))
    ap.add_argument("--schedules", default=",".join(SCHEDULES))
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--out", type=Path, default=REPO_ROOT / "build" / "hls_csim" / "runs")
    args = ap.parse_args(argv)
    kb = KernelBuild(FP32)
    t0 = time.monotonic()
    exe = build_csim(kb)
    print(f"C simulation testbench: {exe.relative_to(REPO_ROOT)} ({time.monotonic() - t0:.1f} s to build or check)")
    window = default_window(FP32, kb.cons_bits)
    print(f"{'case':<22} {'manifold-passes':>15} {'bodies':>7} {'differing bits':>14} {'window hazards':>14} "
          f"{'csim s':>7} {'golden s':>8}  result")
    bad = 0
    for scene in args.scenes.split(","):
        for schedule in args.schedules.split(","):
            job = scene_job(scene, schedule, args.iters, kb)
            res = run_csim_step(job, args.out / f"{scene}-{schedule}", exe, kb, window)
            c = res.comparison
            verdict = "bit-exact" if res.bit_exact else f"MISMATCH: {c.first_mismatch}"
            bad += not res.bit_exact
            print(f"{scene + '/' + schedule:<22} {c.records:>15,} {c.bodies:>7,} {c.differing_bits:>14} "
                  f"{res.window_hazards:>14,} {res.registers['wall_s']:>7.3f} {res.golden_seconds:>8.2f}  {verdict}")
    print(f"window hazards: records naming a dynamic body that one of the {window} records before them in the pass "
          "names too; the synthesized kernel (DEPENDENCE false on the velocities) equals this C simulation only "
          "where that is 0 for a window of at least its pipeline's records in flight.")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
